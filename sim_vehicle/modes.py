"""Rover's flight-mode table: numbers, names and what each mode needs and allows."""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum


class Mode(IntEnum):
    """Rover ``Mode::Number`` values."""

    MANUAL = 0
    ACRO = 1
    STEERING = 3
    HOLD = 4
    LOITER = 5
    FOLLOW = 6
    SIMPLE = 7
    CIRCLE = 9
    AUTO = 10
    RTL = 11
    SMART_RTL = 12
    GUIDED = 15
    INITIALISING = 16


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

# HEARTBEAT base_mode bits (MAV_MODE_FLAG)
CUSTOM_MODE_ENABLED = 1
GUIDED_ENABLED = 8
MANUAL_INPUT_ENABLED = 64
SAFETY_ARMED = 128


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
