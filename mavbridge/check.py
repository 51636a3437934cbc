"""`mavbridge check`: a preflight check of an ArduPilot Rover (real or simulated) for the companion.

It connects exactly as `mavbridge run` would (same configuration, same Link), and judges what the
companion relies on: the heartbeat (ArduPilot, boat), the parameters (with the expected value, the
actual one and the fix), the telemetry rates the port delivers, GPS and home, the mission, and the
NMPC's solve time on this computer. Each finding is PASS, WARN or FAIL; any FAIL makes the exit code 1.

Stream rates are measured twice: *as configured* (after asking the autopilot to go back to its
configured rates with SET_MESSAGE_INTERVAL 0, i.e. the SRn_* / MAVn_* parameters of the port) and
*after request* (after the companion's own request logic). Both must meet the need: the companion asks
only once, when it starts, and an autopilot that reboots mid-run falls back to its configured rates.
At the end the check asks for the configured rates again, leaving the port as it found it.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vessel.config import ConfigError

from .cli_run import parse_north_east
from .nmpc.config import SOLVERS

PASS, WARN, FAIL = "PASS", "WARN", "FAIL"
MAV_AUTOPILOT_ARDUPILOTMEGA = 3
MAV_TYPE_SURFACE_BOAT = 11
THROTTLE_LEFT, THROTTLE_RIGHT = 73, 74
MSG_GPS_RAW_INT, MSG_HOME_POSITION = 24, 242
MAV_CMD_REQUEST_MESSAGE = 512
POSITION_NEED_HZ = 5.0
DEFAULT_SOLVES = 300
DEFAULT_MAX_RANGE_M = 5000.0
RATE_WINDOW_S = 3.0  # rates are counted over this much autopilot time (time_boot_ms)
FS_ACTIONS = {0: "none", 1: "RTL", 2: "Hold", 3: "SmartRTL or RTL or Hold", 4: "SmartRTL or Hold", 5: "Terminate",
              6: "Loiter or Hold"}


@dataclass(frozen=True)
class Finding:
    """One line of the report."""

    status: str
    item: str
    expected: str
    actual: str
    fix: str = ""


class Report:
    """The findings, printed as one table at the end."""

    def __init__(self) -> None:
        self.findings: list[Finding] = []

    def add(self, status: str, item: str, expected: str, actual: str, fix: str = "") -> Finding:
        """Record a finding (a PASS carries no fix)."""
        finding = Finding(status, item, expected, actual, "" if status == PASS else fix)
        self.findings.append(finding)
        return finding

    @property
    def failed(self) -> bool:
        """True if any finding is a FAIL."""
        return any(f.status == FAIL for f in self.findings)

    def table(self) -> str:
        """A fixed-width table: status, check, expected, actual, fix."""
        header = Finding("RESULT", "CHECK", "EXPECTED", "ACTUAL", "FIX")
        rows = [header, *self.findings]
        widths = [max(len(getattr(r, name)) for r in rows) for name in ("status", "item", "expected", "actual")]
        lines = []
        for r in rows:
            cells = [r.status, r.item, r.expected, r.actual]
            line = "  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True))
            lines.append((line + "  " + r.fix).rstrip())
        counts = {s: sum(f.status == s for f in self.findings) for s in (PASS, WARN, FAIL)}
        lines.append(f"{counts[PASS]} passed, {counts[WARN]} warnings, {counts[FAIL]} failed")
        return "\n".join(lines)


def _fmt(value: float | None) -> str:
    """A parameter value as the user would type it."""
    if value is None:
        return "not readable"
    return f"{value:g}"


def rc_findings(report: Report, channel: int, values: dict[str, float | None]) -> None:
    """RCn_MIN/TRIM/MAX: readable, within 800..2200 µs, MIN < TRIM < MAX with room either side of TRIM."""
    name = f"RC{channel}_MIN/TRIM/MAX"
    lo, trim, hi = values["MIN"], values["TRIM"], values["MAX"]
    expected = "800 <= MIN < TRIM < MAX <= 2200"
    if lo is None or trim is None or hi is None:
        report.add(FAIL, name, expected, "not readable",
                   f"the companion turns forces into PWM with RC{channel}_MIN/TRIM/MAX; check the link")
        return
    actual = f"{lo:g}/{trim:g}/{hi:g}"
    fix = f"calibrate the transmitter (radio calibration) or set RC{channel}_MIN 1100, _TRIM 1500, _MAX 1900"
    if not (800 <= lo < trim < hi <= 2200):
        report.add(FAIL, name, expected, actual, fix)
    elif trim - lo < 100 or hi - trim < 100:
        which = "reverse" if channel == 3 else "one side of steering"
        report.add(WARN, name, "TRIM >= 100 µs from MIN and MAX", actual,
                   f"TRIM close to an end leaves little {which}; " + fix)
    else:
        report.add(PASS, name, expected, actual)


def parameter_findings(report: Report, read: Callable[[str], float | None], system_id: int, output: str,
                       period_s: float, acceptance_m: float) -> None:
    """Judge every parameter the companion relies on; ``read(name)`` returns the value or None."""
    rc_mode = output == "rc_override"
    mygcs = read("SYSID_MYGCS")
    gcs_name = "SYSID_MYGCS"
    if mygcs is None:  # ArduPilot 4.7 renamed it
        mygcs, gcs_name = read("MAV_GCS_SYSID"), "MAV_GCS_SYSID"
    if mygcs is not None and int(mygcs) == system_id:
        report.add(PASS, gcs_name, str(system_id), _fmt(mygcs))
    else:
        report.add(FAIL if rc_mode else WARN, gcs_name, f"{system_id} (companion system_id)", _fmt(mygcs),
                   f"set {gcs_name} {system_id}, or system_id: {_fmt(mygcs)} in the companion config; "
                   "the autopilot obeys RC overrides only from that system")

    for servo, function, side in ((1, THROTTLE_LEFT, "ThrottleLeft"), (3, THROTTLE_RIGHT, "ThrottleRight")):
        value = read(f"SERVO{servo}_FUNCTION")
        status = PASS if value is not None and int(value) == function else FAIL
        report.add(status, f"SERVO{servo}_FUNCTION", f"{function} ({side})", _fmt(value),
                   f"set SERVO{servo}_FUNCTION {function}: the companion's mixer assumes "
                   f"output {servo} drives the {'left' if servo == 1 else 'right'} thruster")

    frame = read("FRAME_CLASS")
    report.add(PASS if frame is not None and int(frame) == 2 else FAIL, "FRAME_CLASS", "2 (boat)", _fmt(frame),
               "set FRAME_CLASS 2 and reboot the autopilot")

    override = read("RC_OVERRIDE_TIME")
    expected = f"> {period_s:g} s (control period), <= 2 s"
    bad = FAIL if rc_mode else WARN
    if override is None:
        report.add(bad, "RC_OVERRIDE_TIME", expected, "not readable", "check the link")
    elif override < 0:
        report.add(bad, "RC_OVERRIDE_TIME", expected, f"{override:g} (never expires)",
                   "set RC_OVERRIDE_TIME 0.5: with -1 a stalled companion's last command never times out")
    elif override <= period_s:
        report.add(bad, "RC_OVERRIDE_TIME", expected, f"{override:g} s",
                   f"set RC_OVERRIDE_TIME 0.5: at or below the {period_s:g} s control period the overrides "
                   "lapse between two commands (0 disables them)")
    elif override < 3 * period_s or override > 2.0:
        report.add(WARN, "RC_OVERRIDE_TIME", f"{3 * period_s:g}..2 s", f"{override:g} s",
                   "set RC_OVERRIDE_TIME 0.5: shorter lapses on one late command, longer keeps a stalled "
                   "companion's last command that long")
    else:
        report.add(PASS, "RC_OVERRIDE_TIME", expected, f"{override:g} s")

    options = read("RC_OPTIONS")
    if options is not None and int(options) & 2:
        report.add(bad, "RC_OPTIONS", "bit 1 (2, ignore MAVLink overrides) clear", _fmt(options),
                   f"set RC_OPTIONS {int(options) & ~2}")
    elif options is not None:
        report.add(PASS, "RC_OPTIONS", "bit 1 (2, ignore MAVLink overrides) clear", _fmt(options))

    for channel in (1, 3):
        rc_findings(report, channel, {s: read(f"RC{channel}_{s}") for s in ("MIN", "TRIM", "MAX")})

    speed = read("WP_SPEED")
    report.add(PASS if speed is not None and speed > 0 else FAIL, "WP_SPEED", "> 0 m/s", _fmt(speed),
               "set WP_SPEED 2: Rover refuses to arm at 0, and GUIDED thrust is a fraction of it")
    radius = read("WP_RADIUS")
    if radius is not None and abs(radius - acceptance_m) <= 0.05:
        report.add(PASS, "WP_RADIUS", f"{acceptance_m:g} m (scenario acceptance)", f"{radius:g} m")
    else:
        report.add(WARN, "WP_RADIUS", f"{acceptance_m:g} m (scenario acceptance)", _fmt(radius),
                   f"set WP_RADIUS {acceptance_m:g} so that AUTO and the companion agree on arrival")

    slew = read("MOT_SLEWRATE")
    if rc_mode and slew is not None and 0 < slew < 1000:
        report.add(WARN, "MOT_SLEWRATE", "0 (off) or >= 1000 %/s", f"{slew:g} %/s",
                   "set MOT_SLEWRATE 0: the autopilot's throttle slew lags the NMPC's commands and skews "
                   "the left/right split the companion computed")
    elif slew is not None:
        report.add(PASS, "MOT_SLEWRATE", "0 (off) or >= 1000 %/s", f"{slew:g} %/s")

    action = read("FS_ACTION")
    if action is None or int(action) == 0:
        report.add(FAIL, "FS_ACTION", "1..6 (2 = Hold)", _fmt(action),
                   "set FS_ACTION 2: with 0 a lost transmitter or GCS link does nothing")
    else:
        report.add(PASS, "FS_ACTION", "1..6 (2 = Hold)", f"{int(action)} ({FS_ACTIONS.get(int(action), '?')})")
    timeout = read("FS_TIMEOUT")
    if timeout is None or not 0.5 <= timeout <= 5.0:
        report.add(WARN, "FS_TIMEOUT", "0.5..5 s", _fmt(timeout), "set FS_TIMEOUT 1.5 (Rover's default)")
    else:
        report.add(PASS, "FS_TIMEOUT", "0.5..5 s", f"{timeout:g} s")
    throttle_fs = read("FS_THR_ENABLE")
    if throttle_fs is None or int(throttle_fs) == 0:
        report.add(WARN, "FS_THR_ENABLE", ">= 1 (RC failsafe on)", _fmt(throttle_fs),
                   "set FS_THR_ENABLE 1: otherwise losing the safety pilot's transmitter goes unnoticed")
    else:
        report.add(PASS, "FS_THR_ENABLE", ">= 1 (RC failsafe on)", _fmt(throttle_fs))
    gcs_fs = read("FS_GCS_ENABLE")
    if gcs_fs is not None and int(gcs_fs) >= 1:
        report.add(WARN, "FS_GCS_ENABLE", "0 (see deploy/otter-rover.parm)", _fmt(gcs_fs),
                   f"the companion ({gcs_name}) ends its process after every run; FS_ACTION then follows "
                   "within FS_GCS_TIMEOUT, even under a pilot in MANUAL. Set 0 unless that is wanted")
    else:
        report.add(PASS, "FS_GCS_ENABLE", "0 (see deploy/otter-rover.parm)", _fmt(gcs_fs))
    arming = read("ARMING_CHECK")
    if arming is not None and int(arming) == 0:
        report.add(WARN, "ARMING_CHECK", "!= 0", "0", "set ARMING_CHECK 1: pre-arm checks catch bad GPS/compass")


def stream_params(read: Callable[[str], float | None], port: int, stream: str) -> tuple[str, float | None]:
    """The configured rate of ``stream`` on stream channel ``port``: SRn_ (4.5/4.6), else MAVn+1_ (4.7)."""
    name = f"SR{port}_{stream}"
    value = read(name)
    if value is None:
        alt = f"MAV{port + 1}_{stream}"
        alt_value = read(alt)
        if alt_value is not None:
            return alt, alt_value
    return name, value


def rate_findings(report: Report, label: str, rates: dict[str, float] | None, needs: dict[str, tuple[float, str]],
                  fix_for: Callable[[str], str]) -> None:
    """One finding per message: measured rate against need."""
    for name, (need, severity) in needs.items():
        item = f"{name} rate {label}"
        if rates is None:
            report.add(FAIL, item, f">= {need:g} Hz", "no heartbeats to time it", "check the link")
            continue
        rate = rates.get(name, 0.0)
        status = PASS if rate >= need else severity
        report.add(status, item, f">= {need:g} Hz", f"{rate:.1f} Hz", fix_for(name))


class Preflight:
    """Runs every check against one autopilot over one Link."""

    def __init__(self, config: Any, scenario: Any, report: Report, port: int = 2, solves: int = DEFAULT_SOLVES,
                 waypoint_ne: tuple[float, float] | None = None, max_range_m: float = DEFAULT_MAX_RANGE_M,
                 log: Callable[[str], None] = print) -> None:
        self.config, self.scenario, self.report = config, scenario, report
        self.port, self.solves, self.waypoint_ne, self.max_range_m = port, solves, waypoint_ne, max_range_m
        self.log = log
        self.period_s = float(scenario.controller.period_s)
        self.seen: dict[str, Any] = {}
        self.params: dict[str, float | None] = {}

    # -- link helpers --------------------------------------------------------------------------------
    def _remember(self, msg: Any) -> None:
        self.seen[msg.get_type()] = msg

    def _read(self, link: Any, name: str) -> float | None:
        if name not in self.params:
            self.params[name] = link.read_parameter(name, timeout_s=1.5)
        return self.params[name]

    def _measure(self, link: Any, names: tuple[str, ...]) -> dict[str, float] | None:
        """Messages per autopilot second over RATE_WINDOW_S of the autopilot's clock (time_boot_ms).

        None if the autopilot said nothing at all; all zeros if nothing timestamped arrived.
        """
        counts = dict.fromkeys(names, 0)
        first_ms: list[int] = []
        heard = [False]

        def count(msg: Any) -> bool:
            heard[0] = True
            stamp = getattr(msg, "time_boot_ms", None)
            if stamp is None:
                return False
            if not first_ms or stamp < first_ms[0] - 5000:  # first stamp, or the autopilot rebooted
                first_ms[:] = [stamp]
                for name in counts:
                    counts[name] = 0
            if stamp >= first_ms[0] + RATE_WINDOW_S * 1000:
                return True
            if msg.get_type() in counts and stamp >= first_ms[0]:
                counts[msg.get_type()] += 1
            return False

        done = link.wait_for(count, RATE_WINDOW_S + 5.0) is not None
        if not heard[0]:
            return None
        if not done:
            return dict.fromkeys(names, 0.0) if not first_ms else {n: c / RATE_WINDOW_S for n, c in counts.items()}
        return {name: n / RATE_WINDOW_S for name, n in counts.items()}

    def _configured_intervals(self, link: Any, streams: dict[int, float]) -> None:
        """SET_MESSAGE_INTERVAL 0 for each message: back to the port's configured stream rate."""
        from .link import mavlink

        for msg_id in (mavlink.MAVLINK_MSG_ID_HEARTBEAT, *streams):
            link.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, 0.0))

    # -- the checks ----------------------------------------------------------------------------------
    def run(self) -> Report:
        """Every check in order; the solve-time check runs after the link is closed."""
        from .link import Link, LinkError

        cfg = self.config
        try:
            link = Link(cfg.connect, cfg.system_id, cfg.component_id, None, cfg.baud)
        except LinkError as exc:
            self.report.add(FAIL, "connection", cfg.connect, str(exc), "check the device/URL and baud")
            self.solve_time()
            return self.report
        link.handlers.append(self._remember)
        try:
            self._with_link(link)
        except LinkError as exc:
            self.report.add(FAIL, "link", "answers", str(exc), "check the link, then run the check again")
        finally:
            link.close()
        self.solve_time()
        return self.report

    def _with_link(self, link: Any) -> None:
        cfg = self.config
        try:
            link.wait_autopilot(cfg.connect_timeout_s)
        except Exception as exc:
            self.report.add(FAIL, "heartbeat", f"autopilot on {cfg.connect}", str(exc),
                            "check wiring, SERIALn_PROTOCOL 2, baud rate and the connection string")
            return
        self.heartbeat()
        parameter_findings(self.report, lambda name: self._read(link, name), cfg.system_id, cfg.output,
                           self.period_s, float(self.scenario.waypoint.acceptance_radius_m))
        self.streams(link)
        self.gps_and_home(link)
        self.mission(link)

    def heartbeat(self) -> None:
        """ArduPilot, and a boat."""
        hb = self.seen.get("HEARTBEAT")
        sysid, compid = (hb.get_srcSystem(), hb.get_srcComponent()) if hb else (0, 0)
        ok = hb is not None and hb.autopilot == MAV_AUTOPILOT_ARDUPILOTMEGA
        self.report.add(PASS if ok else FAIL, "heartbeat autopilot", "3 (ArduPilot)",
                        f"{hb.autopilot if hb else '-'} from {sysid}/{compid}",
                        "the companion speaks ArduPilot Rover's dialect only")
        boat = hb is not None and hb.type == MAV_TYPE_SURFACE_BOAT
        self.report.add(PASS if boat else FAIL, "heartbeat vehicle type", "11 (SURFACE_BOAT)",
                        str(hb.type if hb else "-"), "set FRAME_CLASS 2 (boat) and reboot the autopilot")

    def streams(self, link: Any) -> None:
        """Rates as configured, then after the companion's own request; restore the configured ones after."""
        from .companion import STREAMS_HZ, Companion
        from .link import mavlink

        needs = {"ATTITUDE": (1.0 / self.period_s, FAIL), "GLOBAL_POSITION_INT": (POSITION_NEED_HZ, FAIL),
                 "LOCAL_POSITION_NED": (POSITION_NEED_HZ, WARN)}
        stream_of = {"ATTITUDE": "EXTRA1", "GLOBAL_POSITION_INT": "POSITION", "LOCAL_POSITION_NED": "POSITION"}
        configured = {s: stream_params(lambda n: self._read(link, n), self.port, s) for s in ("EXTRA1", "POSITION")}
        names = tuple(needs)

        def configure_fix(msg: str) -> str:
            param, value = configured[stream_of[msg]]
            want = math.ceil(max(STREAMS_HZ.get(getattr(mavlink, f"MAVLINK_MSG_ID_{msg}"), needs[msg][0]),
                                 needs[msg][0]))
            return (f"set {param} {want} (now {_fmt(value)}) for the companion's port; SET_MESSAGE_INTERVAL "
                    "requests are lost when the autopilot reboots")

        self._configured_intervals(link, STREAMS_HZ)
        before = self._measure(link, names)
        rate_findings(self.report, "as configured", before, needs, configure_fix)
        companion = Companion(self.config, self.scenario, Path("."), log=self.log)
        companion._request_streams(link)
        after = self._measure(link, names)
        rate_findings(self.report, "after request", after, needs,
                      lambda msg: "the autopilot did not honour SET_MESSAGE_INTERVAL or REQUEST_DATA_STREAM: "
                                  "check the link's bandwidth (baud) and " + configure_fix(msg))
        self._configured_intervals(link, STREAMS_HZ)

    def gps_and_home(self, link: Any) -> None:
        """GPS_RAW_INT fix type and HOME_POSITION, each asked for with MAV_CMD_REQUEST_MESSAGE."""
        for msg_id, name in ((MSG_GPS_RAW_INT, "GPS_RAW_INT"), (MSG_HOME_POSITION, "HOME_POSITION")):
            if name not in self.seen:
                link.command_long(MAV_CMD_REQUEST_MESSAGE, (float(msg_id),))
                link.wait_for(lambda m, n=name: m.get_type() == n, 2.0)
        gps = self.seen.get("GPS_RAW_INT")
        if gps is None:
            self.report.add(FAIL, "GPS fix", ">= 3 (3D)", "no GPS_RAW_INT", "check the GPS and GPS_TYPE")
        else:
            self.report.add(PASS if gps.fix_type >= 3 else FAIL, "GPS fix", ">= 3 (3D)",
                            f"{gps.fix_type} ({gps.satellites_visible} satellites)",
                            "wait for a 3D fix in open sky before arming")
        home = self.seen.get("HOME_POSITION")
        if home is None:
            self.report.add(FAIL, "home position", "set", "no HOME_POSITION",
                            "home is set at the first GPS fix (or arming); wait for GPS")
        else:
            self.report.add(PASS, "home position", "set", f"{home.latitude / 1e7:.7f}, {home.longitude / 1e7:.7f}")

    def mission(self, link: Any) -> None:
        """A waypoint to fly to (mission item 1.. or --waypoint), within range of home."""
        from vessel.geo import ned_from_latlon

        from .link import LinkError, mavlink

        expected = f"a waypoint < {self.max_range_m:g} m from home"
        if self.waypoint_ne is not None:
            target, source = self.waypoint_ne, "--waypoint"
        else:
            try:
                items = link.download_mission()
            except LinkError as exc:
                self.report.add(FAIL, "mission", expected, str(exc), "check the link")
                return
            home = items[0] if items else None
            waypoints = [i for i in items[1:] if i.command == mavlink.MAV_CMD_NAV_WAYPOINT]
            if home is None or not waypoints:
                self.report.add(FAIL, "mission", expected, f"{max(0, len(items) - 1)} item(s), no NAV_WAYPOINT",
                                "upload the waypoint: `mission upload FILE` (or give mavbridge run --waypoint)")
                return
            first = waypoints[0]
            target = ned_from_latlon(home.x / 1e7, home.y / 1e7, first.x / 1e7, first.y / 1e7)
            source = f"item {first.seq} of {len(items) - 1}"
        distance = math.hypot(*target)
        actual = f"{distance:.0f} m (N {target[0]:.0f}, E {target[1]:.0f}; {source})"
        if distance >= self.max_range_m:
            self.report.add(FAIL, "mission waypoint", expected, actual,
                            "wrong coordinates or home? upload a waypoint near the boat")
        elif distance <= self.scenario.waypoint.acceptance_radius_m:
            self.report.add(WARN, "mission waypoint", expected, actual,
                            "the boat is already within the acceptance radius: nothing to fly")
        else:
            self.report.add(PASS, "mission waypoint", expected, actual)

    def solve_time(self) -> None:
        """A warm-up of ``solves`` closed-loop solves of the configured NMPC, timed on this computer."""
        import numpy as np

        from .nmpc import RollAwareNmpc

        if self.solves <= 0:
            return
        sc = self.scenario
        self.log(f"timing {self.solves} NMPC solves ({sc.controller.solver})...")
        nmpc = RollAwareNmpc(sc.controller, sc.params(), sc.sea.waves(), sc.sea.current())
        x, t, walls = sc.start.state(), 0.0, []
        target = (sc.waypoint.north_m, sc.waypoint.east_m)
        for _ in range(self.solves):
            result = nmpc.solve(x, t, target)
            walls.append(result.wall_time_s)
            x, t = np.asarray(result.states)[1], t + self.period_s  # follow the plan: warm starts as in flight
        steady = np.array(walls[min(5, len(walls) - 1):]) * 1e3
        median, p95, worst = np.median(steady), np.percentile(steady, 95), np.max(steady)
        period_ms = self.period_s * 1e3
        actual = f"median {median:.1f}, p95 {p95:.1f}, max {worst:.1f} ms ({len(walls)} solves)"
        expected = f"p95 < {period_ms:g} ms (period)"
        item = f"NMPC solve time ({sc.controller.solver})"
        fix = "use solver rti (--solver rti / controller.solver), a shorter horizon, or a faster computer"
        if p95 >= period_ms:
            self.report.add(FAIL, item, expected, actual, fix)
        elif worst >= period_ms or p95 >= 0.5 * period_ms:
            self.report.add(WARN, item, expected, actual, "late solves fall back to the previous plan; " + fix)
        else:
            self.report.add(PASS, item, expected, actual)


