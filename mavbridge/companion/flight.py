"""`mavbridge run`: the companion process that flies the roll-aware NMPC over MAVLink.

Link -> state -> NMPC -> command, on the autopilot's clock (ATTITUDE.time_boot_ms), at the
controller's period. It relies only on what a stock ArduPilot Rover sends and accepts: HEARTBEAT,
ATTITUDE, GLOBAL_POSITION_INT, LOCAL_POSITION_NED, the mission protocol, PARAM_VALUE, COMMAND_ACK;
TIMESYNC (its answer to ours: the link's round trip, for delay compensation); SCALED_IMU / RAW_IMU (for
the wave estimator, where streamed); and it sends RC_CHANNELS_OVERRIDE (MANUAL) or SET_ATTITUDE_TARGET
(GUIDED).

The loop is put together from parts: the NMPC (built outside and passed in), a ``WaveSource`` (all
it knows about the sea; by default the estimator, gated on its confidence by a ``WaveGate``), an
output path (``output_paths``), a ``MissionTracker``, the ``Supervisor`` and a ``RunRecorder`` whose
CSV schema and metrics the in-process experiment shares.
"""

from __future__ import annotations

import gc
import json
import math
import signal
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mavbridge.companion.command_channel import CommandChannel
from mavbridge.companion.config import CompanionConfig, load_companion_config
from mavbridge.companion.delay import make_compensator
from mavbridge.companion.engage_gate import far_waypoint
from mavbridge.companion.mission_tracker import MissionTracker
from mavbridge.companion.notices import LoopNotices
from mavbridge.companion.output_paths import MODE_HOLD, make_output
from mavbridge.companion.start import DeferredStart, start_flight, switch_mode_at_start, wave_step
from mavbridge.companion.start import log_result as _log_result
from mavbridge.companion.state import StateEstimate
from mavbridge.companion.summary import LoopEvents, loop_metrics, summary_lines
from mavbridge.companion.supervisor import Phase, Supervisor
from mavbridge.companion.wave_gate import WaveGate
from mavbridge.lab.runlog import RunRecorder, write_csv
from mavbridge.lab.scenario import Scenario
from mavbridge.link.connection import Link, LinkError, mavlink
from mavbridge.link.port_guard import hold_exclusively, refuse_if_taken
from mavbridge.link.reboot import watch_reboots
from mavbridge.nmpc import RollAwareNmpc
from mavbridge.nmpc.disturbance import IDLE, DisturbanceObserver, observe_period
from mavbridge.nmpc.model_state import resolve_heave_feedback
from mavbridge.preflight.rules import Context
from mavbridge.waves.source import SCENARIO_TRUTH, WaveSource
from vessel import CalmWater
from vessel.allocation import achieved_tau
from vessel.config import to_mapping

# The NMPC's next plan is prepared in a background thread while the loop waits for the autopilot (nrti, asrti):
# at Python's 5 ms switch interval a message that woke the loop could wait up to 5 ms for the interpreter, half
# a period at --speedup 10 (``mavbridge run`` sets this for its process)
GIL_SWITCH_S = 0.0005

__all__ = ["GIL_SWITCH_S", "Companion", "CompanionConfig", "build_nmpc", "load_companion_config", "ready_for_loop",
           "schedule", "wave_step"]


def ready_for_loop() -> None:
    """The interpreter set for the control loop, once everything before it is built: the loop first to the
    interpreter (``GIL_SWITCH_S``), and what was built so far (the NMPC's functions, the solver, the modules) left
    out of the cyclic garbage collector's passes (``gc.freeze``), so that a full pass over it (up to about a
    millisecond here) is not in some step's time. What the loop allocates is collected as before."""
    sys.setswitchinterval(GIL_SWITCH_S)
    gc.collect()
    gc.freeze()


