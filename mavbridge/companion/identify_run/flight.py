"""`mavbridge run --identify`: the companion flying the identification sequence instead of the NMPC.

Everything but the control step is the ordinary run's (``Companion``): the link, the start, the consent, mode and
arming rules (``--set-mode``/``--arm``/``--engage-after``; without them it waits for the pilot and commands
nothing), the supervisor (a pilot's mode change or disarming ends it), the stale-state neutral, ``--max-time``
and the run folder (companion.tlog, companion.csv, metrics.json). The step asks the sequence for throttle and
steering and sends them on the RC override path through the autopilot's own RC calibration and
PILOT_STEER_TYPE; it asks the autopilot for SERVO_OUTPUT_RAW (the motors' outputs `mavbridge identify` reads).
The brake after each hard turn allows for the command delay the link's delay compensation measures (the state's
age plus the uplink's one-way delay), the median over the last ``DELAY_STEPS_KEPT`` steps.
Limits: farther than ``max_range_m`` from where the sequence started, or past the sequence's longest duration,
it stands down (neutral, then the sticks released) and ends; the range is a failure (exit 1).
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from mavbridge.companion.command_channel import CommandChannel
from mavbridge.companion.flight import Companion
from mavbridge.companion.identify_run.sequence import IdentifySequence, Pose, Sticks, limit_s
from mavbridge.companion.mission_tracker import MissionTracker, download_mission
from mavbridge.companion.output_paths import Command, DryRun, RcOverride
from mavbridge.companion.outputs import STEER_TYPES_REVERSING, RcCalibration, pwm_from_fraction
from mavbridge.link.connection import Link, LinkError, mavlink
from vessel import OtterParameters, shaft_speeds_to_tau

SERVO_OUTPUT_HZ = 10.0
DELAY_STEPS_KEPT = 20  # control steps whose measured command delay the brake takes the median of


@dataclass(frozen=True)
class ScriptedStep:
    """One period's sticks in the shape the run's recorder takes (no solve: zero time, status ``scripted``);
    ``tau`` is what the model's propellers would give for them (N, N·m), for the CSV."""

    sticks: Sticks
    tau: tuple[float, float]
    wall_time_s: float = 0.0
    iterations: int = 0
    success: bool = True
    status: str = "scripted"
    fallback: str | None = None
    fallback_source: str | None = None
    stats: dict[str, float] = field(default_factory=dict)


def model_tau(params: OtterParameters, sticks: Sticks) -> tuple[float, float]:
    """(τ_X, τ_N) the model's propellers give for the sticks through the skid mixer (outputs clipped to ±1)."""
    m = params.matrices()
    outputs = [min(max(sticks.throttle + k * sticks.steering, -1.0), 1.0) for k in (1.0, -1.0)]
    n = [o * float(m.n_max) if o >= 0 else o * abs(float(m.n_min)) for o in outputs]
    tau_x, tau_n = shaft_speeds_to_tau(params, n[0], n[1])
    return float(tau_x), float(tau_n)


def stick_pwm(fraction: float, cal: RcCalibration, reversed_: bool) -> int:
    """The PWM the autopilot reads back as ``fraction``; a reversed channel mirrored about trim."""
    pwm = pwm_from_fraction(fraction, cal)
    return 2 * cal.trim - pwm if reversed_ else pwm


class ScriptedRc(RcOverride):
    """The RC override path with the sequence's sticks as its input instead of the NMPC's τ."""

    def compute(self, result: Any, now_ms: int) -> Command:
        """Steering and throttle PWM for a ``ScriptedStep``'s sticks (the steering mirrored in reverse where
        PILOT_STEER_TYPE reverses it, as the autopilot reads it)."""
        assert self.setup is not None, "prepare() first"
        s = result.sticks
        if not (math.isfinite(s.throttle) and math.isfinite(s.steering)):
            raise ValueError(f"sticks: non-finite throttle {s.throttle!r} or steering {s.steering!r}")
        stick = -s.steering if (self.setup.steer_type in STEER_TYPES_REVERSING and s.throttle < 0) else s.steering
        steering = stick_pwm(stick, self.setup.steering, self.setup.steering_reversed)
        throttle = stick_pwm(s.throttle, self.setup.throttle, self.setup.throttle_reversed)
        channels = self._channels(steering, throttle)
        return Command({"steering_pwm_us": steering, "throttle_pwm_us": throttle},
                       lambda link: link.rc_override(channels))


class HomeOnly(MissionTracker):
    """The mission's home only: the identification flies around where the boat is and takes no waypoint."""

    def load(self, link: Any, set_home: Any) -> None:
        """Download the mission for its home (item 0); its waypoints are not flown (said once)."""
        items = download_mission(link)
        if not items:
            raise LinkError("mission download returned nothing (not even home)")
        set_home(items[0].x / 1e7, items[0].y / 1e7)
        if len(items) > 1 and not self.total:
            self.log(f"identification: the autopilot's mission ({len(items) - 1} items) is not flown")
        self.waypoints, self.loaded, self.total, self.changed = [], [], len(items) - 1, False


