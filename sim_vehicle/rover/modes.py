"""Rover's flight-mode table: numbers, names and what each mode needs and allows."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from pymavlink.dialects.v20 import ardupilotmega as mavlink


class Mode(IntEnum):
    """Rover ``Mode::Number`` values, as pymavlink's ROVER_MODE enum names them."""

    MANUAL = mavlink.ROVER_MODE_MANUAL
    ACRO = mavlink.ROVER_MODE_ACRO
    STEERING = mavlink.ROVER_MODE_STEERING
    HOLD = mavlink.ROVER_MODE_HOLD
    LOITER = mavlink.ROVER_MODE_LOITER
    FOLLOW = mavlink.ROVER_MODE_FOLLOW
    SIMPLE = mavlink.ROVER_MODE_SIMPLE
    CIRCLE = mavlink.ROVER_MODE_CIRCLE
    AUTO = mavlink.ROVER_MODE_AUTO
    RTL = mavlink.ROVER_MODE_RTL
    SMART_RTL = mavlink.ROVER_MODE_SMART_RTL
    GUIDED = mavlink.ROVER_MODE_GUIDED
    INITIALISING = mavlink.ROVER_MODE_INITIALIZING


@dataclass(frozen=True)
class ModeInfo:
    """How a mode behaves for heartbeat bits, arming and entry."""

    manual_input: bool
    autopilot: bool
    armable: bool
    implemented: bool


MODE_INFO: dict[Mode, ModeInfo] = {
    Mode.MANUAL: ModeInfo(True, False, True, True),
    Mode.ACRO: ModeInfo(True, False, True, True),
    Mode.STEERING: ModeInfo(True, False, True, True),
    Mode.HOLD: ModeInfo(False, False, True, True),
    Mode.LOITER: ModeInfo(False, True, True, True),
    Mode.FOLLOW: ModeInfo(False, True, True, False),
    Mode.SIMPLE: ModeInfo(False, False, True, False),
    Mode.CIRCLE: ModeInfo(False, True, True, False),
    Mode.AUTO: ModeInfo(False, True, True, True),
    Mode.RTL: ModeInfo(False, True, False, True),
    Mode.SMART_RTL: ModeInfo(False, True, False, False),
    Mode.GUIDED: ModeInfo(False, True, True, True),
    Mode.INITIALISING: ModeInfo(True, False, False, False),
}

# HEARTBEAT base_mode bits
CUSTOM_MODE_ENABLED = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
GUIDED_ENABLED = mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
MANUAL_INPUT_ENABLED = mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
SAFETY_ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def base_mode(mode: Mode, armed: bool) -> int:
    """The HEARTBEAT base_mode Rover reports for ``mode``."""
    info = MODE_INFO[mode]
    bits = CUSTOM_MODE_ENABLED
    if info.manual_input:
        bits |= MANUAL_INPUT_ENABLED
    if info.autopilot:
        bits |= GUIDED_ENABLED
    if armed:
        bits |= SAFETY_ARMED
    return bits


def lookup(number: float) -> Mode | None:
    """The mode with this number, or None for anything else (fractions, NaN, unknown numbers)."""
    try:
        if number != int(number):
            return None
        return Mode(int(number))
    except (ValueError, OverflowError):
        return None
