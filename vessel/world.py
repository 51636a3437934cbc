"""One world: the physical world of a run — the plant's vessel, sea (waves, current, wind), start pose.

The simulator (``sim-vehicle --sea/--scenario``), the in-process experiment plants and the plots all
read the world from here, and the NMPC's simulation truth is the same ``World.sea``. Named presets are
the only place a sea is spelled out in code: ``paper`` (the paper's regular sea, H 1.75 m, λ 35 m,
T 6 s, travelling West, −90°) and ``calm``.

A scenario file is a world plus the companion's sections (mission, controller, experiment settings).
This module knows every top-level section name as data (:data:`SCENARIO_SECTIONS`), so the simulator,
which reads only the world, rejects a misspelled section (``sae:``, ``waypont:``) with the same rule and
the same message as ``mavbridge``, whose ``Scenario`` checks on import that its fields are these.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from vessel.config import ConfigError, from_mapping, read_yaml, to_mapping
from vessel.params import PARAMETER_SETS, OtterParameters
from vessel.sea.irregular_sea import IrregularSea
from vessel.sea.state import SeaState, Start
from vessel.vessel_spec import VesselSpec, relative_to

WORLD_SECTIONS: tuple[str, ...] = ("vessel", "sea", "start")
"""The top-level scenario sections that describe the world (read by the simulator and mavbridge)."""

SCENARIO_SECTIONS: tuple[str, ...] = ("name", "description", *WORLD_SECTIONS, "waypoint", "controller",
                                      "t_max_s", "plant", "plant_dt_s", "deadline_s", "reference", "estimation")
"""Every top-level section of a single-run scenario file; mavbridge's ``Scenario`` has exactly these."""

RUN_SET_SECTIONS: tuple[str, ...] = ("base", "description", "runs")
"""The top-level sections of a set of runs (``base`` scenario + ``runs`` overrides)."""

SEA_PRESETS: Mapping[str, SeaState] = MappingProxyType({
    "paper": SeaState(),  # SeaState's defaults are the paper's sea: 1.75 m, 35 m, 6 s, travelling to -90°
    "calm": SeaState(height_m=0.0),
})
"""Named seas for ``sim-vehicle --sea NAME``, ``vessel maneuver --sea NAME`` and ``sea: NAME`` in a scenario file."""


@dataclass(frozen=True)
class World:
    """The physical world of one run; the default is the paper's (published Otter, paper's sea, East)."""

    vessel: VesselSpec = dataclasses.field(default_factory=VesselSpec)
    sea: SeaState = dataclasses.field(default_factory=lambda: SEA_PRESETS["paper"])
    start: Start = dataclasses.field(default_factory=Start)

    def __post_init__(self) -> None:
        if not isinstance(self.vessel, VesselSpec):  # World("corrected") and World({...}) read as in a file
            object.__setattr__(self, "vessel", VesselSpec.from_config(self.vessel, "vessel"))

    def params(self) -> OtterParameters:
        """The plant's parameter set (the boat itself; the controller's model is its own setting)."""
        return self.vessel.params()

    def rigid_state(self) -> np.ndarray:
        """The 12 rigid-body states at the start (η NED and rad, ν body)."""
        return self.start.state()

    def plant_state(self) -> np.ndarray:
        """The 14 plant states at the start: the rigid-body states, propellers stopped."""
        return np.concatenate([self.start.state(), np.zeros(2)])

    def to_mapping(self) -> dict[str, Any]:
        """The world as the three scenario sections, plain data (for a resolved scenario file)."""
        data = {name: to_mapping(getattr(self, name)) for name in WORLD_SECTIONS}
        data["sea"] = sea_to_mapping(self.sea)
        return data


def sea_to_mapping(sea: SeaState) -> dict[str, Any]:
    """A sea as plain data that both ``sea:`` and ``from_mapping(SeaState, …)`` read back.

    A regular sea is written exactly as before (no ``spectrum`` key); an irregular one as
    ``spectrum: {spectrum: jonswap, hs_m, …, seed, sea_state}`` — IrregularSea's own field names, which
    the ``sea:`` section accepts beside its ``kind`` / top-level ``seed`` / ``sea_state`` spelling.
    """
    data = to_mapping(sea)
    if data["spectrum"] is None:
        del data["spectrum"]
    return data


def sea_preset(name: str, where: str = "sea") -> SeaState:
    """A named sea, or a one-line ConfigError naming ``where`` and the names allowed."""
    try:
        return SEA_PRESETS[name]
    except KeyError:
        raise ConfigError(f"{where}: {name!r} is not one of {', '.join(SEA_PRESETS)}") from None


def world_preset(name: str) -> World:
    """The default world with a named sea (``paper`` or ``calm``)."""
    return World(sea=sea_preset(name))


def check_sections(data: Mapping[str, Any], where: str, allowed: tuple[str, ...] = SCENARIO_SECTIONS) -> None:
    """Reject an unknown top-level key (a misspelled section) with the loaders' one-line message."""
    unknown = sorted(set(map(str, data)) - set(allowed))
    if unknown:
        prefix = f"{where}: " if where else ""
        raise ConfigError(f"{prefix}unknown key '{unknown[0]}' (allowed: {', '.join(sorted(allowed))})")


