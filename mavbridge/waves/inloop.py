"""The realistic in-process plant for ``mavbridge experiment``: hidden sea, heave, sensors at 20 Hz.

The paper's set-up (``vessel.closed_loop.TauPlant``) hands the NMPC the true wave and never samples a
sensor. Here the rigid-body model driven by τ (RK4 at ``dt_s``, τ held over the control period) runs in
the true sea — its phase drawn from a seed the estimator never sees, the hull optionally heaving with
the sea — and every half control period (the ATTITUDE rate, 20 Hz at T = 0.1 s) the true state goes
through ``vessel.sensors.SensorModel`` (seeded) and, as a ``MotionSample``, into a ``WaveSource``. The
IMU's specific force comes from the plant's own ẋ (``vessel.imu.specific_force``).

``estimate_metrics`` compares the estimate with the truth at the end of a run: direction (°), period,
wavelength and height (%), and the phase of the predicted wave at the horizon's end (°).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from mavbridge.nmpc.compiled_model import compiled_model
from mavbridge.waves.calibration import hull_response, record_plant, settings_for
from mavbridge.waves.half_period import half_period
from mavbridge.waves.kinematic import estimate_errors, paper_sea
from mavbridge.waves.phase.bank_source import BankFeed
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.source import (
    EstimateHold,
    MotionSample,
    WaveEstimate,
    WaveSource,
    sea_spread,
    spread_line,
)
from vessel import Plant, RegularWaves, WaveField
from vessel.closed_loop import substeps_per_period
from vessel.dynamics import OceanCurrent, plant_ode, rigid_body_ode
from vessel.imu import specific_force
from vessel.plant import plant_step, rk4_step
from vessel.sea.wind import Wind
from vessel.sensors import SensorModel, SensorParams

SAMPLES_PER_PERIOD = 2  # ATTITUDE at 20 Hz for the paper's T = 0.1 s
SETTLE_S = 10.0  # a watched run's hull floats this long unwatched first (see ``SensedPlant.watch``)


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


class SensedPlant:
    """The boat in the true sea, driven by τ (the rigid body: the paper's set-up) or, with ``propellers``, by the
    shaft-speed commands through the propellers' dynamics and saturation (so a thrust the model does not know
    shows); feeds a wave source with sensor readings at 20 Hz."""

    def __init__(self, params: Any, waves: WaveField, current: OceanCurrent, x0: np.ndarray, period_s: float,
                 dt_s: float, surface_heave: bool, sensors: SensorModel, source: WaveSource,
                 wind: Wind | None = None, propellers: bool = False) -> None:
        self.propellers = propellers
        if propellers:
            ode = plant_ode(params, waves, current, surface_heave, wind)
            step = plant_step(params, waves, current, dt_s, "rk4", surface_heave, wind)
        else:
            ode = rigid_body_ode(params, waves, current, surface_heave, wind)
            step = rk4_step(ode, dt_s)
        self.dt = dt_s
        self.half_s = period_s / SAMPLES_PER_PERIOD
        self.substeps = substeps_per_period(self.half_s, dt_s)
        # a half period's substeps bound to preallocated arrays (no DM conversions per call); compiled in an
        # irregular sea (see ``half_period``)
        self._half = half_period(step, self.substeps, dt_s)
        nx = ode.size1_in(0)
        x, u, t = ca.SX.sym("x", nx), ca.SX.sym("u", 2), ca.SX.sym("t")
        xdot = ode(x, u, t)
        self._imu, _ = compiled_model(
            ca.Function("imu", [x, u, t], [specific_force(x[6:12], xdot[6:12], x[3], x[4], params.g)]))
        self.x = np.concatenate([np.asarray(x0, float)[:12], np.zeros(nx - 12)])
        self.sensors, self.source = sensors, source
        self._input = np.zeros(2)  # τ (N, N·m), or the shaft-speed commands (rad/s) with propellers

    @property
    def rigid_state(self) -> np.ndarray:
        """The 12 rigid-body states."""
        return self.x[:12].copy()

    @property
    def shaft_speeds(self) -> tuple[float, float] | None:
        """Actual shaft speeds (rad/s) with propellers; None for the τ-driven body."""
        return (float(self.x[12]), float(self.x[13])) if self.propellers else None

    def sense(self, t: float) -> None:
        """Sample the sensors at ``t`` (true state, last applied τ for the IMU) and feed the wave source."""
        x_in, u_in, t_in = self._imu.inputs[0:3]
        x_in[:] = self.x
        u_in[:] = self._input
        t_in[0] = t
        self._imu()
        reading = self.sensors.sample(t, self.x[0:6], self.x[6:12], self._imu.outputs[0])
        self.source.observe(MotionSample(reading.t_s, reading.attitude, reading.rates, reading.position_ned,
                                         reading.velocity_ned, reading.accel_body))

    def watch(self, seconds: float, period_s: float,
              on_period: Callable[[float, np.ndarray], None] | None = None) -> None:
        """The boat drifting with idle thrusters for ``seconds`` before t = 0, sensed as in the run (the wave
        source learns; the run's clock then starts at 0 where this ends). It has floated unwatched for
        ``SETTLE_S`` before that: the model starts at rest on a calm waterline, and no skipper's companion
        connects while the hull is still being dropped into the sea (its first seconds heave and pitch as no
        boat afloat does). ``on_period(t, x)``: what the companion sees each watched period (the rigid state),
        thrusters idle."""
        steps, settle = round(seconds / period_s), round(SETTLE_S / period_s) if seconds > 0 else 0
        for i in range(settle + steps):
            t = (i - steps - settle) * period_s
            if i >= settle:
                self.sense(t)
                if on_period is not None:
                    on_period(t, self.rigid_state)
            self.advance(t, np.zeros(2), (0.0, 0.0), sensed=i >= settle)

    def advance(self, t: float, tau: np.ndarray, n_cmd: tuple[float, float], sensed: bool = True) -> None:
        """One control period from ``t`` with τ (or, with propellers, ``n_cmd``) held, sensing at each half period
        inside it (``sensed``; not while the hull settles unwatched)."""
        self._input = np.asarray(n_cmd if self.propellers else tau, float)
        self._half.hold(self._input)
        for i in range(SAMPLES_PER_PERIOD):
            t0 = t + i * self.half_s
            if i > 0 and sensed:
                self.sense(t0)
            x_next = self._half.run(self.x, t0)
            if not np.isfinite(x_next).all():
                raise FloatingPointError(f"plant state became non-finite at t = {t0:.2f} s")
            self.x = x_next.copy()


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

    def step(self, t: float, plant: SensedPlant, nmpc: Any) -> dict[str, float]:
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
