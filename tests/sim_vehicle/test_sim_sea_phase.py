"""A phase nobody is told: the simulator's sea gets its phase origin from ``--seed``, written only to its run folder.

Crest timing is read from the true-state CSV (``wave_elevation_m`` under the boat at each simulated
time); what goes over MAVLink is compared between seeds by message types and field names, the parameter
table, and the values of every message that carries no motion.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from sim_vehicle.harness import SimProcess
from sim_vehicle.mavlink.telemetry import Telemetry
from sim_vehicle.rover.battery import Battery
from tests.rover import SET_MESSAGE_INTERVAL
from tests.waits import command, wait_for

RUN_S = 3.0


def _run(tmp_path: Path, name: str, *flags: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """A short unpaced run without links; (t s, elevation m, slope E rad) from its state.csv, and its stderr."""
    log_dir = tmp_path / name
    proc = subprocess.run([sys.executable, "-m", "sim_vehicle", "--no-tcp", "--no-out", "--speedup", "0",
                           "--duration", str(RUN_S), "--log-dir", str(log_dir), "--params-store",
                           str(tmp_path / f"{name}.params.json"), *flags],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    with (log_dir / "state.csv").open() as f:
        rows = list(csv.DictReader(f))
    t = np.array([float(r["t_s"]) for r in rows])
    zeta = np.array([float(r["wave_elevation_m"]) for r in rows])
    slope_e = np.array([float(r["wave_slope_e_rad"]) for r in rows])
    return t, zeta, slope_e, proc.stderr


@pytest.mark.parametrize("sea", [["--sea", "paper"], ["--sea", "jonswap:1.75,6,-90"]], ids=["regular", "jonswap"])
def test_seed_sets_crest_timing(tmp_path: Path, sea: list[str]) -> None:
    """Different seeds: different elevations at the same boot times; the same seed: the same record."""
    t1, z1, s1, err1 = _run(tmp_path, "a", *sea, "--seed", "11")
    t2, z2, _, _ = _run(tmp_path, "b", *sea, "--seed", "11")
    t3, z3, _, _ = _run(tmp_path, "c", *sea, "--seed", "12")
    assert np.array_equal(t1, t2) and np.array_equal(t1, t3)
    assert np.array_equal(z1, z2), "the same seed gave a different sea"
    assert np.max(np.abs(z1 - z3)) > 0.2, "different seeds gave (nearly) the same crest timing"
    assert np.max(np.abs(s1)) > 0.02, "the true slope (East) is not recorded"  # waves travel West
    assert "seed 11" in err1, err1
    record = json.loads((tmp_path / "a" / "sea.json").read_text())
    assert record["seed"] == 11


def test_fresh_seed_by_default(tmp_path: Path) -> None:
    """Without --seed each start draws its own phase origin (and says which in its start line)."""
    _, z1, _, err1 = _run(tmp_path, "a", "--sea", "paper")
    _, _, _, err2 = _run(tmp_path, "b", "--sea", "paper")
    seeds = [json.loads((tmp_path / n / "sea.json").read_text())["seed"] for n in ("a", "b")]
    assert seeds[0] != seeds[1]
    assert f"seed {seeds[0]}" in err1 and f"seed {seeds[1]}" in err2
    # the drawn seed is the one the sea used (two random phases may by chance give nearly the same record,
    # so the records are not compared with each other): replaying it gives the same elevations
    _, replay, _, _ = _run(tmp_path, "a-replay", "--sea", "paper", "--seed", str(seeds[0]))
    assert np.array_equal(z1, replay)


def test_sea_phase_boot_keeps_the_paper_sea(tmp_path: Path) -> None:
    """--sea-phase boot: phase 0 at boot, ζ = (H/2)·sin(ωt − k·s) at the boat as before (for truth tests)."""
    t, z, _, _ = _run(tmp_path, "a", "--sea", "paper", "--sea-phase", "boot", "--ideal-sensors")
    with (tmp_path / "a" / "state.csv").open() as f:
        east = np.array([float(r["east_m"]) for r in csv.DictReader(f)])
    omega, k = 2 * np.pi / 6.0, 2 * np.pi / 35.0
    assert z[0] == 0.0  # sin(0) at the origin at t = 0
    assert np.allclose(z, 0.875 * np.sin(omega * t + k * east), atol=1e-6)  # travelling West: s = −E


# Messages that carry no motion (at rest, thrusters stopped): their values, not only their fields, must not
# depend on the seed. Time stamps are left out (the two runs sample at different wall instants).
STATIC_TYPES = ("HEARTBEAT", "SYS_STATUS", "BATTERY_STATUS", "MISSION_CURRENT", "STATUSTEXT", "SERVO_OUTPUT_RAW",
                "RC_CHANNELS", "RC_CHANNELS_SCALED")


# What grows with simulated time at rest, seed or not: the battery's charge used (1 A of hotel load, one more
# mAh every 3.6 s) and the voltage and remaining charge that follow it. Each run samples its own stretch of
# simulated time (how long the start, the stream request and the parameter list took in wall time, times the
# speedup), so these would differ between two seeds only because the runs did not start at the same instant.
ELAPSED_FIELDS = ("current_consumed", "energy_consumed", "battery_remaining", "voltages", "voltage_battery")


def _static_values(msg: Any) -> tuple[tuple[str, object], ...]:
    """A message's field values without its time stamps and what accumulates with time, hashable."""
    return tuple(sorted((k, repr(v)) for k, v in msg.to_dict().items()
                        if "time" not in k and k != "mavpackettype" and k not in ELAPSED_FIELDS))


