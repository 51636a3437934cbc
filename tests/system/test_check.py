"""`mavbridge check` against a real `sim-vehicle` process running the deployed parameter file.

The simulator loads deploy/otter-rover.parm (plus one deliberate mistake per failing case); the check
connects to its second UDP output, which is stream-rate channel 2 (SR2_*) like the boat's SERIAL2.
"""

from __future__ import annotations

import io
from contextlib import redirect_stdout
from pathlib import Path

import pytest

from mavbridge.cli import main
from mavbridge.preflight.report import FAIL, PASS, WARN, Report
from mavbridge.preflight.rules import (
    Context,
    enforced_violations,
    parameter_findings,
    rc_findings,
    tau_form_findings,
)
from sim_vehicle.harness import SimProcess
from sim_vehicle.rover.params import ParamTable, read_parm
from tests.waits import upload_waypoint

ROOT = Path(__file__).resolve().parents[2]
PARM = ROOT / "deploy" / "otter-rover.parm"
pytestmark = pytest.mark.slow


def _check(tmp_path: Path, extra_parm: str = "", *args: str, waypoint: tuple[float, float] | None = (85, 75)
           ) -> tuple[int, str, dict[str, tuple[str, str, str, str]]]:
    """Start the simulator on the deployed .parm (+ extra lines), run the check; (exit code, text, rows)."""
    parm = tmp_path / "boat.parm"
    parm.write_text(PARM.read_text() + "\n# test override\n" + extra_parm + "\n")
    with SimProcess(tmp_path, speedup=5, udp_outs=2, extra=["--params", str(parm)]) as sim:
        if waypoint is not None:
            upload_waypoint(sim.connect(), *waypoint)
        out = io.StringIO()
        with redirect_stdout(out):
            code = main(["check", "--config", str(ROOT / "deploy" / "companion-sim.yaml"),
                         "--connect", f"udpin:127.0.0.1:{sim.udp_ports[1]}", "--timeout", "10", *args])
    text = out.getvalue()
    return code, text, check_rows(text)


def check_rows(text: str) -> dict[str, tuple[str, str, str, str]]:
    """The check's printed table: {item: (result, expected, actual, fix)}."""
    rows = {}
    for line in text.splitlines():
        status, _, rest = line.partition("  ")
        if status in (PASS, WARN, FAIL):
            cells = [c.strip() for c in rest.strip().split("  ") if c.strip()]
            rows[cells[0]] = (status, *cells[1:], "", "")[:4]
    return rows


def test_check_passes_on_the_deployed_configuration(tmp_path: Path) -> None:
    """Every item passes: parameters, rates as configured and after request, GPS, home, mission, solve time."""
    code, text, rows = _check(tmp_path, "", "--solver", "rti", "--solves", "30")
    assert code == 0, text
    assert not [name for name, row in rows.items() if row[0] == FAIL], text
    for item in ("heartbeat vehicle type", "SYSID_MYGCS", "SERVO1_FUNCTION", "SERVO3_FUNCTION", "FRAME_CLASS",
                 "RC_OVERRIDE_TIME", "RC1_MIN/TRIM/MAX", "RC3_MIN/TRIM/MAX", "WP_SPEED", "FS_ACTION",
                 "ATTITUDE rate as configured", "GLOBAL_POSITION_INT rate as configured",
                 "ATTITUDE rate after request", "GPS fix", "home position", "mission waypoint"):
        assert rows[item][0] == PASS, f"{item}: {rows.get(item)}\n{text}"
    # A measurement of this computer: a WARN when other work shares the cores, never a FAIL for rti.
    assert rows["NMPC solve time (rti)"][0] in (PASS, WARN), text
    assert "113 m" in rows["mission waypoint"][2]


def test_wrong_servo_function_fails_with_value_and_fix(tmp_path: Path) -> None:
    """SERVO1_FUNCTION 1 (RCPassThru) instead of 73: FAIL naming it, the value and the fix."""
    code, text, rows = _check(tmp_path, "SERVO1_FUNCTION,1", "--solves", "0", waypoint=None)
    assert code == 1
    status, expected, actual, fix = rows["SERVO1_FUNCTION"]
    assert (status, actual) == (FAIL, "1") and "73" in expected and "set SERVO1_FUNCTION 73" in fix, text
    assert rows["mission"][0] == FAIL  # nothing uploaded: also a FAIL, with the upload hint
    assert "mission upload" in rows["mission"][3]


def test_gcs_sysid_mismatch_fails(tmp_path: Path) -> None:
    """SYSID_MYGCS 254 while the companion is 255: the autopilot would ignore every RC override."""
    code, text, rows = _check(tmp_path, "SYSID_MYGCS,254", "--solves", "0")
    assert code == 1
    status, expected, actual, fix = rows["SYSID_MYGCS"]
    assert (status, actual) == (FAIL, "254") and expected.startswith("255"), text
    assert "set SYSID_MYGCS 255" in fix and "system_id: 254" in fix


