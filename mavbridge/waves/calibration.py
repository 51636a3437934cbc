"""How the hull's roll and pitch follow the surface slope: measured once on the vessel model.

The estimator reads the surface slope from the boat's roll and pitch. A real hull (and our vessel
model) follows the slope through its own dynamics, so near the encounter frequency its pitch lags the
slope along the hull (the Otter model, 1.5 m/s into the paper's waves: ≈ 15° late, gain ≈ 1.0–1.1) and
its roll differs from the slope across it. Left alone, that lag tilts the slope phasors against the
heave phasor and corrupts k and ω. ``hull_response`` measures the ratio attitude/slope (complex: gain
and phase) from a record of a plant run in a regular sea; ``settings_for`` turns it into estimator
settings. Pure numbers; ``record_plant`` runs any ``vessel.Plant`` the caller built (with whatever
options, e.g. heave following the sea) at constant shaft speeds.
"""

from __future__ import annotations

import cmath
import math
from dataclasses import replace

import numpy as np

from mavbridge.waves.settings import EstimatorSettings
from vessel import Plant, RegularWaves


def hull_response(roll: np.ndarray, pitch: np.ndarray, slope_across: np.ndarray, slope_along: np.ndarray,
                  wave_phase: np.ndarray) -> tuple[complex | None, complex | None]:
    """(roll/slope-across, pitch/slope-along) as complex ratios at the wave's phase; None where the slope is ~0.

    All arrays are samples of one record (equal spacing, whole encounter periods preferred); roll is
    taken with the sign the estimator uses (``roll_sign`` applied by the caller).
    """
    rotor = np.exp(-1j * np.asarray(wave_phase, float))

    def ratio(response: np.ndarray, drive: np.ndarray) -> complex | None:
        d = complex(np.mean(np.asarray(drive, float) * rotor))
        return complex(np.mean(np.asarray(response, float) * rotor)) / d if abs(d) > 1e-4 else None

    return ratio(roll, slope_across), ratio(pitch, slope_along)


def settings_for(roll: complex | None, pitch: complex | None,
                 base: EstimatorSettings | None = None) -> EstimatorSettings:
    """Estimator settings with the measured hull response (an axis without a measurement keeps its value)."""
    s = base or EstimatorSettings()
    if roll is not None:
        s = replace(s, roll_gain=abs(roll), roll_phase_deg=math.degrees(cmath.phase(roll)))
    if pitch is not None:
        s = replace(s, pitch_gain=abs(pitch), pitch_phase_deg=math.degrees(cmath.phase(pitch)))
    return s


def record_plant(plant: Plant, waves: RegularWaves, shaft_speeds: tuple[float, float], seconds: float,
                 skip_s: float = 30.0, step_s: float = 0.05, roll_sign: float = 1.0) -> tuple[np.ndarray, ...]:
    """Run ``plant`` (already in ``waves``) and record (roll, pitch, slope across, slope along, wave phase).

    The first ``skip_s`` seconds (the start transient) are dropped.
    """
    steps = max(1, round(step_s / plant.dt))
    rows = []
    while plant.time < seconds:
        x, t = plant.state, plant.time
        a_n, a_e = waves.slope_angles(x[0], x[1], t)
        c, s = math.cos(x[5]), math.sin(x[5])
        chi = waves.travel_dir_rad
        phase = waves.frequency * t - waves.wavenumber * (x[0] * math.cos(chi) + x[1] * math.sin(chi))
        if t >= skip_s:
            rows.append((roll_sign * x[3], x[4], a_e * c - a_n * s, a_n * c + a_e * s, phase))
        plant.advance(shaft_speeds, steps)
    data = np.array(rows)
    return tuple(data[:, i] for i in range(5))