def test_static_values_do_not_depend_on_how_long_the_boat_has_been_up() -> None:
    """Two batteries at rest, 2 s and 6 s after boot: the same static values (current_consumed is 1 and 2 mAh)."""
    readings = []
    for seconds in (2.0, 6.0):
        telemetry = SimpleNamespace(battery=Battery())
        for _ in range(round(seconds / 0.01)):
            telemetry.battery.update((0.0, 0.0), 0.01)
        readings.append(Telemetry.battery_status(telemetry))  # type: ignore[arg-type]
    assert readings[0].current_consumed != readings[1].current_consumed  # what made the seeds' sets differ
    assert _static_values(readings[0]) == _static_values(readings[1])


def _seen(seed: int, workdir: Path) -> tuple[dict[str, frozenset[str]], dict[str, float], set[tuple[str, tuple]]]:
    """Over ~3 simulated seconds with all streams on and the parameter list requested: message types and their
    field names, the whole parameter table, and the distinct values of the motion-free messages."""
    fields: dict[str, frozenset[str]] = {}
    params: dict[str, float] = {}
    static: set[tuple[str, tuple]] = set()
    param_count = -1
    with SimProcess(workdir, speedup=10, waves="paper", sensors="realistic", sea_phase="hidden",
                    extra=["--seed", str(seed)]) as sim:
        conn = sim.connect()
        conn.mav.request_data_stream_send(1, 1, 0, 10, 1)
        assert command(conn, SET_MESSAGE_INTERVAL, 26, 100000) == 0  # SCALED_IMU (on request only)
        conn.mav.param_request_list_send(1, 1)
        start = wait_for(conn, "ATTITUDE", 10).time_boot_ms
        deadline = time.monotonic() + 60
        done = False
        indices: set[int] = set()
        last_param = time.monotonic()
        while not done:
            now = time.monotonic()
            if now > deadline:
                raise TimeoutError(f"3 simulated s of ATTITUDE and {param_count} parameters did not arrive in 60 s "
                                   f"({len(params)} parameters so far; banner seen: {'STATUSTEXT' in fields})")
            if 0 < param_count and len(indices) < param_count and now - last_param > 1.0:
                # as a ground station does: a download that stalls (a busy machine's full socket buffer drops
                # PARAM_VALUEs, as a lossy radio would) is completed by reading the missing ones by index
                for index in sorted(set(range(param_count)) - indices)[:20]:
                    conn.mav.param_request_read_send(1, 1, b"", index)
                last_param = now
            elif len(params) == param_count and "STATUSTEXT" not in fields and now - last_param > 1.0:
                conn.mav.param_request_list_send(1, 1)  # the banner (STATUSTEXT) was dropped the same way: again
                last_param = now
            msg = conn.recv_match(blocking=True, timeout=0.5)
            if msg is None or msg.get_type() == "BAD_DATA":
                continue
            kind = msg.get_type()
            fields[kind] = frozenset(msg.get_fieldnames())
            if kind == "PARAM_VALUE":
                params[msg.param_id] = msg.param_value
                param_count, last_param = msg.param_count, time.monotonic()
                indices.add(int(msg.param_index))
            elif kind in STATIC_TYPES:
                static.add((kind, _static_values(msg)))
            done = (kind == "ATTITUDE" and msg.time_boot_ms - start > 3000 and len(params) == param_count
                    and "STATUSTEXT" in fields)
    return fields, params, static


def test_mavlink_does_not_depend_on_the_seed(tmp_path: Path) -> None:
    """Two seeds: the same message types with the same fields, the same parameter table (no seed in it) and
    the same values in every message that carries no motion (the sea shows only through the motion)."""
    fields_a, params_a, static_a = _seen(1, tmp_path / "a")
    fields_b, params_b, static_b = _seen(2, tmp_path / "b")
    assert {"ATTITUDE", "GPS_RAW_INT", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "RAW_IMU",
            "SCALED_IMU2", "SCALED_IMU", "PARAM_VALUE", "STATUSTEXT", "HEARTBEAT"} <= set(fields_a)
    assert fields_a == fields_b
    assert len(params_a) > 50 and "SIM_AHRS_NOISE" in params_a
    assert params_a == params_b
    assert {kind for kind, _ in static_a} == set(STATIC_TYPES)
    assert static_a == static_b, static_a ^ static_b