def test_streams_off_on_the_companion_port_fail(tmp_path: Path) -> None:
    """SR2_EXTRA1/SR2_POSITION 0: the as-configured rates fail (naming the parameter and the fix) even though
    the companion's own request would bring them up: after a reboot the autopilot is back at its SR2 rates."""
    code, text, rows = _check(tmp_path, "SR2_EXTRA1,0\nSR2_POSITION,0", "--solves", "0")
    assert code == 1
    status, _, actual, fix = rows["ATTITUDE rate as configured"]
    assert status == FAIL and actual == "0.0 Hz" and "set SR2_EXTRA1 20 (now 0)" in fix, text
    assert rows["GLOBAL_POSITION_INT rate as configured"][0] == FAIL
    assert "SR2_POSITION" in rows["GLOBAL_POSITION_INT rate as configured"][3]
    assert rows["ATTITUDE rate after request"][0] == PASS  # the request works; the configuration does not


def test_unreadable_and_insane_rc_calibration() -> None:
    """RC ranges: unreadable and inverted are FAIL, a trim at the end is WARN."""
    report = Report()
    rc_findings(report, 1, {"MIN": None, "TRIM": 1500, "MAX": 1900})
    rc_findings(report, 3, {"MIN": 1900, "TRIM": 1500, "MAX": 1100})
    rc_findings(report, 3, {"MIN": 1100, "TRIM": 1120, "MAX": 1900})
    assert [f.status for f in report.findings] == [FAIL, FAIL, WARN]
    assert "reverse" in report.findings[2].fix


def test_parameter_rules_for_override_time_and_failsafes() -> None:
    """RC_OVERRIDE_TIME -1 / at the period fail for rc_override; FS_ACTION 0 fails; GUIDED softens GCS id."""
    values = {"SYSID_MYGCS": 255, "SERVO1_FUNCTION": 73, "SERVO3_FUNCTION": 74, "FRAME_CLASS": 2,
              "RC_OVERRIDE_TIME": -1, "RC_OPTIONS": 2, "WP_SPEED": 2, "WP_RADIUS": 2, "MOT_SLEWRATE": 100,
              "FS_ACTION": 0, "FS_TIMEOUT": 1.5, "FS_THR_ENABLE": 1, "FS_GCS_ENABLE": 0,
              **{f"RC{c}_{s}": v for c in (1, 3) for s, v in (("MIN", 1100), ("TRIM", 1500), ("MAX", 1900))}}
    report = Report()
    parameter_findings(report, values.get, 255, "rc_override", 0.1, 2.0)
    by_item = {f.item: f for f in report.findings}
    assert by_item["RC_OVERRIDE_TIME"].status == FAIL and "never" in by_item["RC_OVERRIDE_TIME"].actual
    assert by_item["RC_OPTIONS"].status == FAIL and "set RC_OPTIONS 0" in by_item["RC_OPTIONS"].fix
    assert by_item["FS_ACTION"].status == FAIL
    assert by_item["MOT_SLEWRATE"].status == WARN
    values.update(RC_OVERRIDE_TIME=0.1, SYSID_MYGCS=1, FS_ACTION=2)
    report = Report()
    parameter_findings(report, values.get, 255, "attitude_target", 0.1, 2.0)
    by_item = {f.item: f for f in report.findings}
    assert by_item["SYSID_MYGCS"].status == WARN and by_item["RC_OVERRIDE_TIME"].status == WARN
    assert not report.failed


def test_no_autopilot_is_a_fail_with_exit_code_1() -> None:
    """Nobody on the port: one FAIL line naming the connection, exit code 1, no solve timing."""
    import socket

    from sim_vehicle.harness import free_port

    out = io.StringIO()
    with redirect_stdout(out):
        port = free_port(socket.SOCK_DGRAM)
        code = main(["check", "--connect", f"udpin:127.0.0.1:{port}", "--timeout", "0.5", "--solves", "0"])
    assert code == 1
    assert "FAIL    heartbeat" in out.getvalue() and "0 passed, 0 warnings, 1 failed" in out.getvalue()


GOOD = {"SYSID_MYGCS": 255, "SERVO1_FUNCTION": 73, "SERVO3_FUNCTION": 74, "FRAME_CLASS": 2, "RC_OVERRIDE_TIME": 0.5,
        "RC_OPTIONS": 0, "WP_SPEED": 2, "WP_RADIUS": 2, "MOT_SLEWRATE": 0, "FS_ACTION": 2, "FS_TIMEOUT": 1.5,
        "FS_THR_ENABLE": 1, "FS_GCS_ENABLE": 0, "ARMING_CHECK": 1,
        **{f"RC{c}_{s}": v for c in (1, 3) for s, v in (("MIN", 1100), ("TRIM", 1500), ("MAX", 1900))}}


