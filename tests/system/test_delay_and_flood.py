"""The companion over a slow link and under a hostile flood: real `sim-vehicle` and `mavbridge run` processes.

Paced runs (lockstep cannot wait through a relay, and in lockstep the state's age is zero by construction).
What is checked holds under load: the waypoint is reached, the logged age of the state matches the relay's
delay (in simulated time, which the relay's delay is given in), the flood's packets were all counted as
foreign while the companion flew, and no traceback appeared. Waits are on the companion's own lines and on
its exit, each with a timeout that names what was awaited.
"""

from __future__ import annotations

import socket
import statistics
from pathlib import Path

import pytest

from bench.chaos_relay import ChaosRelay, Faults
from bench.hostile_flood import MESSAGE_TYPES, HostileFlood
from sim_vehicle.harness import SimProcess, free_port
from tests.system.test_companion_sitl import HOME, Companion

pytestmark = [pytest.mark.slow, pytest.mark.integration]
SPEEDUP = 5.0
DELAY_S, JITTER_S = 0.4, 0.1  # the acceptance: 400 ms one-way, 100 ms jitter (simulated s, each way)
FLOOD = 2000  # hostile packets (every message type several times)


def test_compensated_run_through_a_slow_link_reaches_and_logs_the_links_delay(tmp_path: Path) -> None:
    faults = Faults(delay_s=DELAY_S, jitter_s=JITTER_S)
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(tmp_path / "sim", speedup=SPEEDUP, waves="paper", extra=[HOME, "--wipe"], udp_outs=1)
    with ChaosRelay(port, faults, faults, seed=1, time_scale=SPEEDUP, port=sim.udp_ports[0]), sim:
        companion = Companion(port, tmp_path / "companion", waypoint="20,15")
        try:
            code = companion.wait(240)
        finally:
            companion.stop()
    assert code == 0, "\n".join(companion.lines[-30:])
    metrics = companion.metrics()
    assert metrics["phase"] == "ARRIVED", metrics
    delay = metrics["delay"]
    assert delay["compensation"] == "on"
    ages = [float(row["state_age_s"]) for row in companion.rows()]
    assert len(ages) == metrics["steps"] and delay["state_age_s_median"] == pytest.approx(statistics.median(ages),
                                                                                          abs=1e-3)
    # never younger than the fastest datagram; older only by jitter and the companion's own reading latency
    assert DELAY_S - JITTER_S <= delay["state_age_s_median"] <= DELAY_S + JITTER_S + 0.15, delay
    assert 2 * (DELAY_S - JITTER_S) <= delay["round_trip_autopilot_s"] <= 2 * (DELAY_S + JITTER_S) + 0.2, delay
    assert delay["prediction_s_median"] > delay["state_age_s_median"] + (DELAY_S - JITTER_S) - 0.05, delay
    print(f"\n{DELAY_S * 1000:.0f} ± {JITTER_S * 1000:.0f} ms each way: {delay}, avg roll {metrics['avg_roll_deg']}")


def test_hostile_flood_on_the_companions_port_while_it_flies(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=SPEEDUP, waves="paper", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        port = sim.udp_ports[0]
        companion = Companion(port, tmp_path / "companion")  # Balanced's 85,75: the flood ends well before it
        flood = HostileFlood(port, FLOOD, rate=1000.0, seed=3)
        try:
            assert companion.wait_line("phase: engaged", 120), "the companion never engaged:\n" + \
                "\n".join(companion.lines[-20:])
            flood.start()
            code = companion.wait(240)
        finally:
            flood.running = False
            companion.stop()
    assert flood.done.is_set() and flood.sent == FLOOD, f"the flood outlasted the flight: {flood.sent} of {FLOOD} sent"
    assert len(flood.types) == len(MESSAGE_TYPES)
    tracebacks = [line for line in companion.lines if "Traceback" in line]
    assert not tracebacks, "\n".join(companion.lines[-40:])
    assert code == 0, "\n".join(companion.lines[-30:])
    metrics = companion.metrics()
    assert metrics["phase"] == "ARRIVED", metrics
    assert metrics["link"]["foreign"] >= 0.95 * FLOOD, metrics["link"]  # read and refused, while it flew
    print(f"\nflood of {FLOOD}: {metrics['link']}, avg roll {metrics['avg_roll_deg']}, "
          f"arrival {metrics['time_to_waypoint_s']} s")
