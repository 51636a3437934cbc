"""The wave side of the realistic in-process run for ``mavbridge experiment``: hidden sea, calibration, sensors.

The paper's set-up (``vessel.closed_loop.TauPlant``) hands the NMPC the true wave and never samples a
sensor. In the realistic run the plant (``mavbridge.lab.sensed_plant.SensedPlant``) runs in the true sea — its
phase drawn here from a seed the estimator never sees (``hidden_sea``), the hull optionally heaving with the sea —
and every half control period (the ATTITUDE rate, 20 Hz at T = 0.1 s) its true state goes through
``vessel.sensors.SensorModel`` (``sensor_model``, seeded) into a ``WaveSource``; ``WaveFeed`` hands the NMPC its
wave each step.

``estimate_metrics`` compares the estimate with the truth at the end of a run: direction (°), period,
wavelength and height (%), and the phase of the predicted wave at the horizon's end (°).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, Protocol

import numpy as np

from mavbridge.waves.calibration import hull_response, record_plant, settings_for
from mavbridge.waves.kinematic import estimate_errors, paper_sea
from mavbridge.waves.phase.bank_source import BankFeed
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.source import (
    EstimateHold,
    WaveEstimate,
    WaveSource,
    sea_spread,
    spread_line,
)
from vessel import Plant, RegularWaves, WaveField
from vessel.sensors import SensorModel, SensorParams

SAMPLES_PER_PERIOD = 2  # ATTITUDE at 20 Hz for the paper's T = 0.1 s
SETTLE_S = 10.0  # a watched run's hull floats this long unwatched first (see ``SensedPlant.watch``)


class Sensed(Protocol):
    """What the wave feed needs of the plant (``mavbridge.lab.sensed_plant.SensedPlant``)."""

    @property
    def rigid_state(self) -> np.ndarray:
        """The 12 rigid-body states."""

    def sense(self, t: float) -> None:
        """Sample the sensors at ``t`` into the wave source."""


def hidden_sea(waves: WaveField, seed: int) -> WaveField:
    """The true sea with its phase origin drawn from ``seed`` (regular waves only; others unchanged)."""
    if not isinstance(waves, RegularWaves):
        return waves
    phase = float(np.random.default_rng([7919, seed]).uniform(-math.pi, math.pi))
    return dataclasses.replace(waves, phase_rad=phase)


@functools.lru_cache(maxsize=32)
def calibrated_settings(params: Any, surface_heave: bool, roll_sign: float) -> EstimatorSettings:
    """The hull's roll/pitch response to the slope, measured once on the vessel model in a fixed lab sea.

    Measured once per process for each (params, surface_heave, roll_sign), on which alone it depends (the lab
    sea and the manoeuvre are fixed; ``params`` is a frozen, hashable dataclass), and the settings are frozen:
    a sweep's runs share the 80 s recording instead of repeating it each run.

    The lab sea is the paper's wave at another phase, the hull heading 45° at 70 rad/s shafts for 80 s:
    a property of the hull, not of the run's (hidden) sea. The model hull rolls in it with the sign the
    estimator is told (``roll_sign``: +1 the paper's plant, −1 geometric, a real hull), so the sign lives in
    ``roll_sign`` alone and the measured ``roll_phase_deg`` is the hull's dynamic lag, a few degrees, never
    the ±180° of a sign said twice.
    """
    sea = dataclasses.replace(paper_sea(2.0), paper_roll_sign=roll_sign > 0)
    x0 = np.zeros(14)
    x0[5] = math.radians(45.0)
    plant = Plant(params, sea, dt=0.01, x0=x0, surface_heave=surface_heave)
    base = EstimatorSettings(roll_sign=roll_sign)
    return settings_for(*hull_response(*record_plant(plant, sea, (70.0, 70.0), 80.0, roll_sign=roll_sign)), base)


def sensor_model(kind: str, seed: int) -> SensorModel:
    """The default (SITL-like) or ideal sensors, noise seeded by ``seed``."""
    params = SensorParams.ideal() if kind == "ideal" else SensorParams()
    return SensorModel(params, np.random.default_rng([104729, seed]))


def estimate_metrics(est: WaveEstimate | None, truth: WaveField, t_s: float, x: np.ndarray,
                     horizon_s: float) -> dict[str, float | None]:
    """Errors of the final estimate against the true regular wave; the phase at the horizon's end.

    The boat's position at the horizon end is extrapolated along its NED velocity (x: 12 rigid states).
    """
    keys = ("direction_err_deg", "period_err_pct", "length_err_pct", "height_err_pct", "phase_err_deg")
    if est is None or not isinstance(truth, RegularWaves):
        return dict.fromkeys(keys)
    c, s = math.cos(x[5]), math.sin(x[5])
    v_n, v_e = c * x[6] - s * x[7], s * x[6] + c * x[7]
    north, east = x[0] + v_n * horizon_s, x[1] + v_e * horizon_s
    err = estimate_errors(est, truth, t_s + horizon_s, north, east)
    values = (err.direction_deg, err.period_pct, err.length_pct, err.height_pct, err.phase_deg)
    return dict(zip(keys, (float(v) for v in values), strict=True))


class WaveFeed:
    """Per control step: sense, ask the wave source, hand the NMPC its wave; notes and metrics of the run.

    ``truth`` mode hands the NMPC the true (hidden-phase) wave; ``estimated`` mode the estimate's field,
    or None below the confidence threshold (calm prediction, R = 0: the Direct behaviour). Says once when
    it flies without the roll term and each time the confidence drops. ``predicted`` mode is ``estimated``
    with a phase-resolved bank (``bank``, a ``bank_source.BankFeed``) that replaces the regular wave while
    the predictor is confident.
    """

    def __init__(self, mode: str, source: WaveSource, truth: WaveField, horizon_s: float,
                 say: Any = None, hold_s: float = 0.0, bank: BankFeed | None = None) -> None:
        self.mode, self.source, self.truth, self.horizon_s = mode, source, truth, horizon_s
        self.say = say
        self.bank = bank
        if bank is not None:
            bank.note = self._note
        self.notes: list[str] = []
        self.first_confident_s: float | None = None
        self.confident_steps = self.steps = self.spread_steps = 0
        self._spread_on = False
        self.estimator_ms: list[float] = []
        self.first_errors: dict[str, float | None] = {}
        self._confident: bool | None = None
        self._hold = EstimateHold(hold_s)  # keep flying on the last confident estimate this long

    def _note(self, line: str) -> None:
        self.notes.append(line)
        if self.say is not None:
            self.say(line)

    def step(self, t: float, plant: Sensed, nmpc: Any) -> dict[str, float]:
        """Sense at ``t``, set the NMPC's wave, return the wave columns of the log row."""
        import time

        start = time.perf_counter()
        plant.sense(t)
        self.steps += 1
        if self.mode == "truth":
            if nmpc.takes_waves:  # else it was built with the (irregular) truth itself
                nmpc.set_wave(self.truth)
            est = self.source.estimate(t)
            self.estimator_ms.append((time.perf_counter() - start) * 1e3)
            return est.row() if est is not None else {}
        est = self._hold.apply(self.source.estimate(t), t)
        if self.bank is not None:
            wave, spread = self.bank.step(t, nmpc, est)
        else:
            wave, spread = est, sea_spread(self.source, est is not None)
        nmpc.set_wave(wave.field() if wave is not None else None)
        nmpc.set_sea_spread(spread)
        self.estimator_ms.append((time.perf_counter() - start) * 1e3)
        self._track_spread(t, spread, wave is not None or bool(getattr(nmpc, "bank_active", False)))
        if est is not None and self.first_confident_s is None:
            self.first_errors = estimate_metrics(est, self.truth, t, plant.rigid_state, self.horizon_s)
        self._track(t, est is not None, bool(getattr(nmpc, "roll_term_active", True)))
        latest = self.source.latest(t) if hasattr(self.source, "latest") else est
        row: dict[str, float] = latest.row() if latest is not None else {}
        if self.bank is not None:
            row["wave_bank_on"] = float(bool(getattr(nmpc, "bank_active", False)))
        return row

    def _track_spread(self, t: float, spread: np.ndarray | None, explained: bool) -> None:
        """Count the steps planned on the sea's statistics alone; say when that starts and stops."""
        alone = spread is not None and not explained
        self.spread_steps += int(alone)
        if alone and not self._spread_on and spread is not None:
            self._note(f"t = {t:.1f} s: sea statistics known ({spread_line(spread)}): "
                       "the roll term acts on the expected roll")
        elif self._spread_on and not alone:
            self._note(f"t = {t:.1f} s: the roll term no longer acts on the sea's statistics alone")
        self._spread_on = alone

    def _track(self, t: float, confident: bool, roll_term: bool) -> None:
        """Count confident steps; say when the roll term is off at the start and when confidence changes."""
        if confident:
            self.confident_steps += 1
            if self.first_confident_s is None:
                self.first_confident_s = t
        if confident == self._confident:
            return
        if self._confident is None and not confident:
            self._note(f"t = {t:.1f} s: no confident wave estimate yet: flying without the roll term (Direct)")
        elif confident:
            self._note(f"t = {t:.1f} s: wave estimate confident: "
                       + ("the roll term is on" if roll_term else "planning with it (R = 0: no roll term)"))
        elif self._confident:
            self._note(f"t = {t:.1f} s: wave estimate confidence dropped: flying without the roll term (Direct)")
        self._confident = confident

    def metrics(self, t_end: float, x_end: np.ndarray) -> dict[str, Any]:
        """Time to a confident estimate, final errors against the truth, the estimator's cost per step."""
        regular = isinstance(self.truth, RegularWaves)  # an irregular sea has one phase per component
        names = {"estimated": getattr(self.source, "name", "estimated"),
                 "predicted": getattr(self.source, "name", "estimated+phase-bank")}
        out: dict[str, Any] = {"wave_source": names.get(self.mode, "scenario-truth"),
                               "sea_phase_rad": float(self.truth.phase_rad) if regular else None}
        ms = np.asarray(self.estimator_ms, float)
        out["estimator_ms_median"] = float(np.median(ms)) if ms.size else None
        out["estimator_ms_p99"] = float(np.percentile(ms, 99)) if ms.size else None
        if self.mode not in names:
            return out
        if self.bank is not None:
            out.update(self.bank.metrics())
        latest = self.source.latest(t_end) if hasattr(self.source, "latest") else None
        out.update(time_to_confident_s=self.first_confident_s,
                   confident_fraction=self.confident_steps / max(self.steps, 1),
                   sea_statistics_fraction=self.spread_steps / max(self.steps, 1),
                   final_confidence=latest.confidence if latest is not None else 0.0,
                   notes=list(self.notes),
                   at_first_confident={**self.first_errors},
                   **estimate_metrics(latest, self.truth, t_end, x_end, self.horizon_s))
        return out
