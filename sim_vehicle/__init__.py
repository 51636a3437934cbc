"""A software-in-the-loop ArduPilot Rover (boat, skid steering) around the ``vessel`` plant.

It speaks MAVLink like ArduPilot so that the companion and mission tools can be tested against it
unchanged; only their connection strings differ from the real boat.

Rooms: Rover's behaviour in ``sim_vehicle.rover``, the MAVLink side in ``sim_vehicle.mavlink``, the JSON
backend for the real firmware in ``sim_vehicle.json_backend``; at the top level the loop that owns time
(``sim``, ``sim_hold``, ``lockstep``, ``clock``), the plant and its sensing (``physics``, ``sensing``), logs,
ports, the command line and the test ``harness``.

May import: ``vessel``. Never ``mavbridge`` or ``mission`` (nor they it: only MAVLink joins them).
"""

__all__ = ["__version__"]

__version__ = "0.1.0"
