"""GUIDED targets that make Rover's own loops give the NMPC's steering and throttle: its loops inverted.

In GUIDED, Rover turns a body-yaw-rate target ρ into steering = FF_r·ρ + P_r·(ρ − r) + I_r + D_r and a speed
target s into throttle = (CRUISE_THROTTLE / 100 / CRUISE_SPEED + ATC_SPEED_FF)·s + P_s·(s − u) + I_s + D_s
(``AR_AttitudeControl``; our simulator's ``sim_vehicle/rover/control.py`` likewise, without ATC_SPEED_FF and the D
terms). The RC path sends the steering and throttle that give the plan's τ through the skid mixer; this form sends
the ρ and s for which those expressions, with the measured r and u, equal that steering and throttle. The gains
are read from the autopilot at start (``mavbridge.companion.parameters``; ATC_SPEED_FF and the D gains where the
firmware has them: absent they are 0, ATC_STR_RAT_MAX 0 is no limit, as in Rover). Not inverted: the speed
target's ramp (ATC_ACCEL_MAX), the turn-rate target's (ATC_STR_ACC_MAX: real firmware only), and the difference
between the body yaw rate r used here and the earth-frame yaw rate Rover's loop measures (small at this boat's
roll). Rover's speed target is SET_ATTITUDE_TARGET's thrust × WP_SPEED, at most WP_SPEED: a target above it is
sent as thrust 1 (the log's thrust_frac shows it), where the inversion no longer holds, so the companion says at
start when WP_SPEED is below what full throttle needs (``wp_speed_problem``); ``deploy/otter-guided-tau.parm``
sets 3.5 m/s. With Rover's 2 m/s the plan's full thrust became 77 % throttle and Balanced arrived 24 % late (116.8
s against 94.6 s with 3 and with 3.5 m/s, lockstep, seed 1).

The D terms must be off: the targets jump every 0.1 s, where a D term kicks. Rover's integrators may stay on
(its stock gains): these targets differ from r and u whenever the plan accelerates or turns, so the integrators
wind against them, and following them in the companion (the same errors integrated over its 0.1 s period, with
Rover's anti-windup) drifted from the autopilot's own (100 Hz in the simulator: Balanced 175.6 s, Direct
130.6 s, against 116.8 s and 63.2 s with them off). What they add is seen instead, in the motors' outputs
(``feedback``: SERVO_OUTPUT_RAW), and offset; ``deploy/otter-guided-tau.parm`` turning them off remains an
option, with WP_SPEED 3.5 and ATC_BRAKE 1.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mavbridge.companion.outputs import skid_fractions
from vessel import OtterParameters

LOOP_PARAMETERS = ("CRUISE_THROTTLE", "CRUISE_SPEED", "ATC_SPEED_P", "ATC_STR_RAT_FF", "ATC_STR_RAT_P",
                   "ATC_STR_RAT_MAX", "ATC_SPEED_I", "ATC_SPEED_IMAX", "ATC_STR_RAT_I", "ATC_STR_RAT_IMAX")
# Newer firmware's PID terms (0 by default; our simulator has none): absent reads as 0, and is said.
OPTIONAL_LOOP_PARAMETERS = ("ATC_SPEED_FF", "ATC_SPEED_D", "ATC_STR_RAT_D")
BRAKE = "ATC_BRAKE"  # Rover 4.x, default 1: the speed loop may reverse while the speed target is still ahead
SURGE_MARGIN_MPS = 1.0  # the paper's sea surges the hull past its calm-water full speed (3.3 m/s logged at 2.6)
_WINDS_UP = "Rover's integrators wind up against the inverted targets"
_KICKS = "a D term kicks at every new target, which the inversion does not give"
_MUST_BE_ZERO = {"ATC_STR_RAT_I": _WINDS_UP, "ATC_SPEED_I": _WINDS_UP, "ATC_STR_RAT_D": _KICKS, "ATC_SPEED_D": _KICKS}
INTEGRATORS = ("ATC_STR_RAT_I", "ATC_SPEED_I")  # allowed when the output feedback sees what they do


def _checked(values: dict[str, float | None]) -> dict[str, float]:
    """The gains by name, the optional ones 0 when absent; ValueError naming the first unreadable or negative."""
    checked: dict[str, float] = {}
    for name in (*LOOP_PARAMETERS, *OPTIONAL_LOOP_PARAMETERS):
        value = values.get(name)
        if value is None and name in OPTIONAL_LOOP_PARAMETERS:
            value = 0.0
        if value is None or not math.isfinite(value) or value < 0:
            raise ValueError(f"{name}: {value!r} is not readable or not >= 0")
        checked[name] = value
    for name in ("CRUISE_THROTTLE", "CRUISE_SPEED"):
        if not checked[name] > 0:
            raise ValueError(f"{name}: {checked[name]!r} must be > 0 for the loops to be inverted")
    if not checked["ATC_STR_RAT_FF"] + checked["ATC_STR_RAT_P"] > 0:
        raise ValueError("ATC_STR_RAT_FF + ATC_STR_RAT_P must be > 0 for the turn-rate loop to be inverted")
    return checked


@dataclass(frozen=True)
class RoverLoops:
    """The gains of Rover's turn-rate and speed loops that the inversion needs (SI: rad/s, m/s)."""

    speed_ff: float  # throttle fraction per m/s of target: CRUISE_THROTTLE / 100 / CRUISE_SPEED + ATC_SPEED_FF
    speed_p: float
    rate_ff: float
    rate_p: float
    rate_max_rad_s: float  # ATC_STR_RAT_MAX; 0 there is Rover's "no limit", inf here
    must_be_zero: tuple[tuple[str, float], ...] = ()  # (name, value) of the I and D gains
    absent: tuple[str, ...] = ()  # optional parameters the autopilot did not answer for (taken as 0)
    brake: bool = True  # ATC_BRAKE not 0 (absent: Rover's default, 1)

    @classmethod
    def from_values(cls, values: dict[str, float | None]) -> RoverLoops:
        """From parameter values by name (``OPTIONAL_LOOP_PARAMETERS`` may be None: absent); ValueError naming the
        first one missing or out of range."""
        v = _checked(values)
        rate_max = math.radians(v["ATC_STR_RAT_MAX"]) if v["ATC_STR_RAT_MAX"] > 0 else math.inf
        return cls(v["CRUISE_THROTTLE"] / 100.0 / v["CRUISE_SPEED"] + v["ATC_SPEED_FF"], v["ATC_SPEED_P"],
                   v["ATC_STR_RAT_FF"], v["ATC_STR_RAT_P"], rate_max, tuple((n, v[n]) for n in _MUST_BE_ZERO),
                   tuple(n for n in (*OPTIONAL_LOOP_PARAMETERS, BRAKE) if values.get(n) is None),
                   values.get(BRAKE) != 0)

    def gain_on(self, integrators_allowed: bool = False) -> tuple[str, float] | None:
        """The first I or D gain that is on (I gains only unless ``integrators_allowed``), (name, value), or None."""
        return next(((name, gain) for name, gain in self.must_be_zero
                     if gain != 0 and not (integrators_allowed and name in INTEGRATORS)), None)

    @property
    def integrators_on(self) -> bool:
        """Rover's turn-rate or speed integrator is on (its stock gains): the output feedback must see them."""
        return any(gain != 0 for name, gain in self.must_be_zero if name in INTEGRATORS)

    def gain_problem(self, integrators_allowed: bool = False) -> str | None:
        """Why the inversion cannot be used with these gains (a D term on, or an integrator unless
        ``integrators_allowed``), or None."""
        if (on := self.gain_on(integrators_allowed)) is None:
            return None
        name, gain = on
        return (f"{name} is {gain:g}; set it to 0 ({_MUST_BE_ZERO[name]}); deploy/otter-guided-tau.parm sets it "
                "to 0; or use attitude_form rate")

    @property
    def fastest_planned_mps(self) -> float:
        """The fastest forward speed (m/s) full throttle must pass at: the feed-forwards' own full speed
        1 / speed_ff (CRUISE_SPEED × 100 / CRUISE_THROTTLE with ATC_SPEED_FF 0) plus ``SURGE_MARGIN_MPS``, since
        waves surge the hull past it."""
        return 1.0 / self.speed_ff + SURGE_MARGIN_MPS

    def full_throttle_target_mps(self) -> float:
        """The speed target (m/s) full throttle needs at ``fastest_planned_mps``; (1 + P·u) / (FF + P) grows with
        u, so slower speeds (and full astern down to u = −1 / FF) need less."""
        return self.speed_for_throttle(1.0, self.fastest_planned_mps)

    def wp_speed_problem(self, wp_speed_mps: float) -> str | None:
        """What a WP_SPEED below ``full_throttle_target_mps`` does to this form (its cap on Rover's speed target
        cuts the plan's full thrust), or None."""
        needed = self.full_throttle_target_mps()
        if wp_speed_mps >= needed:
            return None
        return (f"WP_SPEED {wp_speed_mps:g} m/s caps Rover's speed target below the {needed:.2f} m/s full throttle "
                f"needs at {self.fastest_planned_mps:.1f} m/s: the plan's thrust is cut near full speed; "
                f"set WP_SPEED >= {needed:.2f} (deploy/otter-guided-tau.parm)")

    def warnings(self, wp_speed_mps: float) -> list[str]:
        """What flies but not as planned with these settings: WP_SPEED cutting full throttle, ATC_BRAKE 0 (Rover
        then zeroes a reverse throttle while the speed target is ahead: the plan's braking is lost), and the
        parameters taken as Rover's defaults because the autopilot has none (or, ATC_BRAKE, did not answer)."""
        said = [problem] if (problem := self.wp_speed_problem(wp_speed_mps)) else []
        if not self.brake:
            said.append("ATC_BRAKE is 0: Rover zeroes a reverse throttle while the speed target is ahead, so the "
                        "plan's braking is lost; set ATC_BRAKE 1")
        if self.absent:
            said.append(f"{', '.join(self.absent)} absent from the autopilot: taken as Rover's defaults "
                        "(0; ATC_BRAKE 1)")
        return said

    def speed_for_throttle(self, throttle: float, speed_mps: float) -> float:
        """The speed target (m/s) whose feed-forward + P output is ``throttle`` at forward speed ``speed_mps``."""
        return (throttle + self.speed_p * speed_mps) / (self.speed_ff + self.speed_p)

    def rate_for_steering(self, steering: float, yaw_rate: float) -> float:
        """The turn-rate target (rad/s, within ±ATC_STR_RAT_MAX, which Rover applies too) whose FF + P output is
        ``steering``."""
        rate = (steering + self.rate_p * yaw_rate) / (self.rate_ff + self.rate_p)
        return float(np.clip(rate, -self.rate_max_rad_s, self.rate_max_rad_s))


