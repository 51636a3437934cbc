"""`mavbridge run`: the companion process that flies the roll-aware NMPC over MAVLink.

Link -> state -> NMPC -> command, on the autopilot's clock (ATTITUDE.time_boot_ms), at the
controller's period. It relies only on what a stock ArduPilot Rover sends and accepts: HEARTBEAT,
ATTITUDE, GLOBAL_POSITION_INT, LOCAL_POSITION_NED, the mission protocol, PARAM_VALUE, COMMAND_ACK;
and it sends RC_CHANNELS_OVERRIDE (MANUAL) or SET_ATTITUDE_TARGET (GUIDED).
"""

from __future__ import annotations

import csv
import json
import math
import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from vessel.config import ConfigError, bounded, from_mapping, read_yaml, to_mapping
from vessel.geo import ned_from_latlon

from .link import MAV_COMP_ID_ONBOARD_COMPUTER, Link, LinkError, mavlink
from .nmpc import RollAwareNmpc
from .nmpc.config import choice
from .outputs import (
    ATTITUDE_TYPE_MASK_HEADING,
    RcCalibration,
    RcSetup,
    attitude_command,
    neutral_pwm,
    rc_command,
)
from .scenario import Scenario
from .state import StateEstimate
from .supervisor import Phase, Supervisor

OUTPUTS = ("rc_override", "attitude_target")
ARRIVAL_ACTIONS = ("hold", "release")
MODE_MANUAL, MODE_HOLD, MODE_GUIDED = 0, 4, 15
REQUIRED_MODE = {"rc_override": MODE_MANUAL, "attitude_target": MODE_GUIDED}
STREAMS_HZ = {mavlink.MAVLINK_MSG_ID_ATTITUDE: 20.0, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 10.0,
              mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0}
# REQUEST_DATA_STREAM fallback: EXTRA1 carries ATTITUDE, POSITION the two position messages.
FALLBACK_STREAMS_HZ = {mavlink.MAV_DATA_STREAM_EXTRA1: 20, mavlink.MAV_DATA_STREAM_POSITION: 10}


@dataclass(frozen=True)
class CompanionConfig:
    """How the companion reaches the autopilot and what it commands. Defaults suit the simulator."""

    connect: str = "udpin:0.0.0.0:14551"
    baud: int = bounded(921600, 1200, 4_000_000, "baud", "serial speed (serial connections only)")
    system_id: int = bounded(255, 1, 255, "", "our MAVLink system id; must equal SYSID_MYGCS for RC override")
    component_id: int = bounded(MAV_COMP_ID_ONBOARD_COMPUTER, 1, 255, "", "our component id (191: onboard)")
    output: str = choice("rc_override", OUTPUTS, "rc_override (MANUAL) or attitude_target (GUIDED)")
    link_timeout_s: float = bounded(2.0, 0.2, 60.0, "s", "no heartbeat this long = link lost")
    max_link_outage_s: float = bounded(10.0, 0.5, 600.0, "s", "a link lost longer than this ends the run "
                                       "(the pilot has had the sticks back for a while; no silent resume)")
    max_distance_m: float = bounded(10_000.0, 10.0, 1e6, "m", "a position farther than this from home is rejected")
    connect_timeout_s: float = bounded(30.0, 0.5, 600.0, "s", "wait this long for the autopilot at start")
    stale_state_s: float = bounded(0.5, 0.05, 10.0, "s", "state older than this (autopilot time) is not used")
    lookahead_steps: int = bounded(5, 1, 400, "steps", "attitude_target: plan step whose heading/speed is sent")
    on_arrival: str = choice("hold", ARRIVAL_ACTIONS, "hold: switch to HOLD at the waypoint; release: only stop")
    max_time_s: float | None = bounded(None, 0.1, 1e6, "s", "end the run after this much autopilot time engaged")

    def __post_init__(self) -> None:
        for name, choices in (("output", OUTPUTS), ("on_arrival", ARRIVAL_ACTIONS)):
            if getattr(self, name) not in choices:
                raise ConfigError(f"{name}: {getattr(self, name)!r} is not one of {', '.join(choices)}")


