"""The companion's parts flown from a log: ``Flight`` takes the log's messages in order (see the package
docstring), ``prepare_flight`` builds it for one log."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.companion.outputs import skid_fractions
from mavbridge.companion.rover_modes import mode_name
from mavbridge.companion.state import StateEstimate
from mavbridge.field.boat import BoatOutputs
from mavbridge.field.logs import LogError
from mavbridge.field.trial import Trial, mode_of, on_timeline
from mavbridge.lab.runlog import STATE_COLUMNS
from mavbridge.link.connection import mavlink
from mavbridge.nmpc.disturbance import IDLE, DisturbanceObserver, observe_period
from vessel.allocation import achieved_tau

MEASURE_S = 2.0  # autopilot s the companion measures the rates after its mission download, then solves cold
HOME_MESSAGES = ("HOME_POSITION", "MISSION_ITEM_INT", "MISSION_ITEM")  # item 0 of a mission is the home


@dataclass(frozen=True)
class ReplayRequest:
    """What `mavbridge replay` was asked (the flags)."""

    log: str
    fmt: str = "auto"
    sysid: int | None = None
    config: str | None = None
    scenario: str | None = None
    out: str | None = None
    solver: str | None = None
    output: str | None = None
    attitude_form: str | None = None
    waypoint: tuple[float, float] | None = None
    start_s: float | None = None
    stop_s: float | None = None
    plan_all: bool = False  # also plan where the companion would not command (``Flight.shadow``)


@dataclass
class Flight:
    """The companion's parts, flown from the log (see the module docstring)."""

    nmpc: Any
    gate: Any  # the companion's: watches before it would engage, steps only where it would command
    output: Any
    tracker: Any
    params: Any  # the vessel's (for the skid fractions of τ)
    period_ms: int
    window: tuple[float, float]
    boat: BoatOutputs
    state: StateEstimate
    shadow: Any = None  # the steps where the companion would not command: planned on a gate of their own
    home: tuple[float, float] | None = None  # set on the state when the log first shows a home (None: already set)
    rows: list[dict[str, Any]] = field(default_factory=list)
    mode: str = ""
    armed: bool = False
    engaged_s: float | None = None  # the first step the companion would have commanded (its engagement)
    due_s: float | None = None  # the ATTITUDE whose step waits for the log to pass its time
    prepare_at_s: float | None = None  # the companion's cold solve: this long after it knew its home
    prepare_at_engaging: bool = False  # and again at its first step (a companion with ``start_at_s``, lockstep)
    next_tick_ms: int | None = None
    prepared: bool = False
    arrived_s: float | None = None
    observer: Any = None  # the companion's disturbance observer (None: its config says none)
    stale_s: float = 0.5  # the companion's stale_state_s (the observer leaves a stale state out)
    start_s: float = 0.0  # the companion's start_at_s: before it, it takes no step (nor its observer's period)
    rc_path: bool = True  # the companion flew the RC path (its observer knows the thrust only there)
    home_from_mission: bool = False  # the log holds a mission's download: the companion knew its home from item 0,
    # not from an earlier HOME_POSITION (on a busy machine its download ends later)
    solve_ms: list[float] = field(default_factory=list)
    engaged_solve_ms: list[float] = field(default_factory=list)  # (the gate's steps: its summary's step time)

    def take(self, t: float, msg: Any) -> None:
        """One message of the log at ``t``: to the state, the boat's columns or the mode; a step when due.

        A step due at an ATTITUDE is taken once the log is past that autopilot time (or at the companion's command,
        which followed its step): the companion reads what has come in a burst, then steps, so the HEARTBEAT that
        says it is armed, stamped the same millisecond but logged after the ATTITUDE, is in its step."""
        kind = msg.get_type()
        if self.due_s is not None and (t > self.due_s or kind == "RC_CHANNELS_OVERRIDE"):
            self._tick(self.due_s)
            self.due_s = None
        if kind == "HEARTBEAT":
            self.mode, self.armed = mode_of(msg), bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind in ("RC_CHANNELS", "SERVO_OUTPUT_RAW"):
            self.boat.take(msg)
        elif kind == "RC_CHANNELS_OVERRIDE":
            self._logged(t, msg)
        elif kind in HOME_MESSAGES:
            mission_home = getattr(msg, "seq", -1) == 0
            if self.home is not None and (mission_home or (kind == "HOME_POSITION" and not self.home_from_mission)):
                self.state.set_home(*self.home)  # the companion knows positions from its mission download on
                self.home, self.prepare_at_s = None, t + MEASURE_S
        else:
            before = self.state.rejected
            self.state.on_message(msg)
            if kind == "ATTITUDE" and self.state.rejected == before and self.state.ready():
                self._motion(t)

    def _motion(self, t: float) -> None:
        """An ATTITUDE with a position: to the estimator, to the watch before engaging, the cold solve at the
        companion's start; its step once the log is past it."""
        self.gate.observe(on_timeline(self.state.motion_sample(), t))
        if self.engaged_s is None:  # what the boat has seen of the sea, as the companion watches it
            self.gate.watch(t)
        if self.prepare_at_s is None:
            self.prepare_at_s = t + MEASURE_S
        if not self.prepared and t >= self.prepare_at_s and self.tracker.waypoints:
            from mavbridge.companion.start import wave_step

            wave_step(self.gate.source, self.nmpc, t)  # (the companion's cold solve, after measuring the rates)
            self.nmpc.prepare(self.state.vector(), t, self.tracker.waypoints[0])
            self.prepared = True
        self.due_s = t

    def finish(self) -> None:
        """The step the log's last ATTITUDE was due, then the state the log ends with: a log that stops at the
        waypoint arrives at its last step. A companion's own log ends where it arrived, and its step may have seen a
        position stamped a few milliseconds after the ATTITUDE that made the step (received first), which the
        log's order puts after that step."""
        if self.due_s is not None:
            self._tick(self.due_s)
            self.due_s = None
        if self.arrived_s is not None or not self.rows or not self.state.ready():
            return
        x = self.state.vector()
        if self.tracker.target(float(x[0]), float(x[1])) is None:
            self.arrived_s = float(self.rows[-1]["t_s"])

    def _logged(self, t: float, msg: Any) -> None:
        """The companion's own override (its tlog holds what it sent), beside the step it followed."""
        if self.rows and self.rows[-1]["t_s"] == t and "logged_steering_pwm_us" not in self.rows[-1]:
            self.rows[-1]["logged_steering_pwm_us"] = getattr(msg, f"chan{self.boat.steering_channel}_raw", None)
            self.rows[-1]["logged_throttle_pwm_us"] = getattr(msg, f"chan{self.boat.throttle_channel}_raw", None)

    def would_command(self) -> bool:
        """The companion commands now: the boat armed, in the output's mode."""
        return self.armed and self.mode == mode_name(self.output.required_mode)

    def _tick(self, t: float) -> None:
        """A control step at the controller's period on the log's clock, inside the window, until arrival; only
        where the companion would command, unless every step is planned (``shadow``)."""
        from mavbridge.companion.flight import schedule

        due, self.next_tick_ms, _ = schedule(round(t * 1000), self.next_tick_ms, self.period_ms)
        if not self.window[0] <= t <= self.window[1] or self.arrived_s is not None:
            return
        if not due:
            self._arrival_between_steps(t)
            return
        would = self.would_command()
        if not would and t >= self.start_s:  # as the companion: the observer's period, idle when disarmed, unknown
            # when a pilot drives
            self._observe(t, None if self.armed else IDLE)
        if not would and self.shadow is None:
            return
        x = self.state.vector()
        target = self.tracker.target(float(x[0]), float(x[1]))
        if target is None:
            self.arrived_s = t
            return
        if would and self.engaged_s is None:
            self.engaged_s = t
            if self.prepare_at_engaging:  # (the companion's cold solve from this state, as at a fixed start)
                self.nmpc.prepare(x, t, target)
        self._step(t, x, target, self.gate if would else self.shadow, would)

    def _step(self, t: float, x: np.ndarray, target: tuple[float, float], gate: Any, would: bool) -> None:
        """Plan with ``gate``'s wave (the companion's, or the one of the steps it would not command)."""
        wave = gate.step(self.nmpc, t)
        if not self.prepared:
            self.nmpc.prepare(x, t, target)
            self.prepared = True
        result = self.nmpc.solve(x, t, target, defer_advance=True)
        gate.command_sent()  # (as the companion, once its command is out)
        if would:  # (as the companion: the RC path's command as the propellers give it; unknown in GUIDED)
            given = result.tau if np.all(np.isfinite(result.tau)) else IDLE
            self._observe(t, np.array(achieved_tau(self.nmpc.params, *given)) if self.rc_path else None)
        self.nmpc.advance()
        other = self.shadow if gate is self.gate else self.gate
        if other is not None:
            other.given_elsewhere()  # the NMPC's sea spread came from this gate: the other gives its own again
        self.solve_ms.append(result.wall_time_s * 1e3)
        if would:
            self.engaged_solve_ms.append(result.wall_time_s * 1e3)
        self.rows.append(self._row(t, x, result, wave, would))

    def _observe(self, t: float, tau: np.ndarray | None) -> None:
        observe_period(self.observer, self.nmpc, self.state, round(t * 1000), tau, self.stale_s, lambda line: None)

    def _arrival_between_steps(self, t: float) -> None:
        """An attitude between the replay's steps: the boat may be inside the last waypoint's acceptance radius
        there. The companion steps at the attitudes its own ticks fell on, which a skipped tick moves off the
        replay's grid; its arrival can be at one of these, with a state the next step's no longer shows (a GPS
        fix later). Only the last waypoint, and the tracker left alone: an intermediate one is reached (dropped)
        at a step, as the companion does, so the replay's commands stay the companion's. The replay may so
        arrive an attitude or more before a companion that skipped nothing (a grazing pass it never saw)."""
        waypoints = self.tracker.waypoints
        if self.rows and len(waypoints) == 1:
            x = self.state.vector()
            if math.hypot(waypoints[0][0] - float(x[0]), waypoints[0][1] - float(x[1])) <= self.tracker.acceptance_m:
                self.arrived_s = t

    def _row(self, t: float, x: np.ndarray, result: Any, wave: dict[str, float], would: bool) -> dict[str, Any]:
        """The step's columns: state, command (and what it means for the motors), the boat's, the wave's."""
        try:
            sent = self.output.compute(result, round(t * 1000)).columns
        except ValueError:
            sent = {}  # a plan that cannot be sent: the companion sends neutral instead
        _, _, throttle, steering = skid_fractions(self.params, float(result.tau[0]), float(result.tau[1]))
        return {"t_s": t, "mode": self.mode, "armed": int(self.armed), "would_command": int(would),
                **dict(zip(STATE_COLUMNS, (float(v) for v in x), strict=True)),
                "tau_x_n": float(result.tau[0]), "tau_n_nm": float(result.tau[1]), "cmd_throttle": throttle,
                "cmd_steering": steering, **sent, **self.boat.columns, **wave,
                "roll_term": int(result.roll_term_active), "solve_ms": result.wall_time_s * 1e3,
                "status": result.status, "fallback": result.fallback_source or ""}


