"""Surge and yaw against the command the logs hold, and ``identify``: every estimate of a set of logs.

The command, in this order of preference: shaft speeds (``n1``/``n2``), τ_X/τ_N, the motors' outputs. Surge
uses its thrust fraction (``surge``); full scale is the model's n_max — or the log's fastest shaft when faster —,
the model's bollard pull as a force, or a motor output of 1. Yaw uses τ_N (N·m), else n1 − n2 (rpm), else half
the difference of the motors' thrust fractions, while under way ahead (UNDER_WAY_M_S over ground, where the log
says its speed; the propulsion command forward, where it holds one).
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.identify.analyse import Frames, Identification, frames, identify_axis, select
from mavbridge.identify.asymmetry import straight_windows, thrust_ratio
from mavbridge.identify.logdata import RPM, LogData
from mavbridge.identify.series import Stretch, moving_average
from mavbridge.identify.surge import fit_surge, steady_points
from mavbridge.identify.yaw import nomoto_estimates
from mavbridge.identify.yawfield import YawReplay, steering_of
from vessel import OtterParameters

UNDER_WAY_M_S = 0.3
SPEED_SMOOTH_S = 5.0  # speed over ground jumps from fix to fix: under way is judged on its 5 s average
KINDS = {"shafts": ("n1", "n2"), "tau": ("tau_X", "tau_N"), "motors": ("left", "right")}
LABELS = {"shafts": "shaft speeds n1, n2", "tau": "commanded force tau_X", "motors": "motor outputs (servo PWM)"}


def command_kind(sets: list[Frames]) -> str | None:
    """The propulsion command the logs hold, by preference."""
    for kind, (a, _) in KINDS.items():
        if any(f.has(a) for f in sets):
            return kind
    return None


def full_scale(kind: str, sets: list[Frames], base: OtterParameters) -> tuple[float, float]:
    """(forward, reverse) full command: rad/s for shafts (the model's, or the log's fastest), N for τ_X, 1 for
    motor outputs."""
    if kind == "tau":
        return base.bollard_pull_forward_kgf * base.g, base.bollard_pull_reverse_kgf * base.g
    if kind == "motors":
        return 1.0, 1.0
    m = base.matrices()
    values = [np.concatenate([f.column(s, n) for s in f.items]) for f in sets for n in KINDS["shafts"] if f.items]
    both = np.concatenate(values) if values else np.zeros(1)
    both = both[np.isfinite(both)]
    return max(m.n_max, float(np.max(both, initial=0.0))), max(abs(m.n_min), float(-np.min(both, initial=0.0)))


def _fraction(kind: str, a: np.ndarray, b: np.ndarray, full: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """(the command as the page shows it, thrust fraction) of two command columns."""
    if kind == "tau":
        return a, np.where(a >= 0, a / full[0], a / full[1])

    def part(n: np.ndarray) -> np.ndarray:
        return np.where(n >= 0, n * n / full[0] ** 2, -n * n / full[1] ** 2)

    shown = 0.5 * (a + b) / (RPM if kind == "shafts" else 1.0)
    return shown, 0.5 * (part(a) + part(b))


def identify_surge(sets: list[Frames], base: OtterParameters, result: Identification) -> None:
    """Steady speed at full forward and reverse command (``surge_speed_full_forward_m_s`` and ``_reverse_``)."""
    kind = command_kind(sets)
    if kind is None:
        result.missing.append("surge: the logs hold no propulsion command (shaft speeds, tau_X or motor outputs): "
                              "surge not identifiable")
        return
    if not any(f.has("speed") for f in sets):
        result.missing.append("surge: the logs hold no speed over ground: surge not identifiable")
        return
    full = full_scale(kind, sets, base)
    items = []
    for s in select(sets, (*KINDS[kind], "speed", "r", "pitch")):
        shown, fraction = _fraction(kind, s.y[:, 0], s.y[:, 1], full)
        items.append(Stretch(s.t, np.column_stack([shown, fraction, s.y[:, 2], s.y[:, 3], s.y[:, 4]])))
    points = steady_points(items)
    unit = {"shafts": "rpm", "tau": "N", "motors": "output"}[kind]
    result.surge = {"kind": kind, "label": LABELS[kind], "unit": unit, "points": points,
                    "full_forward": full[0] / (RPM if kind == "shafts" else 1.0),
                    "full_reverse": full[1] / (RPM if kind == "shafts" else 1.0), "full_si": full}
    for reverse, name in ((False, "surge_speed_full_forward_m_s"), (True, "surge_speed_full_reverse_m_s")):
        got = fit_surge(points, reverse, LABELS[kind])
        if isinstance(got, str):
            result.missing.append(got)
        else:
            result.estimates[name] = got


def _steerings(kind: str, sets: list[Frames]) -> list[tuple[tuple[str, ...], str, str]]:
    """The steering commands to try, by preference: (columns, name, unit)."""
    found = []
    if kind in ("tau", "shafts") and any(f.has("tau_N") for f in sets):
        found.append((("tau_N",), "tau_N", "N·m"))
    if kind == "shafts":
        found.append((("n1", "n2"), "n1 - n2", "rpm"))
    if kind == "motors":
        found.append((("left", "right"), "the motors' thrust difference", "thrust fraction"))
    return found


def _under_way(f: Frames, s: Stretch) -> np.ndarray:
    """Under way (the 5 s average speed over ground above UNDER_WAY_M_S) and, where the log holds the propulsion
    command, going ahead: astern a hull answers its helm otherwise (the reverse thrust is weaker for the same
    fraction, and the flow at the propellers is reversed), and one Nomoto model of both fits neither (a simulated
    identification run: K 27 deg/s with its reverse legs, 43 without, 43 from the plant's own zig-zag)."""
    speed = f.column(s, "speed")
    ahead = np.ones(s.t.size, bool)
    for a, b in (("n1", "n2"), ("left", "right"), ("tau_X", "tau_X")):
        command = f.column(s, a) + f.column(s, b)
        if np.isfinite(command).any():
            ahead = np.nan_to_num(command) > 0
            break
    if not np.isfinite(speed).any():
        return ahead
    return ahead & (moving_average(np.nan_to_num(speed), round(SPEED_SMOOTH_S / s.dt)) >= UNDER_WAY_M_S)


def identify_yaw(sets: list[Frames], result: Identification) -> None:
    """Nomoto K, T and the yaw rate with no steering (see the module docstring): from the first steering command
    that explains the yaw rate."""
    kind = command_kind(sets)
    if kind is None:
        result.missing.append("yaw: the logs hold no steering command (tau_N, n1 - n2 or motor outputs): yaw not "
                              "identifiable")
        return
    why = []
    for names, command, unit in _steerings(kind, sets):
        items = []
        for s in select(sets, (*names, "r"), _under_way):
            delta = s.y[:, 0] if len(names) == 1 else steering_of(kind, s.y[:, 0], s.y[:, 1])
            items.append(Stretch(s.t, np.column_stack([delta, s.y[:, -1]])))
        got = nomoto_estimates(items, command, unit)
        if isinstance(got, str):
            why.append(got)
            continue
        result.estimates.update(got[0])
        result.yaw = (got[1], items, f"{command} ({unit})")
        speed = any(f.has("speed") for f in sets)
        columns = (*KINDS[kind], *names, "r", *(("speed",) if speed else ()))
        result.yaw_replay = YawReplay(kind, names, select(sets, columns, _under_way), speed)
        return
    result.missing.append("; ".join(why))


def identify(logs: list[LogData], base: OtterParameters) -> Identification:
    """Every estimate the logs allow, and a line for each they do not."""
    sets = [frames(log) for log in logs]
    result = Identification()
    for axis in ("roll", "pitch"):
        identify_axis(sets, axis, result)
    identify_surge(sets, base, result)
    identify_propellers(sets, result)
    identify_yaw(sets, result)
    return result


def identify_propellers(sets: list[Frames], result: Identification) -> None:
    """The starboard to port thrust ratio (``propeller_thrust_ratio``) where the logs hold the motors' outputs; each
    log's yaw rate its gyro's where it has one (the differentiated yaw carries the attitude's noise)."""
    if command_kind(sets) != "motors":
        return
    items = [s for f in sets for s in select([f], ("left", "right", "r_gyro" if f.has("r_gyro") else "r"))]
    got = thrust_ratio(straight_windows(items))
    if isinstance(got, str):
        result.missing.append(got)
    else:
        result.estimates["propeller_thrust_ratio"] = got


def surge_full_rad_s(result: Identification) -> tuple[float | None, float | None]:
    """The full forward/reverse shaft speeds (rad/s) the surge figures refer to, for shaft commands only."""
    if result.surge.get("kind") != "shafts":
        return None, None
    full = result.surge["full_si"]
    return float(full[0]), float(full[1]) if math.isfinite(full[1]) else None
