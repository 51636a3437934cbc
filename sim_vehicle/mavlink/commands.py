"""COMMAND_LONG / COMMAND_INT and SET_MODE handling, answered with COMMAND_ACK as Rover answers them.

The handler is owned by the GCS endpoint and built with everything it needs (vehicle, telemetry, mission
server, per-channel stream schedules, STATUSTEXT); it never reaches back into the endpoint itself.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.link import Channel
from sim_vehicle.mavlink.mission_protocol import MissionServer
from sim_vehicle.mavlink.streams import Schedule
from sim_vehicle.mavlink.telemetry import Telemetry
from sim_vehicle.rover.guided import valid_location
from sim_vehicle.rover.modes import CUSTOM_MODE_ENABLED, Mode
from sim_vehicle.rover.vehicle import Vehicle

ARM_MAGIC, DISARM_MAGIC = 2989, 21196
REPOSITION_CHANGE_MODE = 1  # DO_REPOSITION param2 bit (MAV_DO_REPOSITION_FLAGS_CHANGE_MODE)
REBOOT_FORCE = 20190226  # PREFLIGHT_REBOOT_SHUTDOWN param6: REBOOT_SHUTDOWN_CONDITIONS_FORCE (reboot even armed)
M = mavlink
log = logging.getLogger(__name__)


def _params(msg: mavlink.MAVLink_message) -> list[float]:
    """param1..7 of a COMMAND_LONG, or of a COMMAND_INT (x, y from degE7 to degrees)."""
    if msg.get_type() == "COMMAND_INT":
        return [msg.param1, msg.param2, msg.param3, msg.param4, msg.x / 1e7, msg.y / 1e7, msg.z]
    return [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7]


def _ack(msg: mavlink.MAVLink_message, command: int, result: int) -> mavlink.MAVLink_message:
    """COMMAND_ACK of ``command`` back to the sender of ``msg``."""
    return M.MAVLink_command_ack_message(
        command=command,
        result=result,
        progress=0,
        result_param2=0,
        target_system=msg.get_srcSystem(),
        target_component=msg.get_srcComponent(),
    )


class CommandHandler:
    """Runs commands on the vehicle and answers them; ``text`` sends a STATUSTEXT (to one channel or all)."""

    def __init__(
        self,
        vehicle: Vehicle,
        telemetry: Telemetry,
        missions: MissionServer,
        schedule: Callable[[Channel], Schedule],
        text: Callable[[int, str, Channel | None], None],
    ) -> None:
        self.vehicle, self.telemetry, self.missions = vehicle, telemetry, missions
        self.schedule, self.text = schedule, text
        self.reboot_requested = False  # the simulator restarts after this step (the ACK goes out first)
        self._table: dict[int, Callable[[Channel, list[float], list[mavlink.MAVLink_message]], int]] = {
            M.MAV_CMD_COMPONENT_ARM_DISARM: self._arm_disarm,
            M.MAV_CMD_DO_SET_MODE: lambda _c, p, _f: self._set_mode(int(p[0]), p[1]),
            M.MAV_CMD_MISSION_START: lambda _c, _p, _f: vehicle.set_mode(Mode.AUTO),
            M.MAV_CMD_NAV_RETURN_TO_LAUNCH: lambda _c, _p, _f: vehicle.set_mode(Mode.RTL),
            M.MAV_CMD_DO_REPOSITION: lambda _c, p, _f: self._reposition(p),
            M.MAV_CMD_DO_CHANGE_SPEED: lambda _c, p, _f: self._change_speed(p[1]),
            M.MAV_CMD_DO_SET_MISSION_CURRENT: lambda _c, p, _f: self._result(missions.set_current(p[0])),
            M.MAV_CMD_SET_MESSAGE_INTERVAL: self._set_interval,
            M.MAV_CMD_GET_MESSAGE_INTERVAL: self._get_interval,
            M.MAV_CMD_REQUEST_MESSAGE: self._request_message,
            M.MAV_CMD_GET_HOME_POSITION: self._home_position,
            M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._capabilities,
            M.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: lambda _c, p, _f: self._reboot(p),
        }

    def handle_command(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """Run one COMMAND_LONG / COMMAND_INT and ACK it to its sender; messages it asks for follow the ACK."""
        follow_up: list[mavlink.MAVLink_message] = []
        run = self._table.get(msg.command)
        try:
            result = run(channel, _params(msg), follow_up) if run is not None else M.MAV_RESULT_UNSUPPORTED
        except (ValueError, OverflowError):  # NaN or absurd numbers where an integer is needed
            result = M.MAV_RESULT_FAILED
        except Exception:  # a bug must still be answered, or the sender retries into a timeout
            log.exception("command %s failed", msg.command)
            result = M.MAV_RESULT_FAILED
        channel.send(_ack(msg, msg.command, result))
        for reply in follow_up:
            channel.send(reply)

    def handle_set_mode(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """SET_MODE message: honoured with CUSTOM_MODE_ENABLED; ArduPilot ACKs it as "command" 11 (its msg id)."""
        channel.send(_ack(msg, M.MAVLINK_MSG_ID_SET_MODE, self._set_mode(msg.base_mode, msg.custom_mode)))

    @staticmethod
    def _result(ok: bool) -> int:
        """ACCEPTED or FAILED."""
        return M.MAV_RESULT_ACCEPTED if ok else M.MAV_RESULT_FAILED

    def _set_mode(self, base_mode: int, custom_mode: float) -> int:
        """A mode change asked with CUSTOM_MODE_ENABLED in base_mode (else DENIED)."""
        if not base_mode & CUSTOM_MODE_ENABLED:
            return M.MAV_RESULT_DENIED
        return self.vehicle.set_mode(custom_mode)

    def _arm_disarm(self, _channel: Channel, p: list[float], _follow_up: list[mavlink.MAVLink_message]) -> int:
        """COMPONENT_ARM_DISARM: p1 1 arms (p2 2989 forces), 0 disarms."""
        if p[0] == 1:
            return self.vehicle.arm(force=p[1] == ARM_MAGIC)
        if p[0] == 0:
            return self.vehicle.disarm()
        return M.MAV_RESULT_UNSUPPORTED

    def _reboot(self, p: list[float]) -> int:
        """PREFLIGHT_REBOOT_SHUTDOWN p1 1 reboots the autopilot; like ArduPilot, refused while armed unless p6 is
        the force value. p1 0 (nothing for the autopilot) is accepted; shutdown and bootloader are not simulated."""
        if p[0] == 0:
            return M.MAV_RESULT_ACCEPTED
        if p[0] != 1:
            return M.MAV_RESULT_UNSUPPORTED
        if self.vehicle.armed and p[5] != REBOOT_FORCE:
            return M.MAV_RESULT_FAILED
        self.reboot_requested = True
        return M.MAV_RESULT_ACCEPTED

    def _change_speed(self, speed: float) -> int:
        """DO_CHANGE_SPEED p2 (m/s): a new speed for AUTO or GUIDED waypoints; other modes have none to change."""
        if not math.isfinite(speed) or speed < 0:
            return M.MAV_RESULT_FAILED
        return self._result(self.vehicle.change_speed(speed))

    def _reposition(self, p: list[float]) -> int:
        """DO_REPOSITION: a guided waypoint (p1 speed if > 0); outside GUIDED only with the change-mode flag."""
        v = self.vehicle
        lat, lon = p[4], p[5]
        if not valid_location(lat, lon):
            return M.MAV_RESULT_DENIED
        if v.mode != Mode.GUIDED:
            change_mode = math.isfinite(p[1]) and int(p[1]) & REPOSITION_CHANGE_MODE
            if not change_mode or v.set_mode(Mode.GUIDED) != M.MAV_RESULT_ACCEPTED:
                return M.MAV_RESULT_DENIED
        speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else None  # None: after a mode change, which forgets
        return self._result(v.guided_goto(lat, lon, speed))  # an earlier DO_CHANGE_SPEED

    def _set_interval(self, channel: Channel, p: list[float], _follow_up: list[mavlink.MAVLink_message]) -> int:
        """SET_MESSAGE_INTERVAL p1 message id, p2 interval (µs; -1 stop, 0 default) on this channel."""
        msg_id = int(p[0])
        if msg_id not in self.telemetry.builders or not math.isfinite(p[1]):
            self.text(M.MAV_SEVERITY_INFO, f"No ap_message for mavlink id ({msg_id})", channel)
            return M.MAV_RESULT_FAILED
        self.schedule(channel).set_interval(msg_id, p[1])
        return M.MAV_RESULT_ACCEPTED

    def _get_interval(self, channel: Channel, p: list[float], follow_up: list[mavlink.MAVLink_message]) -> int:
        """GET_MESSAGE_INTERVAL: answered with MESSAGE_INTERVAL after the ACK (-1 = not streamed)."""
        msg_id = int(p[0])
        if msg_id not in self.telemetry.builders:
            return M.MAV_RESULT_FAILED
        interval = 1.0 if msg_id == M.MAVLINK_MSG_ID_HEARTBEAT else self.schedule(channel).interval(msg_id)
        interval_us = -1 if interval is None else round(interval * 1e6)
        follow_up.append(M.MAVLink_message_interval_message(message_id=msg_id, interval_us=interval_us))
        return M.MAV_RESULT_ACCEPTED

    def _request_message(self, _channel: Channel, p: list[float], follow_up: list[mavlink.MAVLink_message]) -> int:
        """REQUEST_MESSAGE p1: that message once, after the ACK (if it exists now)."""
        msg_id = int(p[0])
        if msg_id not in self.telemetry.builders:
            return M.MAV_RESULT_FAILED
        reply = self.telemetry.build(msg_id)
        if reply is not None:
            follow_up.append(reply)
        return M.MAV_RESULT_ACCEPTED

    def _home_position(self, _channel: Channel, _p: list[float], follow_up: list[mavlink.MAVLink_message]) -> int:
        """GET_HOME_POSITION: HOME_POSITION and GPS_GLOBAL_ORIGIN after the ACK."""
        follow_up += [self.telemetry.plant.home_position(), self.telemetry.plant.gps_global_origin()]
        return M.MAV_RESULT_ACCEPTED

    def _capabilities(self, _channel: Channel, p: list[float], follow_up: list[mavlink.MAVLink_message]) -> int:
        """REQUEST_AUTOPILOT_CAPABILITIES p1 = 1: AUTOPILOT_VERSION after the ACK."""
        if p[0] != 1:
            return M.MAV_RESULT_FAILED
        follow_up.append(self.telemetry.autopilot_version())
        return M.MAV_RESULT_ACCEPTED
