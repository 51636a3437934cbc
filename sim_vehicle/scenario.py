"""The simulator's world from its command line: ``--scenario``, ``--sea``, ``--sea-state``, ``--current``,
``--vessel``, ``--home``; and the sea's hidden phase origin drawn from ``--seed``.

The world (vessel, sea, start) comes from ``vessel.world`` — ``load_world`` for a scenario file (the loader
``mavbridge`` uses too, with the same rule for unknown sections) — and the flags given on top replace parts of
it: ``--sea`` the waves, ``--current`` the current, ``--vessel`` the hull. Without a scenario the boat starts at
rest at home, pointing the home heading, in calm water. ``--sea`` takes a named sea (``paper``, ``calm``: the
``vessel.world`` presets; ``--waves NAME`` is its old name), the regular ``H,LENGTH,PERIOD,DIR`` or an irregular
``jonswap:HS,TP,DIR[,GAMMA[,SPREADING]]`` / ``pm:HS,TP,DIR``.

:func:`seeded_waves` gives the sea a phase origin nobody is told: regular waves a phase in [0, 2π),
irregular seas a time origin in [0, 1 h) (every component's phase advanced by ωᵢ·t₀), both from the
run's seed. The simulator and the JSON backend use it, and write the seed only to their run folders.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from vessel.argtypes import naming
from vessel.config import ConfigError, validate
from vessel.geo import Home
from vessel.sea.irregular import IrregularWaves
from vessel.sea.irregular_sea import IrregularSea, parse_sea_spec
from vessel.sea.state import SeaState, Start
from vessel.sea.waves import RegularWaves, WaveField
from vessel.vessel_spec import load_vessel
from vessel.world import SEA_PRESETS, World, check_whole_scenario, load_world, sea_preset

SEA_HELP = (f"the sea's waves: a named sea ({' or '.join(SEA_PRESETS)}: the paper's 1.75 m, 35 m, 6 s waves "
            "from the East), regular H,LENGTH,PERIOD,DIR (m, m, s, deg: H >= 0, LENGTH and PERIOD > 0) or an "
            "irregular jonswap:HS,TP,DIR[,GAMMA[,SPREADING]] / pm:HS,TP,DIR (m, s, deg); default: the scenario's "
            "sea, else calm. --waves NAME is its old name")
SEA_STATE_HELP = ("irregular JONSWAP sea of NATO sea state N in [0, 8] (paper Table I: Hs mid-band, modal Tp), "
                  "in place of --sea's or the scenario's waves (default: none: theirs, else calm)")
CURRENT_HELP = ("uniform current: SPEED m/s in [0, 5] and DIR, the direction it flows to, deg in [-360, 360] "
                "(default: the scenario's current, else none)")
TIME_ORIGIN_MAX_S = 3600.0  # an irregular sea's hidden time origin is drawn from [0, this)


def parse_numbers(text: str, count: int, what: str) -> list[float]:
    """``count`` comma-separated finite numbers, or a one-line ConfigError naming ``what``."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count:
        raise ConfigError(f"{what}: expected {count} comma-separated numbers, got {text!r}")
    if not all(math.isfinite(v) for v in values):
        raise ConfigError(f"{what}: every number must be finite, got {text!r}")
    return values


def _checked(sea: SeaState, what: str) -> SeaState:
    """Ranges first (so a zero wavelength is a range error, not a division), then the wave field itself."""
    validate(sea, what)
    try:
        sea.waves()
    except ConfigError as exc:
        raise ConfigError(f"{what}.{exc}") from None
    return sea


def parse_sea(text: str, base: SeaState) -> SeaState:
    """A named sea (its waves, ``base``'s current and wind), ``H_M,LENGTH_M,PERIOD_S,DIR_DEG`` (regular) or
    ``jonswap:…``/``pm:…`` (irregular) -> ``base``, these waves."""
    if text in SEA_PRESETS:
        return base.with_waves_of(sea_preset(text, "--sea"))
    if ":" in text:
        return dataclasses.replace(base, spectrum=parse_sea_spec(text, "--sea"))
    height, length, period, direction = parse_numbers(text, 4, "--sea")
    sea = dataclasses.replace(base, height_m=height, length_m=length, period_s=period, travel_dir_deg=direction,
                              spectrum=None)
    return _checked(sea, "--sea")


def parse_sea_state(number: int, base: SeaState) -> SeaState:
    """``--sea-state N``: ``base`` with a JONSWAP sea of NATO sea state N (paper Table I), N in [0, 8]."""
    try:
        return dataclasses.replace(base, spectrum=IrregularSea(sea_state=number, tp_s=6.0 if number == 1 else None))
    except ConfigError as exc:
        raise ConfigError(f"--sea-state: {exc}") from None


def seeded_waves(waves: WaveField, seed: int) -> WaveField:
    """The sea with its phase origin drawn from ``seed``: a phase (regular) or a time origin (irregular)."""
    if isinstance(waves, RegularWaves):
        return dataclasses.replace(waves, phase_rad=float(np.random.default_rng(seed).uniform(0.0, 2 * math.pi)))
    if isinstance(waves, IrregularWaves):
        return waves.advanced(hidden_time_origin_s(seed))
    return waves


def hidden_time_origin_s(seed: int) -> float:
    """The time origin ``seed`` hides (s), added to the sea's own ``start_s``: the simulator's t meets the
    scenario sea's t + this. An in-process twin of a simulator run engaged at t flies the same stretch with
    ``IrregularSea.start_s`` = the scenario's ``start_s`` + this + t."""
    return float(np.random.default_rng(seed).uniform(0.0, TIME_ORIGIN_MAX_S))


def parse_current(text: str, base: SeaState) -> SeaState:
    """``SPEED_M_S,DIR_DEG`` -> ``base`` with this uniform current flowing towards DIR_DEG."""
    speed, direction = parse_numbers(text, 2, "--current")
    sea = dataclasses.replace(base, current_speed_mps=speed, current_dir_deg=direction)
    validate(sea, "--current")
    return sea


def sim_world(scenario: Path | None, sea: str | None, current: str | None, home: Home,
              sea_state: int | None = None, vessel: str | None = None) -> World:
    """The world the simulator runs in, from the flags as given (None: not given); one-line ConfigErrors, each
    naming its flag. ``vessel`` (``--vessel``: a named set or a vessel file) replaces the scenario's plant."""
    if scenario is not None:
        with naming("--scenario"):
            world = load_world(scenario)
            check_whole_scenario(scenario)  # the sections beyond the world, as mavbridge reads them
    else:
        world = World(sea=SEA_PRESETS["calm"], start=Start(heading_deg=home.heading_deg))
    if sea is not None:
        world = dataclasses.replace(world, sea=parse_sea(sea, world.sea))
    if sea_state is not None:
        world = dataclasses.replace(world, sea=parse_sea_state(sea_state, world.sea))
    if current is not None:
        world = dataclasses.replace(world, sea=parse_current(current, world.sea))
    if vessel is not None:
        with naming("--vessel"):  # (a vessel file's own error names the flag that gave it)
            world = dataclasses.replace(world, vessel=load_vessel(vessel, "--vessel"))
    return world
