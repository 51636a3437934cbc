"""Between the wave source and the NMPC: the roll term only on a confident wave, said in the log, summed up.

Once per control step ``step`` asks the source for the wave at autopilot time t; a confident answer
goes to the NMPC (``set_wave(field)``: the roll term on), no answer means ``set_wave(None)`` (calm
prediction, R = 0: the Direct behaviour). Each change between the two is logged once, with the time
and the estimate. The source's measured sea statistics (the estimator's ``spread``: the NED slope
covariance its wave does not explain) go to ``set_sea_spread``, the expected-roll term; while they act
without a confident wave (an irregular sea) that is said once too, and counted. The log row is the
source's ``latest`` fit even when it is not confident (the estimator's own figures), else the confident
estimate's. The estimator's cost (every ``observe`` since the last step, the samples sent after its command
(``command_sent``), and the step's ``estimate``) is timed per control step, so it counts in the step time.
"""

from __future__ import annotations

import math
import struct
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.waves.source import (
    EstimateHold,
    MotionSample,
    WaveEstimate,
    WaveSource,
    sea_spread,
    send_held,
    spread_line,
)
from vessel.config import ConfigError

_WAVE_BITS = struct.Struct("<6d")  # an estimate's wave numbers, the key of the field made of them
WATCH_EVERY_S = 0.1  # before engaging, the source is asked this often whether it knows the sea
SPELL_S = 1.0  # steps further apart than this (autopilot s: the pilot had the boat): the samples between are no step's


def describe(est: WaveEstimate) -> str:
    """One line of an estimate: travel direction (° NED), period, wavelength, height, confidence."""
    return (f"towards {math.degrees(est.travel_dir_rad) % 360:.0f} deg, period {est.period_s:.2f} s, "
            f"length {est.length_m:.1f} m, height {est.height_m:.2f} m, confidence {est.confidence:.2f}")


def _latest(source: WaveSource, t_s: float) -> WaveEstimate | None:
    """The source's current fit whatever its confidence (estimators have ``latest``), else None."""
    latest = getattr(source, "latest", None)
    return latest(t_s) if latest is not None else None


