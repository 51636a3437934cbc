"""The companion computer's software: the roll-aware NMPC, scenarios and the in-process experiment runner.

Imports ``vessel`` (the model), never ``sim_vehicle``.

Rooms: ``link`` (MAVLink to one autopilot), ``companion`` (the flight of `mavbridge run`), ``nmpc``
(the controller and its ``solvers``), ``waves`` (the sea from the boat's motion), ``lab`` (scenarios,
in-process experiments, plots, the demo), ``sweep``, ``preflight`` (`mavbridge check`) and ``cli``.

May import: ``vessel``, never ``sim_vehicle`` or ``mission``.
"""