def load_companion_config(path: str | Path | None, **overrides: Any) -> CompanionConfig:
    """The YAML configuration (or the defaults), with command-line overrides applied on top."""
    data = read_yaml(path) if path else {}
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of settings")
    data.update({k: v for k, v in overrides.items() if v is not None})
    return from_mapping(CompanionConfig, data, str(path) if path else "configuration")


@dataclass
class RunRecord:
    """What the run measured, written as CSV rows and metrics.json."""

    rows: list[list[Any]] = field(default_factory=list)
    solve_ms: list[float] = field(default_factory=list)
    roll_deg: list[float] = field(default_factory=list)
    overruns: int = 0
    failures: int = 0
    stale: int = 0
    skipped_ticks: int = 0
    engaged_at_ms: int | None = None
    arrived_at_ms: int | None = None
    rates_hz: dict[str, float] = field(default_factory=dict)


CSV_HEADER = ["t_s", "phase", "north", "east", "down", "phi", "theta", "psi", "u", "v", "w", "p", "q", "r",
              "tau_x", "tau_n", "ch1_pwm", "ch3_pwm", "yaw_target_rad", "thrust", "solve_ms", "status",
              "fallback", "sent"]


class Companion:
    """One run of the companion against one autopilot."""

    def __init__(self, config: CompanionConfig, scenario: Scenario, out_dir: Path,
                 waypoint_ne: tuple[float, float] | None = None, arm: bool = False, set_mode: bool = False,
                 dry_run: bool = False, log: Callable[[str], None] = print) -> None:
        self.config, self.scenario, self.out_dir = config, scenario, out_dir
        self.waypoint_override, self.arm, self.set_mode, self.dry_run = waypoint_ne, arm, set_mode, dry_run
        self.log = log
        self.required_mode = REQUIRED_MODE[config.output]
        self.supervisor = Supervisor(self.required_mode, config.link_timeout_s, dry_run)
        self.state = StateEstimate()
        self.record = RunRecord()
        self.params = scenario.params()
        self.period_ms = round(scenario.controller.period_s * 1000)
        self.waypoints: list[tuple[float, float]] = []
        self._stop_reason: str | None = None
        self._commanding = False
        self._mission_changed = False
        self._mission_total: int | None = None
        self._last_command_wall = 0.0
        self._in_loop = False
        self.rc: RcSetup | None = None
        self.wp_speed = 2.0
        self.state.max_distance_m = config.max_distance_m

    # -- setup --------------------------------------------------------------------------------------
    def _on_heartbeat(self, msg: Any) -> None:
        if msg.get_type() == "HEARTBEAT":
            armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            before = self.supervisor.phase
            after = self.supervisor.on_heartbeat(time.monotonic(), armed, int(msg.custom_mode))
            if after != before:
                self.log(f"phase: {after.value}" + (f" ({self.supervisor.reason})" if after.final else ""))

    def _on_mission_notice(self, msg: Any) -> None:
        """Flag a new mission: ArduPilot's "Flight plan received", or MISSION_CURRENT.total changing."""
        kind = msg.get_type()
        if kind == "STATUSTEXT" and "Flight plan received" in str(msg.text):
            self._mission_changed = True
        elif kind == "MISSION_CURRENT" and getattr(msg, "total", 0):
            if self._mission_total is not None and msg.total != self._mission_total:
                self._mission_changed = True
            self._mission_total = msg.total

    def _reload_mission(self, link: Link) -> None:
        """Download the mission again after it changed; keep flying to the old target if that fails."""
        self._mission_changed = False
        try:
            self._load_mission(link)
        except LinkError as exc:
            self.log(f"warning: mission changed but could not be downloaded ({exc}); keeping the old waypoint")

    def _read_calibration(self, link: Link, channel: int) -> RcCalibration:
        values = {}
        for suffix, default in (("MIN", 1100), ("TRIM", 1500), ("MAX", 1900), ("DZ", 30)):
            value = link.read_parameter(f"RC{channel}_{suffix}")
            if value is None:
                self.log(f"warning: RC{channel}_{suffix} not readable, assuming {default}")
                value = default
            values[suffix] = round(value)
        return RcCalibration(values["MIN"], values["TRIM"], values["MAX"], values["DZ"])

    def _read_rc_setup(self, link: Link) -> RcSetup:
        """Everything that decides how the autopilot reads our overrides; refuses setups that ignore them."""
        gcs = link.read_parameter("SYSID_MYGCS")
        gcs = gcs if gcs is not None else link.read_optional_parameter("MAV_GCS_SYSID")  # 4.7 renamed it
        if gcs is not None and round(gcs) != self.config.system_id:
            raise LinkError(f"SYSID_MYGCS is {round(gcs)} but we are system {self.config.system_id}: the autopilot "
                            f"would ignore our RC overrides (set system_id: {round(gcs)} or SYSID_MYGCS)")
        override_time = link.read_optional_parameter("RC_OVERRIDE_TIME")
        if override_time is not None and override_time == 0:
            raise LinkError("RC_OVERRIDE_TIME is 0: the autopilot ignores RC overrides (set it to e.g. 0.5 s)")
        options = link.read_optional_parameter("RC_OPTIONS")
        if options is not None and int(options) & 2:
            raise LinkError("RC_OPTIONS bit 1 is set: the autopilot ignores MAVLink RC overrides (clear it)")
        steer_ch = round(link.read_optional_parameter("RCMAP_ROLL") or 1)
        throttle_ch = round(link.read_optional_parameter("RCMAP_THROTTLE") or 3)
        try:
            setup = RcSetup(self._read_calibration(link, steer_ch), self._read_calibration(link, throttle_ch),
                            steer_ch, throttle_ch, round(link.read_optional_parameter("PILOT_STEER_TYPE") or 0),
                            bool(link.read_optional_parameter(f"RC{steer_ch}_REVERSED") or 0),
                            bool(link.read_optional_parameter(f"RC{throttle_ch}_REVERSED") or 0))
        except ValueError as exc:
            raise LinkError(str(exc)) from None
        self.log(f"RC: steering ch{steer_ch}, throttle ch{throttle_ch}, PILOT_STEER_TYPE {setup.steer_type}")
        return setup

    def _request_streams(self, link: Link) -> None:
        refused = [msg_id for msg_id, rate in STREAMS_HZ.items() if not link.request_message_interval(msg_id, rate)]
        if refused:
            self.log("SET_MESSAGE_INTERVAL not accepted: falling back to REQUEST_DATA_STREAM")
            for stream, rate in FALLBACK_STREAMS_HZ.items():
                link.request_data_stream(stream, rate)
        # Heartbeats (mode, armed) faster than the control period, so a pilot's mode change stops us within one.
        heartbeat_hz = 2.0 / self.scenario.controller.period_s
        if not link.request_message_interval(mavlink.MAVLINK_MSG_ID_HEARTBEAT, heartbeat_hz):
            self.log("warning: HEARTBEAT rate not raised; a mode change is noticed within 1 s only")

    def _measure_rates(self, link: Link, seconds: float = 2.0) -> None:
        """Count what arrives for a while, per second of autopilot time (falls back to wall time)."""
        before = dict(link.rates)
        first_ms = self.state.attitude_ms
        start = time.monotonic()
        link.wait_for(lambda m: False, seconds)
        wall = time.monotonic() - start
        span = ((self.state.attitude_ms or 0) - (first_ms or 0)) / 1000.0 if first_ms is not None else 0.0
        span = span if span > 0 else wall
        for name in ("ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "HEARTBEAT"):
            self.record.rates_hz[name] = round((link.rates.get(name, 0) - before.get(name, 0)) / span, 1)
        self.log("rates per autopilot second: " + ", ".join(f"{k} {v:g} Hz" for k, v in self.record.rates_hz.items()))

    def _load_mission(self, link: Link) -> None:
        items = link.download_mission()
        if not items:
            raise LinkError("mission download returned nothing (not even home)")
        home = items[0]
        waypoints = [ned_from_latlon(home.x / 1e7, home.y / 1e7, i.x / 1e7, i.y / 1e7)
                     for i in items[1:] if i.command == mavlink.MAV_CMD_NAV_WAYPOINT]
        self.log(f"home {home.x / 1e7:.7f}, {home.y / 1e7:.7f}; {len(waypoints)} waypoint(s) from the mission")
        if self.waypoint_override is not None:
            waypoints = [self.waypoint_override]
            north, east = self.waypoint_override
            self.log(f"waypoint overridden: north {north:g} m, east {east:g} m")
        if not waypoints:
            raise LinkError("no waypoint: upload one with `mission upload` or pass --waypoint N,E")
        self.state.set_home(home.x / 1e7, home.y / 1e7)
        self.waypoints = waypoints  # flown in turn from the first; a changed mission restarts them
        self._mission_total = len(items) - 1  # MISSION_CURRENT.total leaves ArduPilot's home out

    def _log_result(self, what: str, result: int | None) -> None:
        if result != mavlink.MAV_RESULT_ACCEPTED:
            reason = "no answer" if result is None else mavlink.enums["MAV_RESULT"][result].name
            self.log(f"warning: {what} not accepted ({reason})")

    # -- control ------------------------------------------------------------------------------------
    def _rc_channels(self, steering_pwm: int, throttle_pwm: int) -> dict[int, int]:
        assert self.rc is not None
        return {self.rc.steering_channel: steering_pwm, self.rc.throttle_channel: throttle_pwm}

    def _release(self, link: Link) -> None:
        """Give the sticks back (RC override 0 = release), a few times since UDP may drop one."""
        if self.config.output == "rc_override" and not self.dry_run and self.rc is not None:
            for _ in range(3):
                link.rc_override(self._rc_channels(0, 0))
        self._commanding = False

    def _neutral(self, link: Link) -> None:
        """Zero thrust, no turn, still overriding (so the sticks do not take over in between)."""
        if self.dry_run:
            return
        if self.config.output == "rc_override" and self.rc is not None:
            link.rc_override(self._rc_channels(*neutral_pwm(self.rc)))
        elif self.config.output == "attitude_target" and self.state.attitude_ms is not None:
            yaw = float(self.state.attitude[2])  # hold the present heading: no pivot towards north
            link.attitude_target(self.state.attitude_ms, (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)), 0.0,
                                 ATTITUDE_TYPE_MASK_HEADING)

    def _finish_at_waypoint(self, link: Link) -> None:
        """Neutral, then HOLD (if configured), then release: the boat is never left to moving sticks."""
        self._neutral(link)
        if self.config.on_arrival == "hold" and not self.dry_run:
            self.supervisor.expected_mode = MODE_HOLD
            self._log_result("HOLD at the waypoint", link.set_mode(MODE_HOLD))
        self._release(link)

    def _control_step(self, link: Link, nmpc: RollAwareNmpc, now_ms: int) -> None:
        phase = self.supervisor.phase
        if not self.supervisor.may_command():
            if self._commanding:
                self._release(link)
            return
        if self.state.age_ms(now_ms) > self.config.stale_state_s * 1000:
            self.record.stale += 1
            if self._commanding:
                self._neutral(link)  # never leave the last command running on old data
            return
        x = self.state.vector()
        if self.record.engaged_at_ms is None:
            self.record.engaged_at_ms = now_ms
        target = self.waypoints[0]
        if math.hypot(target[0] - x[0], target[1] - x[1]) <= self.scenario.waypoint.acceptance_radius_m:
            self.waypoints.pop(0)
            if not self.waypoints:
                self.record.arrived_at_ms = now_ms
                self.supervisor.arrived()
                self.log(f"waypoint reached at t = {now_ms / 1000:.1f} s")
                self._finish_at_waypoint(link)
                return
            target = self.waypoints[0]
        result = nmpc.solve(x, now_ms / 1000.0, target, deadline_s=self.scenario.controller.period_s)
        self.record.solve_ms.append(result.wall_time_s * 1e3)
        self.record.roll_deg.append(math.degrees(x[3]))
        if result.wall_time_s > self.scenario.controller.period_s:
            self.record.overruns += 1
        if not result.success:
            self.record.failures += 1
        ch1 = ch3 = 0
        yaw_target = thrust = math.nan
        if self.config.output == "rc_override":
            assert self.rc is not None
            command = rc_command(self.params, float(result.tau[0]), float(result.tau[1]), self.rc)
            ch1, ch3 = command.steering_pwm, command.throttle_pwm
            if not self.dry_run:
                link.rc_override(self._rc_channels(ch1, ch3))
        else:
            try:
                attitude = attitude_command(result.states, self.wp_speed, self.config.lookahead_steps)
            except ValueError as exc:  # a non-finite plan: stop in place rather than send NaN
                self.log(f"warning: {exc}; holding heading with zero thrust")
                self.record.failures += 1
                self._neutral(link)
                return
            yaw_target, thrust = attitude.yaw_rad, attitude.thrust
            if not self.dry_run:
                link.attitude_target(now_ms, attitude.quaternion(), attitude.thrust, ATTITUDE_TYPE_MASK_HEADING)
        self._commanding = not self.dry_run
        self._last_command_wall = time.monotonic()
        self.record.rows.append([now_ms / 1000.0, phase.name, *np.round(x, 6), *np.round(result.tau, 4), ch1, ch3,
                                 yaw_target, thrust, round(result.wall_time_s * 1e3, 3), result.status,
                                 result.fallback or "", int(not self.dry_run)])

    # -- the run ------------------------------------------------------------------------------------
    def _handle_signal(self, signum: int, frame: Any) -> None:
        self._stop_reason = f"signal {signal.Signals(signum).name}"
        if not self._in_loop:  # still connecting or preparing: stop now, the loop is not there to see it
            raise LinkError(f"stopped by {self._stop_reason} before flying")

    def run(self) -> int:
        """Connect, prepare, fly until a final phase; always releases and writes logs. Returns an exit code."""
        self.out_dir.mkdir(parents=True, exist_ok=True)
        (self.out_dir / "config.yaml").write_text(yaml.safe_dump({"companion": to_mapping(self.config),
                                                                  "scenario": self.scenario.to_mapping()}))
        try:
            link = Link(self.config.connect, self.config.system_id, self.config.component_id,
                        self.out_dir / "companion.tlog", self.config.baud)
        except LinkError as exc:
            self.log(f"mavbridge run: error: {exc}")
            return 1
        link.handlers += [self.state.on_message, self._on_heartbeat, self._on_mission_notice]
        previous = {s: signal.signal(s, self._handle_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        code = 0
        try:
            code = self._fly(link)
        except LinkError as exc:
            self.supervisor.stop(str(exc))
            if self._stop_reason:  # asked to stop (systemd stop, Ctrl-C): not a failure to restart from
                self.log(f"mavbridge run: {exc}")
            else:
                self.log(f"mavbridge run: error: {exc}")
                code = 1
        finally:
            if self._commanding:
                self._neutral(link)
                self._release(link)
            for s, handler in previous.items():
                signal.signal(s, handler)
            self._write_logs(link)
            link.close()
        return code

    def _fly(self, link: Link) -> int:
        # Build the solver first: it takes seconds, during which no heartbeat would be read. In real time a
        # step may wait for asrti's background solve for a quarter period at most, never the whole period.
        controller = self.scenario.controller
        controller = controller.replace(as_wait_s=min(controller.as_wait_s, 0.25 * controller.period_s))
        nmpc = RollAwareNmpc(controller, self.params, self.scenario.sea.waves(), self.scenario.sea.current())
        sysid, compid = link.wait_autopilot(self.config.connect_timeout_s)
        self.log(f"autopilot {sysid}/{compid} on {self.config.connect}; we are {self.config.system_id}/"
                 f"{self.config.component_id}; output {self.config.output}" + (" (dry run)" if self.dry_run else ""))
        if self.config.output == "rc_override":
            self.rc = self._read_rc_setup(link)
        wp_speed = link.read_parameter("WP_SPEED")
        if not (wp_speed and wp_speed > 0):  # older firmware uses CRUISE_SPEED when WP_SPEED is 0
            wp_speed = link.read_parameter("CRUISE_SPEED")
        self.wp_speed = wp_speed if wp_speed and wp_speed > 0 else 2.0
        self._request_streams(link)
        self._load_mission(link)
        self._mission_changed = False
        self._measure_rates(link)
        if self.state.ready():  # the cold, full solve before the loop, so that every step in it is warm
            prepared = nmpc.prepare(self.state.vector(), (self.state.attitude_ms or 0) / 1000.0, self.waypoints[0])
            self.log(f"solver {controller.solver} prepared in {prepared.wall_time_s * 1e3:.0f} ms ({prepared.status})")
        self.supervisor.self_commanded = self.set_mode or self.arm
        if self.set_mode:
            self.supervisor.expected_mode = self.required_mode
            self._log_result(f"mode {self.required_mode}", link.set_mode(self.required_mode))
        if self.arm:
            self._log_result("arming", link.arm())
        next_tick_ms: int | None = None
        self._in_loop = True
        if self._stop_reason:
            self.supervisor.stop(self._stop_reason)
        period_s = self.scenario.controller.period_s
        while not self.supervisor.phase.final:
            if self._stop_reason:
                self.supervisor.stop(self._stop_reason)
                break
            link.heartbeat_if_due()
            link.recv(0.05)
            link.drain()  # act on the newest state, never on a backlog
            if self._mission_changed:
                self._reload_mission(link)
            phase_before = self.supervisor.phase
            if self.supervisor.tick(time.monotonic()) != phase_before:
                self.log(f"phase: {self.supervisor.phase.value}")
            if self.supervisor.phase == Phase.TAKEN_OVER and self._commanding:
                self._release(link)
            if self.supervisor.outage_s(time.monotonic()) > self.config.max_link_outage_s:
                self.supervisor.stop(f"link lost for more than {self.config.max_link_outage_s:g} s")
                break
            if self._commanding and time.monotonic() - self._last_command_wall > 3 * period_s:
                self._neutral(link)  # no fresh step for three periods (no ATTITUDE): stop pushing
                self._release(link)
            now_ms = self.state.attitude_ms
            if now_ms is None:
                continue
            if next_tick_ms is None or now_ms < next_tick_ms - 10 * self.period_ms:  # first tick, or a reboot
                next_tick_ms = now_ms
            if now_ms < next_tick_ms:
                continue
            missed = (now_ms - next_tick_ms) // self.period_ms
            self.record.skipped_ticks += missed
            next_tick_ms += (missed + 1) * self.period_ms
            self._control_step(link, nmpc, now_ms)
            engaged = self.record.engaged_at_ms
            if self.config.max_time_s and engaged is not None and now_ms - engaged > self.config.max_time_s * 1000:
                self.supervisor.stop("max_time_s reached")
        self.log(f"run ended: {self.supervisor.phase.value}" + (f" ({self.supervisor.reason})"
                                                                 if self.supervisor.reason else ""))
        return 0

    def metrics(self) -> dict[str, Any]:
        """avg/max |roll| over engaged control periods, time to waypoint, solve statistics, counters."""
        rec = self.record
        roll = np.abs(np.array(rec.roll_deg)) if rec.roll_deg else np.array([math.nan])
        solve = np.array(rec.solve_ms) if rec.solve_ms else np.array([math.nan])
        arrived = (rec.arrived_at_ms - rec.engaged_at_ms) / 1000.0 if rec.arrived_at_ms and rec.engaged_at_ms \
            else None

        def finite(value: float) -> float | None:
            return round(float(value), 4) if math.isfinite(value) else None

        return {"phase": self.supervisor.phase.name, "reason": self.supervisor.reason, "output": self.config.output,
                "avg_roll_deg": finite(np.mean(roll)), "max_roll_deg": finite(np.max(roll)),
                "time_to_waypoint_s": arrived,
                "engaged_at_s": rec.engaged_at_ms / 1000.0 if rec.engaged_at_ms is not None else None,
                "control_steps": len(rec.solve_ms),
                "solve_ms_median": finite(np.median(solve)), "solve_ms_p95": finite(np.percentile(solve, 95)),
                "solve_ms_max": finite(np.max(solve)), "overruns": rec.overruns, "failures": rec.failures,
                "stale_states": rec.stale, "skipped_ticks": rec.skipped_ticks, "rates_hz": rec.rates_hz,
                "link": dict(self._link_counts)}

    def _write_logs(self, link: Link) -> None:
        self._link_counts = link.counts
        with (self.out_dir / "companion.csv").open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(CSV_HEADER)
            writer.writerows(self.record.rows)
        metrics = self.metrics()
        (self.out_dir / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
        self.log(f"avg roll {metrics['avg_roll_deg']} deg, max roll {metrics['max_roll_deg']} deg, time to waypoint "
                 f"{metrics['time_to_waypoint_s']} s, solve median {metrics['solve_ms_median']} ms; "
                 f"logs in {self.out_dir}")