@dataclass
class WaveGate:
    """Hands the wave source's answer to the NMPC, counts what it did and says when it changes."""

    source: WaveSource
    log: Callable[[str], None] = print
    hold_s: float = 0.0  # keep planning on the last confident estimate this long after the confidence drops
    confident: bool | None = None  # None until the first step
    steps: int = 0
    roll_steps: int = 0
    changes: int = 0
    first_step_s: float | None = None
    first_confident_s: float | None = None
    last: WaveEstimate | None = None
    cost_ms: list[float] = field(default_factory=list)  # per control step: observes, send since the last + estimate
    samples: int = 0  # motion samples observed
    imu_samples: int = 0  # of them, with an IMU specific force (the heave the estimator sees)
    _observe_s: float = 0.0
    spread_steps: int = 0  # steps planned on the sea's statistics alone (no confident wave)
    _spread_on: bool = False
    _rejected: int = 0  # confident estimates the wave model refused
    watched_confident_s: float | None = None  # autopilot time of the first confident estimate, engaged or not
    first_sample_s: float | None = None  # autopilot time of the first motion sample the source got
    _watched_t: float = -math.inf
    _stepped_t: float = -math.inf  # autopilot time of the last step
    _hold: EstimateHold = field(init=False)
    _made: tuple[bytes | None, Any] | None = field(default=None, init=False, repr=False, compare=False)
    # (an estimate's wave numbers as exact bits, the field made of them)
    _spread_given: tuple[weakref.ref, bytes] | None = field(default=None, init=False, repr=False, compare=False)
    # (the NMPC, the 2×2 float spread it last took, as exact bits): the same again is not given again

    def __post_init__(self) -> None:
        self._hold = EstimateHold(self.hold_s)
        use_log = getattr(self.source, "use_log", None)  # a source that can fail on its own says so in our log
        if use_log is not None:
            use_log(self.log)

    def observe(self, sample: MotionSample) -> None:
        """One motion sample to the source (every ATTITUDE), timed."""
        start = time.perf_counter()
        if self.first_sample_s is None:
            self.first_sample_s = sample.t_s
        self.samples += 1
        self.imu_samples += sample.accel_body is not None
        self.source.observe(sample)
        self._observe_s += time.perf_counter() - start

    def watch(self, t_s: float) -> None:
        """Before engaging (called at any rate; it asks every WATCH_EVERY_S of autopilot time): whether the source
        knows the sea yet, said once, with the estimate, when it first does: the skipper learns what the boat has
        seen before handing it over."""
        self._observe_s = 0.0  # what the source cost while watching is not a control step's
        if t_s < self._watched_t:  # the autopilot's clock went back (a reboot): asked again from now on
            self._watched_t = -math.inf
        if self.watched_confident_s is not None or t_s - self._watched_t < WATCH_EVERY_S:
            return
        self._watched_t = t_s
        start = time.perf_counter()
        est = self.source.estimate(t_s)
        send_held(self.source)  # (the samples asked about go now: no step's command comes to send them)
        if est is None:
            return
        self.watched_confident_s = t_s
        self.log(f"waves ({self.source.name}) at t = {t_s:.1f} s, before engaging: {describe(est)}; the roll term "
                 f"acts from the first step ({(time.perf_counter() - start) * 1e3:.2f} ms)")

    def step(self, nmpc: Any, t_s: float) -> dict[str, float]:
        """The wave at ``t_s`` to the NMPC (None: no roll term); returns the log columns of the latest fit."""
        start = time.perf_counter()
        est = self._hold.apply(self.source.estimate(t_s), t_s)
        spell, self._stepped_t = not t_s - self._stepped_t <= SPELL_S, t_s  # (a first step too: the watch's samples)
        self.cost_ms.append((time.perf_counter() - start + (0.0 if spell else self._observe_s)) * 1e3)
        self._observe_s = 0.0
        wave = self._field(est)
        if wave is None:
            est = None
        nmpc.set_wave(wave)
        self._spread(nmpc, wave is not None, t_s)
        self._note(est, t_s)
        shown = est if est is not None else _latest(self.source, t_s)
        if shown is not None:
            self.last = shown
        return shown.row() if shown is not None else {}

    def command_sent(self) -> None:
        """The step's command is out: the samples the source holds go to it now (``send_held``), off the command's
        path; their cost counts in the next step's."""
        start = time.perf_counter()
        send_held(self.source)
        self._observe_s += time.perf_counter() - start

    def _field(self, est: WaveEstimate | None) -> Any:
        """The estimate as the NMPC's wave field; None (no roll term) when there is none or it is outside the
        wave model's ranges (e.g. a breaking steepness), said once per run."""
        if est is None:
            return None
        try:  # exact bits: −0.0 is not 0.0 here
            key: bytes | None = _WAVE_BITS.pack(est.height_m, est.length_m, est.period_s, est.travel_dir_rad,
                                                est.phase_rad, est.roll_sign)
        except (struct.error, TypeError):  # not numbers: the field's own checks say what is wrong
            key = None
        if key is not None and self._made is not None and self._made[0] == key:
            return self._made[1]  # the same wave as the last step's (the fit has not moved): the same field object,
            # which the NMPC and the predictor recognise without building its parameters again
        try:
            made = est.field()
        except (ConfigError, ValueError) as exc:
            if not self._rejected:
                self.log(f"waves ({self.source.name}): estimate outside the wave model ({exc}); no roll term")
            self._rejected += 1
            return None
        self._made = (key, made)
        return made

    def given_elsewhere(self) -> None:
        """Someone else (another gate on the same NMPC: a replay's steps the companion would not command) set the
        NMPC's sea spread since this gate's last step: its next step gives its own again, even if unchanged."""
        self._spread_given = None

    @property
    def statistics_only(self) -> bool:
        """True while the roll term acts on the sea's statistics alone (no confident wave)."""
        return self._spread_on

    def _spread(self, nmpc: Any, explained: bool, t_s: float) -> None:
        """The sea's unexplained slope statistics to the NMPC (the expected-roll term); says when the roll
        term starts or stops acting on them alone (no confident wave)."""
        spread = sea_spread(self.source, explained)
        bits = spread.tobytes() if isinstance(spread, np.ndarray) and spread.dtype == np.float64 \
            and spread.shape == (2, 2) else None
        given = self._spread_given
        if bits is None or given is None or given[0]() is not nmpc or given[1] != bits:  # (it changes with a fit)
            self._spread_given = None
            try:
                nmpc.set_sea_spread(spread)
                self._spread_given = None if bits is None else (weakref.ref(nmpc), bits)
            except ValueError:  # not a covariance (cannot happen with the estimator's): no term, no crash
                spread = None
                nmpc.set_sea_spread(None)
        alone = spread is not None and not explained
        self.spread_steps += int(alone)
        if alone != self._spread_on and (alone or self._spread_on):
            self.log(f"waves ({self.source.name}) at t = {t_s:.1f} s: " + (
                f"sea statistics known ({spread_line(spread)}): the roll term acts on the expected roll"
                if alone and spread is not None else "the roll term no longer acts on the sea's statistics alone"))
        self._spread_on = alone

    def _note(self, est: WaveEstimate | None, t_s: float) -> None:
        """Count the step; log the first state and every change of confidence once."""
        self.steps += 1
        if self.first_step_s is None:
            self.first_step_s = t_s
        now = est is not None
        self.roll_steps += int(now)
        if now and self.first_confident_s is None:
            self.first_confident_s = t_s
        if now and self.watched_confident_s is None:
            self.watched_confident_s = t_s
        if self.confident is None:
            self.log(f"waves ({self.source.name}): " + (f"{describe(est)}; roll term on" if est is not None else
                     "no confident estimate yet: flying without the roll term (Direct behaviour)"))
        elif now != self.confident:
            self.changes += 1
            self.log(f"waves ({self.source.name}) at t = {t_s:.1f} s: " + (
                f"confident: {describe(est)}; roll term on" if est is not None else
                "estimate no longer confident: flying without the roll term (Direct behaviour)"))
        self.confident = now

    def summary(self, solve_ms: list[float]) -> dict[str, Any]:
        """For metrics.json: time to the first confident wave (s of autopilot time after the first step),
        the fraction of steps with the roll term on, the final estimate, the estimator's cost in the step's
        process and the step time with it (``solve_ms`` per step, same steps); for an estimator in a process of its
        own (``wave_process``) also that process's CPU time and faults."""
        cost = np.asarray(self.cost_ms, float)
        out: dict[str, Any] = {
            "source": self.source.name,
            "time_to_confident_s": None if self.first_confident_s is None or self.first_step_s is None
            else round(max(self.first_confident_s - self.first_step_s, 0.0), 3),
            "first_sample_at_s": None if self.first_sample_s is None else round(self.first_sample_s, 3),
            "first_confident_at_s": None if self.watched_confident_s is None else round(self.watched_confident_s, 3),
            "roll_term_fraction": round(self.roll_steps / self.steps, 4) if self.steps else None,
            "sea_statistics_fraction": round(self.spread_steps / self.steps, 4) if self.steps else None,
            "confidence_changes": self.changes,
            "imu_sample_share": round(self.imu_samples / self.samples, 4) if self.samples else None,
            "final": {k: round(v, 4) for k, v in self.last.row().items()} if self.last is not None else None,
            "estimator_ms_median": round(float(np.median(cost)), 4) if cost.size else None,
            "estimator_ms_p99": round(float(np.percentile(cost, 99)), 4) if cost.size else None,
        }
        faults = getattr(self.source, "faults", None)  # the estimator in a process of its own: its time and faults
        if faults is not None:
            out["process"] = {"cpu_s": round(float(getattr(self.source, "cpu_s", 0.0)), 3), **faults}
        if cost.size and len(solve_ms) == cost.size:
            total = cost + np.asarray(solve_ms, float)
            out["step_ms_median"] = round(float(np.median(total)), 4)
            out["step_ms_p99"] = round(float(np.percentile(total, 99)), 4)
        return out


