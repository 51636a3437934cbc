"""ArduPilot's mission protocol: uploads (asked for with MISSION_REQUEST), downloads, clear, set-current."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.link import Channel
from sim_vehicle.rover.auto import MissionRunner
from sim_vehicle.rover.mission import (
    ALL_TYPES,
    CAPACITY,
    FENCE,
    MISSION,
    RALLY,
    Item,
    MissionStore,
    float_xy,
    item_from_float,
    item_from_int,
)
from vessel.geo import Home

RESEND_S = 1.0
UPLOAD_TIMEOUT_S = 8.0
M = mavlink


@dataclass
class Upload:
    """An upload in progress: who sends it, how many items, and what has arrived."""

    channel: Channel
    sysid: int
    compid: int
    mission_type: int
    count: int
    items: list[Item] = field(default_factory=list)
    last_request: float = 0.0
    last_activity: float = 0.0


def stored_item(store: MissionStore, home: Home, mtype: int, seq: int) -> Item | None:
    """Stored item ``seq`` of mission type ``mtype``; for the mission, seq 0 is always the current home."""
    if mtype == MISSION and seq == 0:
        lat, lon = round(home.lat_deg * 1e7), round(home.lon_deg * 1e7)
        return Item(
            frame=M.MAV_FRAME_GLOBAL,
            command=M.MAV_CMD_NAV_WAYPOINT,
            current=0,
            autocontinue=1,
            param1=0.0,
            param2=0.0,
            param3=0.0,
            param4=0.0,
            x=lat,
            y=lon,
            z=home.alt_m,
        )
    items = store.items(mtype)
    return items[seq] if 0 <= seq < len(items) else None


def _item_message(
    item: Item, seq: int, current: int, mtype: int, target: int, target_component: int, as_int: bool
) -> mavlink.MAVLink_message:
    """MISSION_ITEM_INT (degE7 x/y) or, for an old MISSION_REQUEST, MISSION_ITEM (degrees) of ``item``."""
    x, y = (item.x, item.y) if as_int else float_xy(item)
    message = M.MAVLink_mission_item_int_message if as_int else M.MAVLink_mission_item_message
    return message(
        target_system=target,
        target_component=target_component,
        seq=seq,
        frame=item.frame,
        command=item.command,
        current=current,
        autocontinue=item.autocontinue,
        param1=item.param1,
        param2=item.param2,
        param3=item.param3,
        param4=item.param4,
        x=x,
        y=y,
        z=item.z,
        mission_type=mtype,
    )


class MissionServer:
    """Serves mission uploads and downloads on any channel, one upload at a time."""

    def __init__(
        self,
        store: MissionStore,
        runner: MissionRunner,
        home: Home,
        text: Callable[[int, str], None],
        broadcast: Callable[[mavlink.MAVLink_message], None],
        guided_goto: Callable[[float, float], bool],
    ) -> None:
        self.store, self.runner, self.home = store, runner, home
        self.text, self.broadcast = text, broadcast
        self.guided_goto = guided_goto  # MISSION_ITEM current=2: (lat, lon) -> accepted (only in GUIDED)
        self.upload: Upload | None = None
        self._warned_float: set[int] = set()

    def handle(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """Dispatch one MISSION_* message addressed to us."""
        kind = msg.get_type()
        handler = {
            "MISSION_COUNT": self._count,
            "MISSION_ITEM_INT": self._item,
            "MISSION_ITEM": self._item,
            "MISSION_REQUEST_LIST": self._request_list,
            "MISSION_REQUEST_INT": self._request,
            "MISSION_REQUEST": self._request,
            "MISSION_CLEAR_ALL": self._clear,
            "MISSION_SET_CURRENT": self._set_current,
        }.get(kind)
        if handler is not None:
            handler(channel, msg, now)

    def _ack(self, channel: Channel, msg: mavlink.MAVLink_message, result: int, mission_type: int) -> None:
        """MISSION_ACK back to the sender of ``msg``."""
        channel.send(
            M.MAVLink_mission_ack_message(msg.get_srcSystem(), msg.get_srcComponent(), result, mission_type)
        )

    @staticmethod
    def _type(msg: mavlink.MAVLink_message) -> int:
        """The message's mission_type (MAVLink 1 frames have none: the mission)."""
        return int(getattr(msg, "mission_type", MISSION))

    def _count(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """MISSION_COUNT: start (or restart) an upload, or clear with count 0."""
        mtype = self._type(msg)
        if mtype not in (MISSION, FENCE, RALLY):
            self._ack(channel, msg, M.MAV_MISSION_UNSUPPORTED, mtype)
            return
        up = self.upload
        if up is not None and (up.channel is not channel or up.sysid != msg.get_srcSystem()):
            self._ack(channel, msg, M.MAV_MISSION_DENIED, mtype)
            return
        if msg.count == 0:
            self.upload = None
            self.store.clear(mtype)
            self._ack(channel, msg, M.MAV_MISSION_ACCEPTED, mtype)
            return
        if msg.count > CAPACITY:
            self.upload = None
            self._ack(channel, msg, M.MAV_MISSION_NO_SPACE, mtype)
            return
        self.upload = Upload(
            channel, msg.get_srcSystem(), msg.get_srcComponent(), mtype, msg.count, last_activity=now
        )
        self._request_next(now)

    def _request_next(self, now: float) -> None:
        """Ask the uploader for the next item with MISSION_REQUEST, as ArduPilot does."""
        up = self.upload
        assert up is not None
        up.last_request = now
        up.channel.send(
            M.MAVLink_mission_request_message(up.sysid, up.compid, len(up.items), up.mission_type)
        )

    def _item(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """One uploaded item (or a guided go-to with current=2); the last one commits the upload."""
        mtype = self._type(msg)
        if msg.current == 2 and mtype == MISSION:  # a guided "go to" point, not part of an upload
            item = item_from_int(msg) if msg.get_type() == "MISSION_ITEM_INT" else item_from_float(msg)
            ok = item is not None and self.guided_goto(item.x / 1e7, item.y / 1e7)
            self._ack(channel, msg, M.MAV_MISSION_ACCEPTED if ok else M.MAV_MISSION_ERROR, mtype)
            return
        up = self.upload
        if up is None or up.mission_type != mtype:
            self._ack(channel, msg, M.MAV_MISSION_ERROR, mtype)
            return
        if (
            up.channel is not channel
            or up.sysid != msg.get_srcSystem()
            or up.compid != msg.get_srcComponent()
        ):
            self._ack(channel, msg, M.MAV_MISSION_DENIED, mtype)
            return
        if msg.seq != len(up.items):
            self._ack(channel, msg, M.MAV_MISSION_INVALID_SEQUENCE, mtype)
            return
        item = item_from_int(msg) if msg.get_type() == "MISSION_ITEM_INT" else item_from_float(msg)
        if item is None:
            self.upload = None
            self._ack(channel, msg, M.MAV_MISSION_INVALID, mtype)
            return
        up.items.append(item)
        up.last_activity = now
        if len(up.items) < up.count:
            self._request_next(now)
            return
        self.upload = None
        self.store.replace(mtype, up.items)
        self._ack(channel, msg, M.MAV_MISSION_ACCEPTED, mtype)
        if mtype == MISSION:
            self.text(M.MAV_SEVERITY_INFO, "Flight plan received")

    def update(self, now: float) -> None:
        """Re-request a missing item after 1 s; abandon a silent upload after 8 s."""
        up = self.upload
        if up is None:
            return
        if up.channel.closed or now - up.last_activity > UPLOAD_TIMEOUT_S:
            self.upload = None
            up.channel.send(
                M.MAVLink_mission_ack_message(
                    up.sysid, up.compid, M.MAV_MISSION_OPERATION_CANCELLED, up.mission_type
                )
            )
            self.text(M.MAV_SEVERITY_WARNING, "Mission upload timeout")
        elif now - up.last_request > RESEND_S:
            self._request_next(now)

    def _request_list(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """MISSION_REQUEST_LIST: answer with the item count (home included)."""
        mtype = self._type(msg)
        if mtype not in (MISSION, FENCE, RALLY):
            self._ack(channel, msg, M.MAV_MISSION_UNSUPPORTED, mtype)
        elif self.upload is not None:
            self._ack(channel, msg, M.MAV_MISSION_DENIED, mtype)
        else:
            channel.send(
                M.MAVLink_mission_count_message(
                    msg.get_srcSystem(), msg.get_srcComponent(), self.store.count(mtype), mtype
                )
            )

    def _request(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """MISSION_REQUEST_INT / MISSION_REQUEST: send that item (float form with a warning)."""
        mtype = self._type(msg)
        if mtype not in (MISSION, FENCE, RALLY):
            self._ack(channel, msg, M.MAV_MISSION_UNSUPPORTED, mtype)
            return
        if self.upload is not None:
            self._ack(channel, msg, M.MAV_MISSION_DENIED, mtype)
            return
        item = stored_item(self.store, self.home, mtype, msg.seq)
        src, comp = msg.get_srcSystem(), msg.get_srcComponent()
        if item is None:
            channel.send(M.MAVLink_mission_count_message(src, comp, self.store.count(mtype), mtype))
            self._ack(channel, msg, M.MAV_MISSION_ERROR, mtype)
            return
        current = 1 if mtype == MISSION and msg.seq == self.runner.current and self.store.present() else 0
        as_int = msg.get_type() == "MISSION_REQUEST_INT"
        if not as_int and id(channel) not in self._warned_float:
            self._warned_float.add(id(channel))
            self.text(M.MAV_SEVERITY_WARNING, "got MISSION_REQUEST; use MISSION_REQUEST_INT!")
        channel.send(_item_message(item, msg.seq, current, mtype, src, comp, as_int))

    def _clear(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """MISSION_CLEAR_ALL for one type or all."""
        mtype = self._type(msg)
        if mtype not in (MISSION, FENCE, RALLY, ALL_TYPES):
            self._ack(channel, msg, M.MAV_MISSION_UNSUPPORTED, mtype)
        elif self.upload is not None:
            self._ack(channel, msg, M.MAV_MISSION_DENIED, mtype)
        else:
            self.store.clear(mtype)
            self._ack(channel, msg, M.MAV_MISSION_ACCEPTED, mtype)

    def _set_current(self, channel: Channel, msg: mavlink.MAVLink_message, now: float) -> None:
        """MISSION_SET_CURRENT."""
        self.set_current(msg.seq)

    def set_current(self, seq: float) -> bool:
        """Make ``seq`` the current item and announce it in MISSION_CURRENT; False if no such item."""
        if not math.isfinite(seq) or not self.runner.set_current(int(seq)):
            return False
        total = max(0, len(self.store.items(MISSION)) - 1)
        self.broadcast(
            M.MAVLink_mission_current_message(int(seq), total, self.runner.mission_state(False), 0)
        )
        return True
