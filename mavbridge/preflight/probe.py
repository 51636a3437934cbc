"""The part of the preflight check that talks to the vehicle: heartbeat, parameters, rates, GPS, mission.

It connects exactly as `mavbridge run` would (same configuration, same ``Link``) and writes each
finding into a ``Report``. Stream rates are measured twice: *as configured* (after asking the autopilot
to go back to the port's SRn_* / MAVn_* rates with SET_MESSAGE_INTERVAL 0) and *after request* (after
the companion's own requests, ``mavbridge.link.streams``). Both must meet the need: the companion asks only
once, when it starts, and an autopilot that reboots mid-run falls back to its configured rates. At the
end the probe asks for the configured rates again, leaving the port as it found it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from mavbridge.companion.mission_tracker import download_mission
from mavbridge.companion.parameters import engage_problem, rc_channels, read_command_parameters
from mavbridge.link import streams
from mavbridge.link.connection import Link, LinkError, mavlink
from mavbridge.link.param_reads import ParamAnswers, ParamBudget, ParamRequest, read_parameters
from mavbridge.link.retry import count_retry
from mavbridge.preflight.report import FAIL, PASS, WARN, Report
from mavbridge.preflight.rules import RULES, Context, fmt_value, parameter_findings, tau_form_findings
from vessel.geo import DEFAULT_MAX_RANGE_M, ned_from_latlon
from vessel.wording import counted

POSITION_NEED_HZ = 5.0
REQUESTED_WAIT_S = 0.5  # an accepted REQUEST_MESSAGE's message: waited for this long (or the link's timeout)
REQUEST_ROUNDS = 8  # ... and asked again at most this often (lost 8 times running: 0.07 % at 40 % loss)
RATE_WINDOW_S = 3.0  # rates are counted over this much autopilot time (time_boot_ms)
STREAM_OF = {"ATTITUDE": "EXTRA1", "GLOBAL_POSITION_INT": "POSITION", "LOCAL_POSITION_NED": "POSITION"}
STREAM_GROUPS = ("EXTRA1", "POSITION", "RAW_SENS")


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
        report.add(PASS if rate >= need else severity, item, f">= {need:g} Hz", f"{rate:.1f} Hz", fix_for(name))


def measure_window(link: Any, names: tuple[str, ...]) -> dict[str, float] | None:
    """Messages per autopilot second over RATE_WINDOW_S of the autopilot's clock (time_boot_ms).

    None if the autopilot said nothing at all; all zeros if nothing timestamped arrived.
    """
    counts = dict.fromkeys(names, 0)
    first_ms: list[int] = []
    heard = [False]

    def count(msg: Any) -> bool:
        heard[0] = True
        stamp = getattr(msg, "time_boot_ms", None)
        if stamp is None:  # RAW_IMU (time_usec): counted within the window the stamped messages open
            if first_ms and msg.get_type() in counts:
                counts[msg.get_type()] += 1
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
    if not done and not first_ms:
        return dict.fromkeys(names, 0.0)
    return {name: n / RATE_WINDOW_S for name, n in counts.items()}


def known_channels(params: dict[str, float | None]) -> tuple[int, int]:
    """The RC inputs RCMAP names in ``params`` (Rover's 1 and 3 while unread)."""
    return rc_channels({k: v for k, v in params.items() if v is not None}) or (1, 3)


def read_ahead(link: Any, params: dict[str, float | None], port: int) -> None:
    """The check's own parameters (its rules, the stream rates of ``port``, the RC inputs' calibration) into
    ``params`` (None: no value), in batched reads within a budget of their own (``param_budget_s``); what
    ``params`` holds a value for already is not asked again."""
    budget, timeout = ParamBudget(link.param_budget.total_s), link.retry.timeout_s
    first = [ParamRequest((r.parameter, *r.aliases), required=not r.skip_unreadable) for r in RULES]
    first += [ParamRequest((f"SR{port}_{s}", f"MAV{port + 1}_{s}")) for s in STREAM_GROUPS]
    first += [ParamRequest((name,)) for name in ("RCMAP_ROLL", "RCMAP_THROTTLE")]
    first = [r for r in first if not any(params.get(n) is not None for n in r.names)]

    def calibration(answers: ParamAnswers) -> list[ParamRequest]:
        channels = known_channels({**params, **answers.values})
        return [ParamRequest((f"RC{ch}_{s}",)) for ch in dict.fromkeys(channels) for s in ("MIN", "TRIM", "MAX")
                if params.get(f"RC{ch}_{s}") is None]

    answers = read_parameters(link, first, budget, timeout, follow=calibration)
    for name in (n for r in first + calibration(answers) for n in r.names):
        params[name] = answers.values.get(name)


def _asked(accepted: int) -> str:
    """How often the autopilot accepted the request for a message that never came (a lossy link or, for
    HOME_POSITION, no home yet)."""
    return f" (requested {accepted}×, accepted, nothing came)" if accepted else ""


def requested(link: Any, seen: dict[str, Any], name: str, command: int,
              params: tuple[float, ...]) -> tuple[Any | None, int, Any]:
    """Message ``name`` (in ``seen``, the newest message of each type the link's handlers recorded, or asked for
    with ``command``), how many requests the autopilot accepted, and its last answer (None: none asked, or no ACK).
    Asked again (a counted command retry) while the autopilot accepts the request but the message does not
    arrive, lost on the way, at most ``REQUEST_ROUNDS`` times; an answer other than ACCEPTED ends the asking."""
    accepted, result = 0, None
    while name not in seen and accepted < REQUEST_ROUNDS:
        if accepted:
            count_retry(link.counts, "command")
        result = link.command_long(command, params)
        if result != mavlink.MAV_RESULT_ACCEPTED:
            break
        accepted += 1
        if name not in seen:  # (it may have come with the ACK)
            link.wait_for(lambda m: m.get_type() == name, max(link.retry.timeout_s, REQUESTED_WAIT_S))
    return seen.get(name), accepted, result


def home_position(link: Any, seen: dict[str, Any]) -> tuple[Any | None, str]:
    """HOME_POSITION and, when not had, why: MAV_CMD_GET_HOME_POSITION first, which ArduPilot answers FAILED
    while it has no home (so a boat without one is told at once); REQUEST_MESSAGE where that command is
    unsupported, which ArduPilot accepts with or without a home (then only the count of rounds ends it)."""
    home, accepted, result = requested(link, seen, "HOME_POSITION", mavlink.MAV_CMD_GET_HOME_POSITION, ())
    if home is None and result == mavlink.MAV_RESULT_UNSUPPORTED:
        home, accepted, result = requested(link, seen, "HOME_POSITION", mavlink.MAV_CMD_REQUEST_MESSAGE,
                                           (float(mavlink.MAVLINK_MSG_ID_HOME_POSITION),))
    if home is not None:
        return home, ""
    if result == mavlink.MAV_RESULT_FAILED:
        return None, "no home: GET_HOME_POSITION answered FAILED"
    return None, f"no HOME_POSITION{_asked(accepted)}"


class Probe:
    """Every vehicle-side check over one Link, into one report."""

    def __init__(self, config: Any, scenario: Any, report: Report, port: int = 2,
                 waypoint_ne: tuple[float, float] | None = None, max_range_m: float = DEFAULT_MAX_RANGE_M,
                 log: Callable[[str], None] = print) -> None:
        self.config, self.scenario, self.report = config, scenario, report
        self.port, self.waypoint_ne, self.max_range_m, self.log = port, waypoint_ne, max_range_m, log
        self.period_s = float(scenario.controller.period_s)
        self.seen: dict[str, Any] = {}
        self.params: dict[str, float | None] = {}  # every name asked (None: no value), from the batched reads

    def _remember(self, msg: Any) -> None:
        self.seen[msg.get_type()] = msg

    def _read(self, link: Any, name: str) -> float | None:
        if name not in self.params:  # (everything is read ahead in batches; this is the fallback)
            self.params[name] = link.read_parameter(name)
        return self.params[name]

    def run(self) -> None:
        """Connect, run every vehicle check, close; a link that fails is one FAIL finding."""
        cfg = self.config
        try:
            link = Link(cfg.connect, cfg.system_id, cfg.component_id, None, cfg.baud, cfg, self.log)
        except LinkError as exc:
            self.report.add(FAIL, "connection", cfg.connect, str(exc), "check the device/URL and baud")
            return
        link.handlers.append(self._remember)
        try:
            self._with_link(link)
        except LinkError as exc:
            self.report.add(FAIL, "link", "answers", str(exc), "check the link, then run the check again")
        finally:
            link.close()

    def _with_link(self, link: Any) -> None:
        cfg = self.config
        try:
            link.wait_autopilot(cfg.connect_timeout_s)
        except LinkError as exc:
            self.report.add(FAIL, "heartbeat", f"autopilot on {cfg.connect}", str(exc),
                            "check wiring, SERIALn_PROTOCOL 2, baud rate and the connection string")
            if link.signed:  # perhaps an autopilot that does not sign (its packets were rejected)
                self.signing(link)
            return
        self.heartbeat()
        self.signing(link)
        self.command_parameters(link)
        read_ahead(link, self.params, self.port)
        read = lambda name: self._read(link, name)  # noqa: E731
        parameter_findings(self.report, read, cfg.system_id, cfg.output, self.period_s,
                           float(self.scenario.waypoint.acceptance_radius_m), self._channels())
        if cfg.output == "attitude_target" and cfg.attitude_form == "tau":
            tau_form_findings(self.report, read, read)
        self.streams(link)
        self.gps_and_home(link)
        self.mission(link)

    def _channels(self) -> tuple[int, int]:
        """The RC inputs RCMAP names (Rover's 1 and 3 while unread)."""
        return known_channels(self.params)

    def command_parameters(self, link: Any) -> None:
        """What `mavbridge run` reads before it engages, read and judged as it does (one budget, one line)."""
        cfg = self.config
        ctx = Context(cfg.system_id, cfg.output, self.period_s, float(self.scenario.waypoint.acceptance_radius_m),
                      cfg.attitude_form)
        needed = read_command_parameters(link, cfg.output, cfg.attitude_form)
        self.params.update({name: needed.values.get(name) for name in needed.names})
        problem = engage_problem(needed, ctx)
        item, expected = "parameters the commands need", f"read within {link.param_budget.total_s:g} s and usable"
        if problem is None:
            self.report.add(PASS, item, expected, needed.summary())
        else:
            self.report.add(FAIL, item, expected, problem.removeprefix("refusing to engage: "),
                            "`mavbridge run` refuses to engage until this passes: fix the parameter or the link")

    def heartbeat(self) -> None:
        """ArduPilot, and a boat."""
        hb = self.seen.get("HEARTBEAT")
        sysid, compid = (hb.get_srcSystem(), hb.get_srcComponent()) if hb else (0, 0)
        ok = hb is not None and hb.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
        self.report.add(PASS if ok else FAIL, "heartbeat autopilot", "3 (ArduPilot)",
                        f"{hb.autopilot if hb else '-'} from {sysid}/{compid}",
                        "the companion speaks ArduPilot Rover's dialect only")
        boat = hb is not None and hb.type == mavlink.MAV_TYPE_SURFACE_BOAT
        self.report.add(PASS if boat else FAIL, "heartbeat vehicle type", "11 (SURFACE_BOAT)",
                        str(hb.type if hb else "-"), "set FRAME_CLASS 2 (boat) and reboot the autopilot")

    def signing(self, link: Any) -> None:
        """MAVLink 2 signing: PASS when the autopilot's packets arrive signed with our key, FAIL when we sign
        and it does not (or uses another key), WARN for an unsigned link (anyone in radio range can command)."""
        item, expected = "MAVLink 2 signing", "signed with our key"
        good, rejected = link.mav.signing.goodsig_count, link.counts.get("unsigned", 0)
        if not link.signed:
            self.report.add(WARN, item, expected, "unsigned link",
                            "anyone in radio range can command the boat: `mavbridge signing setup "
                            "--signing-passphrase-file FILE`, then give the companion the same file")
        elif good > 0:
            self.report.add(PASS, item, expected, f"{good} signed packets, {rejected} rejected")
        else:
            self.report.add(FAIL, item, expected, f"no signed packet ({rejected} unsigned or wrongly signed rejected)",
                            "the autopilot has no key or another one: `mavbridge signing setup` with this passphrase")

    def streams(self, link: Any) -> None:
        """Rates as configured, then after the companion's own request; restore the configured ones after."""
        needs = {"ATTITUDE": (1.0 / self.period_s, FAIL), "GLOBAL_POSITION_INT": (POSITION_NEED_HZ, FAIL),
                 "LOCAL_POSITION_NED": (POSITION_NEED_HZ, WARN)}
        configured = {s: stream_params(lambda n: self._read(link, n), self.port, s) for s in ("EXTRA1", "POSITION")}

        def configure_fix(msg: str) -> str:
            param, value = configured[STREAM_OF[msg]]
            want = math.ceil(max(streams.requested_hz(msg) or needs[msg][0], needs[msg][0]))
            return (f"set {param} {want} (now {fmt_value(value)}) for the companion's port; SET_MESSAGE_INTERVAL "
                    "requests are lost when the autopilot reboots")

        streams.restore_configured(link)
        rate_findings(self.report, "as configured", measure_window(link, tuple(needs)), needs, configure_fix)
        streams.request_streams(link, self.period_s, self.log)
        rates = measure_window(link, (*needs, *streams.IMU_MEASURED))
        rate_findings(self.report, "after request", rates, needs,
                      lambda msg: "the autopilot did not honour SET_MESSAGE_INTERVAL or REQUEST_DATA_STREAM: "
                                  "check the link's bandwidth (baud) and " + configure_fix(msg))
        self.imu(rates, stream_params(lambda n: self._read(link, n), self.port, "RAW_SENS")[0])
        streams.restore_configured(link)

    def imu(self, rates: dict[str, float] | None, param: str) -> None:
        """Whether an IMU stream arrives after the request: WARN if not (the wave estimator then needs the
        GPS height, which is noisier and lags)."""
        name, rate = streams.imu_rate(rates or {})
        need = 1.0 / self.period_s
        expected = f"SCALED_IMU/RAW_IMU >= {need:g} Hz"
        fix = (f"set {param} {math.ceil(streams.IMU_HZ)} for the companion's port (or check the INS); without it "
               "the wave estimator needs the GPS height")
        if name is None:
            self.report.add(WARN, "IMU stream after request", expected, "none arrives", fix)
        else:
            self.report.add(PASS if rate >= need else WARN, "IMU stream after request", expected,
                            f"{name} {rate:.1f} Hz", fix)

    def gps_and_home(self, link: Any) -> None:
        """GPS_RAW_INT fix type (asked for with REQUEST_MESSAGE, ``requested``) and HOME_POSITION
        (``home_position``)."""
        gps, gps_asked, _ = requested(link, self.seen, "GPS_RAW_INT", mavlink.MAV_CMD_REQUEST_MESSAGE,
                                      (float(mavlink.MAVLINK_MSG_ID_GPS_RAW_INT),))
        home, why = home_position(link, self.seen)
        if gps is None:
            self.report.add(FAIL, "GPS fix", ">= 3 (3D)", f"no GPS_RAW_INT{_asked(gps_asked)}",
                            "check the GPS and GPS_TYPE")
        else:
            self.report.add(PASS if gps.fix_type >= 3 else FAIL, "GPS fix", ">= 3 (3D)",
                            f"{gps.fix_type} ({gps.satellites_visible} satellites)",
                            "wait for a 3D fix in open sky before arming")
        if home is None:
            self.report.add(FAIL, "home position", "set", why,
                            "home is set at the first GPS fix (or arming); wait for GPS")
        else:
            self.report.add(PASS, "home position", "set", f"{home.latitude / 1e7:.7f}, {home.longitude / 1e7:.7f}")

    def _mission_target(self, link: Any, expected: str) -> tuple[tuple[float, float], str] | None:
        """The first NAV_WAYPOINT (north, east from home) and where it came from; None after a FAIL finding."""
        if self.waypoint_ne is not None:
            return self.waypoint_ne, "--waypoint"
        try:
            items = download_mission(link)
        except LinkError as exc:
            self.report.add(FAIL, "mission", expected, str(exc), "check the link")
            return None
        home = items[0] if items else None
        waypoints = [i for i in items[1:] if i.command == mavlink.MAV_CMD_NAV_WAYPOINT]
        if home is None or not waypoints:
            self.report.add(FAIL, "mission", expected, f"{counted(max(0, len(items) - 1), 'item')}, no NAV_WAYPOINT",
                            "upload the waypoint: `mission upload FILE` (or give mavbridge run --waypoint)")
            return None
        first = waypoints[0]
        target = ned_from_latlon(home.x / 1e7, home.y / 1e7, first.x / 1e7, first.y / 1e7)
        return target, f"item {first.seq} of {len(items) - 1}"

    def mission(self, link: Any) -> None:
        """A waypoint to fly to (mission item 1.. or --waypoint), within range of home."""
        expected = f"a waypoint < {self.max_range_m:g} m from home"
        found = self._mission_target(link, expected)
        if found is None:
            return
        target, source = found
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
