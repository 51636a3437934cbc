"""The companion's two command paths, as pure functions of the NMPC's answer.

``rc_override`` (MANUAL): τ_X, τ_N -> shaft speeds (the vessel allocation) -> motor outputs in [-1, 1]
-> the inverse of ArduPilot's skid-steer mixer -> steering (ch1) and throttle (ch3) fractions -> PWM
through the autopilot's own RCn_MIN/TRIM/MAX/DZ. ``attitude_target`` (GUIDED): the plan's heading and
surge speed a short look-ahead ahead, as a SET_ATTITUDE_TARGET yaw quaternion and thrust = speed/WP_SPEED.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from vessel import OtterParameters, tau_to_shaft_speeds

# SET_ATTITUDE_TARGET type_mask bits: ignore body roll rate (1), pitch rate (2), yaw rate (4), attitude (128).
ATTITUDE_TYPE_MASK_HEADING = 0b0000_0111  # all three rates ignored: heading from q, and thrust
ATTITUDE_TYPE_MASK_RATE = 0b1000_0011  # roll/pitch rates and q ignored: body yaw rate, and thrust
ATTITUDE_FORMS = ("heading", "rate", "tau")  # tau: mavbridge.companion.guided.inverse


@dataclass(frozen=True)
class RcCalibration:
    """One RC input channel as the autopilot reads it (µs): RCn_MIN, RCn_TRIM, RCn_MAX, RCn_DZ."""

    minimum: int = 1100
    trim: int = 1500
    maximum: int = 1900
    dead_zone: int = 30

    def __post_init__(self) -> None:
        if not (800 <= self.minimum < self.trim < self.maximum <= 2200):
            raise ValueError(f"RC calibration: need 800 <= MIN < TRIM < MAX <= 2200 µs, got {self.minimum}/"
                             f"{self.trim}/{self.maximum}")
        if not 0 <= self.dead_zone < min(self.trim - self.minimum, self.maximum - self.trim):
            raise ValueError(f"RC calibration: dead zone {self.dead_zone} µs must be in [0, half range)")


def pwm_from_fraction(fraction: float, cal: RcCalibration) -> int:
    """PWM (µs) that an ArduPilot centred input with dead zone reads back as ``fraction`` in [-1, 1]."""
    f = min(max(float(fraction), -1.0), 1.0)  # np.clip's result (NaN stays NaN: trim), without numpy's cost
    if f > 0:
        return round(cal.trim + cal.dead_zone + f * (cal.maximum - cal.trim - cal.dead_zone))
    if f < 0:
        return round(cal.trim - cal.dead_zone + f * (cal.trim - cal.dead_zone - cal.minimum))
    return cal.trim


def fraction_from_pwm(pwm: int, cal: RcCalibration) -> float:
    """The fraction in [-1, 1] ArduPilot reads from a PWM on a centred channel with dead zone."""
    pwm = min(max(pwm, cal.minimum), cal.maximum)
    high, low = cal.trim + cal.dead_zone, cal.trim - cal.dead_zone
    if pwm > high:
        return (pwm - high) / (cal.maximum - high)
    if pwm < low:
        return (pwm - low) / (low - cal.minimum)
    return 0.0


def motor_output(n: float, n_max: float, n_min: float) -> float:
    """Motor output in [-1, 1] for a shaft speed (rad/s): +1 is n_max, −1 is n_min (reverse)."""
    return min(max(float(n / n_max if n >= 0 else n / abs(n_min)), -1.0), 1.0)  # np.clip's, in plain Python


def inverse_skid_mix(left: float, right: float) -> tuple[float, float]:
    """(throttle, steering) fractions that ArduPilot's skid mixer (left = t + s, right = t − s) turns into
    these motor outputs; exact because |t| + |s| = max(|left|, |right|) <= 1 never saturates the mixer."""
    return 0.5 * (left + right), 0.5 * (left - right)


# PILOT_STEER_TYPE: 0 default and 2 reverse the steering input while the throttle input is negative,
# 3 leaves it unchanged; 1 (two paddles) is not supported by the companion.
STEER_TYPES_REVERSING = (0, 2)
STEER_TYPE_UNCHANGED = 3


@dataclass(frozen=True)
class RcSetup:
    """How the autopilot reads the companion's RC override: channels, calibration, PILOT_STEER_TYPE."""

    steering: RcCalibration = RcCalibration()
    throttle: RcCalibration = RcCalibration()
    steering_channel: int = 1  # RCMAP_ROLL
    throttle_channel: int = 3  # RCMAP_THROTTLE
    steer_type: int = 0  # PILOT_STEER_TYPE
    steering_reversed: bool = False  # RCn_REVERSED of the steering channel
    throttle_reversed: bool = False

    def __post_init__(self) -> None:
        if self.steer_type not in (*STEER_TYPES_REVERSING, STEER_TYPE_UNCHANGED):
            raise ValueError(f"PILOT_STEER_TYPE: {self.steer_type} is not supported (allowed 0, 2, 3; "
                             "1 = two paddles cannot carry the companion's steering)")
        for name in ("steering_channel", "throttle_channel"):
            if not 1 <= getattr(self, name) <= 8 or self.steering_channel == self.throttle_channel:
                raise ValueError(f"RCMAP: {name} {getattr(self, name)} must be a distinct channel in [1, 8]")


