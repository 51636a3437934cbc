"""AUTO mode's mission runner: walks the stored mission, turning nav items into navigator targets."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from sim_vehicle.rover.control import NavState, NavTarget
from sim_vehicle.rover.mission import (
    DO_CHANGE_SPEED,
    GLOBAL_FRAMES,
    NAV_LOITER_TIME,
    NAV_LOITER_UNLIM,
    NAV_RETURN_TO_LAUNCH,
    NAV_WAYPOINT,
    Item,
    MissionStore,
)
from sim_vehicle.rover.params import ParamTable, default_speed
from vessel.geo import Home

NOT_STARTED, ACTIVE, COMPLETE = "not started", "active", "complete"


@dataclass
class Leg:
    """The nav item being driven: its seq, target, and how long to wait on arrival (s; inf = forever)."""

    seq: int
    target: NavTarget
    hold_s: float
    arrived_at: float | None = None


class MissionRunner:
    """Executes the mission from ``current`` (seq >= 1), reporting arrivals through callbacks."""

    def __init__(
        self,
        store: MissionStore,
        params: ParamTable,
        home: Home,
        on_reached: Callable[[int], None],
        on_text: Callable[[int, str], None],
    ) -> None:
        self.store, self.params, self.home = store, params, home
        self.on_reached, self.on_text = on_reached, on_text
        self.current = 1
        self.state = NOT_STARTED
        self.leg: Leg | None = None
        self.speed: float | None = None  # from DO_CHANGE_SPEED; None = WP_SPEED
        self._version = store.version

    def rewind(self) -> None:
        """Back to the first item (disarming outside AUTO does this)."""
        self.current, self.state, self.leg, self.speed = 1, NOT_STARTED, None, None

    def set_current(self, seq: int) -> bool:
        """Jump to item ``seq``; False if there is no such item (home cannot be made current)."""
        if not 1 <= seq < len(self.store.items(0)):
            return False
        self.current, self.leg = seq, None
        if self.state == COMPLETE:
            self.state = NOT_STARTED
        return True

    def start_or_resume(self) -> None:
        """On AUTO entry: restart a finished mission (or always, with MIS_RESTART=1), else resume."""
        if self.state == COMPLETE or self.params["MIS_RESTART"] == 1:
            self.rewind()
        self.state, self.leg = ACTIVE, None

    def change_speed(self, speed: float) -> None:
        """DO_CHANGE_SPEED (m/s) in AUTO: the current leg and every later one drive at ``speed``."""
        self.speed = speed
        if self.leg is not None:
            self.leg.target.speed = speed

    def pause(self) -> None:
        """Leaving AUTO: keep the place in the mission."""
        self.leg = None

    def update(self, nav: NavState, now: float) -> NavTarget | None:
        """The target to drive to now, or None once the mission has ended (the boat then holds)."""
        if self._version != self.store.version:  # mission changed while running: restart the current leg
            self._version, self.leg = self.store.version, None
            if self.current >= len(self.store.items(0)):
                self.current = 1
        if self.state != ACTIVE:
            return None
        for _ in range(len(self.store.items(0)) + 1):  # bounded walk over non-nav items
            if self.leg is None and not self._load_leg(nav):
                return None
            leg = self.leg
            assert leg is not None
            if leg.arrived_at is None and self._arrived(leg, nav):
                leg.arrived_at = now
                self.on_reached(leg.seq)
                self.on_text(
                    6,
                    f"Reached waypoint #{leg.seq} dist "
                    f"{math.hypot(leg.target.north - nav.north, leg.target.east - nav.east):.0f}m",
                )
            if leg.arrived_at is not None and now - leg.arrived_at >= leg.hold_s:
                self.current, self.leg = leg.seq + 1, None
                continue
            return leg.target
        return None

    def _arrived(self, leg: Leg, nav: NavState) -> bool:
        """Within WP_RADIUS, or past the destination along the leg."""
        t = leg.target
        if math.hypot(t.north - nav.north, t.east - nav.east) <= max(0.1, self.params["WP_RADIUS"]):
            return True
        dn, de = t.north - t.origin_north, t.east - t.origin_east
        length = math.hypot(dn, de)
        return (
            length > 1e-3
            and ((nav.north - t.origin_north) * dn + (nav.east - t.origin_east) * de) >= length**2
        )

    def _load_leg(self, nav: NavState) -> bool:
        """Run DO items up to the next nav item and make it the leg; False (and finish) at the end."""
        items = self.store.items(0)
        while self.current < len(items):
            item = items[self.current]
            if item.is_nav:
                leg = self._make_leg(self.current, item, nav, items)
                if leg is not None:
                    self.leg = leg
                    return True
            elif item.command == DO_CHANGE_SPEED and math.isfinite(item.param2) and item.param2 > 0:
                self.speed = float(item.param2)
            self.current += 1
        self.state, self.leg = COMPLETE, None
        self.on_text(6, "Mission Complete")
        return False

    def _position(self, item: Item, nav: NavState) -> tuple[float, float]:
        """NED position of a nav item; lat/lon 0/0 (or a non-global frame) means "here"."""
        if item.frame not in GLOBAL_FRAMES or (item.x == 0 and item.y == 0):
            return nav.north, nav.east
        return self.home.to_ned(item.x / 1e7, item.y / 1e7)

    def _make_leg(self, seq: int, item: Item, nav: NavState, items: list[Item]) -> Leg | None:
        """Turn a nav item into a leg; unsupported nav commands are skipped (None)."""
        speed = self.speed if self.speed is not None else default_speed(self.params)
        hold = item.param1 if math.isfinite(item.param1) and item.param1 > 0 else 0.0
        if item.command == NAV_WAYPOINT:
            north, east = self._position(item, nav)
        elif item.command == NAV_RETURN_TO_LAUNCH:
            north, east = 0.0, 0.0
        elif item.command == NAV_LOITER_UNLIM:
            north, east = self._position(item, nav)
            hold = math.inf
        elif item.command == NAV_LOITER_TIME:
            north, east = self._position(item, nav)
        else:
            return None
        more = any(it.is_nav for it in items[seq + 1 :])
        stop = hold > 0 or not more
        return Leg(seq, NavTarget(north, east, nav.north, nav.east, max(0.0, speed), stop), hold)

    def mission_state(self, in_auto: bool) -> int:
        """MISSION_CURRENT.mission_state: 1 none, 2 not started, 3 active, 4 paused, 5 complete."""
        if not self.store.present():
            return 1
        if self.state == COMPLETE:
            return 5
        if self.state == ACTIVE and in_auto:
            return 3
        return 2 if self.state == NOT_STARTED else 4
