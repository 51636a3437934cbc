"""The identified figures as ``OtterParameters`` fields, and the check that the model then does what the log did.

Roll and pitch periods are not inputs of the model: they follow from the hydrostatics and the inertia. The
hydrostatics (masses, pontoons) are kept and the hull's radius of gyration (``gyration_roll``/``gyration_pitch``)
is solved for, by bisection, so that the linearised 6-DOF model at rest (M ẍ + D ẋ + G x = 0, the mode with the
most roll or pitch in it) has the identified natural period; ``zeta_roll``/``zeta_pitch`` likewise for the
damping ratio. Surge: ``max_speed`` sizes X_u, set so that the model's steady speeds measured on the plant at the
log's steady commands match the log's (``calibrate_max_speed``); the reverse bollard pull gives the reverse speed; where
the log's shafts turn faster than the model's n_max, the thrust coefficient is lowered so that n_max is the log's
(same bollard pull). Nomoto T gives ``yaw_time_constant`` (T_yaw sizes N_r = M66/T).
``plant_decay`` measures a model's free decay on ``vessel.Plant`` with the same fit as the log's decays.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from mavbridge.identify.decay import DecayFit, fit_decay
from vessel import OtterParameters, Plant

DOF = {"roll": 3, "pitch": 4}
GYRATION = {"roll": "gyration_roll", "pitch": "gyration_pitch"}
ZETA = {"roll": "zeta_roll", "pitch": "zeta_pitch"}
GYRATION_RANGE_M = (0.02, 4.0)
ZETA_RANGE = (0.0, 1.9)
DECAY_DEG = 5.0
PLANT_CORRECTIONS = 3
SPEED_SETTLE_S = 40.0
SPEED_CORRECTIONS = 4


def linear_mode(p: OtterParameters, axis: str) -> tuple[float, float]:
    """(ω_n rad/s, ζ) of the model's mode with the most ``axis`` (roll or pitch) in it, linearised at rest."""
    m = p.matrices()
    A = np.block([[np.zeros((6, 6)), np.eye(6)], [-m.M_inv @ m.G, -m.M_inv @ m.D]])
    values, vectors = np.linalg.eig(A)
    dof = DOF[axis]
    best, share = None, -1.0
    for k, lam in enumerate(values):
        if lam.imag <= 1e-9:
            continue
        v = np.abs(vectors[:6, k])
        if v[dof] / (np.linalg.norm(v) or 1.0) > share:
            best, share = lam, v[dof] / (np.linalg.norm(v) or 1.0)
    if best is None:
        return math.nan, math.nan
    return float(abs(best)), float(-best.real / abs(best))


def _bisect(f: Callable[[float], float], lo: float, hi: float, target: float) -> float:
    """x in [lo, hi] with f(x) = target for a monotonic f (nan when the target is beyond its range)."""
    f_lo, f_hi = f(lo) - target, f(hi) - target
    if f_lo * f_hi > 0:
        return math.nan
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        f_mid = f(mid) - target
        if f_mid * f_lo <= 0:
            hi = mid
        else:
            lo, f_lo = mid, f_mid
    return 0.5 * (lo + hi)


def _linear_fields(base: OtterParameters, axis: str, omega: float | None, zeta: float | None) -> dict[str, float]:
    """The fields giving the linearised model's ``axis`` mode the natural frequency ``omega`` and damping ``zeta``."""
    p, fields = base, {}
    for _ in range(3):  # the two are nearly independent: a few alternations settle them
        if omega is not None:
            g = _bisect(lambda r, p=p: linear_mode(p.replace(**{GYRATION[axis]: r}), axis)[0], *GYRATION_RANGE_M,
                        omega)
            if math.isfinite(g):
                fields[GYRATION[axis]] = g
                p = p.replace(**{GYRATION[axis]: g})
        if zeta is not None:
            z = _bisect(lambda q, p=p: linear_mode(p.replace(**{ZETA[axis]: q}), axis)[1], *ZETA_RANGE, zeta)
            if math.isfinite(z):
                fields[ZETA[axis]] = z
                p = p.replace(**{ZETA[axis]: z})
    return fields


def fit_axis(base: OtterParameters, axis: str, period_s: float | None, zeta: float | None) -> dict[str, float]:
    """The gyration radius and damping ratio fields giving ``axis`` the identified natural period and damping as
    the plant's own free decay measures them (only the fields identified): solved on the linearised model, then
    corrected by what ``plant_decay`` measures (the plant's decay is a little slower than its linearisation). A
    figure the field cannot reach (a damping below what the coupled hull already has) is left out."""
    omega = None if period_s is None else 2 * math.pi / period_s
    aim_omega, aim_zeta = omega, zeta
    fields = _linear_fields(base, axis, aim_omega, aim_zeta)
    best, best_error = fields, math.inf
    for _ in range(PLANT_CORRECTIONS + 1):
        measured = plant_decay(base.replace(**fields), axis)
        if measured is None:
            break
        error = abs(measured.omega_n / omega - 1) if omega else abs(measured.zeta / max(zeta or 0, 1e-3) - 1)
        if error < best_error:
            best, best_error = fields, error
        if error < 0.002 or error > 0.3:
            break  # matched, or the plant's decay is not this mode's (coupled, too damped): the best stands
        aim_omega = None if omega is None else aim_omega * omega / measured.omega_n
        aim_zeta = None if zeta is None else max(aim_zeta * zeta / max(measured.zeta, 1e-3), 0.0)
        fields = _linear_fields(base, axis, aim_omega, aim_zeta)
    fields = best
    return {k: round(v, 4) for k, v in fields.items()}