SPECTRUM_KEYS: tuple[str, ...] = ("kind", *(f.name for f in dataclasses.fields(IrregularSea)))
"""The keys of a ``sea.spectrum`` mapping: ``kind`` (jonswap or pm; IrregularSea's ``spectrum``, also accepted
under that name), and IrregularSea's other fields; ``seed`` and ``sea_state`` may also sit beside it."""


def _irregular_fields(value: Mapping[str, Any], where: str) -> dict[str, Any]:
    """``sea:`` with ``spectrum: {kind, hs_m, …}``, ``seed:`` and/or ``sea_state:`` as SeaState fields.

    ``spectrum.kind`` is IrregularSea's ``spectrum``; ``spreading_s: null`` means long-crested; a
    ``sea_state`` alone is a JONSWAP sea from the paper's Table I. Unknown keys are one-line errors.
    """
    fields = dict(value)
    spectrum = fields.pop("spectrum", None)
    seed, state = fields.pop("seed", None), fields.pop("sea_state", None)
    if spectrum is None and seed is None and state is None:
        return fields
    if spectrum is None:
        spectrum = {}
    if not isinstance(spectrum, Mapping):
        raise ConfigError(f"{where}.spectrum: expected a mapping with keys {', '.join(SPECTRUM_KEYS)}, "
                          f"got {spectrum!r}")
    check_sections(spectrum, f"{where}.spectrum", SPECTRUM_KEYS)
    if "kind" in spectrum and "spectrum" in spectrum:
        raise ConfigError(f"{where}.spectrum: give kind or spectrum, not both")
    irregular = {("spectrum" if k == "kind" else k): v for k, v in spectrum.items()
                 if not (k == "spreading_s" and v is None)}
    for name, value in (("seed", seed), ("sea_state", state)):
        if value is not None and name in irregular:
            raise ConfigError(f"{where}: give {name} beside spectrum or inside it, not both")
    if seed is not None:
        irregular["seed"] = seed
    if state is not None:
        irregular["sea_state"] = state
    fields["spectrum"] = irregular
    return fields


def _sea(value: Any, where: str) -> SeaState:
    """``sea:`` as a preset name or a mapping of SeaState fields; the wave field is built to check it."""
    if isinstance(value, str):
        sea = sea_preset(value, f"{where}sea")
    else:
        fields = _irregular_fields(value, f"{where}sea") if isinstance(value, Mapping) else value
        sea = from_mapping(SeaState, fields, f"{where}sea")
    try:
        sea.waves()
    except ConfigError as exc:  # e.g. a breaking wave: a cross-field check of the wave field
        raise ConfigError(f"{where}sea.{exc}") from None
    return sea


def world_from_mapping(data: Mapping[str, Any], where: str) -> World:
    """The world of a single-run scenario mapping; unknown sections and bad values are one-line errors.

    ``where`` prefixes every message (a file name, or ``file: runs.NAME``); fields are named as
    ``sea.height_m``. The other (companion) sections are allowed but not read.
    """
    check_sections(data, where)
    prefix = f"{where}: " if where else ""
    vessel = VesselSpec.from_config(data.get("vessel", PARAMETER_SETS[0]), f"{prefix}vessel")
    sea = _sea(data["sea"], prefix) if "sea" in data else SEA_PRESETS["paper"]
    start = from_mapping(Start, data.get("start"), f"{prefix}start")
    return World(vessel, sea, start)


def read_scenario_file(path: str | Path) -> dict[str, Any]:
    """A scenario file's top-level mapping (one run, or a set); empty or non-mapping files are errors."""
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{path}: is a directory, expected a scenario YAML file")
    data = read_yaml(path)
    if data is None or data == {}:
        raise ConfigError(f"{path}: empty scenario file (expected sections such as "
                          f"{', '.join(WORLD_SECTIONS)}, waypoint, controller)")
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of scenario sections, got {type(data).__name__}")
    return data


def is_run_set(data: Mapping[str, Any]) -> bool:
    """True for a set of runs (``base`` + ``runs``) rather than a single scenario."""
    return "runs" in data or "base" in data


def load_world(path: str | Path) -> World:
    """The world of a single-run scenario file (``sim-vehicle --scenario``); one-line errors."""
    data = read_scenario_file(path)
    if is_run_set(data):
        raise ConfigError(f"{path}: a set of runs; give the simulator a single-run scenario")
    with relative_to(path):
        return world_from_mapping(data, str(path))


SCENARIO_CHECKS = "otter_rollaware.scenario_checks"
"""Entry-point group of checkers of a whole scenario file: a package that reads more of the file than the world
(``mavbridge``: the waypoint, controller, experiment sections) registers a callable taking the file's path and
raising a one-line ConfigError (``pyproject.toml``). A reader of the world alone (``sim-vehicle --scenario``)
runs them, and so refuses what ``mavbridge`` refuses without importing it (design.md: sim_vehicle never imports
mavbridge); without ``mavbridge`` installed the world is still checked and the rest of the file is nobody's."""


def check_whole_scenario(path: str | Path) -> list[str]:
    """Run every registered checker (:data:`SCENARIO_CHECKS`) on the scenario file ``path``; each raises a
    one-line ConfigError on a bad field. The names of the checkers that ran, sorted (none when none is
    registered)."""
    from importlib.metadata import entry_points

    ran = []
    for point in sorted(entry_points(group=SCENARIO_CHECKS), key=lambda p: p.name):
        point.load()(path)
        ran.append(point.name)
    return ran
