"""The companion through a lossy radio: real `sim-vehicle` and `mavbridge run` with the chaos relay between them.

Paced runs (lockstep cannot wait for a command the relay lost): what is checked holds under load — the
companion reads every parameter its commands depend on (none assumed), downloads the mission whole, arms,
switches mode and reaches a short waypoint; every command is acknowledged within its retry budget; the
simulator executes each once however often it was sent. ``bench/link_faults.py`` covers 0-50 % loss × 0-400 ms.
"""

from __future__ import annotations

import io
import os
import socket
import threading
from collections import Counter
from collections.abc import Iterator
from contextlib import redirect_stdout
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil

from bench.chaos_relay import ChaosRelay, Faults
from mavbridge.cli import main
from mavbridge.link.retry import RETRY_KINDS
from mavbridge.preflight.report import FAIL, PASS
from sim_vehicle.harness import SimProcess, free_port
from tests.rover import ARM, DO_SET_MODE
from tests.system.test_check import PARM, ROOT, check_rows
from tests.system.test_companion_sitl import HOME, Companion
from tests.waits import upload_waypoint, wait_for
from vessel.geo import latlon_from_ned

pytestmark = [pytest.mark.slow, pytest.mark.integration]
SPEEDUP = 5.0
WAYPOINT = "20,15"  # short: the run is about the link, not the sea
RETRY_FLAGS = ("--command-timeout", "0.3", "--command-retries", "25")  # 0.64 ** 26 < 1e-4 per request at 40 %


class StatusTexts(threading.Thread):
    """Collects every STATUSTEXT the simulator sends on its TCP port (channel 0, outside the relay)."""

    def __init__(self, conn: Any) -> None:
        super().__init__(daemon=True)
        self.conn, self.texts, self.running = conn, Counter(), True

    def run(self) -> None:
        while self.running:
            msg = self.conn.recv_match(type="STATUSTEXT", blocking=True, timeout=0.2)
            if msg is not None:
                self.texts[str(msg.text)] += 1


def received_commands(sim: SimProcess) -> list[Any]:
    """Every COMMAND_LONG the simulator received from the companion (sysid 255), from its .tlog."""
    log = mavutil.mavlink_connection(str(sim.log_dir / "sim_vehicle.tlog"))
    out = []
    while (msg := log.recv_match(type="COMMAND_LONG")) is not None:
        if msg.get_srcSystem() == 255:
            out.append(msg)
    return out


