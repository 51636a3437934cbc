"""The companion link's retries against the real simulator: give-ups in one line, resends that do no harm,
and the flags that set them (one-line errors, exit 2)."""

from __future__ import annotations

import itertools
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from bench.chaos_relay import ChaosRelay, Faults
from mavbridge.link.connection import Link
from mavbridge.link.retry import RetryPolicy, RetrySettings
from sim_vehicle.harness import SimProcess, free_port
from tests.rover import ACCEPTED, ARM, MANUAL
from tests.waits import command_texts, set_mode

pytestmark = pytest.mark.integration


@pytest.fixture
def deaf_link(tmp_path: Path) -> Iterator[tuple[Link, list[str], ChaosRelay]]:
    """A companion Link whose every datagram to the simulator is lost (telemetry still arrives)."""
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(tmp_path / "sim", speedup=5.0, udp_outs=1)
    lines: list[str] = []
    with ChaosRelay(port, Faults(), Faults(loss=1.0), time_scale=5.0, port=sim.udp_ports[0]) as relay, sim:
        link = Link(f"udpin:127.0.0.1:{port}", settings=RetrySettings(0.1, 2), log=lines.append)
        try:
            link.wait_autopilot(30)
            yield link, lines, relay
        finally:
            link.close()


def test_an_unanswered_command_is_sent_three_times_then_one_line(deaf_link) -> None:
    link, lines, relay = deaf_link
    before = relay.up.received
    assert link.arm() is None
    assert lines == ["link: COMMAND_LONG MAV_CMD_COMPONENT_ARM_DISARM: no COMMAND_ACK after 3 tries (0.1 s each)"]
    assert link.counts["retries"] == 2
    assert relay.up.received - before >= 3  # (heartbeats may be among them)


def test_an_unanswered_parameter_read_gives_up_in_one_line(deaf_link) -> None:
    link, lines, _relay = deaf_link
    assert link.read_parameter("RC1_MAX", RetryPolicy(0.05, 0)) is None
    assert lines == ["link: PARAM_REQUEST_READ RC1_MAX: no PARAM_VALUE after 1 try (0.05 s each)"]


def test_the_simulator_runs_a_repeated_arm_and_mode_once(tmp_path: Path) -> None:
    """ArduPilot does not de-duplicate on confirmation: ARM when armed and the mode it is in are ACCEPTED again
    with no second effect (no second "Throttle armed")."""
    with SimProcess(tmp_path / "sim", speedup=5.0) as sim:
        conn = sim.connect()
        first, texts_first = command_texts(conn, ARM, 1, 2989)
        second, texts_second = command_texts(conn, ARM, 1, 2989)
        assert (first, second) == (ACCEPTED, ACCEPTED)
        assert "Throttle armed" in texts_first and "Throttle armed" not in texts_second
        assert set_mode(conn, MANUAL) == ACCEPTED and set_mode(conn, MANUAL) == ACCEPTED


def mavbridge(*args: str, config: Path | None = None) -> subprocess.CompletedProcess[str]:
    cmd = [sys.executable, "-m", "mavbridge.cli", *args, *(["--config", str(config)] if config else [])]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize(("sub", "flag", "value", "expected"), [
    ("run", "--command-timeout", "0", "argument --command-timeout: '0' is outside the allowed range: finite and > 0 s"),
    ("run", "--command-timeout", "nan",
     "argument --command-timeout: 'nan' is outside the allowed range: finite and > 0 s"),
    ("check", "--command-retries", "-1", "argument --command-retries: -1 is outside the allowed range >= 0"),
    ("check", "--param-budget", "nan", "argument --param-budget: 'nan' is outside the allowed range: finite and > 0 s"),
])
def test_bad_retry_flags_are_one_line_and_exit_2(sub: str, flag: str, value: str, expected: str) -> None:
    result = mavbridge(sub, flag, value)
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.strip().splitlines() == [f"mavbridge {sub}: error: {expected}"]


def test_a_parameter_budget_out_of_range_is_one_line_and_exit_2() -> None:
    result = mavbridge("run", "--param-budget", "0.5")
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.strip().splitlines() == ["mavbridge: error: --param-budget: 0.5 is outside the allowed range "
                                                  "[1, 600] s"]


@pytest.mark.parametrize(("field", "value", "expected"), [
    ("command_retries", -1, "command_retries: -1 is outside the allowed range [0, 1000]"),
    ("command_timeout_s", 0, "command_timeout_s: 0 is outside the allowed range (0, 60] s"),
    ("param_budget_s", 1000, "param_budget_s: 1000 is outside the allowed range [1, 600] s"),
])
def test_bad_retry_settings_in_the_yaml_are_one_line_and_exit_2(tmp_path: Path, field: str, value: float,
                                                                  expected: str) -> None:
    config = tmp_path / "companion.yaml"
    config.write_text(f"{field}: {value}\n")
    result = mavbridge("run", "--waypoint", "10,10", config=config)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0], result.stderr


def test_duplicated_datagrams_and_late_heartbeats_are_dropped(tmp_path: Path) -> None:
    """Every datagram twice, a fifth held back: each message passes once; a HEARTBEAT overtaken by a newer one
    is dropped (it would report an old armed state); other late messages pass."""
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(tmp_path / "sim", speedup=5.0, udp_outs=1)
    down = Faults(duplicate=1.0, reorder=0.2, reorder_s=0.2)
    with ChaosRelay(port, down, Faults(), time_scale=5.0, port=sim.udp_ports[0]) as relay, sim:
        link = Link(f"udpin:127.0.0.1:{port}")
        try:
            link.wait_autopilot(30)
            link.request_message_interval(0, 20.0)  # heartbeats at 20 Hz: some are overtaken
            seen: list[tuple[int, str]] = []
            link.handlers.append(lambda m: seen.append((m.get_seq(), m.get_type())))
            link.wait_for(lambda m: False, 3.0)
        finally:
            link.close()
    assert relay.down.duplicated > 50 and link.counts["stale"] >= relay.down.duplicated * 0.9, link.counts
    seqs = [seq for seq, _ in seen]
    assert all(seq not in seqs[max(0, i - 63):i] for i, seq in enumerate(seqs)), "a duplicate got through"
    beats = [seq for seq, kind in seen if kind == "HEARTBEAT"]
    assert len(beats) > 10 and all(0 < (b - a) % 256 < 128 for a, b in itertools.pairwise(beats)), beats
    assert any((b - a) % 256 >= 128 for a, b in itertools.pairwise(seqs)), "no late message passed (reorder 20 %)"
