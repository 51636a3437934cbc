"""The helm: turns heading / turn-rate and speed targets into steering and throttle, as Rover's controllers do.

It owns the two rate controllers (steering, speed) and the throttle slew state, so that the modes only say
what they want (a heading, a rate, a speed) and never touch controller internals.
"""

from __future__ import annotations

from sim_vehicle.rover.control import NavState, SpeedControl, SteeringControl
from sim_vehicle.rover.params import ParamTable

STILL_RATE_RAD_S = 1e-3  # below these, a zero-speed target with no turn is "stop": the integrators rest
STILL_YAW_RATE_RAD_S = 0.02


class Helm:
    """Steering and speed control plus MOT_SLEWRATE / MOT_THR_MAX on the throttle that goes to the mixer."""

    def __init__(self, params: ParamTable) -> None:
        self.params = params
        self.steer = SteeringControl(params)
        self.speed = SpeedControl(params)
        self.slewed_throttle = 0.0  # last throttle after the slew limit, [-1, 1]

    def reset(self, forward_speed: float) -> None:
        """Forget integrators; the speed ramp restarts from the boat's current forward speed (m/s)."""
        self.steer.reset()
        self.speed.reset(forward_speed)

    def heading(self, heading: float, speed: float, nav: NavState, dt: float) -> tuple[float, float]:
        """Heading (rad, NED) and speed (m/s) targets -> steering and throttle in [-1, 1]."""
        return self.rate(self.steer.rate_for_heading(heading, nav), speed, nav, dt)

    def rate(self, rate: float, speed: float, nav: NavState, dt: float) -> tuple[float, float]:
        """Turn-rate (rad/s) and speed (m/s) targets -> steering and throttle in [-1, 1]."""
        throttle = self.speed.throttle_for_speed(speed, nav, dt)
        still = abs(rate) < STILL_RATE_RAD_S and abs(nav.yaw_rate) < STILL_YAW_RATE_RAD_S
        if speed == 0.0 and throttle == 0.0 and still:
            self.steer.reset()
            return 0.0, 0.0
        return self.steer.steering_for_rate(rate, nav, dt), throttle

    def accel_limited_speed(self, speed: float, dt: float) -> float:
        """The speed target the speed controller will ramp to this step under ATC_ACCEL_MAX (not stepped)."""
        ramp = self.speed.ramp_target
        step = max(0.1, self.params["ATC_ACCEL_MAX"]) * dt
        return ramp + max(-step, min(step, speed - ramp))

    def slew_limited(self, throttle: float, dt: float) -> float:
        """``throttle`` after MOT_SLEWRATE (percent of full range per second) from the last output (not stepped)."""
        slew = self.params["MOT_SLEWRATE"] / 100.0 * dt
        if slew <= 0:
            return throttle
        return self.slewed_throttle + max(-slew, min(slew, throttle - self.slewed_throttle))

    def output_throttle(self, throttle: float, dt: float) -> float:
        """Step the slew limit with this demand and clip to MOT_THR_MAX: the throttle the mixer gets."""
        self.slewed_throttle = self.slew_limited(throttle, dt)
        limit = max(0.0, min(100.0, self.params["MOT_THR_MAX"])) / 100.0
        return max(-limit, min(limit, self.slewed_throttle))
