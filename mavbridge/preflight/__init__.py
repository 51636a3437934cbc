"""`mavbridge check`: a preflight check of an ArduPilot Rover (real or simulated) for the companion.

In parts: ``rules`` (the parameters the companion relies on, as a table that `mavbridge run` enforces
too; which ones it must read at all is ``mavbridge.companion.parameters``, judged here the same way),
``probe`` (talks to the vehicle: heartbeat, parameters, stream rates, GPS and home, mission),
``solve_time`` (the NMPC on this computer), ``report`` (the PASS/WARN/FAIL table) and ``cli``.
Each finding is PASS, WARN or FAIL; any FAIL makes the exit code 1.

May import: ``vessel``, ``mavbridge.link``, ``mavbridge.companion`` (settings, outputs), ``mavbridge.nmpc``
and ``mavbridge.cli.args`` (the flags it shares with `run`). Imported by ``mavbridge.cli`` and, for its
rules table (``rules``), by ``mavbridge.companion``, which enforces the same rules.
"""
