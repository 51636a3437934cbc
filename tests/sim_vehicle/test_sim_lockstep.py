"""`sim-vehicle --lockstep`: simulated time waits at each control tick for the controller's command.

The state machine alone (pure), then a real simulator process driven by a pymavlink client that plays
the companion (system 255 = SYSID_MYGCS): time stands while it is silent, one command releases one tick.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from sim_vehicle.harness import SimProcess, sim_vehicle_command
from sim_vehicle.lockstep import MAX_MISSED_IN_A_ROW, Lockstep
from tests.waits import drain, wait_for, wait_sim_time

START_S = 2.0


def test_ticks_are_whole_periods_of_the_clock_once_the_controller_commands() -> None:
    lock = Lockstep(period_s=0.1, timeout_s=1.0, controller_sysid=255)
    assert not lock.is_tick(1.0, attitude_sent=True)  # not engaged: paced
    lock.on_message("RC_CHANNELS_OVERRIDE", 77)  # another system's command does not engage
    lock.on_message("HEARTBEAT", 255)  # nor a heartbeat of the controller
    assert not lock.engaged
    lock.on_message("RC_CHANNELS_OVERRIDE", 255)
    assert lock.engaged and lock.stats.engagements == 1
    assert not lock.is_tick(1.05, attitude_sent=True)  # between grid points
    assert not lock.is_tick(1.10, attitude_sent=False)  # no ATTITUDE, no tick
    assert lock.is_tick(1.10 + 1e-9, attitude_sent=True)
    assert not lock.command_arrived()
    lock.on_message("SET_ATTITUDE_TARGET", 255)  # the held tick's command
    assert lock.command_arrived()
    assert not lock.is_tick(1.15, attitude_sent=True)  # less than a period later: no hold
    assert lock.is_tick(1.2, attitude_sent=True)


def test_a_late_first_command_still_lands_the_holds_on_the_controllers_ticks() -> None:
    """The controller (on the same grid) answers the 34.80 s sample, but its command arrives after the 34.85 s
    ATTITUDE went out: the holds must fall on 34.90, 35.00, ... (its ticks), not on 34.85, 34.95, ..."""
    lock = Lockstep(period_s=0.1, timeout_s=1.0, controller_sysid=255)
    assert not lock.is_tick(34.80, attitude_sent=True)
    assert not lock.is_tick(34.85, attitude_sent=True)
    lock.on_message("RC_CHANNELS_OVERRIDE", 255)  # for the 34.80 s sample, arriving late
    assert lock.is_tick(34.90, attitude_sent=True)
    assert not lock.command_arrived()  # the late command does not release the 34.90 s hold
    lock.on_message("RC_CHANNELS_OVERRIDE", 255)
    assert lock.command_arrived()
    assert not lock.is_tick(34.95, attitude_sent=True)
    assert lock.is_tick(35.00, attitude_sent=True)


def test_a_command_between_ticks_releases_nothing_and_the_grid_stays() -> None:
    """A stand-down, or a command that comes after its tick timed out, arrives between holds: it moves
    nothing, and the next hold waits for a command of its own."""
    lock = Lockstep(period_s=0.1, timeout_s=1.0, controller_sysid=255, start_s=10.05)
    assert lock.is_tick(10.10, attitude_sent=True)  # the start time's grid point on or after it
    lock.timed_out(10.10, 1.0)
    assert not lock.is_tick(10.15, attitude_sent=True)
    lock.on_message("RC_CHANNELS_OVERRIDE", 255)  # the late command for 10.10 s
    lock.on_message("MANUAL_CONTROL", 255)
    assert not lock.is_tick(10.15 + 1e-9, attitude_sent=True)
    assert lock.is_tick(10.20, attitude_sent=True)
    assert not lock.command_arrived()
    lock.on_message("RC_CHANNELS_OVERRIDE", 255)
    assert lock.command_arrived() and not lock.is_tick(10.25, attitude_sent=True)
    assert lock.is_tick(10.30, attitude_sent=True)


def test_a_silent_controller_is_released_after_a_few_timeouts() -> None:
    lock = Lockstep(period_s=0.1, timeout_s=0.5, controller_sysid=255, start_s=3.0)
    assert not lock.is_tick(2.9, attitude_sent=True)
    for k in range(MAX_MISSED_IN_A_ROW):
        assert lock.is_tick(3.0 + 0.1 * k, attitude_sent=True)
        lock.timed_out(3.0 + 0.1 * k, 0.5)
    assert not lock.engaged and lock.stats.timeouts == MAX_MISSED_IN_A_ROW
    assert not lock.is_tick(3.5, attitude_sent=True)  # paced again (the start time counts once)
    assert "3 timed out" in lock.stats.summary()




def test_aligned_streams_fall_on_multiples_of_their_interval() -> None:
    """Lockstep: a stream requested at any moment is sent on the same grid, so runs see the same samples."""
    from sim_vehicle.mavlink.streams import Schedule
    from sim_vehicle.rover.params import ParamTable

    attitude = 30
    for aligned, expected in ((True, [0.05, 0.10, 0.15]), (False, [0.063, 0.113, 0.163])):
        schedule = Schedule(ParamTable(), 0, aligned=aligned)
        schedule.set_interval(attitude, 50_000)
        sent = [t for t in (0.013 + 0.001 * k for k in range(160)) if attitude in schedule.due(t)]
        assert sent[0] == pytest.approx(0.013)  # the first one goes out at once
        assert sent[1:4] == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("flags", [["--lockstep", "0"], ["--lockstep-timeout", "-1"], ["--lockstep-start", "3"]])
def test_bad_lockstep_flags_are_one_line_and_exit_2(tmp_path: Path, flags: list[str]) -> None:
    done = subprocess.run([*sim_vehicle_command(), "--no-tcp", "--no-out", "--params-store",
                           str(tmp_path / "p.json"), *flags], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "lockstep" in done.stderr and "Traceback" not in done.stderr
    assert len(done.stderr.strip().splitlines()) <= 3  # argparse: usage + one error line


def _override(conn: Any) -> None:
    conn.mav.rc_channels_override_send(1, 1, 1500, 0, 1500, 0, 0, 0, 0, 0)


def _no_attitude_after(conn: Any, t_s: float) -> None:
    """Nothing queued on the link is stamped later than ``t_s``: simulated time stood (a held sim sends nothing)."""
    stamps = [m.time_boot_ms / 1000.0 for m in drain(conn) if getattr(m, "time_boot_ms", None) is not None]
    assert max(stamps, default=t_s) == pytest.approx(t_s, abs=1e-3), stamps


def test_time_holds_at_a_tick_until_the_controllers_command(tmp_path: Path) -> None:
    extra = ["--lockstep", "0.1", "--lockstep-start", str(START_S), "--lockstep-timeout", "30"]
    with SimProcess(tmp_path, speedup=10, extra=extra, wait_for_client=True) as sim:
        conn = sim.connect(source_system=255)  # SYSID_MYGCS: the controller
        conn.mav.request_data_stream_send(1, 1, 10, 20, 1)  # EXTRA1 = ATTITUDE at 20 Hz on the TCP channel
        tick = wait_sim_time(conn, START_S, "ATTITUDE", timeout=60)
        assert tick.time_boot_ms == round(START_S * 1000)  # the held tick is the start time itself
        time.sleep(1.0)  # wall time passes; simulated time must not (10x pacing would have made it 10 s)
        _no_attitude_after(conn, START_S)
        for k in range(1, 4):  # each command releases exactly one period
            _override(conn)
            nxt = wait_for(conn, "ATTITUDE", 30, lambda m, k=k: m.time_boot_ms >= round((START_S + 0.1 * k) * 1000))
            assert nxt.time_boot_ms == round((START_S + 0.1 * k) * 1000)
            time.sleep(0.3)
            _no_attitude_after(conn, START_S + 0.1 * k)
        err = sim.stop()
    assert "3 released by a command" in err, err
    assert "0 timed out" in err, err


if __name__ == "__main__":
    sys.exit(pytest.main([__file__, "-q"]))
