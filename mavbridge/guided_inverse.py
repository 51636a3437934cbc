"""GUIDED targets that make Rover's own loops give the NMPC's steering and throttle: its loops inverted.

In GUIDED, Rover turns a body-yaw-rate target ρ into steering = FF_r·ρ + P_r·(ρ − r) + I_r and a speed
target s into throttle = (CRUISE_THROTTLE / 100 / CRUISE_SPEED)·s + P_s·(s − u) + I_s (``AR_AttitudeControl``;
our simulator's ``sim_vehicle/control.py`` likewise). The RC path sends the steering and throttle that give
the plan's τ through the skid mixer; this form sends the ρ and s for which those two expressions, with the
measured r and u, equal that steering and throttle. The gains are read from the autopilot at start; the
speed target's ramp (ATC_ACCEL_MAX) is not inverted, nor real firmware's D terms, ATC_SPEED_FF and
ATC_STR_ACC_MAX (our simulator has none of them), nor the difference between the body yaw rate r used here
and the earth-frame yaw rate Rover's loop measures (small at this boat's roll). Rover's speed target is
SET_ATTITUDE_TARGET's thrust × WP_SPEED, at most WP_SPEED: a target above it is sent as thrust 1 (the log's
thrust_frac shows it), where the inversion no longer holds, so the companion says at start when WP_SPEED is
below what full throttle needs (``wp_speed_problem``); ``deploy/otter-guided-tau.parm`` sets 3 m/s. With
Rover's 2 m/s the plan's full thrust became 77 % throttle and Balanced arrived 24 % late (116.8 s against
94.6 s with 3 m/s, lockstep, seed 1).

The integrators must be off (ATC_STR_RAT_I = ATC_SPEED_I = 0): these targets differ from r and u whenever
the plan accelerates or turns, so Rover's integrators would wind up against them. Following them in the
companion (the same errors integrated over its 0.1 s period, with Rover's anti-windup) was tried against
our simulator: Balanced took 175.6 s and Direct 130.6 s, against 116.8 s and 63.2 s with the integrators
off, since a copy at 10 Hz drifts from the autopilot's own (100 Hz in the simulator). The companion's
feedback (a new plan every 0.1 s) takes the integrators' place.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from vessel import OtterParameters

from .link import LinkError
from .outputs import skid_fractions

LOOP_PARAMETERS = ("CRUISE_THROTTLE", "CRUISE_SPEED", "ATC_SPEED_P", "ATC_STR_RAT_FF", "ATC_STR_RAT_P",
                   "ATC_STR_RAT_MAX", "ATC_SPEED_I", "ATC_SPEED_IMAX", "ATC_STR_RAT_I", "ATC_STR_RAT_IMAX")


@dataclass(frozen=True)
class RoverLoops:
    """The gains of Rover's turn-rate and speed loops that the inversion needs (SI: rad/s, m/s)."""

    speed_ff: float  # throttle fraction per m/s: CRUISE_THROTTLE / 100 / CRUISE_SPEED
    speed_p: float
    rate_ff: float
    rate_p: float
    rate_max_rad_s: float
    speed_i: float = 0.0
    speed_imax: float = 0.0
    rate_i: float = 0.0
    rate_imax: float = 0.0

    @classmethod
    def from_values(cls, values: dict[str, float | None]) -> RoverLoops:
        """From parameter values by name; ValueError naming the first one missing or out of range."""
        for name in LOOP_PARAMETERS:
            value = values.get(name)
            if value is None or not math.isfinite(value) or value < 0:
                raise ValueError(f"{name}: {value!r} is not readable or not >= 0")
        for name in ("CRUISE_THROTTLE", "CRUISE_SPEED", "ATC_STR_RAT_MAX"):
            if not values[name] > 0:
                raise ValueError(f"{name}: {values[name]!r} must be > 0 for the loops to be inverted")
        if not values["ATC_STR_RAT_FF"] + values["ATC_STR_RAT_P"] > 0:
            raise ValueError("ATC_STR_RAT_FF + ATC_STR_RAT_P must be > 0 for the turn-rate loop to be inverted")
        return cls(values["CRUISE_THROTTLE"] / 100.0 / values["CRUISE_SPEED"], values["ATC_SPEED_P"],
                   values["ATC_STR_RAT_FF"], values["ATC_STR_RAT_P"], math.radians(values["ATC_STR_RAT_MAX"]),
                   values["ATC_SPEED_I"], values["ATC_SPEED_IMAX"], values["ATC_STR_RAT_I"], values["ATC_STR_RAT_IMAX"])

    @classmethod
    def read(cls, link: Any) -> RoverLoops:
        """Read the gains over the link; LinkError when one is unreadable or unusable, or an integrator is on."""
        try:
            loops = cls.from_values({name: link.read_parameter(name) for name in LOOP_PARAMETERS})
        except ValueError as exc:
            raise LinkError(f"attitude_form tau: {exc}") from None
        problem = loops.integrator_problem()
        if problem:
            raise LinkError(f"attitude_form tau: {problem}")
        return loops

    def integrator_problem(self) -> str | None:
        """Why the inversion cannot be used with these gains (an integrator on), or None."""
        for name, gain in (("ATC_STR_RAT_I", self.rate_i), ("ATC_SPEED_I", self.speed_i)):
            if gain != 0:
                return (f"{name} is {gain:g}; set ATC_STR_RAT_I and ATC_SPEED_I to 0 (Rover's integrators wind up "
                        "against the inverted targets), or use attitude_form rate")
        return None

    def full_throttle_target_mps(self) -> float:
        """The largest speed target (m/s) full throttle needs at a forward speed up to the feed-forward's own full
        speed 1 / speed_ff (CRUISE_SPEED × 100 / CRUISE_THROTTLE): (1 + P·u) / (FF + P) grows with u to 1 / FF."""
        return 1.0 / self.speed_ff

    def wp_speed_problem(self, wp_speed_mps: float) -> str | None:
        """What a WP_SPEED below ``full_throttle_target_mps`` does to this form (its cap on Rover's speed target
        cuts the plan's full thrust), or None."""
        needed = self.full_throttle_target_mps()
        if wp_speed_mps >= needed:
            return None
        return (f"WP_SPEED {wp_speed_mps:g} m/s caps Rover's speed target below the {needed:.2f} m/s full throttle "
                f"needs (CRUISE_SPEED x 100 / CRUISE_THROTTLE): the plan's thrust is cut near full speed; set "
                f"WP_SPEED >= {needed:.2f} (deploy/otter-guided-tau.parm)")

    def speed_for_throttle(self, throttle: float, speed_mps: float) -> float:
        """The speed target (m/s) whose feed-forward + P output is ``throttle`` at forward speed ``speed_mps``."""
        return (throttle + self.speed_p * speed_mps) / (self.speed_ff + self.speed_p)

    def rate_for_steering(self, steering: float, yaw_rate: float) -> float:
        """The turn-rate target (rad/s, within ±ATC_STR_RAT_MAX) whose FF + P output is ``steering``."""
        rate = (steering + self.rate_p * yaw_rate) / (self.rate_ff + self.rate_p)
        return float(np.clip(rate, -self.rate_max_rad_s, self.rate_max_rad_s))


def loop_targets(params: OtterParameters, loops: RoverLoops, tau_x: float, tau_n: float, speed_mps: float,
                 yaw_rate: float) -> tuple[float, float]:
    """(turn-rate target rad/s, speed target m/s) for the plan's first τ (N, N·m) at the plan's initial u (m/s)
    and r (rad/s): the state as measured, or as predicted to when the command acts with delay compensation."""
    _, _, throttle, steering = skid_fractions(params, tau_x, tau_n)
    return loops.rate_for_steering(steering, yaw_rate), loops.speed_for_throttle(throttle, speed_mps)