@pytest.mark.parametrize(("name", "bad"), [("SYSID_MYGCS", 254), ("RC_OVERRIDE_TIME", 0), ("RC_OPTIONS", 3)])
def test_the_rules_the_companion_enforces_are_the_checks_rules(name: str, bad: float) -> None:
    """One table: a value that makes the check FAIL for rc_override is the one `mavbridge run` refuses."""
    ctx = Context(255, "rc_override", 0.1, 2.0)
    assert enforced_violations(GOOD.get, ctx) == []
    values = {**GOOD, name: bad}
    report = Report()
    parameter_findings(report, values.get, 255, "rc_override", 0.1, 2.0)
    finding = {f.item: f for f in report.findings}[name]
    assert [f.item for f in report.findings if f.status != PASS] == [name]
    assert finding.status == FAIL
    (problem,) = enforced_violations(values.get, ctx)
    assert problem.startswith(f"{name} is ") and finding.fix in problem
    guided = Report()
    parameter_findings(guided, values.get, 255, "attitude_target", 0.1, 2.0)
    assert {f.item: f.status for f in guided.findings}[name] == WARN  # GUIDED does not use overrides


def test_unreadable_parameters_are_reported_not_refused() -> None:
    """The companion refuses only what it read; the check reports what it could not read."""
    values = {k: v for k, v in GOOD.items() if k not in ("SYSID_MYGCS", "RC_OVERRIDE_TIME")}
    assert enforced_violations(values.get, Context(255, "rc_override", 0.1, 2.0)) == []
    report = Report()
    parameter_findings(report, values.get, 255, "rc_override", 0.1, 2.0)
    by_item = {f.item: f for f in report.findings}
    assert by_item["MAV_GCS_SYSID"].actual == "not readable" and by_item["MAV_GCS_SYSID"].status == FAIL
    assert by_item["RC_OVERRIDE_TIME"].fix == "check the link"


def test_tau_form_needs_are_judged_as_the_companion_judges_them() -> None:
    """Rover's default gains: the D terms pass (the integrators are on: said, the companion closes the inversion
    on SERVO_OUTPUT_RAW) and WP_SPEED 2 is a WARN (full thrust cut); a D term on is a FAIL naming it; with
    deploy/otter-guided-tau.parm over the defaults everything passes."""
    table = ParamTable()
    report = Report()
    tau_form_findings(report, lambda name: table[name] if name in table else None, lambda _name: None)
    by_item = {f.item: f for f in report.findings}
    gains, wp_speed = by_item["tau form: D gains"], by_item["tau form: WP_SPEED"]
    assert gains.status == PASS and "SERVO_OUTPUT_RAW" in gains.actual
    kicked = Report()
    tau_form_findings(kicked, lambda name: 0.05 if name == "ATC_SPEED_D" else (table[name] if name in table else None),
                      lambda name: 0.05 if name == "ATC_SPEED_D" else None)
    d_term = {f.item: f for f in kicked.findings}["tau form: D gains"]
    assert d_term.status == FAIL and d_term.actual == "ATC_SPEED_D is 0.05" and "otter-guided-tau.parm" in d_term.fix
    assert wp_speed.status == WARN and wp_speed.actual == "2 m/s" and ">= 3.04" in wp_speed.fix
    assert by_item["tau form: ATC_BRAKE"].status == WARN  # not readable
    values = {**{d.name: table[d.name] for d in table.defs}, **read_parm(ROOT / "deploy" / "otter-rover.parm"),
              **read_parm(ROOT / "deploy" / "otter-guided-tau.parm")}
    report = Report()
    tau_form_findings(report, values.get, values.get)
    assert [(f.item, f.status) for f in report.findings] == [("tau form: D gains", PASS),
                                                             ("tau form: WP_SPEED", PASS),
                                                             ("tau form: ATC_BRAKE", PASS)]


def test_check_for_the_tau_form_passes_with_its_parameter_file(tmp_path: Path) -> None:
    """`mavbridge check --output attitude_target --attitude-form tau` against the simulator given the boat's and
    the tau form's parameter files: the form's items pass, and so does everything else."""
    tau = (ROOT / "deploy" / "otter-guided-tau.parm").read_text()
    code, text, rows = _check(tmp_path, tau, "--output", "attitude_target", "--attitude-form", "tau", "--solves", "0")
    for item in ("tau form: D gains", "tau form: WP_SPEED", "tau form: ATC_BRAKE"):
        assert rows[item][0] == PASS, text
    assert code == 0, text