def make_wave_source(kind: str, sea_waves: Any, roll_sign: float = 1.0, position_lag_s: float = 0.0,
                     vessel_params: Any = None, process: bool = False, wait_s: float | None = None) -> WaveSource:
    """``estimated``: the wave estimator (``make_estimator``: the window fit by default) fed by the autopilot's
    streams (``roll_sign`` +1 for the paper's
    plant, −1 for a real hull; ``position_lag_s`` the GPS lag it compensates), with the hull's roll/pitch
    response to the slope measured on the vessel model (``vessel_params``, riding the sea as a real hull
    does; about a second) as the in-process experiment does; ``scenario``: the scenario's sea
    (``sea_waves``), simulation truth. ``process``: the estimator in a process of its own (``wave_process``; waiting
    ``wait_s`` at most for it, default ``WAIT_S``; 0 when paced: never); the caller closes it."""
    from dataclasses import replace

    from mavbridge.waves import EstimatorSettings, make_estimator
    from mavbridge.waves.source import ScenarioTruth

    if kind == "scenario":  # (``sea_waves`` may be a callable: the sea is built only for simulation truth)
        return ScenarioTruth(sea_waves() if callable(sea_waves) else sea_waves)
    if kind != "estimated":
        raise ValueError(f"waves: {kind!r} is not one of estimated, scenario")
    settings = EstimatorSettings(roll_sign=roll_sign, position_lag_s=position_lag_s)
    if vessel_params is not None:
        from mavbridge.waves.inloop import calibrated_settings

        settings = replace(calibrated_settings(vessel_params, True, roll_sign), position_lag_s=position_lag_s)
    if process:
        from mavbridge.companion.wave_process import WAIT_S, EstimatorProcess

        return EstimatorProcess(settings, WAIT_S if wait_s is None else wait_s)
    return make_estimator(settings)
