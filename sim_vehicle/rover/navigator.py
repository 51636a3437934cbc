"""What Rover's autopilot modes drive toward: GUIDED targets, the mission's legs, home in RTL, the loiter point.

The navigator holds that state (the GUIDED target and its waypoint speed, the loiter point, RTL's arrival) and
turns it into steering and throttle through the helm, each step, for GUIDED, AUTO, RTL and LOITER.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.rover.auto import MissionRunner
from sim_vehicle.rover.control import NavCommand, NavState, NavTarget, loiter, navigate
from sim_vehicle.rover.guided import GuidedTarget
from sim_vehicle.rover.helm import Helm
from sim_vehicle.rover.modes import Mode
from sim_vehicle.rover.params import ParamTable, default_speed

GUIDED_TIMEOUT_S = 3.0


class Navigator:
    """Targets of the autopilot modes and the navigator's last output (NAV_CONTROLLER_OUTPUT)."""

    def __init__(
        self,
        params: ParamTable,
        helm: Helm,
        runner: MissionRunner,
        text: Callable[[int, str], None],
        reached: Callable[[int], None],
        on_mission_end: Callable[[], None],
    ) -> None:
        self.params, self.helm, self.runner = params, helm, runner
        self.text, self.reached, self.on_mission_end = text, reached, on_mission_end
        self.guided: GuidedTarget | None = None
        self.guided_speed: float | None = None  # DO_CHANGE_SPEED toward GUIDED waypoints, until the mode changes
        self.loiter_at = (0.0, 0.0)  # NED north, east (m) the boat loiters around
        self.rtl_done = False
        self.output: NavCommand | None = None
        self.nav = NavState()
        self.now = 0.0

    def enter_mode(self, nav: NavState) -> None:
        """A mode change: forget GUIDED targets and RTL's arrival; loiter from the stopping point."""
        self.nav = nav
        self.loiter_at = self.stopping_point()
        self.guided, self.guided_speed = None, None
        self.rtl_done = False

    # ----- GUIDED inputs ----------------------------------------------------------------------------------
    def guided_waypoint_speed(self) -> float:
        """Speed toward a GUIDED position target: the last DO_CHANGE_SPEED in this GUIDED spell, else default."""
        return self.guided_speed if self.guided_speed is not None else default_speed(self.params)

    def change_guided_speed(self, speed: float) -> bool:
        """DO_CHANGE_SPEED in GUIDED (Rover's ModeGuided::set_desired_speed): toward waypoints, the current one
        and later ones; accepted while loitering; refused for heading/rate targets, which carry their own speed.
        """
        g = self.guided
        if g is not None and g.waypoint is None:
            return False
        self.guided_speed = speed
        if g is not None and g.waypoint is not None:
            g.speed = g.waypoint.speed = speed
        return True

    # ----- the step ---------------------------------------------------------------------------------------
    def demands(self, mode: Mode, nav: NavState, now: float, dt: float) -> tuple[float, float]:
        """Steering and throttle in [-1, 1] of an autopilot mode (GUIDED, AUTO, RTL, LOITER) this step."""
        self.nav, self.now, self.output = nav, now, None
        if mode == Mode.GUIDED:
            demands = self._guided_demands(dt)
            if demands is not None:
                return demands
        return self._navigate(self._target(mode), dt)

    def _guided_demands(self, dt: float) -> tuple[float, float] | None:
        """Demands of a GUIDED heading or turn-rate target; None when GUIDED navigates or loiters instead.

        Such targets expire 3 s after the last message: the boat then loiters at its stopping point.
        """
        g = self.guided
        if g is None or g.waypoint is not None:
            return None
        if self.now - g.time > GUIDED_TIMEOUT_S:
            self.text(mavlink.MAV_SEVERITY_NOTICE, "target not received last 3secs, stopping")
            self.loiter_at = self.stopping_point()
            self.guided = None
            return None
        if g.heading is not None:
            return self.helm.heading(g.heading, g.speed, self.nav, dt)
        return self.helm.rate(g.rate or 0.0, g.speed, self.nav, dt)

    def _target(self, mode: Mode) -> NavTarget | None:
        """Where the navigator drives now (GUIDED waypoint, mission leg, home in RTL); None: loiter."""
        if mode == Mode.GUIDED:
            return self._guided_waypoint()
        if mode == Mode.AUTO:
            target = self.runner.update(self.nav, self.now)
            if target is None:
                self.on_mission_end()
            return target
        if mode == Mode.RTL and not self.rtl_done:
            return self._rtl_target()
        return None

    def _within_wp_radius(self, north: float, east: float) -> bool:
        """True if the boat is within WP_RADIUS (at least 0.1 m) of the NED point (m)."""
        return math.hypot(north - self.nav.north, east - self.nav.east) <= max(0.1, self.params["WP_RADIUS"])

    def _guided_waypoint(self) -> NavTarget | None:
        """The GUIDED waypoint, until it is within WP_RADIUS (MISSION_ITEM_REACHED 0, then loiter)."""
        g = self.guided
        if g is None or g.waypoint is None:
            return None
        if self._within_wp_radius(g.waypoint.north, g.waypoint.east):
            self.reached(0)
            self.guided = None
            return None
        return g.waypoint

    def _rtl_target(self) -> NavTarget | None:
        """Home at RTL_SPEED (else the default speed), until within WP_RADIUS of it."""
        p, nav = self.params, self.nav
        if self._within_wp_radius(0.0, 0.0):
            self.text(mavlink.MAV_SEVERITY_INFO, "Reached destination")
            self.rtl_done, self.loiter_at = True, (0.0, 0.0)
            return None
        speed = p["RTL_SPEED"] if p["RTL_SPEED"] > 0 else default_speed(p)
        return NavTarget(0.0, 0.0, nav.north, nav.east, speed)

    def _navigate(self, target: NavTarget | None, dt: float) -> tuple[float, float]:
        """Drive toward ``target`` with the navigator, or loiter around ``loiter_at`` without one."""
        p, nav = self.params, self.nav
        if target is not None:
            lookahead = max(3.0, 2.0 * p["TURN_RADIUS"])
            self.output = navigate(target, nav, lookahead_m=lookahead, accel=p["ATC_ACCEL_MAX"])
            self.loiter_at = self.stopping_point()
        else:
            self.output = loiter(*self.loiter_at, nav, p["LOIT_RADIUS"], p["LOIT_SPEED_GAIN"], default_speed(p))
        return self.helm.heading(self.output.heading, self.output.speed, nav, dt)

    def stopping_point(self) -> tuple[float, float]:
        """Where the boat would come to rest braking at ATC_ACCEL_MAX (NED north, east, m): where it loiters."""
        nav, decel = self.nav, max(0.1, self.params["ATC_ACCEL_MAX"])
        speed = nav.ground_speed
        return nav.north + nav.vn * speed / (2 * decel), nav.east + nav.ve * speed / (2 * decel)