def _pwm(fraction: float, cal: RcCalibration, reversed_: bool) -> int:
    """PWM that ArduPilot reads back as ``fraction``; a reversed channel is mirrored about trim first."""
    pwm = pwm_from_fraction(fraction, cal)
    return 2 * cal.trim - pwm if reversed_ else pwm


@dataclass(frozen=True)
class RcCommand:
    """What goes out on RC_CHANNELS_OVERRIDE, and how it was derived (for the log)."""

    steering_pwm: int
    throttle_pwm: int
    n_left: float
    n_right: float
    throttle: float
    steering: float


def skid_fractions(params: OtterParameters, tau_x: float, tau_n: float) -> tuple[float, float, float, float]:
    """(left, right) shaft speeds (rad/s) for τ_X (N) and τ_N (N·m) through the vessel's allocation, and the
    (throttle, steering) fractions that ArduPilot's skid mixer turns into those motor outputs."""
    mats = params.matrices()
    n_left, n_right = tau_to_shaft_speeds(params, tau_x, tau_n)
    throttle, steering = inverse_skid_mix(motor_output(n_left, mats.n_max, mats.n_min),
                                          motor_output(n_right, mats.n_max, mats.n_min))
    return n_left, n_right, throttle, steering


def rc_command(params: OtterParameters, tau_x: float, tau_n: float, setup: RcSetup) -> RcCommand:
    """Steering/throttle PWM for a surge force (N) and yaw moment (N·m), through the vessel's allocation and
    the exact inverse of how ArduPilot reads the sticks and mixes them for skid steering."""
    n_left, n_right, throttle, steering = skid_fractions(params, tau_x, tau_n)
    stick = -steering if (setup.steer_type in STEER_TYPES_REVERSING and throttle < 0) else steering
    return RcCommand(_pwm(stick, setup.steering, setup.steering_reversed),
                     _pwm(throttle, setup.throttle, setup.throttle_reversed), n_left, n_right, throttle, steering)


def neutral_pwm(setup: RcSetup) -> tuple[int, int]:
    """(steering, throttle) PWM at trim: zero thrust, no turn."""
    return setup.steering.trim, setup.throttle.trim


@dataclass(frozen=True)
class AttitudeCommand:
    """A GUIDED target: yaw (rad, NED, 0 = North) or, in the rate form, a body yaw rate (rad/s, positive
    turning right), and thrust = speed / WP_SPEED in [-1, 1]."""

    yaw_rad: float
    thrust: float
    speed_mps: float
    yaw_rate_rad_s: float | None = None

    def quaternion(self) -> tuple[float, float, float, float]:
        """(w, x, y, z) of a pure yaw rotation, as SET_ATTITUDE_TARGET carries it."""
        return (math.cos(self.yaw_rad / 2), 0.0, 0.0, math.sin(self.yaw_rad / 2))

    @property
    def type_mask(self) -> int:
        """SET_ATTITUDE_TARGET's type_mask: heading from q, or the body yaw rate field."""
        return ATTITUDE_TYPE_MASK_HEADING if self.yaw_rate_rad_s is None else ATTITUDE_TYPE_MASK_RATE


def attitude_command(states: np.ndarray, wp_speed_mps: float, lookahead_steps: int = 5,
                     form: str = "heading") -> AttitudeCommand:
    """Heading (or yaw rate, ``form`` "rate") and surge speed of the NMPC plan ``lookahead_steps`` ahead
    (rows of [η, ν]: ψ at column 5, u at 6, r at 11)."""
    if not wp_speed_mps > 0:
        raise ValueError(f"WP_SPEED: {wp_speed_mps!r} m/s must be > 0 to scale thrust")
    if form not in ("heading", "rate"):
        raise ValueError(f"attitude_form: {form!r} is not heading or rate (tau: mavbridge.companion.guided.inverse)")
    k = min(max(lookahead_steps, 1), len(states) - 1)
    if not (math.isfinite(states[k, 5]) and math.isfinite(states[k, 6]) and math.isfinite(states[k, 11])):
        raise ValueError(f"plan: non-finite heading, speed or yaw rate at step {k}")
    yaw = math.atan2(math.sin(states[k, 5]), math.cos(states[k, 5]))
    speed = float(states[k, 6])
    rate = float(states[k, 11]) if form == "rate" else None
    return AttitudeCommand(yaw, float(np.clip(speed / wp_speed_mps, -1.0, 1.0)), speed, rate)
