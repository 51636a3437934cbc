"""Scenarios: YAML files describing a vessel, a sea state, a start, a waypoint and the controller.

A file is either one scenario (a mapping of the sections below) or a set: ``base`` (a scenario) plus
``runs`` (name -> overrides merged into the base, section by section). Degrees appear only in fields
whose names end in ``_deg``; everything inside is SI with radians. Unknown keys, non-finite numbers and
out-of-range values are errors naming the file, the field and the allowed range.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vessel import ConfigError, otter_parameters
from vessel.config import bounded, from_mapping, read_yaml, to_mapping
from vessel.params import PARAMETER_SETS
from vessel.sea_state import SeaState, Start

from .nmpc import NmpcConfig
from .nmpc.config import choice

PLANTS = ("tau", "propellers")
RUN_NAME = re.compile(r"^[A-Za-z0-9_.-]+$")


@dataclass(frozen=True)
class Waypoint:
    """The goal (NED, m) and the radius that counts as arrived."""

    north_m: float = bounded(85.0, -1e5, 1e5, "m")
    east_m: float = bounded(75.0, -1e5, 1e5, "m")
    acceptance_radius_m: float = bounded(2.0, 0.1, 1000.0, "m", "arrival when closer than this")


@dataclass(frozen=True)
class Reference:
    """Published results to compare with (e.g. the paper's Table III); null when not reached."""

    avg_roll_deg: float | None = bounded(None, 0.0, 90.0, "deg")
    max_roll_deg: float | None = bounded(None, 0.0, 90.0, "deg")
    time_to_waypoint_s: float | None = bounded(None, 0.0, 1e5, "s")


@dataclass(frozen=True)
class Scenario:
    """One closed-loop run."""

    name: str = "run"
    description: str = ""
    vessel: str = choice("published", PARAMETER_SETS, "Otter parameter set")
    sea: SeaState = dataclasses.field(default_factory=SeaState)
    start: Start = dataclasses.field(default_factory=Start)
    waypoint: Waypoint = dataclasses.field(default_factory=Waypoint)
    controller: NmpcConfig = dataclasses.field(default_factory=NmpcConfig)
    t_max_s: float = bounded(180.0, 0.1, 1e5, "s", "episode length limit")
    plant: str = choice("tau", PLANTS, "tau: rigid body driven by τ; propellers: shaft-speed plant")
    plant_dt_s: float = bounded(0.01, 1e-4, 0.1, "s", "plant RK4 step (divides the control period)")
    deadline_s: float | None = bounded(None, 1e-4, 10.0, "s", "solve deadline (null: none, deterministic)")
    reference: Reference = dataclasses.field(default_factory=Reference)

    def __post_init__(self) -> None:
        if self.vessel not in PARAMETER_SETS:
            raise ConfigError(f"vessel: {self.vessel!r} is not one of {', '.join(PARAMETER_SETS)}")
        if self.plant not in PLANTS:
            raise ConfigError(f"plant: {self.plant!r} is not one of {', '.join(PLANTS)}")
        if not RUN_NAME.match(self.name):
            raise ConfigError(f"name: {self.name!r} must be letters, digits, '_', '-' or '.'")
        ratio = self.controller.period_s / self.plant_dt_s
        if abs(ratio - round(ratio)) > 1e-6:
            raise ConfigError(f"plant_dt_s: {self.plant_dt_s:g} s must divide controller.period_s "
                              f"{self.controller.period_s:g} s")
        gap = math.hypot(self.waypoint.north_m - self.start.north_m, self.waypoint.east_m - self.start.east_m)
        if gap <= self.waypoint.acceptance_radius_m:
            raise ConfigError(f"waypoint: ({self.waypoint.north_m:g}, {self.waypoint.east_m:g}) m is within "
                              f"the acceptance radius {self.waypoint.acceptance_radius_m:g} m of the start; "
                              f"allowed: farther than acceptance_radius_m")

    def params(self):
        """The vessel's parameter set."""
        return otter_parameters(self.vessel)

    def to_mapping(self) -> dict:
        """The resolved scenario as plain data (for saving as YAML)."""
        return to_mapping(self)


def _merge(base: Any, override: Any) -> Any:
    """Mapping merge, section by section; everything else replaces."""
    if isinstance(base, dict) and isinstance(override, dict):
        out = dict(base)
        for key, value in override.items():
            out[key] = _merge(base.get(key), value) if key in base else copy.deepcopy(value)
        return out
    return copy.deepcopy(override)


def _parse(cls: type, data: Any, where: str) -> Any:
    """from_mapping with the message prefixed by ``where`` and no empty field prefix."""
    try:
        return from_mapping(cls, data, "")
    except ConfigError as exc:
        message = str(exc)
        message = message[2:] if message.startswith(": ") else message
        raise ConfigError(f"{where}: {message}") from None


def scenario_from_mapping(data: Any, where: str, name: str | None = None) -> Scenario:
    """A Scenario from plain data; ``name`` (the run name) wins over a name in the data."""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{where}: expected a mapping of scenario sections, got {type(data).__name__}")
    if name is not None:
        data = {**data, "name": name}
    return _parse(Scenario, data, where)


def load_scenarios(path: str | Path) -> list[Scenario]:
    """Every run a scenario file defines (one for a single scenario, the named runs for a set)."""
    path = Path(path)
    if path.is_dir():
        raise ConfigError(f"{path}: is a directory, expected a scenario YAML file")
    data = read_yaml(path)
    if isinstance(data, dict) and ("runs" in data or "base" in data):
        unknown = sorted(set(data) - {"base", "runs", "description"})
        if unknown:
            raise ConfigError(f"{path}: unknown key '{unknown[0]}' (allowed: base, description, runs)")
        base = data.get("base") or {}
        runs = data.get("runs")
        if not isinstance(base, dict):
            raise ConfigError(f"{path}: base: expected a mapping of scenario sections")
        if not isinstance(runs, dict) or not runs:
            raise ConfigError(f"{path}: runs: expected a mapping of run names to overrides (at least one)")
        scenarios = []
        for run_name, override in runs.items():
            if override is not None and not isinstance(override, dict):
                raise ConfigError(f"{path}: runs.{run_name}: expected a mapping of overrides")
            merged = _merge(base, override or {})
            scenarios.append(scenario_from_mapping(merged, f"{path}: runs.{run_name}", str(run_name)))
        return scenarios
    if data is None:
        data = {}
    default_name = data.get("name") if isinstance(data, dict) and "name" in data else path.stem
    return [scenario_from_mapping(data, str(path), default_name)]
