"""The companion through a lossy radio: real `sim-vehicle` and `mavbridge run` with the chaos relay between them.

Paced runs (lockstep cannot wait for a command the relay lost): what is checked holds under load — the
companion arms, switches mode, reads its parameters and reaches a short waypoint; every command is
acknowledged within its retry budget; the simulator executes each once however often it was sent.
"""

from __future__ import annotations

import os
import socket
import threading
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil

from bench.chaos_relay import ChaosRelay, Faults
from sim_vehicle.harness import SimProcess, free_port
from tests.rover import ARM, DO_SET_MODE
from tests.system.test_companion_sitl import HOME, Companion

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


def run_through(lossy: tuple[SimProcess, ChaosRelay, int], tmp_path: Path) -> tuple[Companion, StatusTexts]:
    """One companion run to the short waypoint, with the simulator's STATUSTEXTs collected on channel 0."""
    sim, _relay, port = lossy
    texts = StatusTexts(sim.connect())
    texts.start()
    companion = Companion(port, tmp_path / "companion", *RETRY_FLAGS, waypoint=WAYPOINT)
    try:
        code = companion.wait(float(os.environ.get("LINK_FAULTS_TIMEOUT", "240")))
    finally:
        companion.stop()
        texts.running = False
        texts.join(timeout=2)
    assert code == 0, "\n".join(companion.lines[-30:])
    return companion, texts


def assert_no_give_up(companion: Companion) -> None:
    """Nothing abandoned: no give-up line, no unanswered command, no unread parameter."""
    bad = [line for line in companion.lines if line.startswith("link:") or "not accepted" in line
           or "not readable" in line]
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("lossy", [Faults(loss=0.4)], indirect=True, ids=["loss40"])
def test_forty_percent_loss_each_way_arms_reads_and_arrives(lossy, tmp_path: Path) -> None:
    companion, texts = run_through(lossy, tmp_path)
    metrics = companion.metrics()
    assert metrics["phase"] == "ARRIVED", metrics
    assert_no_give_up(companion)
    relay = lossy[1].summary()
    assert relay["down"]["dropped"] > 0.3 * relay["down"]["received"], relay
    assert relay["up"]["dropped"] > 0.3 * relay["up"]["received"], relay
    assert metrics["link"]["retries"] > 0, metrics["link"]
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
