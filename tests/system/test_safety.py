"""Safe by default (issue 17): real `sim-vehicle`, `mission` and `mavbridge run` processes over UDP loopback.

A far waypoint is never flown (no RC_CHANNELS_OVERRIDE leaves the companion), a second companion on a port
refuses, a link lost for longer than 10 s is a failure (exit 1), and the companion says that it waits for
the pilot. What is awaited is a line the companion prints or its exit; every wait has a bound that names it.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from pymavlink import mavutil

from mavbridge.cli.args import REAL_TIME_SOLVER
from sim_vehicle.harness import SimProcess, free_port
from tests.waits import WaitTimeoutError

HOME = "--home=-35.363261,149.165230,584,90"
pytestmark = pytest.mark.slow


class Run:
    """A `mavbridge run` child whose output lines are collected as they come."""

    def __init__(self, port: int, out: Path, *extra: str) -> None:
        self.out = out
        cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--out",
               str(out), *extra]
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.lines: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.rstrip())

    def text(self) -> str:
        """Everything printed so far."""
        return "\n".join(self.lines)

    def await_line(self, text: str, timeout: float) -> None:
        """Block until a line containing ``text`` was printed; WaitTimeoutError naming it otherwise."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if any(text in line for line in self.lines):
                return
            if self.proc.poll() is not None:
                time.sleep(0.3)  # the reader thread's last lines
                if any(text in line for line in self.lines):
                    return
                break
            time.sleep(0.05)
        raise WaitTimeoutError(f"no line with {text!r} from mavbridge run within {timeout:g} s:\n{self.text()}")

    def wait(self, timeout: float) -> int:
        """The exit code; WaitTimeoutError (after killing it) if it runs longer than ``timeout``."""
        try:
            return self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            self.stop()
            raise WaitTimeoutError(f"mavbridge run did not end within {timeout:g} s:\n{self.text()}") from None

    def stop(self) -> None:
        """Kill it if it still runs."""
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


@pytest.fixture
def runs() -> Iterator[list[Run]]:
    started: list[Run] = []
    yield started
    for run in started:
        run.stop()


def _upload(port: int, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mission.cli", "upload", *args, "--connect",
                           f"udpin://127.0.0.1:{port}", "--timeout", "20"], capture_output=True, text=True, timeout=120)


def _sent(tlog: Path, kind: str, commands: tuple[int, ...] = ()) -> int:
    """How many ``kind`` messages (COMMAND_LONG: with one of ``commands``) the companion sent; its tlog holds
    both ways, ours are from system 255."""
    log = mavutil.mavlink_connection(str(tlog), dialect="ardupilotmega")
    count = 0
    while (msg := log.recv_match(type=kind)) is not None:
        count += msg.get_srcSystem() == 255 and (not commands or msg.command in commands)
    log.close()
    return count


def test_far_mission_is_refused_before_arming_and_no_override_is_sent(tmp_path: Path, runs: list[Run]) -> None:
    """A 6 km mission (uploaded with a raised --max-range) against the companion's default 5 km."""
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe"], udp_outs=2) as sim:
        gcs_port, companion_port = sim.udp_ports
        refused = _upload(gcs_port, "--waypoint", "6000,0")
        assert refused.returncode == 2 and "--max-range 5000 m" in refused.stderr, refused.stderr
        uploaded = _upload(gcs_port, "--waypoint", "6000,0", "--max-range", "7000")
        assert uploaded.returncode == 0, uploaded.stderr
        run = Run(companion_port, tmp_path / "far", "--arm", "--set-mode")
        runs.append(run)
        assert run.wait(180) == 1, run.text()
        gcs = sim.connect(source_system=250)
        heartbeat = gcs.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
    assert any("farther than --max-range 5000 m: not engaging" in line for line in run.lines), run.text()
    assert "6.0 km from home" in run.text()
    assert _sent(tmp_path / "far" / "companion.tlog", "HEARTBEAT") > 0  # the log did record what it sent
    assert _sent(tmp_path / "far" / "companion.tlog", "RC_CHANNELS_OVERRIDE") == 0
    arm_or_mode = (mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavutil.mavlink.MAV_CMD_DO_SET_MODE)
    assert _sent(tmp_path / "far" / "companion.tlog", "COMMAND_LONG", arm_or_mode) == 0  # neither armed nor moded
    assert _sent(tmp_path / "far" / "companion.tlog", "COMMAND_LONG") > 0  # (it did ask for its streams)
    assert heartbeat is not None and heartbeat.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED == 0


