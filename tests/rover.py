"""Rover's numbers for tests, in one place and from pymavlink's enums: modes, commands, results, masks."""

from __future__ import annotations

from pymavlink.dialects.v20 import ardupilotmega as mavlink

M = mavlink

# Rover flight modes (HEARTBEAT custom_mode, DO_SET_MODE param2)
MANUAL = M.ROVER_MODE_MANUAL
ACRO = M.ROVER_MODE_ACRO
HOLD = M.ROVER_MODE_HOLD
LOITER = M.ROVER_MODE_LOITER
AUTO = M.ROVER_MODE_AUTO
RTL = M.ROVER_MODE_RTL
GUIDED = M.ROVER_MODE_GUIDED
MODE_NAMES = {
    number: entry.name.removeprefix("ROVER_MODE_")
    for number, entry in M.enums["ROVER_MODE"].items()
    if not entry.name.endswith("ENUM_END")
}

# commands
ARM = M.MAV_CMD_COMPONENT_ARM_DISARM
DO_SET_MODE = M.MAV_CMD_DO_SET_MODE
DO_REPOSITION = M.MAV_CMD_DO_REPOSITION
DO_CHANGE_SPEED = M.MAV_CMD_DO_CHANGE_SPEED
SET_MESSAGE_INTERVAL = M.MAV_CMD_SET_MESSAGE_INTERVAL
REQUEST_MESSAGE = M.MAV_CMD_REQUEST_MESSAGE

# MAV_RESULT
ACCEPTED, DENIED, UNSUPPORTED, FAILED = (
    M.MAV_RESULT_ACCEPTED,
    M.MAV_RESULT_DENIED,
    M.MAV_RESULT_UNSUPPORTED,
    M.MAV_RESULT_FAILED,
)

KEEP = 65535  # RC_CHANNELS_OVERRIDE: leave this channel as it is
