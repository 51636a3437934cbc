"""Scenarios: a world (vessel, sea, start) plus the mission, the controller and the experiment settings.

A file is either one scenario (a mapping of the sections below) or a set: ``base`` (a scenario) plus
``runs`` (name -> overrides merged into the base, section by section). The world sections are read by
``vessel.world`` — the same loader and the same rule for unknown sections as ``sim-vehicle --scenario``.
Degrees appear only in fields whose names end in ``_deg``; everything inside is SI with radians. Unknown
keys, non-finite numbers and out-of-range values are errors naming the file, the field and the allowed
range; so is an empty file.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mavbridge.nmpc import NmpcConfig
from mavbridge.nmpc.config import choice
from vessel import ConfigError
from vessel.config import bounded, from_mapping, to_mapping
from vessel.params import OtterParameters
from vessel.sea.state import SeaState, Start
from vessel.vessel_spec import VesselSpec, relative_to
from vessel.world import (
    RUN_SET_SECTIONS,
    SCENARIO_SECTIONS,
    WORLD_SECTIONS,
    World,
    check_sections,
    is_run_set,
    read_scenario_file,
    world_from_mapping,
)

PLANTS = ("tau", "propellers")
WAVE_SOURCES = ("truth", "estimated", "predicted")
BANK_SPREADS = ("full", "residual", "none")  # mavbridge.waves.phase.bank_source.SPREAD_MODES
SENSOR_MODELS = ("default", "ideal")
DISTURBANCES = ("estimated", "truth", "none")
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
class Estimation:
    """What the in-process loop tells the NMPC about the sea, and how realistic the plant and sensors are.

    The defaults are the paper's setting (truth fed to the NMPC, no heave, phase 0, no sensors), so
    Table III's files stay as they are. ``waves: estimated`` feeds the wave estimator from simulated
    sensors (``vessel.sensors``, seeded) at 20 Hz; ``hidden_phase`` draws the sea's phase from ``seed``
    (the estimator never sees it); ``surface_heave`` makes the hull heave with the sea. Minimal stand-in
    for the sea seed of the ``simsea`` branch (the lead reconciles the two).
    """

    waves: str = choice("truth", WAVE_SOURCES, "truth: the true wave to the NMPC; estimated: the wave estimator; "
                        "predicted: the estimator and the phase predictor's bank of controller.wave_components "
                        "components while it is confident 1 s ahead")
    bank_spread: str = choice("full", BANK_SPREADS, "predicted: the statistics term while the bank is in use: the "
                              "sea's whole slope covariance (full), its share the predictor's skill leaves "
                              "(residual), or none")
    bank_oracle: bool = dataclasses.field(default=False, metadata={"doc": "predicted, simulation only: the bank is "
                                          "made of the true sea's components (a bound on what a predictor gives)"})
    bank_true_slope: bool = dataclasses.field(default=False, metadata={"doc": "predicted, simulation only: the "
                                              "predictor is fed the true slope at its track instead of the attitude"})
    spread_truth: bool = dataclasses.field(default=False, metadata={"doc": "estimated, irregular sea, simulation "
                                           "only: the statistics term gets the sea's true slope covariance in place "
                                           "of the estimator's, whenever the estimator gives one (a bound on what "
                                           "the estimated statistics can give)"})
    bank_select: str = choice("compressed", ("compressed", "strongest"), "predicted: the K components handed to the "
                              "NMPC: the fit compressed over its horizon, or the fit's K of most slope energy")
    bank_fade: bool = dataclasses.field(default=True, metadata={"doc": "predicted: fade the bank out of the NMPC's "
                                        "horizon where the predictor's measured skill halves"})
    bank_lead_s: float = bounded(1.0, 0.0, 4.0, "s", "predicted: the bank is used while the predictor is confident "
                                 "this far ahead")
    surface_heave: bool = False
    hidden_phase: bool = False
    seed: int = bounded(0, 0, 2**31 - 1, "", "seed of the hidden sea phase and of the sensor noise")
    sensors: str = choice("default", SENSOR_MODELS, "default: vessel.sensors defaults; ideal: exact readings")
    calibrate: bool = True
    roll_sign: float = bounded(1.0, -1.0, 1.0, "", "+1 paper plant, -1 a real hull (estimator's roll sign)")
    watch_s: float = bounded(0.0, 0.0, 3600.0, "s", "the estimator watches the boat drifting at the start, "
                             "thrusters idle, this long before the run (as the companion watches from connection "
                             "until the pilot engages); the run's clock starts after it")
    hold_s: float = bounded(20.0, 0.0, 600.0, "s", "keep flying on the last confident estimate this long after "
                            "the confidence drops (0: degrade at once); in-process and in the companion")
    disturbance: str = choice("estimated", DISTURBANCES, "realistic runs: the current and steady loads the NMPC "
                              "predicts with: estimated (from the boat's own motion, as the companion does), truth "
                              "(simulation only: the plant's current told to the NMPC, a bound) or none")

    def __post_init__(self) -> None:
        for name, allowed in (("waves", WAVE_SOURCES), ("sensors", SENSOR_MODELS), ("bank_spread", BANK_SPREADS),
                              ("disturbance", DISTURBANCES),
                              ("bank_select", ("compressed", "strongest"))):
            if getattr(self, name) not in allowed:
                raise ConfigError(f"estimation.{name}: {getattr(self, name)!r} is not one of {', '.join(allowed)}")
        if self.spread_truth and self.waves != "estimated":
            raise ConfigError(f"estimation.spread_truth: needs waves: estimated (it replaces the estimator's "
                              f"statistics), not {self.waves!r}")
        if self.roll_sign not in (-1.0, 1.0):
            raise ConfigError(f"estimation.roll_sign: {self.roll_sign!r} is not one of -1, 1")

    @property
    def realistic(self) -> bool:
        """True when anything differs from the paper's setting (then the sensed 20 Hz loop runs)."""
        return self.waves in ("estimated", "predicted") or self.surface_heave or self.hidden_phase