def test_far_waypoint_flag_is_refused_before_connecting(tmp_path: Path) -> None:
    """`--waypoint` beyond `--max-range`: one line naming both flags, exit 2, no run folder written."""
    out = tmp_path / "never"
    port = free_port(socket.SOCK_DGRAM)
    done = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}",
                           "--waypoint", "10000000,0", "--out", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "--waypoint" in done.stderr and "--max-range 5000 m" in done.stderr
    assert not out.exists()


def test_second_companion_on_a_port_refuses_and_the_first_waits_for_the_pilot(tmp_path: Path,
                                                                               runs: list[Run]) -> None:
    """The first companion (no --arm / --set-mode) waits and says so; a second one on its port refuses at once."""
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe"], udp_outs=2) as sim:
        gcs_port, companion_port = sim.udp_ports
        assert _upload(gcs_port, "--waypoint", "85,75").returncode == 0
        first = Run(companion_port, tmp_path / "first")
        runs.append(first)
        first.await_line("waiting for the pilot to switch to MANUAL", 120)
        second = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--connect",
                                 f"udpin:0.0.0.0:{companion_port}", "--out", str(tmp_path / "second")],
                                capture_output=True, text=True, timeout=120)
        assert first.proc.poll() is None, first.text()  # the first one is untouched
    assert second.returncode == 1, second.stderr
    assert f"UDP port {companion_port}" in second.stderr and "already in use" in second.stderr
    assert second.stderr.count("\n") == 1, second.stderr


def test_link_lost_for_more_than_10_s_ends_the_run_with_exit_1(tmp_path: Path, runs: list[Run]) -> None:
    """Engaged, then the autopilot falls silent (SIGSTOP): a failure that systemd's Restart=on-failure sees."""
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe"], udp_outs=2) as sim:
        gcs_port, companion_port = sim.udp_ports
        assert _upload(gcs_port, "--waypoint", "300,0").returncode == 0
        run = Run(companion_port, tmp_path / "lost", "--arm", "--set-mode")
        runs.append(run)
        run.await_line("phase: engaged", 120)
        assert sim.proc is not None
        os.kill(sim.proc.pid, signal.SIGSTOP)
        try:
            code = run.wait(90)
        finally:
            os.kill(sim.proc.pid, signal.SIGCONT)
    assert code == 1, run.text()
    assert "error: link lost for more than 10 s" in run.text()


def test_run_and_check_default_to_the_real_time_solver(tmp_path: Path) -> None:
    """No --solver: `check` times the real-time default (nrti; its header says so), `run` records it in its
    config.yaml."""
    check = subprocess.run([sys.executable, "-m", "mavbridge.cli", "check", "--connect",
                            f"udpin:127.0.0.1:{free_port(socket.SOCK_DGRAM)}", "--timeout", "0.5", "--solves", "0"],
                           capture_output=True, text=True, timeout=120)
    assert f"scenario balanced ({REAL_TIME_SOLVER}," in check.stdout, check.stdout + check.stderr
    config = tmp_path / "companion.yaml"
    config.write_text("connect_timeout_s: 0.5\n")
    run = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--config", str(config), "--connect",
                          f"udpin:127.0.0.1:{free_port(socket.SOCK_DGRAM)}", "--out", str(tmp_path / "run")],
                         capture_output=True, text=True, timeout=180)
    assert run.returncode == 1, run.stdout + run.stderr  # nobody answered
    assert f"solver: {REAL_TIME_SOLVER}" in (tmp_path / "run" / "config.yaml").read_text()


