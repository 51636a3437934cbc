"""Which waypoint the companion flies to: the autopilot's mission (or --waypoint), followed as it changes.

Waypoints are north/east metres from the autopilot's home (flat earth), flown in turn from the first;
one counts as reached inside the scenario's acceptance radius. A new mission — ArduPilot's
"Flight plan received", or MISSION_CURRENT.total changing — is downloaded again and restarts them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from mavbridge.link.connection import LinkError, mavlink
from mavbridge.link.retry import RetryPolicy, ask, count_retry, give_up_line
from vessel.geo import ned_from_latlon
from vessel.wording import counted

MISSION = mavlink.MAV_MISSION_TYPE_MISSION


def _for_us(link: Any, msg: Any) -> bool:
    """A mission-protocol reply addressed to us (or broadcast), for the mission (not fence/rally)."""
    return (getattr(msg, "target_system", 0) in (0, link.system_id)
            and getattr(msg, "mission_type", MISSION) == MISSION)


def _ask(link: Any, request: tuple[Any, ...], answer: Callable[[Any], bool], policy: RetryPolicy,
         awaited: str) -> Any:
    """Send ``request`` (message name, fields) until a message satisfying ``answer`` comes; LinkError if none."""
    reply, tries = ask(lambda _attempt: link.send(*request), link.wait_for, lambda m: answer(m) and _for_us(link, m),
                       policy, lambda: count_retry(link.counts, "mission"))
    if reply is None:
        raise LinkError(give_up_line(f"mission download: {request[0].upper()}", awaited, tries, policy.timeout_s))
    return reply


def download_mission(link: Any, policy: RetryPolicy | None = None) -> list[Any]:
    """The autopilot's mission with the mission protocol (MISSION_REQUEST_INT per item); home is seq 0.

    Each request is repeated on the protocol's timeout (1.5 s, at least 5 retries: ``RetryPolicy.for_mission``).
    """
    assert link.target is not None, "wait_autopilot() first"
    policy = policy or getattr(link, "retry", RetryPolicy()).for_mission()
    sysid, compid = link.target
    count = _ask(link, ("mission_request_list", sysid, compid, MISSION), lambda m: m.get_type() == "MISSION_COUNT",
                 policy, "MISSION_COUNT")
    items = []
    for seq in range(count.count):
        items.append(_ask(link, ("mission_request_int", sysid, compid, seq, MISSION),
                          lambda m, s=seq: m.get_type() == "MISSION_ITEM_INT" and m.seq == s, policy,
                          f"MISSION_ITEM_INT {seq}"))
    link.send("mission_ack", sysid, compid, mavlink.MAV_MISSION_ACCEPTED, MISSION)
    return items


@dataclass
class MissionTracker:
    """The waypoints left to fly and whether the autopilot's mission changed since the last download."""

    acceptance_m: float
    override_ne: tuple[float, float] | None = None  # --waypoint: replaces the mission's waypoints
    log: Callable[[str], None] = print
    waypoints: list[tuple[float, float]] = field(default_factory=list)
    loaded: list[tuple[float, float]] = field(default_factory=list)  # the whole mission as last loaded
    changed: bool = False
    total: int | None = None  # MISSION_CURRENT.total of the mission we hold (ArduPilot leaves home out)

    def on_message(self, msg: Any) -> None:
        """Link handler: flag a new mission."""
        kind = msg.get_type()
        if kind == "STATUSTEXT" and "Flight plan received" in str(msg.text):
            self.changed = True
        elif kind == "MISSION_CURRENT" and getattr(msg, "total", 0):
            if self.total is not None and msg.total != self.total:
                self.changed = True
            self.total = msg.total

    def load(self, link: Any, set_home: Callable[[float, float], None]) -> None:
        """Download the mission; home (item 0) goes to ``set_home(lat_deg, lon_deg)``. LinkError if none."""
        items = download_mission(link)
        if not items:
            raise LinkError("mission download returned nothing (not even home)")
        home = items[0]
        lat, lon = home.x / 1e7, home.y / 1e7
        waypoints = [ned_from_latlon(lat, lon, i.x / 1e7, i.y / 1e7)
                     for i in items[1:] if i.command == mavlink.MAV_CMD_NAV_WAYPOINT]
        self.log(f"home {lat:.7f}, {lon:.7f}; {counted(len(waypoints), 'waypoint')} from the mission")
        if self.override_ne is not None:
            waypoints = [self.override_ne]
            self.log(f"waypoint overridden: north {self.override_ne[0]:g} m, east {self.override_ne[1]:g} m")
        if not waypoints:
            raise LinkError("no waypoint: upload one with `mission upload` or pass --waypoint N,E")
        set_home(lat, lon)
        self.waypoints, self.loaded = waypoints, list(waypoints)
        self.total = len(items) - 1
        self.changed = False

    def reload_if_changed(self, link: Any, set_home: Callable[[float, float], None]) -> None:
        """Download again after a change; keep flying to the old target if that fails."""
        if not self.changed:
            return
        self.changed = False
        try:
            self.load(link, set_home)
        except LinkError as exc:
            self.log(f"warning: mission changed but could not be downloaded ({exc}); keeping the old waypoint")

    def target(self, north_m: float, east_m: float) -> tuple[float, float] | None:
        """The waypoint to fly to from (north, east); drops one reached; None once the last is reached."""
        while self.waypoints:
            north, east = self.waypoints[0]
            if math.hypot(north - north_m, east - east_m) > self.acceptance_m:
                return self.waypoints[0]
            self.waypoints.pop(0)
        return None