def build_nmpc(scenario: Scenario, waves: WaveSource, lockstep: bool = False) -> RollAwareNmpc:
    """The scenario's NMPC for flying in real time, planning with the wave source's first answer (calm water
    when it has none). Paced at its period (``RollAwareNmpc.pace``; the loop re-paces it at the autopilot
    clock's rate): a step waits for the background plan a quarter period at most (in ``lockstep``, simulation
    only, the scenario's full ``as_wait_s`` and no budget: wall time does not pass for the boat, and a result
    that depends on the machine's load would not be reproducible). A real hull rides the sea (heave_feedback,
    model_state): only simulation truth keeps the paper's setting."""
    heaves = waves.name != SCENARIO_TRUTH
    controller = scenario.controller.replace(heave_feedback=resolve_heave_feedback(scenario.controller.heave_feedback,
                                                                                   heaves))
    estimate = waves.estimate(0.0)
    field = estimate.field() if estimate is not None else CalmWater()
    nmpc = RollAwareNmpc(controller, scenario.model_params(), field)  # its model alone: no plant, current, wind
    if not lockstep:
        nmpc.pace(controller.period_s)
    return nmpc


def schedule(now_ms: int, next_tick_ms: int | None, period_ms: int) -> tuple[bool, int, int]:
    """(a control step is due at autopilot time ``now_ms``, the next tick, periods missed since the last).

    Ticks are the first samples at or after whole multiples of the period on the autopilot clock, the grid
    `sim-vehicle --lockstep` holds at too. The first sample, or a clock far behind the schedule (the
    autopilot rebooted), starts it again at the next grid point.
    """
    if next_tick_ms is None or now_ms < next_tick_ms - 10 * period_ms:
        next_tick_ms = -(-now_ms // period_ms) * period_ms
    if now_ms < next_tick_ms:
        return False, next_tick_ms, 0
    missed = (now_ms - next_tick_ms) // period_ms
    return True, next_tick_ms + (missed + 1) * period_ms, missed


def write_run_config(out_dir: Path, config: CompanionConfig, scenario: Scenario, wave_source: str) -> None:
    """config.yaml of the run folder: the companion settings, the scenario, and where the waves came from."""
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "config.yaml").write_text(yaml.safe_dump({"companion": to_mapping(config),
                                                         "scenario": scenario.to_mapping(),
                                                         "wave_source": wave_source}))


def wave_source_line(name: str) -> str:
    """What the run says at its start about where its waves come from."""
    if name == SCENARIO_TRUTH:
        return "waves: the scenario's sea (simulation truth); a real boat is told nothing about the sea"
    return f"waves: {name} from the boat's own motion; the roll term waits for a confident estimate"


def companion_metrics(c: Companion) -> dict[str, Any]:
    """What identifies a run (phase, output, solver, wave source), its figures, and the link's counts; a
    one-waypoint mission adds the overshoot past it and the loops around it (the companion's own state)."""
    points = c.mission.loaded
    single = (float(points[0][0]), float(points[0][1])) if len(points) == 1 else None
    return {"phase": c.supervisor.phase.name, "reason": c.supervisor.reason, "output": c.config.output,
            "solver": c.scenario.controller.solver, "wave_source": c.waves.name,
            "heave_feedback": c.nmpc.config.heave_feedback, **loop_metrics(c.record, c.events, single),
            "waves": c.gate.summary(c.record.solve_ms), "link": dict(c.link.counts) if c.link else {},
            "delay": c.delay.summary(),
            "disturbance": c.observer.metrics() if c.observer is not None else None}


def finish_at_waypoint(c: Companion, link: Link, now_ms: int) -> None:
    """Neutral, then HOLD (if configured), then release: the boat is never left to moving sticks."""
    c.events.arrived_at_ms = now_ms
    c.supervisor.arrived()
    since = f", {(now_ms - c.events.engaged_at_ms) / 1000:.1f} s after engaging" \
        if c.events.engaged_at_ms is not None else ""
    c.log(f"waypoint reached at t = {now_ms / 1000:.1f} s (autopilot time){since}")
    c.output.neutral(link, c.state)
    if c.config.on_arrival == "hold" and c.output.sends:
        c.supervisor.expected_mode = MODE_HOLD
        _log_result(c.log, "HOLD at the waypoint", link.set_mode(MODE_HOLD))
    c.commands.release(link)