def surge_fields(base: OtterParameters, forward: float | None, reverse: float | None,
                 full_forward: float | None, full_reverse: float | None) -> dict[str, float]:
    """max_speed (m/s at full forward), bollard_pull_reverse_kgf (from the reverse speed) and the thrust
    coefficients when the log's full shaft speeds (rad/s) exceed the model's."""
    m = base.matrices()
    fields: dict[str, float] = {}
    u_max = base.max_speed
    if forward is not None and forward > 0:
        u_max = fields["max_speed"] = round(forward, 4)
        if full_forward is not None and full_forward > m.n_max * 1.001:
            k = 0.5 * base.bollard_pull_forward_kgf * base.g / full_forward**2
            fields["thrust_coeff_forward"] = float(f"{k:.5g}")
    if reverse is not None and reverse < 0:
        pull = base.bollard_pull_forward_kgf * abs(reverse) / u_max
        fields["bollard_pull_reverse_kgf"] = round(pull, 3)
        n_rev = max(abs(m.n_min), full_reverse or 0.0)
        fields["thrust_coeff_reverse"] = float(f"{0.5 * pull * base.g / n_rev**2:.5g}")
    return fields


def plant_steady(p: OtterParameters, output: float = 1.0,
                 seconds: float = SPEED_SETTLE_S) -> tuple[float, float] | None:
    """(surge speed m/s, pitch rad) the model settles at on ``vessel.Plant`` in calm water with both motors at
    ``output`` of full (means of the last 5 s); None when the plant diverges (a heavy hull can pitch over at full
    speed), or when the model has no upright hull (a payload so heavy that roll has no restoring moment)."""
    try:
        m = p.matrices()
    except ValueError:
        return None
    n = output * float(m.n_max) if output >= 0 else output * abs(float(m.n_min))
    plant = Plant(p, dt=0.01)
    try:
        rows = [plant.advance((n, n), 5)[[6, 4]].astype(float) for _ in range(round(seconds / 0.05))]
    except FloatingPointError:
        return None
    last = np.asarray(rows[-100:])
    return float(np.mean(last[:, 0])), float(np.mean(last[:, 1]))


def plant_speed(p: OtterParameters, output: float = 1.0, seconds: float = SPEED_SETTLE_S) -> float | None:
    """The model's steady surge speed (m/s) at motor ``output`` (``plant_steady``); None when the plant diverges."""
    got = plant_steady(p, output, seconds)
    return None if got is None else got[0]


def calibrate_max_speed(base: OtterParameters, fields: dict[str, float],
                        levels: list[tuple[float, float, int]]) -> dict[str, float]:
    """``fields`` with ``max_speed`` corrected so that the model's own steady speeds, measured on the plant at the
    log's steady forward commands (``levels``: thrust fraction, mean speed m/s, windows), match the log's with the
    least squared relative error over the commands: max_speed only sizes the linear surge damping, and the hull's
    other drag and its trim make the model's speed differ from u = U·s by up to a tenth (3.92 m/s at full with
    max_speed 3.72, 42 kg payload), differently at each speed."""
    out = dict(fields)
    for _ in range(SPEED_CORRECTIONS):
        p = base.replace(**out)
        logs, weights = [], []
        for fraction, speed, _windows in levels:
            got = plant_speed(p, math.sqrt(fraction))
            if got is None or not got > 0 or not speed > 0:
                return out
            logs.append(math.log(speed / got))
            weights.append(1.0)  # each steady command alike, however long the log held it
        if not logs:
            return out
        factor = math.exp(float(np.average(logs, weights=weights)))
        out["max_speed"] = round(min(max(out["max_speed"] * factor, 0.1), 20.0), 4)
        if abs(factor - 1) < 0.003:
            break
    return out


def plant_decay(p: OtterParameters, axis: str, degrees: float = DECAY_DEG, seconds: float = 10.0) -> DecayFit | None:
    """The model's free decay from ``degrees`` in calm water on ``vessel.Plant``, fitted as a log's decay is."""
    x0 = np.zeros(14)
    x0[DOF[axis]] = math.radians(degrees)
    plant = Plant(p, dt=0.01, x0=x0)
    steps = round(seconds / 0.05)
    rows = [plant.state[DOF[axis]]]
    for _ in range(steps):
        rows.append(float(plant.advance((0.0, 0.0), 5)[DOF[axis]]))
    t = np.arange(steps + 1) * 0.05
    return fit_decay(t, np.asarray(rows))
