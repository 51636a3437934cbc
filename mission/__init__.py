"""The operator side: waypoint missions, their files (.plan, .waypoints) and MAVSDK transfer.

May import: ``vessel`` (geodesy, ranges). Talks to an autopilot only through MAVSDK; never imports
``sim_vehicle`` or ``mavbridge``.
"""

from mission.files import read_mission_file, write_mission_file
from mission.plan import Mission, MissionError, MissionItem, validate

__all__ = ["Mission", "MissionError", "MissionItem", "read_mission_file", "validate", "write_mission_file"]