class Companion:
    """One run of the companion against one autopilot."""

    def __init__(self, config: CompanionConfig, scenario: Scenario, out_dir: Path, nmpc: RollAwareNmpc,
                 waves: WaveSource, waypoint_ne: tuple[float, float] | None = None, arm: bool = False,
                 set_mode: bool = False, dry_run: bool = False, log: Callable[[str], None] = print) -> None:
        self.config, self.scenario, self.out_dir, self.nmpc, self.waves = config, scenario, out_dir, nmpc, waves
        self.arm, self.set_mode, self.log = arm, set_mode, log
        self.period_s = scenario.controller.period_s
        self.period_ms = round(self.period_s * 1000)
        ctx = Context(config.system_id, config.output, self.period_s, scenario.waypoint.acceptance_radius_m,
                      config.attitude_form)
        self.output = make_output(config.output, dry_run, scenario.model_params(), ctx, config.lookahead_steps, log,
                                  config.attitude_form)
        self.commands = CommandChannel(self.output, log)
        self.supervisor = Supervisor(self.output.required_mode, config.link_timeout_s, dry_run)
        self.state = StateEstimate(max_distance_m=config.max_distance_m)
        self.mission = MissionTracker(scenario.waypoint.acceptance_radius_m, waypoint_ne, log)
        self.record = RunRecorder(self.period_s)
        self.gate = WaveGate(waves, log, hold_s=scenario.estimation.hold_s)
        self.observer = DisturbanceObserver(nmpc) if config.disturbance == "estimated" else None
        self.observe = partial(observe_period, self.observer, nmpc, self.state, stale_s=config.stale_state_s, log=log)
        self.events = LoopEvents()
        self.notices = LoopNotices(log, self.output.required_mode)
        self.delay = make_compensator(config, nmpc)  # the state's age on the link; prediction over the delay
        self._failure: str | None = None  # set when the run ends in a failure (exit 1): systemd restarts it
        self.link: Link | None = None
        self._stop_reason: str | None = None
        self._signal_interrupts = True  # until the loop runs, a stop signal interrupts a blocking wait
        self._start_ms = round(config.start_at_s * 1000) if config.start_at_s is not None else 0
        self.deferred_start: DeferredStart | None = None  # --set-mode/--arm deferred to a later tick

    def _on_heartbeat(self, msg: Any) -> None:
        if msg.get_type() == "HEARTBEAT":
            armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            before = self.supervisor.phase
            after = self.supervisor.on_heartbeat(time.monotonic(), armed, int(msg.custom_mode))
            if after != before:
                shadow = after == Phase.ENGAGED and not self.output.sends  # a dry run: planning, nothing sent
                self.log(f"phase: {'shadow (dry run: planning, sending nothing)' if shadow else after.value}"
                         + (f" ({self.supervisor.reason})" if after.final else ""))

    def _on_motion(self, msg: Any) -> None:
        """Every ATTITUDE sample (once a position is known) goes to the wave source, after the state took it."""
        if msg.get_type() != "ATTITUDE":
            return
        if self.events.connected_at_ms is None:
            self.events.connected_at_ms = self.state.attitude_ms
        if self.state.ready():
            self.gate.observe(self.state.motion_sample())
            if self.events.engaged_at_ms is None:  # what the boat has seen of the sea, said once it is known
                self.gate.watch((self.state.attitude_ms or 0) / 1000.0)

    def _control_step(self, link: Link, now_ms: int) -> None:
        if not self.supervisor.may_command():
            if self.commands.commanding:
                self.commands.release(link)
            self.observe(now_ms, idle_or_unknown(self))
            return
        if self.state.age_ms(now_ms) > self.config.stale_state_s * 1000:
            self.events.stale += 1
            if self.commands.commanding:
                self.output.neutral(link, self.state)  # never leave the last command running on old data
            return
        x = self.state.vector()
        far = far_waypoint(self.mission.waypoints, self.config.max_range_m, (float(x[0]), float(x[1])))
        if far is not None:  # the engage gate: never a command towards a waypoint out of range (new missions too)
            self._fail(link, far)
            return
        target = self.mission.target(float(x[0]), float(x[1]))
        if self.events.engaged_at_ms is None:
            self.events.engaged_at_ms = now_ms
            if self.config.start_at_s is not None and target is not None:  # the cold solve here, from this state
                self.nmpc.prepare(x, now_ms / 1000.0, target)
        if target is None:
            finish_at_waypoint(self, link, now_ms)
            return
        self._command(link, now_ms, x, target)

    def _command(self, link: Link, now_ms: int, x: np.ndarray, target: tuple[float, float]) -> None:
        """Solve from the state predicted to when the command acts, send, and record the step."""
        age_s, plan_s = self.delay.compensate(now_ms / 1000.0)  # plan_s: when the command will act
        phase, wave = self.supervisor.phase.name, {**self.gate.step(self.nmpc, plan_s), "state_age_s": age_s}
        deadline_s = None  # lockstep: late is not a fault
        if not self.config.lockstep:  # a period of autopilot time, in wall seconds (a tenth at --speedup 10)
            deadline_s = self.delay.wall_seconds(self.period_s)
            self.nmpc.pace(deadline_s)
        x_plan = self.delay.predict(x, now_ms / 1000.0, plan_s, self.nmpc.waves, self.nmpc.disturbance)
        result = self.nmpc.solve(x_plan, plan_s, target, deadline_s=deadline_s, defer_advance=True)
        self.delay.sent(plan_s, result.tau)
        self.output.aim(target)
        columns = self.commands.send(link, result, now_ms, self.state)
        self.gate.command_sent()  # the period's samples to the estimator's process, once the command is out
        self.observe(now_ms, thrust_in_effect(self, result.tau if columns is not None else IDLE), x=x)
        self.nmpc.advance()  # the next period's preparation, once the command is out (see RollAwareNmpc.solve)
        if self.observer is not None:
            wave.update(self.observer.row())
        if columns is None:  # not finite: neutral was sent instead
            if result.success:  # a failed solve is counted by the recorder already
                self.record.failures += 1
            self.record.step(now_ms / 1000.0, x, result, phase=phase, sent=int(self.output.sends), **wave)
            return
        self.record.step(now_ms / 1000.0, x, result, phase=phase, sent=int(self.output.sends), **wave, **columns)
        self.notices.progress(now_ms / 1000.0, math.hypot(target[0] - x[0], target[1] - x[1]), float(x[3]),
                              result.wall_time_s * 1e3)

    def _fail(self, link: Link, reason: str) -> None:
        """End the run as a failure (exit 1), standing down first."""
        self.log(f"mavbridge run: error: {reason}")
        self._failure = reason
        self.supervisor.stop(reason)
        if self.commands.commanding:
            self.commands.stand_down(link, self.state)

    def stop_requested(self) -> bool:
        """True once a signal asked the companion to stop (the loop ends at its next turn)."""
        return self._stop_reason is not None

    def _handle_signal(self, signum: int, frame: Any) -> None:
        self._stop_reason = f"signal {signal.Signals(signum).name}"
        if self._signal_interrupts:  # still connecting or preparing: stop now, the loop is not there to see it
            self._signal_interrupts = False  # once: a second signal while this one unwinds is only noted
            raise LinkError(f"stopped by {self._stop_reason} before flying")

    def run(self) -> int:
        """Connect, prepare, fly until a final phase; always releases and writes logs. Returns an exit code."""
        write_run_config(self.out_dir, self.config, self.scenario, self.waves.name)
        self.log(wave_source_line(self.waves.name))
        try:
            refuse_if_taken(self.config.connect)  # one companion per UDP port
            link = Link(self.config.connect, self.config.system_id, self.config.component_id,
                        self.out_dir / "companion.tlog", self.config.baud, self.config, self.log)
        except LinkError as exc:
            self.log(f"mavbridge run: error: {exc}")
            return 1
        self.link = link
        hold_exclusively(link.conn)
        link.handlers += [self.state.on_message, self._on_motion, self._on_heartbeat, self.mission.on_message]
        watch_reboots(link, self)  # a reboot mid-run: release, streams again, wait for the pilot
        self.delay.attach(link)
        previous = {s: signal.signal(s, self._handle_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        code = 0
        try:
            start_flight(self, link)
            self._fly(link)
        except LinkError as exc:
            self.supervisor.stop(str(exc))
            code = 0 if self._stop_reason else 1  # asked to stop (systemd stop, Ctrl-C): no failure to restart from
            self.log(f"mavbridge run: {exc}" if self._stop_reason else f"mavbridge run: error: {exc}")
        finally:  # a second signal from here on is only noted: the release and the logs must not be cut short
            self._signal_interrupts = False
            if self.commands.commanding:
                self.commands.stand_down(link, self.state)
            write_logs(self)
            link.close()
            for s, handler in previous.items():  # once a signal asked to stop, a later one (a second Ctrl-C, a
                # repeated SIGTERM that comes late on a busy machine) is ignored until the process ends: the default
                # action would kill it with -15 (systemd restarts a service that ends so). SIG_IGN, not a Python
                # handler: the interpreter's shutdown puts Python handlers back to the default action
                signal.signal(s, handler if self._stop_reason is None else signal.SIG_IGN)
        return 1 if self._failure else code

    def _service_link(self, link: Link, next_tick_ms: int | None = None) -> bool:
        """Rest until the next tick can come, read the link, follow the mission and the supervisor; False: end."""
        link.heartbeat_if_due()
        self.events.reads += next_tick_ms is not None  # (the loop's reads once its ticks begin)
        self.delay.read(link, None if next_tick_ms is None else next_tick_ms / 1000.0, self.period_s)
        if self.mission.changed and self.commands.commanding:
            self.commands.stand_down(link, self.state)  # the download blocks for seconds: never leave it running
        self.mission.reload_if_changed(link, self.state.set_home)
        phase_before = self.supervisor.phase
        if self.supervisor.tick(time.monotonic()) != phase_before:
            self.log(f"phase: {self.supervisor.phase.value}")
        if self.supervisor.phase == Phase.TAKEN_OVER and self.commands.commanding:
            self.commands.release(link)  # the sticks are the pilot's
        if self.supervisor.outage_s(time.monotonic()) > self.config.max_link_outage_s:
            self._fail(link, f"link lost for more than {self.config.max_link_outage_s:g} s")
            return False
        if not self.config.lockstep and self.commands.stale(self.period_s):  # (lockstep: the boat's time waits)
            self.commands.stand_down(link, self.state)  # no fresh step for three periods (no ATTITUDE): stop
        return True

    def _fly(self, link: Link) -> None:
        """The loop: one control step per period of autopilot time, until a final phase."""
        next_tick_ms: int | None = None
        self._signal_interrupts = False
        while not self.supervisor.phase.final:
            if self._stop_reason:
                self.supervisor.stop(self._stop_reason)
                break
            if not self._service_link(link, next_tick_ms):
                break
            if self.supervisor.phase == Phase.WAITING and not self.supervisor.self_commanded:
                self.notices.waiting(self.supervisor.reason)
            now_ms = self.state.attitude_ms
            if now_ms is None or now_ms < self._start_ms:
                continue
            due, next_tick_ms, missed = schedule(now_ms, next_tick_ms, self.period_ms)
            if not due:
                continue
            self.events.ticked(missed)
            self.delay.ticked((now_ms - next_tick_ms + self.period_ms) / 1000.0)  # its ATTITUDE's lag past the tick
            self.notices.skipped(missed, self.period_s)
            if self.deferred_start is not None and now_ms >= self.deferred_start.due_ms:
                switch_mode_at_start(self, link, now_ms)
            self._control_step(link, now_ms)
            engaged = self.events.engaged_at_ms
            if self.config.max_time_s and engaged is not None and now_ms - engaged > self.config.max_time_s * 1000:
                self.supervisor.stop("max_time_s reached")
        said, why = self.supervisor.phase.value, self.supervisor.reason
        self.log(f"run ended: {said}" + (f" ({why})" if why and why != said else ""))

    def metrics(self) -> dict[str, Any]:
        """What identifies the run (phase, output, solver, wave source), its figures, and the link's counts."""
        return companion_metrics(self)


def write_logs(c: Companion) -> None:
    """companion.csv and metrics.json of the run folder, and the summary's lines."""
    write_csv(c.out_dir / "companion.csv", c.record.rows)
    m = c.metrics()
    (c.out_dir / "metrics.json").write_text(json.dumps(m, indent=2) + "\n")
    first, *rest = summary_lines(m)
    c.log(f"{first}; logs in {c.out_dir}")
    for line in rest:
        c.log(line)


def idle_or_unknown(c: Companion) -> np.ndarray | None:
    """The thrust while the companion does not command, for its observer: idle when the boat is disarmed, else
    unknown (a pilot drives)."""
    return None if c.supervisor.armed else IDLE


def thrust_in_effect(c: Companion, tau: np.ndarray) -> np.ndarray | None:
    """The thrust the boat has from now on, for the observer: what the propellers give of the command sent on the RC
    path; unknown (None) in GUIDED, where Rover's loops make it, or in a dry run with the boat armed."""
    if c.output.sends and c.config.output == "rc_override":
        return np.array(achieved_tau(c.nmpc.params, *tau))
    return idle_or_unknown(c)
