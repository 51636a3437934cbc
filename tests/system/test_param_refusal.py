"""Never assume what moves the boat (issue 32): real `sim-vehicle` and `mavbridge run` / `check` processes.

A parameter the commands depend on that the autopilot does not have (``sim-vehicle --hide-params``, answered with
PARAM_ERROR as recent ArduPilot does) or never answers for (``--no-param-error``, as older firmware) stops the
companion before it sends anything but parameter reads: one line naming the parameter, exit 1, the autopilot
neither armed nor switched; `mavbridge check` judges it the same way. What may stay unread is the one table of
``mavbridge.companion.parameters``.
"""

from __future__ import annotations

import io
import subprocess
import sys
import time
from contextlib import redirect_stdout
from pathlib import Path

import pytest
from pymavlink import mavutil

from mavbridge.cli import main
from mavbridge.companion.parameters import OPTIONAL, first_round, second_round
from sim_vehicle.harness import SimProcess
from tests.system.test_companion_sitl import HOME

pytestmark = pytest.mark.integration
ROOT = Path(__file__).resolve().parents[2]
READS_ONLY = {"HEARTBEAT", "PARAM_REQUEST_READ", "TIMESYNC"}  # (heartbeats and TIMESYNC are the link's own)


def run(port: int, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    """`mavbridge run --arm --set-mode` to a short waypoint (it must not get that far)."""
    cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--arm",
           "--set-mode", "--waypoint", "20,15", "--out", str(out), *extra]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180)


def sent_by_companion(tlog: Path, component: int = 191) -> dict[str, list]:
    """Every message the companion (255/``component``) sent, by type, from a .tlog."""
    log = mavutil.mavlink_connection(str(tlog))
    sent: dict[str, list] = {}
    while (msg := log.recv_match()) is not None:
        if (msg.get_srcSystem(), msg.get_srcComponent()) == (255, component) and msg.get_type() != "BAD_DATA":
            sent.setdefault(msg.get_type(), []).append(msg)
    return sent


def test_a_parameter_the_autopilot_lacks_is_refused_in_one_line_and_nothing_but_reads_is_sent(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=5, extra=[HOME, "--wipe", "--hide-params", "RC3_TRIM"],
                    udp_outs=2) as sim:
        done = run(sim.udp_ports[0], tmp_path / "run")
        out = io.StringIO()
        with redirect_stdout(out):  # (as component 190: its requests are told apart from the run's in the tlog)
            code = main(["check", "--connect", f"udpin:127.0.0.1:{sim.udp_ports[1]}", "--timeout", "10",
                         "--solves", "0", "--waypoint", "20,15", "--compid", "190"])
    sent = sent_by_companion(sim.log_dir / "sim_vehicle.tlog")  # what reached the autopilot (its log, closed)
    assert done.returncode == 1, done.stdout + done.stderr
    naming = [line for line in done.stdout.splitlines() if "RC3_TRIM" in line]
    assert naming == ["mavbridge run: error: refusing to engage: the autopilot has no RC3_TRIM; the commands "
                      "depend on it"], done.stdout
    assert set(sent) <= READS_ONLY, sorted(set(sent) - READS_ONLY)  # no command, override, mission or stream request
    asked = {str(m.param_id) for m in sent["PARAM_REQUEST_READ"]}
    assert {"RCMAP_ROLL", "RCMAP_THROTTLE", "RC3_TRIM", "RC1_TRIM", "PILOT_STEER_TYPE", "SERVO1_FUNCTION"} <= asked
    # mavbridge check: the same judgement, as one FAIL (exit 1)
    row = next(line for line in out.getvalue().splitlines() if "parameters the commands need" in line)
    assert code == 1 and row.startswith("FAIL") and "the autopilot has no RC3_TRIM" in row, out.getvalue()


def test_a_parameter_that_is_never_answered_is_refused_when_the_budget_is_spent(tmp_path: Path) -> None:
    """Older firmware answers nothing for a name it lacks: asked again every --command-timeout until the
    --param-budget is spent, then one line naming it (and the other one unread)."""
    hidden = ["--hide-params", "PILOT_STEER_TYPE,RC1_DZ", "--no-param-error"]
    with SimProcess(tmp_path / "sim", speedup=5, extra=[HOME, "--wipe", *hidden], udp_outs=1) as sim:
        start = time.monotonic()
        done = run(sim.udp_ports[0], tmp_path / "run", "--param-budget", "3", "--command-timeout", "0.3")
        took = time.monotonic() - start
    assert done.returncode == 1, done.stdout + done.stderr
    refusal = [line for line in done.stdout.splitlines() if "refusing to engage" in line]
    assert len(refusal) == 1, done.stdout
    assert refusal[0].startswith("mavbridge run: error: refusing to engage: PILOT_STEER_TYPE not readable: no answer "
                                 "to "), refusal[0]
    assert "within the 3 s parameter budget (also unread: RC1_DZ)" in refusal[0], refusal[0]
    assert "--param-budget" in refusal[0]
    sent = sent_by_companion(tmp_path / "run" / "companion.tlog")
    assert set(sent) <= READS_ONLY, sorted(set(sent) - READS_ONLY)
    asks = [m for m in sent["PARAM_REQUEST_READ"] if m.param_id == "PILOT_STEER_TYPE"]
    assert len(asks) >= 5, len(asks)  # asked again every 0.3 s while the 3 s lasted
    assert took >= 3.0  # (a lower bound: the budget was spent, however slow the machine)


def test_guided_refuses_without_the_speed_that_scales_its_thrust(tmp_path: Path) -> None:
    """attitude_target without WP_SPEED: refused (it used to fly on an assumed 2 m/s)."""
    with SimProcess(tmp_path / "sim", speedup=5, extra=[HOME, "--wipe", "--hide-params", "WP_SPEED"],
                    udp_outs=1) as sim:
        done = run(sim.udp_ports[0], tmp_path / "run", "--output", "attitude_target")
    assert done.returncode == 1, done.stdout + done.stderr
    assert "mavbridge run: error: refusing to engage: the autopilot has no WP_SPEED;" in done.stdout, done.stdout
    assert set(sent_by_companion(tmp_path / "run" / "companion.tlog")) <= READS_ONLY


def test_what_may_stay_unread_is_one_table_with_a_reason_each() -> None:
    """Every parameter some output asks for only briefly is in ``OPTIONAL`` with its reason; nothing that turns
    forces into commands (RC calibration, RCMAP, steer type, mixer, speed scale) is among them."""
    asked = [r for output, form in (("rc_override", None), ("attitude_target", "rate"), ("attitude_target", "tau"))
             for r in first_round(output, form)]
    asked += second_round("rc_override", {"RCMAP_ROLL": 1, "RCMAP_THROTTLE": 3})
    optional = {n for r in asked if not r.required for n in r.names}
    assert optional == {n for n, leeway in OPTIONAL.items() if leeway.unread_ok}
    assert all(len(leeway.reason) > 40 for leeway in OPTIONAL.values())
    never = {"RCMAP_ROLL", "RCMAP_THROTTLE", "PILOT_STEER_TYPE", "RC3_TRIM", "RC1_REVERSED", "SERVO1_FUNCTION",
             "FRAME_CLASS", "WP_SPEED", "CRUISE_THROTTLE", "ATC_STR_RAT_FF"}
    assert never <= {n for r in asked if r.required for n in r.names} and not never & set(OPTIONAL)
