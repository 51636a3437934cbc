"""The companion's command paths as strategies: RC override, attitude target, and the dry run (null output).

Each path knows how to get ready on the link (read what decides how the autopilot reads it), how to
turn an NMPC answer into what goes out (``compute``: the log columns and the message, nothing sent),
how to send it (``command``), how to hold the boat still while still commanding (``neutral``) and how
to hand the sticks back (``release``). ``DryRun`` wraps a path: it computes what that path would send
and sends nothing at all, so the loop never asks which path or mode it is in.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from mavbridge.companion.guided.feedback import OutputFeedback, motors_from
from mavbridge.companion.guided.inverse import RoverLoops, default_speed, loop_targets
from mavbridge.companion.outputs import (
    ATTITUDE_FORMS,
    ATTITUDE_TYPE_MASK_HEADING,
    AttitudeCommand,
    RcSetup,
    attitude_command,
    neutral_pwm,
    rc_command,
    skid_fractions,
)
from mavbridge.companion.parameters import rc_setup, read_or_refuse
from mavbridge.link.connection import LinkError, mavlink
from mavbridge.preflight.rules import Context
from vessel import OtterParameters

MODE_MANUAL, MODE_HOLD, MODE_GUIDED = mavlink.ROVER_MODE_MANUAL, mavlink.ROVER_MODE_HOLD, mavlink.ROVER_MODE_GUIDED
Log = Callable[[str], None]


@dataclass(frozen=True)
class Command:
    """What one control step would send: the log columns, and the send itself."""

    columns: dict[str, Any]
    send: Callable[[Any], None]


class Output(Protocol):
    """One command path (see the module docstring)."""

    name: str
    required_mode: int
    sends: bool

    def prepare(self, link: Any) -> None:
        """Read what decides how the autopilot takes this path's commands; LinkError if it would ignore them."""
        ...

    def compute(self, result: Any, now_ms: int) -> Command:
        """The command for an NMPC answer; ValueError if the plan cannot be sent (non-finite)."""
        ...

    def command(self, link: Any, result: Any, now_ms: int) -> dict[str, Any]:
        """Compute and send; returns the log columns."""
        ...

    def neutral(self, link: Any, state: Any) -> None:
        """Zero thrust, no turn, still commanding (so the sticks do not take over in between)."""
        ...

    def release(self, link: Any) -> None:
        """Give control back to the pilot."""
        ...

    def aim(self, target_ne: tuple[float, float] | None) -> None:
        """The waypoint the plan goes to (NED m from home), for paths that steer their last metres themselves."""
        ...

    def configure(self, values: dict[str, float]) -> None:
        """What ``prepare`` sets up, from parameter values already read and judged (a log's, in a replay)."""
        ...


class _Sending:
    """``command`` for paths that send: compute, then send."""

    sends = True

    def aim(self, target_ne: tuple[float, float] | None) -> None:
        """Most paths send the plan to the end: the waypoint is the NMPC's business."""

    def command(self, link: Any, result: Any, now_ms: int) -> dict[str, Any]:
        """Compute and send; returns the log columns."""
        cmd = self.compute(result, now_ms)  # type: ignore[attr-defined]
        cmd.send(link)
        return cmd.columns


class RcOverride(_Sending):
    """MANUAL: τ through the vessel's allocation and the inverse of ArduPilot's skid mixer, as RC PWM."""

    name, required_mode = "rc_override", MODE_MANUAL

    def __init__(self, params: OtterParameters, ctx: Context, log: Log) -> None:
        self.params, self.ctx, self.log = params, ctx, log
        self.setup: RcSetup | None = None

    def prepare(self, link: Any) -> None:
        """Read RCMAP, the mapped inputs' calibration, PILOT_STEER_TYPE and the mixer (``parameters``); refuse
        (LinkError, one line) when one is unread or the autopilot would ignore or mix the overrides otherwise."""
        self.configure(read_or_refuse(link, self.ctx, self.log).values)

    def configure(self, values: dict[str, float]) -> None:
        """The RC setup from parameter values already judged (``parameters.engage_problem``)."""
        self.setup = setup = rc_setup(values)
        self.log(f"RC: steering ch{setup.steering_channel}, throttle ch{setup.throttle_channel}, PILOT_STEER_TYPE "
                 f"{setup.steer_type}")

    def _channels(self, steering_pwm: int, throttle_pwm: int) -> dict[int, int]:
        assert self.setup is not None, "prepare() first"
        return {self.setup.steering_channel: steering_pwm, self.setup.throttle_channel: throttle_pwm}

    def compute(self, result: Any, now_ms: int) -> Command:
        """Steering and throttle PWM for the NMPC's (τ_X, τ_N)."""
        assert self.setup is not None, "prepare() first"
        rc = rc_command(self.params, float(result.tau[0]), float(result.tau[1]), self.setup)
        channels = self._channels(rc.steering_pwm, rc.throttle_pwm)
        return Command({"steering_pwm_us": rc.steering_pwm, "throttle_pwm_us": rc.throttle_pwm},
                       lambda link: link.rc_override(channels))

    def neutral(self, link: Any, state: Any) -> None:
        """Both channels at trim."""
        if self.setup is not None:
            link.rc_override(self._channels(*neutral_pwm(self.setup)))

    def release(self, link: Any) -> None:
        """RC override 0 = release, a few times since UDP may drop one."""
        if self.setup is not None:
            for _ in range(3):
                link.rc_override(self._channels(0, 0))