def _waypoints(req: ReplayRequest, trial: Trial) -> tuple[tuple[float, float], list[tuple[float, float]]]:
    """(the frame's origin lat/lon: the log's home, else its first fix; the waypoints north/east of it)."""
    origin = trial.home or trial.origin
    if origin is None:
        raise LogError(f"LOG: {trial.info.path}: no position in the log: nothing to fly from")
    if req.waypoint is not None:
        return origin, [req.waypoint]
    from vessel.geo import ned_from_latlon

    points = [ned_from_latlon(*origin, *p) for p in trial.waypoints]
    if not points:
        raise LogError(f"LOG: {trial.info.path}: no mission waypoint in the log; give --waypoint N,E (metres from "
                       "the log's home)")
    return origin, points


def window_of(req: ReplayRequest) -> tuple[float, float]:
    start, stop = req.start_s or 0.0, math.inf if req.stop_s is None else req.stop_s
    if stop <= start:
        raise LogError(f"--to: {stop:g} s is not after --from {start:g} s")
    return start, stop


def refuse_early(req: ReplayRequest, trial: Trial) -> None:
    """A log the replay cannot fly (no position, no waypoint): LogError now, before seconds of building."""
    _waypoints(req, trial)


def prepare_flight(req: ReplayRequest, trial: Trial, scenario: Any, config: Any, nmpc: Any, waves: Any,
                   say: Any, imu: str | None = None) -> Flight:
    """The companion's parts for this log: state from the log's home (once the log shows it), the IMU kind ``imu``
    (the log's fastest), the output prepared from the log's parameters."""
    from mavbridge.companion.mission_tracker import MissionTracker
    from mavbridge.companion.output_paths import make_output
    from mavbridge.companion.parameters import values_problem
    from mavbridge.companion.wave_gate import WaveGate
    from mavbridge.preflight.rules import Context

    origin, points = _waypoints(req, trial)
    period_s = scenario.controller.period_s
    ctx = Context(config.system_id, config.output, period_s, scenario.waypoint.acceptance_radius_m)
    output = make_output(config.output, True, scenario.model_params(), ctx, config.lookahead_steps, say,
                         config.attitude_form)
    problem = values_problem(trial.params, ctx, config.attitude_form)
    if problem is not None:
        raise LogError(f"replay: the companion would not fly this autopilot: {problem}")
    try:
        output.configure(trial.params)
    except ValueError as exc:
        raise LogError(f"replay: the companion would not fly this autopilot: {exc}") from None
    tracker = MissionTracker(scenario.waypoint.acceptance_radius_m, None, say)
    tracker.waypoints = list(points)
    state = StateEstimate(max_distance_m=config.max_distance_m)
    state.use_imu(imu)  # (None: the first kind that arrives, as the state takes it)
    if trial.home is None:  # the log never says its home: positions from its first fix on
        state.set_home(*origin)
    shadow = WaveGate(waves, lambda line: None, hold_s=scenario.estimation.hold_s) if req.plan_all else None
    gate = WaveGate(waves, say, hold_s=scenario.estimation.hold_s)  # (after the shadow: the source's log is this one's)
    flight = Flight(nmpc, gate, output, tracker, scenario.model_params(), round(period_s * 1000), window_of(req),
                    BoatOutputs.from_parameters(trial.params, say), state, shadow,
                    None if trial.home is None else origin)
    flight.prepare_at_engaging = config.start_at_s is not None
    flight.observer = DisturbanceObserver(nmpc) if config.disturbance == "estimated" else None
    flight.stale_s, flight.start_s = config.stale_state_s, config.start_at_s or 0.0
    flight.rc_path = config.output == "rc_override"
    flight.home_from_mission = bool(trial.waypoints)
    return flight


