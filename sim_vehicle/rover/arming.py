"""Rover's pre-arm checks, worded as ArduPilot words its refusals."""

from __future__ import annotations

from sim_vehicle.rover.modes import MODE_INFO, Mode
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.servos import skid_config_ok

RC_OPTIONS_ARM_THROTTLE_NEUTRAL = 32  # RC_OPTIONS bit: refuse to arm unless the throttle stick is neutral


def prearm_failure(params: ParamTable, mode: Mode, throttle_stick: float) -> str:
    """The first failing arming check, or '' if all pass; ``throttle_stick`` is the pilot's ch3 in [-1, 1]."""
    if not MODE_INFO[mode].armable:
        return "PreArm: Mode not armable"
    if not skid_config_ok(params):
        return "PreArm: check skid steering config"
    if params["ARMING_CHECK"] == 0:
        return ""
    if params["WP_SPEED"] <= 0:
        return "PreArm: WP_SPEED too low"
    if (
        int(params["RC_OPTIONS"]) & RC_OPTIONS_ARM_THROTTLE_NEUTRAL
        and MODE_INFO[mode].manual_input
        and throttle_stick != 0.0
    ):
        return "Arm: Throttle (RC3) is not neutral"
    return ""
