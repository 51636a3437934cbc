"""What `mavbridge identify` writes: the vessel mapping, the model check and identify.json.

``vessel.yaml`` is a vessel mapping — ``base`` (a named parameter set) plus only the ``OtterParameters`` fields
that changed — which loads as the scenario's ``vessel:``, ``controller.model:`` and the companion's ``model:``
(``otter_parameters(base).replace(**fields)``). With ``--base FILE`` the file's own fields come along, the
identified ones over them. The model check measures, on ``vessel.Plant``, the free-decay period and damping of
the base and of the identified model beside what was identified.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from mavbridge.identify.analyse import Identification
from mavbridge.identify.asymmetry import propeller_scale
from mavbridge.identify.commands import surge_full_rad_s
from mavbridge.identify.model import calibrate_max_speed, fit_axis, plant_decay, surge_fields
from mavbridge.identify.payload import fit_payload
from mavbridge.identify.surge import MIN_FRACTION
from mavbridge.identify.yawfield import yaw_time_constant
from vessel import ConfigError, OtterParameters, load_parameters, otter_parameters
from vessel.params import PARAMETER_SETS

T_YAW_RANGE_S = (0.01, 100.0)  # OtterParameters.yaw_time_constant's range
WORKING_FRACTION = 0.2  # a thrust fraction: motor outputs of 0.45 and above
MIN_SURGE_R2 = 0.5  # below this the speed is not linear in the thrust fraction: max_speed would mislead the model


def resolve_base(base: str) -> tuple[OtterParameters, str, dict[str, Any]]:
    """(parameters, the named set under it, the fields a FILE sets) of ``--base``: published, corrected or a vessel
    YAML file (ConfigError, one line, for anything else)."""
    if base in PARAMETER_SETS:
        return otter_parameters(base), base, {}
    path = Path(base)
    if not path.is_file():
        raise ConfigError(f"--base: {base!r} is neither {', '.join(PARAMETER_SETS)} nor a vessel YAML file")
    params = load_parameters(path)
    data = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    named = str(data.pop("base", "published"))
    return params, named, dict(data)


def _value(result: Identification, name: str, min_fit: float = -math.inf) -> float | None:
    got = result.estimates.get(name)
    return got.value if got is not None and math.isfinite(got.value) and got.fit >= min_fit else None


def yaw_identified(result: Identification) -> bool:
    """Nomoto's T was found and its interval lies above zero: the yaw is identified well enough to fit the model's
    ``yaw_time_constant`` to the log (a T whose interval reaches zero says the logs do not hold the yaw's lag; one
    without an interval, nan from fewer than two blocks of the logs, shows nothing either way: refused too)."""
    T = result.estimates.get("yaw_nomoto_time_constant_s")
    return T is not None and math.isfinite(T.value) and T.low > 0


def unfit_lines(result: Identification) -> list[str]:
    """One line per surge figure whose fit is too poor to go into vessel.yaml, and for a yaw not identified well
    enough to fit ``yaw_time_constant``."""
    lines = [f"{name} {e.value:.3g} m/s: fit R² {e.fit:.2f} < {MIN_SURGE_R2:g} (the speed is not linear in the thrust "
             "fraction): not put into vessel.yaml" for name, e in result.estimates.items()
             if name.startswith("surge_") and not e.fit >= MIN_SURGE_R2]
    if result.surge.get("payload_not_used"):
        lines.append(result.surge["payload_not_used"])
    T = result.estimates.get("yaw_nomoto_time_constant_s")
    if T is not None and not yaw_identified(result):
        why = (f"its interval [{T.low:.3g}, {T.high:.3g}] reaches zero" if math.isfinite(T.low)
               else "it has no interval (fewer than two independent blocks of the logs fit)")
        lines.append(f"yaw_nomoto_time_constant_s {T.value:.3g} s: {why}: yaw_time_constant not put into vessel.yaml")
    return lines


def speed_levels(result: Identification) -> list[tuple[float, float, int]]:
    """(thrust fraction, mean speed m/s, windows) of the log's steady forward windows, grouped by command: those at
    a thrust fraction of WORKING_FRACTION or more (half command and above, where a boat works: the model's speed
    curve need not have the hull's shape at a crawl), else the fastest one."""
    groups: dict[float, list[float]] = {}
    for point in result.surge.get("points", []):
        if point.fraction > MIN_FRACTION:
            groups.setdefault(round(point.fraction, 2), []).append(point.speed_m_s)
    levels = [(f, float(np.mean(v)), len(v)) for f, v in sorted(groups.items())]
    working = [level for level in levels if level[0] >= WORKING_FRACTION]
    return working or levels[-1:]


def _propeller_scale(base: OtterParameters, result: Identification) -> tuple[float, float] | None:
    """The propellers' thrust scale the logs show, or the even pair where they show it even and the base is not."""
    ratio = result.estimates.get("propeller_thrust_ratio")
    scale = propeller_scale(ratio)
    if scale is None and ratio is not None and ratio.low <= 1.0 <= ratio.high and base.propeller_scale != (1.0, 1.0):
        scale = (1.0, 1.0)  # the logs show the pair even: a base's asymmetry (an earlier vessel.yaml) is not kept
    return scale


def surge_and_payload(base: OtterParameters, result: Identification, fields: dict[str, Any]) -> dict[str, Any]:
    """``fields`` with the surge fields: ``payload_mass`` where the payload explains the log's steady speeds
    (``payload.fit_payload``: its estimate goes into ``result.estimates``, and why it is not used into
    ``result.surge``), else ``max_speed`` calibrated on the model; the reverse and thrust fields either way."""
    full_forward, full_reverse = surge_full_rad_s(result)
    forward = _value(result, "surge_speed_full_forward_m_s", MIN_SURGE_R2)
    reverse = _value(result, "surge_speed_full_reverse_m_s", MIN_SURGE_R2)
    out = {**fields, **surge_fields(base, forward, reverse, full_forward, full_reverse)}
    if forward is None or "max_speed" not in out:
        return out
    kept = {k: v for k, v in out.items() if k != "max_speed"}
    choice = fit_payload(base.replace(**kept), result)
    if choice is not None:
        result.estimates["payload_mass_kg"] = choice.estimate
        result.surge["payload_not_used"] = choice.why_not
    elif base.payload_load_term:
        result.surge["payload_not_used"] = ("payload_mass: needs steady forward windows at two commands or more "
                                            "(the payload bends the speed curve; one command cannot show it): "
                                            "max_speed is fitted instead")
    if choice is None or not choice.chosen:
        return calibrate_max_speed(base, out, speed_levels(result))
    kept.update(surge_fields(base, None, reverse, None, full_reverse))  # the reverse pull on the base's max_speed
    kept["payload_mass"] = round(choice.estimate.value, 1)
    return kept


def vessel_fields(base: OtterParameters, result: Identification) -> dict[str, Any]:
    """The OtterParameters fields the identified figures change (only those): the propellers first (the model flies
    the log's commands with them), then surge (a payload changes the masses), then roll and pitch on those masses
    (``fit_axis`` solves the gyration for the identified period), then yaw flown through the log."""
    fields: dict[str, Any] = {}
    scale = _propeller_scale(base, result)
    if scale is not None:
        fields["propeller_scale"] = scale
    fields = surge_and_payload(base, result, fields)
    for axis in ("roll", "pitch"):
        period, zeta = _value(result, f"{axis}_period_s"), _value(result, f"{axis}_damping_ratio")
        if period is not None or zeta is not None:
            fields.update(fit_axis(base.replace(**fields), axis, period, zeta))
    T = _value(result, "yaw_nomoto_time_constant_s")
    if T is not None and yaw_identified(result) and result.yaw_replay is not None:
        field = yaw_time_constant(base.replace(**fields), result.yaw_replay)
        if field is not None and T_YAW_RANGE_S[0] <= field <= T_YAW_RANGE_S[1]:
            fields["yaw_time_constant"] = round(field, 3)
    return {k: v if isinstance(v, tuple) else float(v) for k, v in fields.items()}


def model_check(base: OtterParameters, identified: OtterParameters, result: Identification) -> dict[str, Any]:
    """Free-decay period and damping measured on the plant, base model and identified model, beside the log's."""
    check: dict[str, Any] = {}
    for axis in ("roll", "pitch"):
        if f"{axis}_period_s" not in result.estimates:
            continue
        row: dict[str, Any] = {"identified_from_logs": {"period_s": _value(result, f"{axis}_period_s"),
                                                        "damping_ratio": _value(result, f"{axis}_damping_ratio")}}
        for name, params in (("base_model", base), ("identified_model", identified)):
            fit = plant_decay(params, axis)
            row[name] = None if fit is None else {"period_s": round(fit.period_s, 4), "damping_ratio":
                                                  round(fit.zeta, 4)}
        check[axis] = row
    return check


def vessel_mapping(named: str, file_fields: dict[str, Any], fields: dict[str, Any]) -> dict[str, Any]:
    """{base: named set, the base file's fields, the identified fields}: what vessel.yaml holds (a pair such as
    propeller_scale as a list, as YAML writes it)."""
    return {"base": named, **file_fields, **{k: list(v) if isinstance(v, tuple) else v for k, v in fields.items()}}


def write_yaml(path: Path, mapping: dict[str, Any], command: str) -> None:
    """vessel.yaml with a comment saying where it came from."""
    header = (f"# Identified by `{command}`.\n# A vessel mapping: the base parameter set plus the OtterParameters "
              "fields that changed.\n")
    path.write_text(header + yaml.safe_dump(mapping, sort_keys=False), encoding="utf-8")