FEEDBACK_WAIT_S = 2.0  # the tau form waits this long (autopilot time) for the first SERVO_OUTPUT_RAW it asked for
FEEDBACK_WAIT_WALL_S = 30.0  # ... and at most this long in wall time (a held lockstep simulator sends nothing)
OUTPUT_FEEDBACK_HZ = 20.0


def _await_servo_outputs(link: Any) -> bool:
    """True once a SERVO_OUTPUT_RAW arrives; False after FEEDBACK_WAIT_S of the autopilot's clock (its ATTITUDE
    stamps) without one, or FEEDBACK_WAIT_WALL_S of wall time."""
    first: dict[str, int] = {}

    def done(msg: Any) -> bool:
        if msg.get_type() == "SERVO_OUTPUT_RAW":
            return True
        if msg.get_type() != "ATTITUDE":
            return False
        now = int(msg.time_boot_ms)
        return now - first.setdefault("ms", now) > FEEDBACK_WAIT_S * 1000

    msg = link.wait_for(done, FEEDBACK_WAIT_WALL_S)
    return msg is not None and msg.get_type() == "SERVO_OUTPUT_RAW"


def start_feedback(link: Any, loops: RoverLoops, values: dict[str, float], log: Log) -> OutputFeedback | None:
    """The tau form's output feedback (``guided.feedback``): SERVO_OUTPUT_RAW asked for at OUTPUT_FEEDBACK_HZ and
    followed, the motors' channels from the parameter ``values`` read at start. Needed when Rover's integrators
    are on (its stock gains): LinkError (one line) then if the motors' channels are unusable or no
    SERVO_OUTPUT_RAW arrives; with them off it is used where it streams."""
    try:
        motors = motors_from(values)
    except LinkError:
        if loops.integrators_on:
            raise
        return None
    feedback = OutputFeedback(motors)
    link.handlers.append(feedback.on_message)
    link.request_message_interval(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, OUTPUT_FEEDBACK_HZ)
    if _await_servo_outputs(link):
        return feedback
    link.handlers.remove(feedback.on_message)
    if loops.integrators_on:
        raise LinkError("attitude_form tau: Rover's integrators are on (its stock gains) and no SERVO_OUTPUT_RAW "
                        f"arrived within {FEEDBACK_WAIT_S:g} s to see what they do; stream it (SRn_RC_CHAN), or set "
                        "ATC_STR_RAT_I and ATC_SPEED_I to 0 (deploy/otter-guided-tau.parm)")
    log("GUIDED tau form: no SERVO_OUTPUT_RAW; the inversion runs open (Rover's integrators are off)")
    return None


APPROACH_RADIUS_M = 10.0  # GUIDED: the final approach starts this close to the waypoint (about two turning circles)
APPROACH_SPEED_MPS = 1.0  # ... at most this fast, slowing to 0.3 m/s at the waypoint


