"""A software-in-the-loop ArduPilot Rover (boat, skid steering) around the ``vessel`` plant.

It speaks MAVLink like ArduPilot so that the companion and mission tools can be tested against it
unchanged; only their connection strings differ from the real boat.
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
