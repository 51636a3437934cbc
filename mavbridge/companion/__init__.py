"""The flight: the companion process of `mavbridge run` — its settings, its start (autopilot, streams,
mission, cold solve), the autopilot parameters its commands depend on (read, never assumed), the
supervisor that decides when it may command, the range gate, the mission
tracker, the two command paths and their outputs (RC override; GUIDED's attitude targets and the inverse
of Rover's loops), the boat's state from telemetry, delay compensation and prediction, the wave gate
between the wave source and the NMPC, the wave estimator's own process (``wave_process``: its work off the
control step), what it says while flying and its summary.

May import ``vessel``, ``mavbridge.link``, ``mavbridge.nmpc``, ``mavbridge.waves``, ``mavbridge.lab``'s
scenario and run log, and ``mavbridge.preflight.rules`` (the parameter rules `check` and `run` share);
imported by ``mavbridge.cli``, ``mavbridge.preflight``, ``mavbridge.lab`` (the demo's summary) and the tests.
"""