def approach_command(x0: Any, target_ne: tuple[float, float], wp_speed_mps: float) -> AttitudeCommand:
    """GUIDED's final approach: the bearing to the waypoint as Rover's heading target, at a speed that falls with
    the distance (a quarter of it per second, between 0.3 m/s and ``APPROACH_SPEED_MPS``).

    Why: Rover's own loops, with their integrators and a turn-rate loop that lags the plan, make a tighter turn
    than the NMPC expects impossible; within about two turning circles of the waypoint the plan then circled it
    (lockstep, seed 1, the rate form on the estimate: 42 s within 12 m of it at 4.1° of roll, two loops). Its
    heading loop pivots a skid-steered hull towards the bearing, as Rover's own navigation arrives.
    """
    north, east = target_ne[0] - float(x0[0]), target_ne[1] - float(x0[1])
    speed = min(APPROACH_SPEED_MPS, max(0.3, 0.25 * math.hypot(north, east)))
    return AttitudeCommand(math.atan2(east, north), max(-1.0, min(1.0, speed / wp_speed_mps)), speed, None)


class AttitudeTarget(_Sending):
    """GUIDED: SET_ATTITUDE_TARGET in one of three forms: the plan's body yaw rate and speed ``lookahead_steps``
    ahead (rate), its heading and speed there (heading), or the rate and speed targets for which Rover's loops
    give the plan's first thrusts (tau, ``mavbridge.companion.guided.inverse``)."""

    name, required_mode = "attitude_target", MODE_GUIDED

    def __init__(self, lookahead_steps: int, log: Log, form: str = "tau", params: OtterParameters | None = None,
                 ctx: Context | None = None, approach_m: float = APPROACH_RADIUS_M) -> None:
        if form not in ATTITUDE_FORMS or (form == "tau" and params is None):
            raise ValueError(f"attitude_form: {form!r} is not one of {', '.join(ATTITUDE_FORMS)} (tau needs the "
                             "vessel's parameters)")
        self.lookahead_steps, self.log, self.form, self.params = lookahead_steps, log, form, params
        self.approach_m = approach_m
        self.ctx = ctx if ctx is not None else Context(255, self.name, 0.1, 2.0, form)
        self.wp_speed_mps: float | None = None  # read at prepare(): never assumed
        self.loops: RoverLoops | None = None
        self.feedback: OutputFeedback | None = None
        self.target_ne: tuple[float, float] | None = None
        self._approaching = False

    def aim(self, target_ne: tuple[float, float] | None) -> None:
        """The waypoint, for the final approach (``approach_command``)."""
        self.target_ne = target_ne

    def prepare(self, link: Any) -> None:
        """Read what the form depends on (``parameters``): WP_SPEED scales thrust (older firmware: CRUISE_SPEED
        when WP_SPEED is 0), the tau form also Rover's loop gains and its mixer. Refuses (LinkError, one line)
        when one is unread, an I or D term is on or the vehicle is no boat; warns of what flies but not as
        planned (``RoverLoops.warnings``)."""
        values = read_or_refuse(link, self.ctx, self.log).values
        self.configure(values)
        if self.loops is not None:
            self.feedback = start_feedback(link, self.loops, values, self.log)
            if self.feedback is not None:
                self.log("GUIDED: the inversion is closed on SERVO_OUTPUT_RAW (Rover's integrators seen, not assumed)")

    def configure(self, values: dict[str, float]) -> None:
        """WP_SPEED and (tau) Rover's loop gains from parameter values already judged (``parameters``)."""
        self.wp_speed_mps = default_speed(values.get)
        if self.form == "tau":
            self.loops = loops = RoverLoops.from_values(values)
            self.log(f"GUIDED: Rover's loops inverted (speed FF {loops.speed_ff:.3f}/m/s, P {loops.speed_p:g}; "
                     f"turn-rate FF {loops.rate_ff:g}, P {loops.rate_p:g})")
            for warning in loops.warnings(self.wp_speed_mps or 0.0):
                self.log(f"warning: GUIDED tau form: {warning}")

    def _attitude(self, result: Any, now_ms: int) -> AttitudeCommand:
        """The target for this answer in this path's form."""
        assert self.wp_speed_mps is not None, "prepare() first"
        if self.form != "tau":
            return attitude_command(result.states, self.wp_speed_mps, self.lookahead_steps, self.form)
        assert self.loops is not None and self.params is not None, "prepare() first"
        x0 = result.states[0]
        offsets = (0.0, 0.0)
        if self.feedback is not None:
            _, _, throttle, steering = skid_fractions(self.params, float(result.tau[0]), float(result.tau[1]))
            self.feedback.update(now_ms)
            self.feedback.asked(now_ms, throttle, steering)
            offsets = (self.feedback.throttle_offset, self.feedback.steering_offset)
        rate, speed = loop_targets(self.params, self.loops, float(result.tau[0]), float(result.tau[1]),
                                   float(x0[6]), float(x0[11]), offsets)
        if not (math.isfinite(rate) and math.isfinite(speed)):
            raise ValueError("plan: non-finite turn-rate or speed target")
        return AttitudeCommand(float(x0[5]), max(-1.0, min(1.0, speed / self.wp_speed_mps)), speed, rate)

    def compute(self, result: Any, now_ms: int) -> Command:
        """The target in this path's form (see the class docstring) and its log columns; within ``approach_m``
        of the waypoint, the final approach (``approach_command``), said once."""
        att = self._approach(result) or self._attitude(result, now_ms)
        columns = {"yaw_target_rad": att.yaw_rad, "thrust_frac": att.thrust}
        if att.yaw_rate_rad_s is not None:
            columns["yaw_rate_target_rad_s"] = att.yaw_rate_rad_s
        return Command(columns, lambda link: link.attitude_target(now_ms, att.quaternion(), att.thrust,
                                                                  att.type_mask, att.yaw_rate_rad_s or 0.0))

    def _approach(self, result: Any) -> AttitudeCommand | None:
        """The final approach's target when the plan starts within ``approach_m`` of the waypoint, else None."""
        x0 = result.states[0]
        near = self.target_ne is not None and self.approach_m > 0 and math.hypot(
            self.target_ne[0] - x0[0], self.target_ne[1] - x0[1]) < self.approach_m
        if near and not self._approaching:
            self.log(f"GUIDED: final approach within {self.approach_m:g} m: heading for the waypoint at up to "
                     f"{APPROACH_SPEED_MPS:g} m/s with Rover's heading loop")
        self._approaching = near
        if near and self.feedback is not None:
            self.feedback.forget()  # no plan targets while approaching: no request to pair an output with
        return approach_command(x0, self.target_ne, self.wp_speed_mps) if near and self.target_ne else None

    def neutral(self, link: Any, state: Any) -> None:
        """Hold the present heading with zero thrust: no pivot towards north (the output feedback starts
        again from nothing when the plan's targets resume)."""
        if self.feedback is not None:
            self.feedback.forget(offsets=True)
        if state.attitude_ms is not None:
            yaw = float(state.attitude[2])
            link.attitude_target(state.attitude_ms, (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)), 0.0,
                                 ATTITUDE_TYPE_MASK_HEADING)

    def release(self, link: Any) -> None:
        """Nothing to release: GUIDED holds its last target until the mode changes."""