# -- command line -------------------------------------------------------------------------------------
def _count(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {value}")
    return value


def add_check_parser(sub: Any) -> None:
    """`mavbridge check`: the preflight check."""
    check = sub.add_parser("check", help="preflight check of an ArduPilot Rover for the companion",
                           description="Connect like `mavbridge run`, then check the heartbeat, the parameters "
                                       "the companion relies on, the achieved stream rates, GPS and home, the "
                                       "mission, and the NMPC's solve time on this computer. Prints PASS/WARN/"
                                       "FAIL per item; exit code 1 on any FAIL.")
    check.add_argument("--config", help="companion YAML (the same file `mavbridge run` uses)")
    check.add_argument("--connect", help="pymavlink connection: udpin:0.0.0.0:14551, tcp:HOST:PORT, /dev/ttyAMA0")
    check.add_argument("--baud", type=int, help="serial baud rate (default 921600)")
    check.add_argument("--sysid", type=int, help="our system id (default 255)")
    check.add_argument("--compid", type=int, help="our component id (default 191)")
    check.add_argument("--output", choices=("rc_override", "attitude_target"), help="the output to check for")
    check.add_argument("--scenario", help="scenario YAML (default: the paper's Balanced run)")
    check.add_argument("--solver", choices=SOLVERS, help="override the scenario's controller.solver")
    check.add_argument("--solves", type=_count, default=DEFAULT_SOLVES,
                       help=f"NMPC solves to time (default {DEFAULT_SOLVES}; 0 skips the solve-time check)")
    check.add_argument("--port", type=int, default=2, metavar="N",
                       help="stream-rate set of the companion's port: SRn_* / MAV(n+1)_* (default 2 = SERIAL2 on "
                            "a typical Rover; the simulator's 127.0.0.1:14551 output is 2 as well)")
    check.add_argument("--waypoint", type=parse_north_east, metavar="N,E",
                       help="check this waypoint instead of the mission")
    check.add_argument("--max-range", type=float, default=DEFAULT_MAX_RANGE_M, metavar="M",
                       help=f"largest distance home-waypoint in m (default {DEFAULT_MAX_RANGE_M:g})")
    check.add_argument("--timeout", type=float, help="wait this long for the autopilot (s; default from config)")


def check_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge check`; 1 if anything FAILed, else 0."""
    from .cli_run import _scenario
    from .companion import load_companion_config

    if not 0 <= args.port <= 9:
        raise ConfigError(f"--port: {args.port} is outside the allowed range [0, 9]")
    config = load_companion_config(args.config, connect=args.connect, baud=args.baud, system_id=args.sysid,
                                   component_id=args.compid, output=args.output, connect_timeout_s=args.timeout)
    scenario = _scenario(args.scenario, args.solver)
    report = Report()
    print(f"mavbridge check: {config.connect} as {config.system_id}/{config.component_id}, output {config.output}, "
          f"scenario {scenario.name} ({scenario.controller.solver}, period {scenario.controller.period_s:g} s)")
    start = time.monotonic()
    Preflight(config, scenario, report, args.port, args.solves, args.waypoint, args.max_range).run()
    print(report.table())
    print(f"({time.monotonic() - start:.1f} s)")
    return 1 if report.failed else 0