@dataclass(frozen=True)
class Scenario:
    """One closed-loop run: the world, then what the companion and the experiment runner need."""

    name: str = "run"
    description: str = ""
    world: World = dataclasses.field(default_factory=World)
    waypoint: Waypoint = dataclasses.field(default_factory=Waypoint)
    controller: NmpcConfig = dataclasses.field(default_factory=NmpcConfig)
    t_max_s: float = bounded(180.0, 0.1, 1e5, "s", "episode length limit")
    plant: str = choice("tau", PLANTS, "tau: rigid body driven by τ; propellers: shaft-speed plant")
    plant_dt_s: float = bounded(0.01, 1e-4, 0.1, "s", "plant RK4 step (divides the control period)")
    deadline_s: float | None = bounded(None, 1e-4, 10.0, "s", "solve deadline (null: none, deterministic)")
    reference: Reference = dataclasses.field(default_factory=Reference)
    estimation: Estimation = dataclasses.field(default_factory=Estimation)

    def __post_init__(self) -> None:
        if self.plant not in PLANTS:
            raise ConfigError(f"plant: {self.plant!r} is not one of {', '.join(PLANTS)}")
        self._refuse_propellers_on_the_tau_plant()
        if not RUN_NAME.match(self.name):
            raise ConfigError(f"name: {self.name!r} must be letters, digits, '_', '-' or '.'")
        ratio = self.controller.period_s / self.plant_dt_s
        if abs(ratio - round(ratio)) > 1e-6:
            raise ConfigError(f"plant_dt_s: {self.plant_dt_s:g} s must divide controller.period_s "
                              f"{self.controller.period_s:g} s")
        start = self.world.start
        gap = math.hypot(self.waypoint.north_m - start.north_m, self.waypoint.east_m - start.east_m)
        if gap <= self.waypoint.acceptance_radius_m:
            raise ConfigError(f"waypoint: ({self.waypoint.north_m:g}, {self.waypoint.east_m:g}) m is within "
                              f"the acceptance radius {self.waypoint.acceptance_radius_m:g} m of the start; "
                              f"allowed: farther than acceptance_radius_m")

    def _refuse_propellers_on_the_tau_plant(self) -> None:
        """A vessel whose propellers differ from the law (scale, saturation) flown on the τ plant, which has no
        propellers, would silently measure nothing: refuse it."""
        plant = self.world.params()
        if self.plant == "tau" and (plant.propeller_scale != (1.0, 1.0) or plant.shaft_speed_limit_rpm is not None):
            raise ConfigError("plant: tau has no propellers, so the vessel's propeller_scale or "
                              "shaft_speed_limit_rpm would change nothing; use plant: propellers")

    @property
    def vessel(self) -> VesselSpec:
        """The plant's vessel (the boat in the world; simulation truth)."""
        return self.world.vessel

    @property
    def sea(self) -> SeaState:
        """The world's sea (simulation truth)."""
        return self.world.sea

    @property
    def start(self) -> Start:
        """The world's start pose and velocity."""
        return self.world.start

    def plant_params(self) -> OtterParameters:
        """The plant's parameter set: the boat itself (simulation truth, never the controller's)."""
        return self.world.params()

    def model_params(self) -> OtterParameters:
        """The controller's model of the boat (``controller.model``; default the published Otter)."""
        return self.controller.model.params()

    def to_mapping(self) -> dict:
        """The resolved scenario as plain data in the file's own layout (for saving as YAML)."""
        data = {f.name: to_mapping(getattr(self, f.name)) for f in dataclasses.fields(self) if f.name != "world"}
        data.update(self.world.to_mapping())
        return {name: data[name] for name in SCENARIO_SECTIONS}