def test_tau_form_against_a_d_term_is_refused_before_arming(tmp_path: Path, runs: list[Run]) -> None:
    """`--attitude-form tau` against an autopilot with a turn-rate D term on (it kicks at every new target): one
    line naming the parameter and the fix, exit 1, neither armed nor moded and no SET_ATTITUDE_TARGET sent."""
    parm = tmp_path / "d.parm"
    parm.write_text("ATC_STR_RAT_D,0.05\n")
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe", "--params", str(parm)],
                    udp_outs=1) as sim:
        run = Run(sim.udp_ports[0], tmp_path / "tau", "--output", "attitude_target", "--attitude-form", "tau",
                  "--arm", "--set-mode", "--waypoint", "85,75")
        runs.append(run)
        assert run.wait(180) == 1, run.text()
    refusal = [line for line in run.lines if "attitude_form tau" in line]
    assert len(refusal) == 1 and "attitude_form tau: ATC_STR_RAT_D is 0.05; set it to 0" in refusal[0], run.text()
    assert "attitude_form rate" in refusal[0], run.text()
    tlog = tmp_path / "tau" / "companion.tlog"
    arm_or_mode = (mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavutil.mavlink.MAV_CMD_DO_SET_MODE)
    assert _sent(tlog, "COMMAND_LONG", arm_or_mode) == 0 and _sent(tlog, "SET_ATTITUDE_TARGET") == 0
    assert _sent(tlog, "PARAM_REQUEST_READ") > 0  # (it did read the gains it refused)


def test_tau_form_with_rovers_stock_integrators_closes_on_the_servo_outputs(tmp_path: Path, runs: list[Run]) -> None:
    """The default GUIDED form against Rover's stock gains (integrators on): taken, SERVO_OUTPUT_RAW asked for and
    followed, said at start."""
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        run = Run(sim.udp_ports[0], tmp_path / "tau", "--output", "attitude_target", "--dry-run", "--waypoint",
                  "85,75")
        runs.append(run)
        run.await_line("closed on SERVO_OUTPUT_RAW", 120)
        run.proc.terminate()  # as systemd stops it: the tlog is closed (a kill may leave its last writes unflushed)
        assert run.proc.wait(60) == 0, run.text()
    assert not any("attitude_form tau:" in line for line in run.lines), run.text()  # not refused
    assert _sent(tmp_path / "tau" / "companion.tlog", "COMMAND_LONG") > 0  # the interval request among them


def test_tau_form_warns_of_what_flies_but_not_as_planned(tmp_path: Path, runs: list[Run]) -> None:
    """Integrators and D terms off but Rover's WP_SPEED 2 and no ATC_BRAKE: the form is taken (no refusal) and the
    companion warns, before it flies, that full throttle is cut and which parameters it took as defaults; the
    output feedback is used where SERVO_OUTPUT_RAW streams, integrators on or off."""
    parm = tmp_path / "gains.parm"
    parm.write_text("ATC_STR_RAT_I,0\nATC_SPEED_I,0\nATC_STR_RAT_D,0\nATC_SPEED_D,0\n")
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe", "--params", str(parm)],
                    udp_outs=1) as sim:
        run = Run(sim.udp_ports[0], tmp_path / "tau", "--output", "attitude_target", "--attitude-form", "tau",
                  "--dry-run", "--waypoint", "85,75")
        runs.append(run)
        run.await_line("absent from the autopilot", 120)
        run.stop()
    warnings = [line for line in run.lines if "warning: GUIDED tau form:" in line]
    assert len(warnings) == 2 and "WP_SPEED 2 m/s caps Rover's speed target" in warnings[0], run.text()
    assert "ATC_SPEED_FF, ATC_BRAKE absent from the autopilot" in warnings[1], run.text()
    assert not any("attitude_form tau:" in line for line in run.lines), run.text()  # not refused