def default_speed(read: Callable[[str], float | None]) -> float | None:
    """Rover's default speed (m/s), which scales SET_ATTITUDE_TARGET's thrust: WP_SPEED, or CRUISE_SPEED where it
    is 0 (older firmware); None when neither is readable and > 0 (the companion then refuses GUIDED: never an
    assumed speed). ``read``: a parameter by name, None when unreadable."""
    for name in ("WP_SPEED", "CRUISE_SPEED"):
        speed = read(name)
        if speed is not None and speed > 0:
            return speed
    return None


def loop_targets(params: OtterParameters, loops: RoverLoops, tau_x: float, tau_n: float, speed_mps: float,
                 yaw_rate: float, offsets: tuple[float, float] = (0.0, 0.0)) -> tuple[float, float]:
    """(turn-rate target rad/s, speed target m/s) for the plan's first τ (N, N·m) at the plan's initial u (m/s)
    and r (rad/s): the state as measured, or as predicted to when the command acts with delay compensation;
    ``offsets`` (throttle, steering) added before the inversion (``guided.feedback``)."""
    _, _, throttle, steering = skid_fractions(params, tau_x, tau_n)
    return (loops.rate_for_steering(steering + offsets[1], yaw_rate),
            loops.speed_for_throttle(throttle + offsets[0], speed_mps))

