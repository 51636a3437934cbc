"""`mavbridge replay LOG`: what the companion would have commanded, fed from a log at the log's own clock.

The companion's own parts, nothing sends: its ``StateEstimate`` takes the log's messages, its wave estimator
(``make_wave_source``, behind its ``WaveGate``) every motion sample, and its NMPC (``build_nmpc``, in
lockstep: each step waits for the solver's background work, as a machine with time to spare would) plans at
the controller's period on the log's clock (``schedule``) towards the log's mission (its ``MissionTracker``
drops each waypoint reached) or ``--waypoint``. The output path (rc_override or attitude_target) is the
companion's, prepared from the log's parameters in a dry run: it computes what it would send and has no link
to send it on. Beside each step are what the boat did (``boat``: the RC inputs the autopilot took and its
motors' outputs) and whether the companion would have been commanding then (armed, in its mode).

The log is read twice: first for its parameters, home and mission, then to fly. The estimator sees the whole
log; the NMPC plans from ``--from`` to ``--to`` (or the arrival). ``DIR/replay.csv`` and ``DIR/replay.png``
are written at the end, in a fresh folder.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.companion.outputs import skid_fractions
from mavbridge.companion.rover_modes import mode_name
from mavbridge.companion.state import StateEstimate
from mavbridge.field.boat import BOAT_COLUMNS, BoatOutputs
from mavbridge.field.logs import LogError, LogReader, check_out, open_log
from mavbridge.field.progress import ProgressLine
from mavbridge.field.trial import Trial, mode_of, on_timeline, record
from mavbridge.lab.runlog import STATE_COLUMNS, WAVE_COLUMNS
from mavbridge.link.connection import mavlink

COMMAND_COLUMNS = ("tau_x_n", "tau_n_nm", "cmd_throttle", "cmd_steering", "steering_pwm_us", "throttle_pwm_us",
                   "yaw_target_rad", "thrust_frac", "yaw_rate_target_rad_s")
COLUMNS = ("t_s", "mode", "armed", "would_command", *STATE_COLUMNS, *COMMAND_COLUMNS, *BOAT_COLUMNS, *WAVE_COLUMNS,
           "roll_term", "solve_ms", "status", "fallback")


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


@dataclass
class Flight:
    """The companion's parts, flown from the log (see the module docstring)."""

    nmpc: Any
    gate: Any
    output: Any
    tracker: Any
    params: Any  # the vessel's (for the skid fractions of τ)
    period_ms: int
    window: tuple[float, float]
    boat: BoatOutputs
    state: StateEstimate
    rows: list[dict[str, Any]] = field(default_factory=list)
    mode: str = ""
    armed: bool = False
    next_tick_ms: int | None = None
    prepared: bool = False
    arrived_s: float | None = None
    solve_ms: list[float] = field(default_factory=list)

    def take(self, t: float, msg: Any) -> None:
        """One message of the log at ``t``: to the state, the boat's columns or the mode; a step when due."""
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            self.mode, self.armed = mode_of(msg), bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind in ("RC_CHANNELS", "SERVO_OUTPUT_RAW"):
            self.boat.take(msg)
        else:
            before = self.state.rejected
            self.state.on_message(msg)
            if kind == "ATTITUDE" and self.state.rejected == before and self.state.ready():
                self.gate.observe(on_timeline(self.state.motion_sample(), t))
                self._tick(t)

    def _tick(self, t: float) -> None:
        """A control step at the controller's period on the log's clock, inside the window, until arrival."""
        from mavbridge.companion.flight import schedule

        due, self.next_tick_ms, _ = schedule(round(t * 1000), self.next_tick_ms, self.period_ms)
        if not self.window[0] <= t <= self.window[1] or self.arrived_s is not None:
            return
        if not due:
            self._arrival_between_steps(t)
            return
        x = self.state.vector()
        target = self.tracker.target(float(x[0]), float(x[1]))
        if target is None:
            self.arrived_s = t
            return
        wave = self.gate.step(self.nmpc, t)
        if not self.prepared:
            self.nmpc.prepare(x, t, target)
            self.prepared = True
        result = self.nmpc.solve(x, t, target)
        self.gate.command_sent()  # (as the companion, once its command is out)
        self.solve_ms.append(result.wall_time_s * 1e3)
        self.rows.append(self._row(t, x, result, wave))

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

    def finish(self) -> None:
        """The state the log ends with: a log that stops at the waypoint arrives at its last step. A companion's
        own log ends where it arrived, and its step may have seen a position stamped a few milliseconds after the
        ATTITUDE that made the step (received first), which the log's order puts after that step."""
        if self.arrived_s is not None or not self.rows or not self.state.ready():
            return
        x = self.state.vector()
        if self.tracker.target(float(x[0]), float(x[1])) is None:
            self.arrived_s = float(self.rows[-1]["t_s"])

    def _row(self, t: float, x: np.ndarray, result: Any, wave: dict[str, float]) -> dict[str, Any]:
        """The step's columns: state, command (and what it means for the motors), the boat's, the wave's."""
        try:
            sent = self.output.compute(result, round(t * 1000)).columns
        except ValueError:
            sent = {}  # a plan that cannot be sent: the companion sends neutral instead
        _, _, throttle, steering = skid_fractions(self.params, float(result.tau[0]), float(result.tau[1]))
        would = self.armed and self.mode == mode_name(self.output.required_mode)
        return {"t_s": t, "mode": self.mode, "armed": int(self.armed), "would_command": int(would),
                **dict(zip(STATE_COLUMNS, (float(v) for v in x), strict=True)),
                "tau_x_n": float(result.tau[0]), "tau_n_nm": float(result.tau[1]), "cmd_throttle": throttle,
                "cmd_steering": steering, **sent, **self.boat.columns, **wave,
                "roll_term": int(result.roll_term_active), "solve_ms": result.wall_time_s * 1e3,
                "status": result.status, "fallback": result.fallback_source or ""}


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if not math.isfinite(value) else f"{value:.6g}"
    return str(value)