class DryRun:
    """The null output: computes what ``inner`` would send, sends nothing, never holds or releases."""

    sends = False

    def __init__(self, inner: Output) -> None:
        self.inner, self.name, self.required_mode = inner, inner.name, inner.required_mode

    def prepare(self, link: Any) -> None:
        """As the wrapped path (reads only), so the logged commands are the ones it would send."""
        self.inner.prepare(link)

    def configure(self, values: dict[str, float]) -> None:
        """As the wrapped path."""
        self.inner.configure(values)

    def compute(self, result: Any, now_ms: int) -> Command:
        """The wrapped path's command."""
        return self.inner.compute(result, now_ms)

    def command(self, link: Any, result: Any, now_ms: int) -> dict[str, Any]:
        """The log columns only."""
        return self.inner.compute(result, now_ms).columns

    def neutral(self, link: Any, state: Any) -> None:
        """Nothing is sent."""

    def release(self, link: Any) -> None:
        """Nothing was taken."""

    def aim(self, target_ne: tuple[float, float] | None) -> None:
        """As the wrapped path."""
        self.inner.aim(target_ne)


def make_output(output: str, dry_run: bool, params: OtterParameters, ctx: Context, lookahead_steps: int,
                log: Log, attitude_form: str = "tau") -> Output:
    """The strategy for ``output`` (rc_override or attitude_target, in ``attitude_form``), in DryRun if asked."""
    paths: dict[str, Callable[[], Output]] = {
        "rc_override": lambda: RcOverride(params, ctx, log),
        "attitude_target": lambda: AttitudeTarget(lookahead_steps, log, attitude_form, params,
                                                  dataclasses.replace(ctx, attitude_form=attitude_form))}
    if output not in paths:
        raise ValueError(f"output: {output!r} is not one of {', '.join(paths)}")
    path = paths[output]()
    return DryRun(path) if dry_run else path
