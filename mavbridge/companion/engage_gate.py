"""The companion's range gate: it never engages on a waypoint farther than ``max_range_m`` from home or the boat.

A waypoint from `--waypoint` or from the autopilot's mission may be anywhere on Earth (a typo, a mission for
another site, a latitude and longitude swapped); flying towards it at full throttle is never what was meant.
Positions are north/east metres from the autopilot's home (NED, flat earth), as the mission tracker holds them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from mavbridge.link.connection import LinkError


class WaypointRefusedError(LinkError):
    """The companion refuses to fly to a waypoint; the message is one line saying which, how far and the limit."""


def far_waypoint(waypoints: Sequence[tuple[float, float]], max_range_m: float,
                 boat_ne: tuple[float, float] | None = None) -> str | None:
    """One line naming the first waypoint farther than ``max_range_m`` from home (0, 0) or from the boat
    (``boat_ne``, when its position is known); None when every waypoint is within range."""
    for index, (north, east) in enumerate(waypoints, start=1):
        distances = [("home", math.hypot(north, east))]
        if boat_ne is not None:
            distances.append(("the boat", math.hypot(north - boat_ne[0], east - boat_ne[1])))
        for origin, distance in distances:
            if not distance <= max_range_m:  # (also a NaN)
                return (f"waypoint {index} (N {north:.0f} m, E {east:.0f} m) is {distance / 1000:,.1f} km from "
                        f"{origin}, farther than --max-range {max_range_m:g} m: not engaging")
    return None


def check_waypoints(waypoints: Sequence[tuple[float, float]], max_range_m: float,
                    boat_ne: tuple[float, float] | None = None) -> None:
    """Raise ``WaypointRefusedError`` (one line) unless every waypoint is within range of home and the boat."""
    reason = far_waypoint(waypoints, max_range_m, boat_ne)
    if reason is not None:
        raise WaypointRefusedError(reason)