def write_rows(path: Path, rows: list[dict[str, Any]]) -> None:
    """replay.csv: COLUMNS, a column a row lacks left empty."""
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=COLUMNS, restval="", extrasaction="ignore")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _cell(v) for k, v in row.items()})


def _config(req: ReplayRequest) -> Any:
    from mavbridge.cli.args import refuse_form_without_guided
    from mavbridge.companion.config import load_companion_config
    from vessel.argtypes import naming

    with naming("--config"):
        config = load_companion_config(req.config, output=req.output, attitude_form=req.attitude_form)
    refuse_form_without_guided(req.attitude_form, config.output)
    return config


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


def _window(req: ReplayRequest) -> tuple[float, float]:
    start, stop = req.start_s or 0.0, math.inf if req.stop_s is None else req.stop_s
    if stop <= start:
        raise LogError(f"--to: {stop:g} s is not after --from {start:g} s")
    return start, stop


def prepare_flight(req: ReplayRequest, trial: Trial, scenario: Any, config: Any, nmpc: Any, waves: Any,
                   say: Any) -> Flight:
    """The companion's parts for this log: state from the log's home, the output prepared from its parameters."""
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
    state.set_home(*origin)
    return Flight(nmpc, WaveGate(waves, say, hold_s=scenario.estimation.hold_s), output, tracker,
                  scenario.model_params(), round(period_s * 1000), _window(req),
                  BoatOutputs.from_parameters(trial.params, say), state)


def summary_lines(flight: Flight, trial: Trial, req: ReplayRequest, solver: str) -> list[str]:
    """What the replay says at its end."""
    rows = flight.rows
    if not rows:
        return ["replay: no control step in the window (no attitude with a position there)"]
    would = sum(r["would_command"] for r in rows)
    lines = [f"replay: {len(rows)} control steps from t = {rows[0]['t_s']:.1f} to {rows[-1]['t_s']:.1f} s of the log "
             f"at {flight.period_ms / 1000:g} s, solver {solver}, output {flight.output.name}; nothing was sent",
             f"replay: the boat was armed in {mode_name(flight.output.required_mode)} (where the companion commands) "
             f"for {would} of them"]
    if flight.arrived_s is not None:
        lines.append(f"replay: the last waypoint reached at t = {flight.arrived_s:.3f} s of the log")
    for what in ("throttle", "steering"):
        cmd = np.array([r.get(f"cmd_{what}", math.nan) for r in rows], float)
        boat = np.array([r.get(f"boat_{what}", math.nan) for r in rows], float)
        both = np.isfinite(cmd) & np.isfinite(boat)
        if both.any():
            lines.append(f"replay: {what}: commanded against the boat's motors, mean |difference| "
                         f"{np.mean(np.abs(cmd[both] - boat[both])):.3f} over {int(both.sum())} steps")
    solve = np.asarray(flight.solve_ms, float)
    lines.append(f"replay: solve median {np.median(solve):.2f} ms, p99 {np.percentile(solve, 99):.2f} ms")
    return lines


def replay_command(req: ReplayRequest) -> int:
    """Carry out `mavbridge replay` (see the module docstring)."""
    from mavbridge.cli.args import single_scenario
    from mavbridge.companion.flight import build_nmpc
    from mavbridge.companion.wave_gate import make_wave_source
    from mavbridge.field.figures import replay_figure
    from mavbridge.lab.runlog import fresh_run_folder

    check_out(req.out)
    reader: LogReader = open_log(Path(req.log), req.fmt, req.sysid, outputs=True)
    config, window = _config(req), _window(req)
    scenario = single_scenario(req.scenario, req.solver, config.model)
    progress = ProgressLine(f"replay: {reader.info.path.name} (its parameters and mission)")
    try:
        trial = record(reader.messages(progress), reader.info)
    finally:
        progress.done()
    _waypoints(req, trial)  # refuse before seconds of building
    waves = make_wave_source("estimated", scenario.sea.waves, config.wave_roll_sign, config.wave_position_lag_s,
                             scenario.model_params())
    with build_nmpc(scenario, waves, lockstep=True) as nmpc:
        flight = prepare_flight(req, trial, scenario, config, nmpc, waves, print)
        progress = ProgressLine(f"replay: {reader.info.path.name}")
        try:
            for t, msg in reader.messages(progress):
                if t > window[1] + 1.0:
                    break
                flight.take(t, msg)
            flight.finish()
        finally:
            progress.done()
    for line in summary_lines(flight, trial, req, scenario.controller.solver):
        print(line)
    folder = fresh_run_folder(Path(req.out) if req.out else Path("runs") / time.strftime("replay-%Y%m%d-%H%M%S"))
    write_rows(folder / "replay.csv", flight.rows)
    (folder / "replay.png").write_bytes(replay_figure(flight.rows, flight.output.name))
    print(f"replay: wrote {folder / 'replay.csv'} and {folder / 'replay.png'}")
    return 0
