"""ArduPilot Rover's modes by name (HOLD, MANUAL, GUIDED, AUTO, ...), for every line a user reads.

HEARTBEAT.custom_mode carries the mode as a number; pymavlink holds Rover's table of names (the same
for a rover and a boat frame), so no hand-written table can fall out of step with the firmware's.
"""

from __future__ import annotations

from mavbridge.link import connection as _link  # sets MAVLINK20 before pymavlink is imported

_ROVER_MODES: dict[int, str] = _link.mavutil.mode_mapping_bynumber(_link.mavlink.MAV_TYPE_SURFACE_BOAT)


def mode_name(mode: int | None) -> str:
    """Rover's name of ``mode`` ("mode 99" for a number Rover does not have, "no mode" for None)."""
    if mode is None:
        return "no mode"
    return _ROVER_MODES.get(int(mode), f"mode {mode}")
