"""The companion's choices as plain data, for its settings and for the command lines (no imports, so that
``--help`` and the argument checks stay quick and nothing needs the flight's modules to name them)."""

OUTPUTS = ("rc_override", "attitude_target")  # MANUAL with RC overrides, GUIDED with SET_ATTITUDE_TARGET
WAVE_SOURCES = ("estimated", "scenario")  # estimated from the boat's motion, or the scenario's sea (simulation)
