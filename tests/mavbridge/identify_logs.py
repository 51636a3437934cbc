"""An Otter API log the identification tests (and bench/identify_speed.py) write themselves: the vessel model
with a known hull, driven by the commands it logs, with roll kicks let free to decay, sensor noise and gaps.

The log holds what the real API logs hold for identification: attitude and rates in degrees, lat/lon, speed
and course over ground, the commanded shaft speeds ``n1``/``n2`` in rpm (``tau_X``/``tau_N`` left empty).
Segments of SEGMENT_S: a steady mean shaft speed, a steering difference (none on every third), and on every
fourth a roll kick at its start, going straight, so that the roll decays freely.
"""

from __future__ import annotations

import math
from datetime import datetime
from pathlib import Path

import numpy as np

from tests.mavbridge.field_logs import EPOCH_S, HOME, OTTER_41
from vessel import OtterParameters, Plant
from vessel.geo import latlon_from_ned

SEGMENT_S = 30.0
RPM = 2 * math.pi / 60


def _schedule(seconds: float, n_max: float, rng: np.random.Generator) -> list[tuple[float, float, bool]]:
    """(mean shaft speed rad/s, half difference rad/s, kick) per segment."""
    out = []
    for k in range(math.ceil(seconds / SEGMENT_S)):
        mean = float(rng.uniform(0.35, 1.0)) * n_max
        diff = 0.0 if k % 3 == 0 or k % 4 == 0 else float(rng.uniform(-0.12, 0.12)) * n_max
        out.append((mean, diff, k % 4 == 0))
    return out


def write_identify_log(path: Path, hull: OtterParameters, seconds: float, seed: int = 0, rate_hz: float = 10.0,
                       kick_deg: float = 6.0, noise_deg: float = 0.05, drop: float = 0.03) -> None:
    """Simulate ``hull`` for ``seconds`` and write its Otter API CSV to ``path`` (see the module docstring)."""
    rng = np.random.default_rng(seed)
    plant = Plant(hull, dt=0.01)
    n_max = hull.matrices().n_max
    steps = round(1.0 / rate_hz / plant.dt)
    lines = [";" + ";".join(OTTER_41)]
    schedule = _schedule(seconds, n_max, rng)
    t = 0.0
    for mean, diff, kick in schedule:
        if kick:
            x = plant.state
            x[3] = math.radians(kick_deg)
            plant.reset(x, plant.time)
        n = (min(mean + diff, n_max), min(mean - diff, n_max))
        for _ in range(round(SEGMENT_S * rate_hz)):
            if t >= seconds:
                break
            x = plant.advance(n, steps)
            t = plant.time
            if rng.random() < drop:
                continue
            lines.append(_row(t, x, n, rng, noise_deg))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def _row(t: float, x: np.ndarray, n: tuple[float, float], rng: np.random.Generator, noise_deg: float) -> str:
    """One row of the CSV at ``t`` of state ``x`` with shaft commands ``n`` (rad/s)."""
    lat, lon = latlon_from_ned(*HOME, float(x[0]), float(x[1]))
    psi = float(x[5])
    vn = x[6] * math.cos(psi) - x[7] * math.sin(psi)
    ve = x[6] * math.sin(psi) + x[7] * math.cos(psi)
    att = np.degrees(x[3:6]) + rng.normal(0, noise_deg, 3)
    rates = np.degrees(x[9:12])
    values = {name: "0.0" for name in OTTER_41}
    values.update(current_time=f"{EPOCH_S + t:.7f}", lat=repr(lat), lon=repr(lon),
                  current_course_over_ground=f"{math.degrees(math.atan2(ve, vn)) % 360:.3f}",
                  current_speed=f"{math.hypot(vn, ve):.4f}", n1=f"{n[0] / RPM:.3f}", n2=f"{n[1] / RPM:.3f}",
                  tau_X="", tau_N="")
    for k in range(3):
        values[f"current_orientation_{k + 1}"] = f"{att[k] % 360 if k == 2 else att[k]:.3f}"
        values[f"current_rotational_velocities_{k + 1}"] = f"{rates[k]:.3f}"
    stamp = datetime.fromtimestamp(EPOCH_S + t).strftime("%Y-%m-%d_%H:%M:%S:%f")
    return stamp + ";" + ";".join(values[c] for c in OTTER_41)