@pytest.fixture
def lossy(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[tuple[SimProcess, ChaosRelay, int]]:
    """Simulator -> relay (the given faults both ways, seed 1) -> a free companion port."""
    faults: Faults = request.param
    companion_port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(tmp_path / "sim", speedup=SPEEDUP, waves="paper", extra=[HOME, "--wipe"], udp_outs=1)
    with ChaosRelay(companion_port, faults, faults, seed=1, time_scale=SPEEDUP, port=sim.udp_ports[0]) as relay, sim:
        yield sim, relay, companion_port


def upload_mission(conn: Any, waypoints: list[tuple[float, float]]) -> None:
    """Home + NAV_WAYPOINTs (north, east metres from the test's home) with the mission protocol, on the simulator's
    TCP port (outside the relay)."""
    home = (-35.363261, 149.165230)
    items = [home, *(latlon_from_ned(*home, north, east) for north, east in waypoints)]
    conn.mav.mission_count_send(1, 1, len(items), 0)
    for seq, (lat, lon) in enumerate(items):
        request = wait_for(conn, ["MISSION_REQUEST", "MISSION_REQUEST_INT"], 5)
        assert request.seq == seq, request
        conn.mav.mission_item_int_send(1, 1, seq, 3, 16, 0, 1, 0, 0, 0, 0, round(lat * 1e7), round(lon * 1e7), 0, 0)
    assert wait_for(conn, "MISSION_ACK", 5).type == 0


def run_through(lossy: tuple[SimProcess, ChaosRelay, int], tmp_path: Path,
                mission: list[tuple[float, float]] | None = None) -> tuple[Companion, StatusTexts]:
    """One companion run to the short waypoint (or through ``mission``, uploaded first), with the simulator's
    STATUSTEXTs collected on channel 0."""
    sim, _relay, port = lossy
    conn = sim.connect()
    if mission:
        upload_mission(conn, mission)
    texts = StatusTexts(conn)
    texts.start()
    companion = Companion(port, tmp_path / "companion", *RETRY_FLAGS, waypoint=None if mission else WAYPOINT)
    try:
        code = companion.wait(float(os.environ.get("LINK_FAULTS_TIMEOUT", "240")))
    finally:
        companion.stop()
        texts.running = False
        texts.join(timeout=2)
    assert code == 0, "\n".join(companion.lines[-30:])
    return companion, texts


def assert_no_give_up(companion: Companion) -> None:
    """Nothing abandoned: no give-up line, no unanswered command, no unread parameter, none assumed."""
    bad = [line for line in companion.lines if line.startswith("link:") or "not accepted" in line
           or "not readable" in line or "assuming" in line or "refusing" in line]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("lossy", [Faults(loss=0.4)], indirect=True, ids=["loss40"])
def test_forty_percent_loss_each_way_reads_every_parameter_downloads_the_mission_and_arrives(lossy,
                                                                                           tmp_path: Path) -> None:
    companion, texts = run_through(lossy, tmp_path, mission=[(12.0, 9.0), (20.0, 15.0)])
    metrics = companion.metrics()
    assert metrics["phase"] == "ARRIVED", metrics
    assert_no_give_up(companion)
    assert any(line.startswith("parameters: 19 parameters read") for line in companion.lines), companion.lines[:8]
    assert any("2 waypoints from the mission" in line for line in companion.lines), companion.lines[:12]
    relay = lossy[1].summary()
    assert relay["down"]["dropped"] > 0.3 * relay["down"]["received"], relay
    assert relay["up"]["dropped"] > 0.3 * relay["up"]["received"], relay
    link = metrics["link"]
    assert link["retries_param"] > 0 and link["retries_mission"] > 0, link  # both had to ask again
    assert link["retries"] == sum(link[f"retries_{kind}"] for kind in RETRY_KINDS), link
    assert texts.texts["Throttle armed"] == 1, texts.texts
    sent_again = [m for m in received_commands(lossy[0]) if m.confirmation > 0]
    assert sent_again, "at 40 % loss some command must have arrived as a resend (confirmation > 0)"
    print(f"\n40 % loss: {metrics['link']}, relay {relay}, time {metrics['time_to_waypoint_s']} s")


@pytest.mark.parametrize("lossy", [Faults(loss=0.3, delay_s=0.1, jitter_s=0.05, duplicate=0.2, reorder=0.1)],
                         indirect=True, ids=["loss30-dup-reorder"])
def test_thirty_percent_loss_with_duplicates_executes_each_command_once(lossy, tmp_path: Path) -> None:
    """ARM and the mode change arrive several times (resends, duplicates), take effect once, and are ACKed."""
    companion, texts = run_through(lossy, tmp_path)
    assert companion.metrics()["phase"] == "ARRIVED"
    assert_no_give_up(companion)
    commands = received_commands(lossy[0])
    arms = [m for m in commands if m.command == ARM and m.param1 == 1]
    modes = [m for m in commands if m.command == DO_SET_MODE]
    assert arms and modes, "the simulator's log must hold the companion's ARM and mode commands"
    repeats = Counter((m.command, m.param1, m.param2) for m in commands)
    assert max(repeats.values()) > 1, f"no command arrived twice (resend or duplicate): {repeats}"
    assert texts.texts["Throttle armed"] == 1, texts.texts  # executed once however often it arrived
    assert texts.texts["Throttle disarmed"] == 0, texts.texts


def test_the_check_through_forty_percent_loss_judges_the_boat_not_the_link(tmp_path: Path) -> None:
    """`mavbridge check` on the deployed configuration through the relay at 40 % loss each way: the parameters,
    GPS, home and the mission (downloaded) pass as on a clean link; a request whose answer the relay drops is asked
    again (at 40 % loss one HOME_POSITION in 2.5 was lost, and the check said "no HOME_POSITION"). The stream
    rates are measured through the loss (60 % of the sent rate arrives), so they are not judged here."""
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(tmp_path / "sim", speedup=SPEEDUP, udp_outs=2, extra=[HOME, "--wipe", "--params", str(PARM)])
    faults = Faults(loss=0.4)
    with ChaosRelay(port, faults, faults, seed=1, time_scale=SPEEDUP, port=sim.udp_ports[1]) as relay, sim:
        upload_waypoint(sim.connect(), 20, 15, home=(-35.363261, 149.165230))
        out = io.StringIO()
        with redirect_stdout(out):
            main(["check", "--config", str(ROOT / "deploy" / "companion-sim.yaml"), "--connect",
                  f"udpin:127.0.0.1:{port}", "--timeout", "10", "--solves", "0", *RETRY_FLAGS])
        summary = relay.summary()
    text = out.getvalue()
    rows = check_rows(text)
    failed = [item for item, row in rows.items() if row[0] == FAIL and " rate " not in item and "IMU" not in item]
    assert not failed, text
    for item in ("parameters the commands need", "GPS fix", "home position", "mission waypoint", "RC1_MIN/TRIM/MAX"):
        assert rows.get(item, ("missing",))[0] == PASS, f"{item}: {rows.get(item)}\n{text}"
    assert "item 1 of 1" in rows["mission waypoint"][2], text  # from the downloaded mission
    assert summary["down"]["dropped"] > 0.3 * summary["down"]["received"], summary
