"""ArduPilot Rover's behaviour as the simulator imitates it: modes, arming, the pilot's sticks and RC,
GUIDED targets, AUTO's mission runner and the navigator, the helm and its controllers, failsafes, the
skid-steer mixer and servo outputs, the battery and the parameter table.

No sockets and no wire format: ``sim_vehicle.mavlink`` turns MAVLink into the calls made here, and
``sim_vehicle.sim`` steps the vehicle with the plant. May import ``vessel``, the simulator's top-level
helpers and, for the channel a driving message came on, ``sim_vehicle.mavlink.link``; imported by the rest
of ``sim_vehicle`` (never by ``mavbridge``).
"""
