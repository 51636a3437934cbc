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

from mavbridge.companion.guided_inverse import RoverLoops, default_speed, loop_targets
from mavbridge.companion.outputs import (
    ATTITUDE_FORMS,
    ATTITUDE_TYPE_MASK_HEADING,
    AttitudeCommand,
    RcSetup,
    attitude_command,
    neutral_pwm,
    rc_command,
)
from mavbridge.companion.parameters import rc_setup, read_or_refuse
from mavbridge.link.connection import mavlink
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


class _Sending:
    """``command`` for paths that send: compute, then send."""

    sends = True

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
        values = read_or_refuse(link, self.ctx, self.log).values
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


class AttitudeTarget(_Sending):
    """GUIDED: SET_ATTITUDE_TARGET in one of three forms: the plan's body yaw rate and speed ``lookahead_steps``
    ahead (rate), its heading and speed there (heading), or the rate and speed targets for which Rover's loops
    give the plan's first thrusts (tau, ``mavbridge.companion.guided_inverse``)."""

    name, required_mode = "attitude_target", MODE_GUIDED

    def __init__(self, lookahead_steps: int, log: Log, form: str = "rate",
                 params: OtterParameters | None = None, ctx: Context | None = None) -> None:
        if form not in ATTITUDE_FORMS or (form == "tau" and params is None):
            raise ValueError(f"attitude_form: {form!r} is not one of {', '.join(ATTITUDE_FORMS)} (tau needs the "
                             "vessel's parameters)")
        self.lookahead_steps, self.log, self.form, self.params = lookahead_steps, log, form, params
        self.ctx = ctx if ctx is not None else Context(255, self.name, 0.1, 2.0, form)
        self.wp_speed_mps: float | None = None  # read at prepare(): never assumed
        self.loops: RoverLoops | None = None

    def prepare(self, link: Any) -> None:
        """Read what the form depends on (``parameters``): WP_SPEED scales thrust (older firmware: CRUISE_SPEED
        when WP_SPEED is 0), the tau form also Rover's loop gains and its mixer. Refuses (LinkError, one line)
        when one is unread, an I or D term is on or the vehicle is no boat; warns of what flies but not as
        planned (``RoverLoops.warnings``)."""
        values = read_or_refuse(link, self.ctx, self.log).values
        self.wp_speed_mps = default_speed(values.get)
        if self.form == "tau":
            self.loops = loops = RoverLoops.from_values(values)
            self.log(f"GUIDED: Rover's loops inverted (speed FF {loops.speed_ff:.3f}/m/s, P {loops.speed_p:g}; "
                     f"turn-rate FF {loops.rate_ff:g}, P {loops.rate_p:g})")
            for warning in loops.warnings(self.wp_speed_mps):
                self.log(f"warning: GUIDED tau form: {warning}")

    def _attitude(self, result: Any) -> AttitudeCommand:
        """The target for this answer in this path's form."""
        assert self.wp_speed_mps is not None, "prepare() first"
        if self.form != "tau":
            return attitude_command(result.states, self.wp_speed_mps, self.lookahead_steps, self.form)
        assert self.loops is not None and self.params is not None, "prepare() first"
        x0 = result.states[0]
        rate, speed = loop_targets(self.params, self.loops, float(result.tau[0]), float(result.tau[1]),
                                   float(x0[6]), float(x0[11]))
        if not (math.isfinite(rate) and math.isfinite(speed)):
            raise ValueError("plan: non-finite turn-rate or speed target")
        return AttitudeCommand(float(x0[5]), max(-1.0, min(1.0, speed / self.wp_speed_mps)), speed, rate)

    def compute(self, result: Any, now_ms: int) -> Command:
        """The target in this path's form (see the class docstring) and its log columns."""
        att = self._attitude(result)
        columns = {"yaw_target_rad": att.yaw_rad, "thrust_frac": att.thrust}
        if att.yaw_rate_rad_s is not None:
            columns["yaw_rate_target_rad_s"] = att.yaw_rate_rad_s
        return Command(columns, lambda link: link.attitude_target(now_ms, att.quaternion(), att.thrust,
                                                                  att.type_mask, att.yaw_rate_rad_s or 0.0))

    def neutral(self, link: Any, state: Any) -> None:
        """Hold the present heading with zero thrust: no pivot towards north."""
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


def make_output(output: str, dry_run: bool, params: OtterParameters, ctx: Context, lookahead_steps: int,
                log: Log, attitude_form: str = "rate") -> Output:
    """The strategy for ``output`` (rc_override or attitude_target, in ``attitude_form``), in DryRun if asked."""
    paths: dict[str, Callable[[], Output]] = {
        "rc_override": lambda: RcOverride(params, ctx, log),
        "attitude_target": lambda: AttitudeTarget(lookahead_steps, log, attitude_form, params,
                                                  dataclasses.replace(ctx, attitude_form=attitude_form))}
    if output not in paths:
        raise ValueError(f"output: {output!r} is not one of {', '.join(paths)}")
    path = paths[output]()
    return DryRun(path) if dry_run else path
