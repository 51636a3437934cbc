"""Heading, turn-rate and speed controllers and the waypoint/loiter navigator, in the spirit of Rover's.

Outputs are ArduPilot's normalised steering and throttle in [-1, 1] that then go through the skid mixer.
Gains come from the ATC_* parameters (read every step, so PARAM_SET applies at once).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sim_vehicle.rover.params import ParamTable
from vessel.geo import wrap_pi

PIVOT_ANGLE_RAD = math.radians(60.0)  # heading error beyond which a skid-steered boat turns on the spot
STOPPED_SPEED = 0.1  # m/s: below this, a zero speed target lets the motors rest


@dataclass
class NavState:
    """What the autopilot's estimator knows: NED position (m), heading (rad), yaw rate, NED velocity."""

    north: float = 0.0
    east: float = 0.0
    down: float = 0.0
    yaw: float = 0.0
    yaw_rate: float = 0.0
    vn: float = 0.0
    ve: float = 0.0

    @property
    def forward_speed(self) -> float:
        """Ground velocity along the heading, m/s (negative when going astern)."""
        return self.vn * math.cos(self.yaw) + self.ve * math.sin(self.yaw)

    @property
    def ground_speed(self) -> float:
        """Horizontal speed over ground, m/s."""
        return math.hypot(self.vn, self.ve)


def turn_rate_limit(rate_max_deg_s: float) -> float:
    """ATC_STR_RAT_MAX (deg/s) as the turn-rate target's limit in rad/s; Rover limits only when it is positive."""
    return math.radians(rate_max_deg_s) if rate_max_deg_s > 0 else math.inf


class SteeringControl:
    """Heading -> turn-rate target (P, limited) -> steering output (FF + PI on the rate error)."""

    def __init__(self, params: ParamTable) -> None:
        self.params = params
        self._integrator = 0.0

    def reset(self) -> None:
        """Forget the integrator (on mode changes and stops)."""
        self._integrator = 0.0

    def rate_for_heading(self, heading_rad: float, nav: NavState) -> float:
        """Turn-rate target (rad/s) that brings the heading to ``heading_rad``."""
        limit = turn_rate_limit(self.params["ATC_STR_RAT_MAX"])
        rate = self.params["ATC_STR_ANG_P"] * wrap_pi(heading_rad - nav.yaw)
        return min(limit, max(-limit, rate))

    def steering_for_rate(self, rate_rad_s: float, nav: NavState, dt: float) -> float:
        """Steering output in [-1, 1] tracking the turn-rate target ``rate_rad_s``."""
        p = self.params
        limit = turn_rate_limit(p["ATC_STR_RAT_MAX"])
        rate = min(limit, max(-limit, rate_rad_s))
        error = rate - nav.yaw_rate
        raw = p["ATC_STR_RAT_FF"] * rate + p["ATC_STR_RAT_P"] * error + self._integrator
        if -1.0 < raw < 1.0 or raw * error < 0:  # integrate only when that does not deepen saturation
            imax = abs(p["ATC_STR_RAT_IMAX"])
            self._integrator = min(imax, max(-imax, self._integrator + p["ATC_STR_RAT_I"] * error * dt))
        return min(1.0, max(-1.0, raw))


class SpeedControl:
    """Speed target (acceleration-limited) -> throttle: cruise feed-forward plus PI on the speed error."""

    def __init__(self, params: ParamTable) -> None:
        self.params = params
        self._integrator = 0.0
        self._target = 0.0

    def reset(self, current_speed: float = 0.0) -> None:
        """Forget the integrator and restart the acceleration ramp from ``current_speed``."""
        self._integrator = 0.0
        self._target = current_speed

    @property
    def ramp_target(self) -> float:
        """Where the acceleration-limited speed ramp stands now (m/s)."""
        return self._target

    def throttle_for_speed(self, speed_m_s: float, nav: NavState, dt: float) -> float:
        """Throttle output in [-1, 1] that tracks ``speed_m_s`` along the heading."""
        p = self.params
        accel = max(0.1, p["ATC_ACCEL_MAX"])
        step = accel * dt
        self._target += min(step, max(-step, speed_m_s - self._target))
        speed = nav.forward_speed
        if speed_m_s == 0.0 and abs(speed) < STOPPED_SPEED:
            self._integrator = 0.0
            return 0.0
        cruise_speed = max(0.1, p["CRUISE_SPEED"])
        feed_forward = self._target * (p["CRUISE_THROTTLE"] / 100.0) / cruise_speed
        error = self._target - speed
        raw = feed_forward + p["ATC_SPEED_P"] * error + self._integrator
        if -1.0 < raw < 1.0 or raw * error < 0:
            imax = abs(p["ATC_SPEED_IMAX"])
            self._integrator = min(imax, max(-imax, self._integrator + p["ATC_SPEED_I"] * error * dt))
        return min(1.0, max(-1.0, raw))


@dataclass
class NavTarget:
    """Where to drive: a destination (NED m), the leg's origin and the speed there."""

    north: float
    east: float
    origin_north: float
    origin_east: float
    speed: float
    stop_at_end: bool = True


@dataclass
class NavCommand:
    """A heading and speed demand from the navigator, plus what NAV_CONTROLLER_OUTPUT reports."""

    heading: float
    speed: float
    distance: float
    bearing: float
    xtrack: float


def navigate(target: NavTarget, nav: NavState, lookahead_m: float, accel: float) -> NavCommand:
    """Follow the leg origin -> destination with a look-ahead point; slow down to stop at the end."""
    dn, de = target.north - target.origin_north, target.east - target.origin_east
    length = math.hypot(dn, de)
    to_n, to_e = target.north - nav.north, target.east - nav.east
    distance = math.hypot(to_n, to_e)
    bearing = math.atan2(to_e, to_n)
    if length < 1e-3:
        aim_n, aim_e, xtrack = target.north, target.east, 0.0
    else:
        un, ue = dn / length, de / length
        rn, re = nav.north - target.origin_north, nav.east - target.origin_east
        along = rn * un + re * ue
        xtrack = rn * ue - re * un
        ahead = min(length, max(0.0, along) + lookahead_m)
        aim_n, aim_e = target.origin_north + un * ahead, target.origin_east + ue * ahead
    heading = math.atan2(aim_e - nav.east, aim_n - nav.north) if distance > 1e-3 else nav.yaw
    speed = target.speed
    if target.stop_at_end:
        speed = min(speed, math.sqrt(2.0 * max(0.1, accel) * distance))
    if abs(wrap_pi(heading - nav.yaw)) > PIVOT_ANGLE_RAD:
        speed = 0.0
    return NavCommand(heading, speed, distance, bearing, xtrack)


def loiter(
    centre_n: float, centre_e: float, nav: NavState, radius: float, gain: float, max_speed: float
) -> NavCommand:
    """Boat loiter: outside the radius drive back at a speed growing with the distance; inside, stop."""
    to_n, to_e = centre_n - nav.north, centre_e - nav.east
    distance = math.hypot(to_n, to_e)
    bearing = math.atan2(to_e, to_n)
    if distance <= radius:
        return NavCommand(nav.yaw, 0.0, distance, bearing, 0.0)
    speed = min(max_speed, (distance - radius) * max(0.0, gain))
    if abs(wrap_pi(bearing - nav.yaw)) > PIVOT_ANGLE_RAD:
        speed = 0.0
    return NavCommand(bearing, speed, distance, bearing, 0.0)
