"""``sim-vehicle --json-backend``: the Otter's plant, sea and ideal sensors behind ArduPilot's JSON SITL
interface, for the real Rover firmware: the wire format, the model stepped per frame, the run folder and the
command line. No MAVLink of its own (the firmware speaks it).

May import ``vessel`` and the simulator's shared helpers (``sim_vehicle.argtypes``, ``sim_vehicle.scenario``,
``sim_vehicle.physics``, ``sim_vehicle.logs``); imported by ``sim_vehicle.cli``.
"""
