"""The driving messages a Rover takes from MAVLink: RC overrides, MANUAL_CONTROL and GUIDED targets.

Each handler checks what Rover checks (sender sysid, mode, type_mask) and hands the vehicle a plain
demand; the GCS endpoint routes the messages here.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.link import Channel
from sim_vehicle.rover.guided import ACC_XY_IGNORE, from_global, from_local
from sim_vehicle.rover.modes import Mode
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.vehicle import Vehicle

log = logging.getLogger("sim_vehicle")
N_OVERRIDE_CHANNELS = 18
NO_CHANGE = 65535  # RC override value that leaves a channel as it is
AXIS_RELEASE = 32767  # MANUAL_CONTROL axis value INT16_MAX: release that channel's override
STEERING_CHANNEL, THROTTLE_CHANNEL = 1, 3

Handler = Callable[[Channel, mavlink.MAVLink_message], None]


class ControlInputs:
    """Handlers for RC_CHANNELS_OVERRIDE, MANUAL_CONTROL, SET_ATTITUDE_TARGET and SET_POSITION_TARGET_*."""

    def __init__(
        self, params: ParamTable, vehicle: Vehicle, sysid: int, text: Callable[[int, str], None]
    ) -> None:
        self.params, self.vehicle, self.sysid, self.text = params, vehicle, sysid, text
        self._ignored_override_from: set[int] = set()

    def handlers(self) -> dict[str, Handler]:
        """Message type -> handler, for the endpoint's dispatch table."""
        return {
            "RC_CHANNELS_OVERRIDE": self.override,
            "MANUAL_CONTROL": self.manual_control,
            "SET_ATTITUDE_TARGET": self.attitude_target,
            "SET_POSITION_TARGET_LOCAL_NED": self.position_target,
            "SET_POSITION_TARGET_GLOBAL_INT": self.position_target,
        }

    def _from_gcs(self, msg: mavlink.MAVLink_message) -> bool:
        """True if the sender is SYSID_MYGCS, the only system whose overrides Rover takes."""
        return msg.get_srcSystem() == int(self.params["SYSID_MYGCS"])

    def override(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """RC_CHANNELS_OVERRIDE, taken only from SYSID_MYGCS (others are logged once and ignored)."""
        src = msg.get_srcSystem()
        if not self._from_gcs(msg):
            if src not in self._ignored_override_from:
                self._ignored_override_from.add(src)
                log.warning(
                    "ignoring RC_CHANNELS_OVERRIDE from system %d (SYSID_MYGCS is %d)",
                    src,
                    int(self.params["SYSID_MYGCS"]),
                )
            return
        channels = [getattr(msg, f"chan{i}_raw", 0) for i in range(1, N_OVERRIDE_CHANNELS + 1)]
        self.vehicle.override(channels)

    def manual_control(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """MANUAL_CONTROL from SYSID_MYGCS aimed at us: y -> steering (ch1), z -> throttle (ch3) overrides.

        As Rover's handle_manual_control_axes: each axis -1000..1000 maps onto RCn_MIN..RCn_MAX, INT16_MAX
        releases the channel; the overrides expire like RC_CHANNELS_OVERRIDE and count as the GCS being seen.
        """
        if not self._from_gcs(msg) or msg.target != self.sysid:
            return
        channels = [NO_CHANGE] * N_OVERRIDE_CHANNELS
        for ch, value in ((STEERING_CHANNEL, msg.y), (THROTTLE_CHANNEL, msg.z)):
            channels[ch - 1] = self._axis_pwm(ch, int(value))
        self.vehicle.override(channels)

    def _axis_pwm(self, ch: int, value: int) -> int:
        """GCS_MAVLINK::manual_override: -1000..1000 -> RCn_MIN..RCn_MAX (truncated); INT16_MAX -> 0 (release)."""
        if value == AXIS_RELEASE:
            return 0
        lo, hi = int(self.params[f"RC{ch}_MIN"]), int(self.params[f"RC{ch}_MAX"])
        pwm = int(lo + (hi - lo) * (value + 1000) / 2000.0)
        return min(NO_CHANGE - 1, max(1, pwm))  # 0 and 65535 are release / no-change codes on the wire

    def attitude_target(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """SET_ATTITUDE_TARGET (the vehicle drops it outside GUIDED)."""
        self.vehicle.attitude_target(msg.type_mask, list(msg.q), msg.body_yaw_rate, msg.thrust)

    def position_target(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """SET_POSITION_TARGET_*: only in GUIDED; accelerations must be ignored (Rover says so), the rest
        that Rover cannot use is dropped silently."""
        v = self.vehicle
        if v.mode != Mode.GUIDED:
            return
        if not int(msg.type_mask) & ACC_XY_IGNORE:
            self.text(mavlink.MAV_SEVERITY_INFO, f"Ignoring {msg.get_type()}; set ACC_IGNORE in mask")
            return
        wp_speed = v.navigator.guided_waypoint_speed()
        if msg.get_type() == "SET_POSITION_TARGET_LOCAL_NED":
            v.set_guided(from_local(msg, v.nav, v.default_speed(), v.now, wp_speed))
        else:
            v.set_guided(from_global(msg, v.home, v.nav, v.default_speed(), v.now, wp_speed))
