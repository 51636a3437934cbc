"""Sweep specifications: a base scenario plus axes, expanded into cases before anything runs.

A SPEC file (YAML)::

    base: balanced.yaml          # a scenario file (relative to the spec) or an inline scenario mapping
    axes:                        # dotted paths into the scenario; every path must be a scenario field
      controller.r: [0, 50, 100]              # a list of values
      controller.q: {start: 1, stop: 9, step: 4}   # an inclusive range (1, 5, 9)
      sea.travel_dir_deg: {values: [-90, -60]}
    sample: {mode: grid}         # grid (default) | random | lhs, with size: N and seed: S for the last two
    reference: {controller.r: 0} # what "Direct" means for a case (default: the same case with R = 0)
    max_cases: 100000            # a larger grid needs --yes

Each case's roll reduction is measured against its reference case — the same world, start and
mission with the ``reference`` overrides applied — which the sweep runs too (once per distinct one).

Every case is validated as a full ``Scenario`` up front, so an unknown axis, a bad value or an empty
axis is one line naming the field before any case runs. A case's identity is a hash of its resolved
scenario (``case_id``): equal cases share a result file, anything different (a seed included) does not.
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.lab.scenario import Scenario, load_scenarios, scenario_from_mapping
from vessel import ConfigError
from vessel.config import read_yaml
from vessel.vessel_spec import relative_to

SAMPLE_MODES = ("grid", "random", "lhs")
MAX_CASES_DEFAULT = 100_000
SPEC_KEYS = ("description", "base", "axes", "sample", "reference", "max_cases")
SAMPLE_KEYS = ("mode", "size", "seed")


@dataclass(frozen=True)
class Case:
    """One closed-loop run of a sweep: the axis values, the resolved scenario, its reference's id."""

    values: dict[str, Any]
    scenario: Scenario
    reference: Scenario | None = None

    @property
    def case_id(self) -> str:
        """16 hex digits of SHA-256 over the resolved scenario (its name excluded)."""
        return case_id(self.scenario)


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: where it came from, its axes in order, and its cases."""

    source: str
    axes: dict[str, list[Any]]
    cases: list[Case]

    def all_scenarios(self) -> dict[str, Scenario]:
        """Every scenario to run, cases and their references, unique by case id, in order."""
        out: dict[str, Scenario] = {}
        for case in self.cases:
            for sc in (case.scenario, case.reference):
                if sc is not None:
                    out.setdefault(case_id(sc), sc)
        return out


def case_id(scenario: Scenario) -> str:
    """Identity of a resolved scenario, independent of its display name."""
    data = scenario.to_mapping()
    data.pop("name", None)
    blob = json.dumps(data, sort_keys=True, default=float).encode()
    return hashlib.sha256(blob).hexdigest()[:16]


def _range_values(where: str, spec: dict) -> list[float]:
    """An inclusive start/stop/step range; one-line errors for a zero or wrong-signed step."""
    unknown = sorted(set(spec) - {"start", "stop", "step"})
    if unknown or not {"start", "stop", "step"} <= set(spec):
        raise ConfigError(f"{where}: a range needs exactly start, stop and step")
    try:
        start, stop, step = (float(spec[k]) for k in ("start", "stop", "step"))
    except (TypeError, ValueError):
        raise ConfigError(f"{where}: start, stop and step must be numbers") from None
    if not all(math.isfinite(v) for v in (start, stop, step)):
        raise ConfigError(f"{where}: start, stop and step must be finite")
    if step == 0 or (stop - start) * step < 0:
        raise ConfigError(f"{where}: step must be non-zero and point from start to stop, got {step:g}")
    count = math.floor((stop - start) / step + 1e-9) + 1
    if count > MAX_CASES_DEFAULT:
        raise ConfigError(f"{where}: {count} values; allowed at most {MAX_CASES_DEFAULT}")
    return [round(start + i * step, 12) for i in range(count)]


def _axis_values(where: str, raw: Any) -> list[Any]:
    """A list, {values: list} or {start, stop, step}; never empty."""
    if isinstance(raw, dict) and "values" in raw:
        if set(raw) != {"values"}:
            raise ConfigError(f"{where}: 'values' stands alone")
        raw = raw["values"]
    if isinstance(raw, dict):
        values = _range_values(where, raw)
    elif isinstance(raw, list):
        values = list(raw)
    else:
        raise ConfigError(f"{where}: expected a list of values or a range {{start, stop, step}}")
    if not values:
        raise ConfigError(f"{where}: empty axis; give at least one value")
    return values


def _set_path(mapping: dict, path: str, value: Any) -> None:
    """mapping[a][b] = value for path 'a.b', creating sections as needed."""
    keys = path.split(".")
    node = mapping
    for key in keys[:-1]:
        child = node.get(key)
        if child is None:
            child = node[key] = {}
        if not isinstance(child, dict):
            raise ConfigError(f"axes.{path}: '{key}' is not a section")
        node = child
    node[keys[-1]] = value


def _sample_settings(raw: Any) -> tuple[str, int | None, int]:
    """(mode, size, seed) from the ``sample`` section."""
    raw = raw or {}
    if not isinstance(raw, dict):
        raise ConfigError("sample: expected a mapping with mode, size, seed")
    unknown = sorted(set(raw) - set(SAMPLE_KEYS))
    if unknown:
        raise ConfigError(f"sample: unknown key '{unknown[0]}' (allowed: {', '.join(SAMPLE_KEYS)})")
    mode = raw.get("mode", "grid")
    if mode not in SAMPLE_MODES:
        raise ConfigError(f"sample.mode: '{mode}' is not one of {', '.join(SAMPLE_MODES)}")
    size = raw.get("size")
    if mode != "grid" and (not isinstance(size, int) or isinstance(size, bool) or size < 1):
        raise ConfigError(f"sample.size: a whole number >= 1 is needed for mode {mode}")
    seed = raw.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise ConfigError(f"sample.seed: expected a whole number, got {seed!r}")
    return mode, size, seed


def combinations(axes: dict[str, list[Any]], mode: str, size: int | None, seed: int) -> list[tuple]:
    """Axis-value tuples: the full grid, a seeded random sample, or a Latin hypercube over value indices."""
    lists = list(axes.values())
    if mode == "grid":
        return list(itertools.product(*lists))
    rng = np.random.default_rng(seed)
    if mode == "random":
        picks = [rng.integers(0, len(v), size) for v in lists]
    else:  # lhs: each axis's index range cut into `size` strata, one draw per stratum, shuffled
        picks = []
        for v in lists:
            strata = (np.arange(size) + rng.random(size)) / size
            picks.append(np.minimum((rng.permutation(strata) * len(v)).astype(int), len(v) - 1))
    return [tuple(v[int(p[i])] for v, p in zip(lists, picks, strict=True)) for i in range(size or 0)]


def _base_mapping(raw: Any, spec_path: Path) -> dict:
    """The base scenario as plain data: a single-scenario file next to the spec, or an inline mapping."""
    if isinstance(raw, str):
        path = (spec_path.parent / raw) if not Path(raw).is_absolute() else Path(raw)
        scenarios = load_scenarios(path)
        if len(scenarios) != 1:
            raise ConfigError(f"base: {raw} defines {len(scenarios)} runs; give a single scenario")
        return scenarios[0].to_mapping()
    if isinstance(raw, dict):
        return copy.deepcopy(raw)
    raise ConfigError("base: expected a scenario file name or a scenario mapping")


def expand(base: dict, axes: dict[str, list[Any]], combos: list[tuple], where: str,
           reference: dict[str, Any]) -> list[Case]:
    """Every combination as a validated case (named case-NNNNN) with its reference scenario."""
    cases = []
    for index, combo in enumerate(combos):
        data = copy.deepcopy(base)
        values = dict(zip(axes, combo, strict=True))
        for path, value in values.items():
            _set_path(data, path, value)
        here = f"{where}: case {index} ({_describe(values)})"
        scenario = scenario_from_mapping(data, here, f"case-{index:05d}")
        for path, value in reference.items():
            _set_path(data, path, value)
        ref = scenario_from_mapping(data, f"{here}: reference", f"ref-{index:05d}")
        cases.append(Case(values, scenario, ref))
    return cases


def _reference_overrides(raw: Any, where: str) -> dict[str, Any]:
    """The ``reference`` section: dotted paths to values; default R = 0 (the paper's Direct)."""
    if raw is None:
        return {"controller.r": 0.0}
    if not isinstance(raw, dict) or not raw:
        raise ConfigError(f"{where}: reference: expected a mapping of dotted paths to values")
    return {str(k): v for k, v in raw.items()}


def _describe(values: dict[str, Any]) -> str:
    return ", ".join(f"{k}={v}" for k, v in values.items())


def _check_axis_paths(axes: dict[str, list[Any]], base: dict, where: str) -> None:
    """Every axis must name a scenario field: probe each with its first value alone."""
    for path, values in axes.items():
        data = copy.deepcopy(base)
        _set_path(data, path, values[0])
        scenario_from_mapping(data, f"{where}: axes.{path}", "probe")


def load_spec(path: str | Path, allow_large: bool = False) -> SweepSpec:
    """Read, validate and expand a SPEC file; ConfigError (one line) on anything wrong."""
    path = Path(path)
    data = read_yaml(path)
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping with base and axes")
    unknown = sorted(set(data) - set(SPEC_KEYS))
    if unknown:
        raise ConfigError(f"{path}: unknown key '{unknown[0]}' (allowed: {', '.join(SPEC_KEYS)})")
    if "base" not in data:
        raise ConfigError(f"{path}: base: missing (a scenario file or mapping)")
    base = _base_mapping(data["base"], path)
    raw_axes = data.get("axes") or {}
    if not isinstance(raw_axes, dict) or not raw_axes:
        raise ConfigError(f"{path}: axes: expected at least one axis (dotted.path: values)")
    axes = {str(k): _axis_values(f"{path}: axes.{k}", v) for k, v in raw_axes.items()}
    with relative_to(path):  # vessel files named in the spec (its base, an axis) are found beside it
        return _expanded(path, data, base, axes, allow_large)


def _expanded(path: Path, data: dict, base: dict, axes: dict[str, list[Any]], allow_large: bool) -> SweepSpec:
    """The spec's cases (see ``load_spec``)."""
    _check_axis_paths(axes, base, str(path))
    mode, size, seed = _sample_settings(data.get("sample"))
    limit = data.get("max_cases", MAX_CASES_DEFAULT)
    count = math.prod(len(v) for v in axes.values()) if mode == "grid" else size
    if count > limit and not allow_large:
        raise ConfigError(f"{path}: {count} cases is over max_cases {limit}; pass --yes to run them")
    reference = _reference_overrides(data.get("reference"), str(path))
    combos = combinations(axes, mode, size, seed)
    return SweepSpec(str(path), axes, expand(base, axes, combos, str(path), reference))
