"""SYS_STATUS sensor bits as ArduPilot sends them with no fence set (issue 17 item 13).

ArduPilot reports an absent fence (FENCE_ENABLE 0) as not present, not enabled and healthy; a clear GEOFENCE
health bit is what ground stations read as a breach (MAVProxy's fence module says "fence breach" when the
health bit goes from set to clear, and it starts from set). The simulator simulates no fence.
"""

from __future__ import annotations

import itertools

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.telemetry import sensor_bits

GEOFENCE = mavlink.MAV_SYS_STATUS_GEOFENCE
RC = mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
PREARM = mavlink.MAV_SYS_STATUS_PREARM_CHECK


@pytest.mark.parametrize(("rc_present", "rc_healthy", "prearm_ok"), list(itertools.product((False, True), repeat=3)))
def test_no_fence_reads_absent_and_healthy(rc_present: bool, rc_healthy: bool, prearm_ok: bool) -> None:
    present, enabled, healthy = sensor_bits(rc_present, rc_healthy, prearm_ok)
    assert not present & GEOFENCE and not enabled & GEOFENCE  # no fence: not present, not enabled
    assert healthy & GEOFENCE  # and not failed: MAVProxy would otherwise say "fence breach"


def test_other_bits_follow_their_inputs() -> None:
    """The RC receiver and pre-arm bits still say what they did: present once RC was seen, healthy when fine."""
    present, enabled, healthy = sensor_bits(rc_present=False, rc_healthy=True, prearm_ok=False)
    assert not present & RC and not healthy & RC and present & PREARM and not healthy & PREARM
    present, enabled, healthy = sensor_bits(rc_present=True, rc_healthy=False, prearm_ok=True)
    assert present & RC and enabled & RC and not healthy & RC and healthy & PREARM
    present, _, healthy = sensor_bits(rc_present=True, rc_healthy=True, prearm_ok=True)
    assert healthy & RC and present & mavlink.MAV_SYS_STATUS_SENSOR_GPS and healthy & mavlink.MAV_SYS_STATUS_SENSOR_GPS
