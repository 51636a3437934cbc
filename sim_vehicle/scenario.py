"""The simulator's world from its command line: ``--scenario``, ``--waves``, ``--sea``, ``--current``, ``--home``.

The world (vessel, sea, start) comes from ``vessel.world`` — ``load_world`` for a scenario file (the loader
``mavbridge`` uses too, with the same rule for unknown sections), a named preset for ``--waves`` — and the
flags given on top replace parts of it: ``--waves``/``--sea`` the waves, ``--current`` the current. Without
a scenario the boat starts at rest at home, pointing the home heading.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from vessel.config import ConfigError, validate
from vessel.geo import Home
from vessel.sea_state import SeaState, Start
from vessel.world import World, load_world, sea_preset, world_preset


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
    """``H_M,LENGTH_M,PERIOD_S,DIR_DEG`` -> ``base`` with these regular waves, travelling towards DIR_DEG."""
    height, length, period, direction = parse_numbers(text, 4, "--sea")
    sea = dataclasses.replace(base, height_m=height, length_m=length, period_s=period, travel_dir_deg=direction)
    return _checked(sea, "--sea")


def parse_current(text: str, base: SeaState) -> SeaState:
    """``SPEED_M_S,DIR_DEG`` -> ``base`` with this uniform current flowing towards DIR_DEG."""
    speed, direction = parse_numbers(text, 2, "--current")
    sea = dataclasses.replace(base, current_speed_mps=speed, current_dir_deg=direction)
    validate(sea, "--current")
    return sea


def sim_world(scenario: Path | None, waves: str | None, sea: str | None, current: str | None,
              home: Home) -> World:
    """The world the simulator runs in, from the flags as given (None: not given); one-line ConfigErrors."""
    if scenario is not None:
        world = load_world(scenario)
        if waves is not None:
            world = dataclasses.replace(world, sea=world.sea.with_waves_of(sea_preset(waves, "--waves")))
    else:
        world = world_preset(waves or "calm")
        world = dataclasses.replace(world, start=Start(heading_deg=home.heading_deg))
    if sea is not None:
        world = dataclasses.replace(world, sea=parse_sea(sea, world.sea))
    if current is not None:
        world = dataclasses.replace(world, sea=parse_current(current, world.sea))
    return world