class IdentifyCompanion(Companion):
    """The ordinary run with the identification sequence as its control step (see the module docstring)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        if self.config.output != "rc_override":
            raise ValueError("the identification run flies the RC override path only")
        inner = self.output.inner if isinstance(self.output, DryRun) else self.output
        path = ScriptedRc(self.scenario.model_params(), inner.ctx, self.log)
        self.output = DryRun(path) if isinstance(self.output, DryRun) else path
        self.commands = CommandChannel(self.output, self.log)
        self.mission = HomeOnly(self.mission.acceptance_m, None, self.log)
        self.params = self.scenario.model_params()
        self.observer = None  # (the sequence flies open loop: no disturbance is learnt or predicted with)
        self.sequence = IdentifySequence()
        self.limit_s = limit_s()
        self._servos_asked = False
        self._leg: str | None = None
        self._delays: deque[float] = deque(maxlen=DELAY_STEPS_KEPT)  # the command delay measured (s), recent steps

    def _ask_servo_outputs(self, link: Link) -> None:
        """SERVO_OUTPUT_RAW at SERVO_OUTPUT_HZ, once: the motors' outputs for `mavbridge identify`."""
        self._servos_asked = True
        if not link.request_message_interval(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, SERVO_OUTPUT_HZ):
            self.log("warning: SERVO_OUTPUT_RAW not granted: the log will hold the sticks only, not the motors")

    def _limit_reason(self, now_ms: int, x: Any) -> tuple[str, bool] | None:
        """(why the run must end, whether that is a failure), or None while within the limits."""
        start = self.sequence.start
        if start is not None:
            away = math.hypot(float(x[0]) - start[0], float(x[1]) - start[1])
            if not away <= self.config.max_range_m:
                return (f"identification: {away:.0f} m from where the sequence started, farther than --max-range "
                        f"{self.config.max_range_m:g} m: standing down", True)
        engaged = self.events.engaged_at_ms
        if engaged is not None and now_ms - engaged > self.limit_s * 1000:
            return f"identification: the sequence's time limit ({self.limit_s:g} s) reached", False
        return None

    def _control_step(self, link: Link, now_ms: int) -> None:
        if not self._servos_asked:
            self._ask_servo_outputs(link)
        if not self.supervisor.may_command():
            if self.commands.commanding:
                self.commands.release(link)
            return
        if self.state.age_ms(now_ms) > self.config.stale_state_s * 1000:
            self.events.stale += 1
            if self.commands.commanding:
                self.output.neutral(link, self.state)
            return
        x = self.state.vector()
        if self.events.engaged_at_ms is None:
            self.events.engaged_at_ms = now_ms
            self.log(f"identification: flying the sequence (at most {self.limit_s:g} s, within "
                     f"{self.config.max_range_m:g} m of here)")
        limit = self._limit_reason(now_ms, x)
        if limit is not None:
            self._end(link, *limit)
            return
        sampled = self.state.attitude_ms / 1000.0 if self.state.attitude_ms is not None else None
        delay = self._command_delay_s(now_ms / 1000.0 if sampled is None else sampled)
        sticks = self.sequence.command(now_ms / 1000.0,
                                       Pose(float(x[0]), float(x[1]), float(x[5]), float(x[11]), sampled), delay)
        if sticks is None:
            self._end(link, "identification sequence complete", False)
            return
        if sticks.leg != self._leg:
            self._leg = sticks.leg
            said = "" if sticks.leg != "brake" or delay is None else f" (command delay {delay:.2f} s measured)"
            self.log(f"identification: {sticks.leg} at t = {now_ms / 1000:.1f} s{said}")
        step = ScriptedStep(sticks, model_tau(self.params, sticks))
        columns = self.commands.send(link, step, now_ms, self.state)
        self.record.step(now_ms / 1000.0, x, step, phase=self.supervisor.phase.name, sent=int(self.output.sends),
                         **(columns or {}))

    def _command_delay_s(self, state_s: float) -> float | None:
        """The median command delay of the recent steps (s), None while none is measured (lockstep, no clock)."""
        delay = self.delay.command_delay_s(state_s)
        if delay is not None and math.isfinite(delay):
            self._delays.append(delay)
        return statistics.median(self._delays) if self._delays else None

    def _end(self, link: Link, reason: str, failure: bool) -> None:
        """Neutral, release, and end the run (a failure: exit 1)."""
        if failure:
            self._fail(link, reason)
            return
        self.log(reason)
        if self.commands.commanding:
            self.commands.stand_down(link, self.state)
        self.supervisor.stop(reason)
