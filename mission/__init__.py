"""The operator side: waypoint missions, their files (.plan, .waypoints) and MAVSDK transfer."""

from .files import read_mission_file, write_mission_file
from .plan import Mission, MissionError, MissionItem, validate

__all__ = ["Mission", "MissionError", "MissionItem", "read_mission_file", "validate", "write_mission_file"]
