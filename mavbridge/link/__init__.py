"""The companion's MAVLink link to one autopilot: the connection and which datagrams are the autopilot's,
requests with retries (many parameters at once within one budget: ``param_reads``), stream requests, reboots
noticed, MAVLink 2 signing, the model of the autopilot's clock, the ``.tlog`` on that clock, and the
one-companion-per-port guard.

Knows MAVLink, not the NMPC or the flight. May import ``vessel`` and its own modules; imported by
``mavbridge.companion``, ``mavbridge.preflight``, ``mavbridge.cli`` and the tests.
"""