def _check_sections_match() -> None:
    """The scenario sections vessel.world knows are exactly this Scenario's fields (world split in three)."""
    fields = [f.name for f in dataclasses.fields(Scenario) if f.name != "world"]
    if sorted([*fields, *WORLD_SECTIONS]) != sorted(SCENARIO_SECTIONS):
        raise RuntimeError(f"vessel.world.SCENARIO_SECTIONS {SCENARIO_SECTIONS} does not match "
                           f"mavbridge.lab.scenario.Scenario's fields {fields} + {WORLD_SECTIONS}")


_check_sections_match()


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
    world = world_from_mapping(data, where)  # also rejects unknown sections, as the simulator does
    settings = {key: value for key, value in data.items() if key not in WORLD_SECTIONS}
    # The world goes in resolved (already validated, so it cannot fail here): the cross-field checks of
    # Scenario.__post_init__ then see the real start, never a default one.
    return _parse(Scenario, {**settings, "world": world.to_mapping()}, where)


def check_scenario_file(path: str | Path) -> None:
    """Read the scenario file as `mavbridge` does, every section, and keep nothing: a bad field is the one-line
    ConfigError it would be here. Registered for any reader of scenario files (an entry point run by
    vessel.world.check_whole_scenario), so that ``sim-vehicle --scenario`` refuses what `mavbridge` refuses."""
    load_scenarios(path)


def load_scenarios(path: str | Path) -> list[Scenario]:
    """Every run a scenario file defines (one for a single scenario, the named runs for a set)."""
    path = Path(path)
    data = read_scenario_file(path)
    with relative_to(path):  # vessel files named in it are found beside it
        return _scenarios(path, data)


def _scenarios(path: Path, data: dict[str, Any]) -> list[Scenario]:
    """The runs of a scenario file's mapping (see ``load_scenarios``)."""
    if not is_run_set(data):
        return [scenario_from_mapping(data, str(path), data.get("name", path.stem))]
    check_sections(data, str(path), RUN_SET_SECTIONS)
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
