"""The Otter USV and the sea: Fossen's 6-DOF model, wave fields, thrust allocation, a numeric plant.

No MAVLink here; both the simulator and the NMPC build on this package. The world of a run (vessel,
sea, start) is described once in :mod:`vessel.world`; latitude/longitude and angle wraps live in
:mod:`vessel.geo`.

Rooms: the hull and its numbers at the top level (``params``, ``dynamics``, ``allocation``, ``plant``,
``imu``, ``sensors``, ``maneuver``, ``world``, ``config``, ``geo``), the sea in ``vessel.sea``.

May import: nothing of ours (numpy, CasADi, PyYAML only). Imported by every other package.
"""

from vessel.allocation import propeller_thrust, shaft_speeds_to_tau, tau_limits, tau_to_shaft_speeds
from vessel.config import ConfigError
from vessel.dynamics import NX_PLANT, NX_RIGID, STATE_COLUMNS, STATE_NAMES, OceanCurrent, plant_ode, rigid_body_ode
from vessel.params import OtterMatrices, OtterParameters, load_parameters, otter_parameters
from vessel.plant import Plant, plant_step
from vessel.sea.irregular import IrregularWaves, hull_averaging_factor, synthesise
from vessel.sea.irregular_sea import IrregularSea, parse_sea_spec
from vessel.sea.spectra import jonswap, nato_sea_state, pierson_moskowitz, wavenumber
from vessel.sea.state import SeaState, Start
from vessel.sea.waves import CalmWater, RegularWaves, WaveField
from vessel.world import SEA_PRESETS, World, load_world, world_preset

__all__ = [
    "NX_PLANT",
    "NX_RIGID",
    "SEA_PRESETS",
    "STATE_COLUMNS",
    "STATE_NAMES",
    "CalmWater",
    "ConfigError",
    "IrregularSea",
    "IrregularWaves",
    "OceanCurrent",
    "OtterMatrices",
    "OtterParameters",
    "Plant",
    "RegularWaves",
    "SeaState",
    "Start",
    "WaveField",
    "World",
    "hull_averaging_factor",
    "jonswap",
    "load_parameters",
    "load_world",
    "nato_sea_state",
    "otter_parameters",
    "parse_sea_spec",
    "pierson_moskowitz",
    "plant_ode",
    "plant_step",
    "propeller_thrust",
    "rigid_body_ode",
    "shaft_speeds_to_tau",
    "synthesise",
    "tau_limits",
    "tau_to_shaft_speeds",
    "wavenumber",
    "world_preset",
]
