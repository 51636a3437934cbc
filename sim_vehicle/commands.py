"""COMMAND_LONG / COMMAND_INT and SET_MODE handling, answered with COMMAND_ACK as Rover answers them."""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from .guided import to_location
from .modes import CUSTOM_MODE_ENABLED, Mode
from .vehicle import ACCEPTED, DENIED, FAILED, UNSUPPORTED

if TYPE_CHECKING:
    from .gcs import Gcs
    from .link import Channel

ARM_MAGIC, DISARM_MAGIC = 2989, 21196
M = mavlink


def _params(msg: mavlink.MAVLink_message) -> list[float]:
    """param1..7 of a COMMAND_LONG, or of a COMMAND_INT (x, y as numbers)."""
    if msg.get_type() == "COMMAND_INT":
        return [msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y), msg.z]
    return [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7]


def handle_command(gcs: Gcs, channel: Channel, msg: mavlink.MAVLink_message) -> None:
    """Run one command and ACK it to its sender; messages it asks for follow the ACK."""
    p = _params(msg)
    follow_up: list[mavlink.MAVLink_message] = []
    if msg.get_type() == "COMMAND_INT":
        p[4], p[5] = p[4] / 1e7, p[5] / 1e7  # x/y of a COMMAND_INT are degE7
    try:
        result = _run(gcs, channel, msg.command, p, follow_up)
    except (ValueError, OverflowError):  # NaN or absurd numbers where an integer is needed
        result = FAILED
    except Exception:  # a bug must still be answered, or the sender retries into a timeout
        logging.getLogger(__name__).exception("command %s failed", msg.command)
        result = FAILED
    channel.send(
        M.MAVLink_command_ack_message(msg.command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())
    )
    for reply in follow_up:
        channel.send(reply)


def _run(
    gcs: Gcs, channel: Channel, command: int, p: list[float], follow_up: list[mavlink.MAVLink_message]
) -> int:
    """The MAV_RESULT of one command."""
    v = gcs.vehicle
    if command == M.MAV_CMD_COMPONENT_ARM_DISARM:
        if p[0] == 1:
            return v.arm(force=p[1] == ARM_MAGIC)
        if p[0] == 0:
            return v.disarm()
        return UNSUPPORTED
    if command == M.MAV_CMD_DO_SET_MODE:
        if not int(p[0]) & CUSTOM_MODE_ENABLED:
            return DENIED
        return v.set_mode(p[1])
    if command == M.MAV_CMD_MISSION_START:
        return v.set_mode(Mode.AUTO)
    if command == M.MAV_CMD_NAV_RETURN_TO_LAUNCH:
        return v.set_mode(Mode.RTL)
    if command == M.MAV_CMD_DO_REPOSITION:
        return _reposition(gcs, p)
    if command == M.MAV_CMD_DO_CHANGE_SPEED:
        return _change_speed(gcs, p[1])
    if command == M.MAV_CMD_DO_SET_MISSION_CURRENT:
        return ACCEPTED if gcs.missions.set_current(p[0]) else FAILED
    if command == M.MAV_CMD_SET_MESSAGE_INTERVAL:
        msg_id = int(p[0])
        if msg_id not in gcs.telemetry.builders or not math.isfinite(p[1]):
            gcs.text(6, f"No ap_message for mavlink id ({msg_id})", channel)
            return FAILED
        gcs.schedule(channel).set_interval(msg_id, p[1])
        return ACCEPTED
    if command == M.MAV_CMD_GET_MESSAGE_INTERVAL:
        msg_id = int(p[0])
        if msg_id not in gcs.telemetry.builders:
            return FAILED
        interval = 1.0 if msg_id == 0 else gcs.schedule(channel).interval(msg_id)
        follow_up.append(
            M.MAVLink_message_interval_message(msg_id, -1 if interval is None else round(interval * 1e6))
        )
        return ACCEPTED
    if command == M.MAV_CMD_REQUEST_MESSAGE:
        msg_id = int(p[0])
        if msg_id not in gcs.telemetry.builders:
            return FAILED
        reply = gcs.telemetry.build(msg_id)
        if reply is not None:
            follow_up.append(reply)
        return ACCEPTED
    if command == M.MAV_CMD_GET_HOME_POSITION:
        follow_up += [gcs.telemetry.home_position(), gcs.telemetry.gps_global_origin()]
        return ACCEPTED
    if command == M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
        if p[0] != 1:
            return FAILED
        follow_up.append(gcs.telemetry.autopilot_version())
        return ACCEPTED
    return UNSUPPORTED


def _change_speed(gcs: Gcs, speed: float) -> int:
    """DO_CHANGE_SPEED: a new speed for AUTO or GUIDED; other modes have none to change."""
    v = gcs.vehicle
    if not math.isfinite(speed) or speed < 0:
        return FAILED
    if v.mode == Mode.AUTO:
        v.runner.speed = speed
        if v.runner.leg is not None:
            v.runner.leg.target.speed = speed
        return ACCEPTED
    if v.mode == Mode.GUIDED:
        if v.guided is not None:
            v.guided.speed = math.copysign(speed, v.guided.speed) if v.guided.speed else speed
        return ACCEPTED
    return FAILED


def _reposition(gcs: Gcs, p: list[float]) -> int:
    """DO_REPOSITION: a guided waypoint; outside GUIDED only with the change-mode flag (p2 bit 0)."""
    v = gcs.vehicle
    speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else v.default_speed()
    target = to_location(p[4], p[5], gcs.vehicle.home, v.nav, speed, v.now)
    if target is None:
        return DENIED
    if v.mode != Mode.GUIDED:
        if not (math.isfinite(p[1]) and int(p[1]) & 1) or v.set_mode(Mode.GUIDED) != ACCEPTED:
            return DENIED
    return ACCEPTED if v.set_guided(target) else FAILED


def handle_set_mode(gcs: Gcs, channel: Channel, msg: mavlink.MAVLink_message) -> None:
    """SET_MODE message: honoured with CUSTOM_MODE_ENABLED, answered by a COMMAND_ACK for command 11."""
    if msg.base_mode & CUSTOM_MODE_ENABLED:
        result = gcs.vehicle.set_mode(msg.custom_mode)
    else:
        result = DENIED
    channel.send(M.MAVLink_command_ack_message(11, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()))
