"""The companion computer's software: the roll-aware NMPC, scenarios and the in-process experiment runner.

Imports ``vessel`` (the model), never ``sim_vehicle``.
"""
