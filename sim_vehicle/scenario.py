"""`sim-vehicle --scenario FILE`: the simulator's part of a scenario YAML (vessel, sea, start).

The simulator reads and validates only the sections that describe the boat's world; the other
sections (waypoint, controller, ...) belong to the companion, which validates the whole file.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from vessel.config import ConfigError, from_mapping, read_yaml
from vessel.params import PARAMETER_SETS
from vessel.sea_state import SeaState, Start


@dataclass(frozen=True)
class SimScenario:
    """What the simulator takes from a scenario: parameter set, sea state and initial state."""

    vessel: str = "published"
    sea: SeaState = field(default_factory=SeaState)
    start: Start = field(default_factory=Start)

    def initial_state(self) -> np.ndarray:
        """The 14 plant states at the start: the scenario's pose and velocity, propellers stopped."""
        return np.concatenate([self.start.state(), np.zeros(2)])


def load_sim_scenario(path: str | Path) -> SimScenario:
    """Read ``vessel``, ``sea`` and ``start`` from a single-run scenario file; one-line errors."""
    data = read_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of scenario sections")
    if "runs" in data or "base" in data:
        raise ConfigError(f"{path}: a set of runs; give the simulator a single-run scenario")
    vessel = data.get("vessel", "published")
    if vessel not in PARAMETER_SETS:
        raise ConfigError(f"{path}: vessel: {vessel!r} is not one of {', '.join(PARAMETER_SETS)}")
    sea = from_mapping(SeaState, data.get("sea"), f"{path}: sea")
    start = from_mapping(Start, data.get("start"), f"{path}: start")
    return SimScenario(vessel, sea, start)
