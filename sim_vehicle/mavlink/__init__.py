"""The simulator's MAVLink side: transports (TCP server, UDP outputs, serial), channels and routing,
stream rates, telemetry built from the plant's state, the command, mission and parameter protocols, and
MAVLink 2 signing, as ArduPilot Rover speaks them.

May import ``vessel``, ``sim_vehicle.rover`` (what a message asks the vehicle to do), the simulator's
top-level helpers and its own modules;
imported by ``sim_vehicle.sim`` and the simulator's command line (never by ``mavbridge``).
"""
