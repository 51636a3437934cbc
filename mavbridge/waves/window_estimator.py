"""The window estimator: the dominant regular wave fitted in the earth frame to the last seconds of motion.

A ``WaveSource`` fed by what an ArduPilot Rover streams (``MotionSample``: ATTITUDE, GPS position and
velocity, the IMU's specific force where streamed), on the autopilot's clock. Each sample is reduced to a
few numbers and kept (``window_s`` seconds of them): the boat's NED position and velocity, its heading, pitch
and roll × ``roll_sign`` (the slope along and across the hull), the hull's down acceleration from the IMU
(a_D = (R·f)_D + g) and, at each new GPS fix, its down position. Every ``fit_interval_s`` (twice that
once confident: a regular sea changes slowly, and the step's budget is shared with the NMPC) the wave
ζ = a·sin(ω t − k (N cos χ + E sin χ) + ε) is fitted to the window by ``window_fit``: warm from the last
fit, else from the window alone. Because the boat's own track is inside the wave's phase, the fit needs no
settling after a turn or a change of speed, and k comes from the ratio of slope to heave, no dispersion
relation (the paper's wave is not a deep-water one).

Confidence (0..1) is the product of: the share of the slope the wave explains, the fit's standard errors of
period, wavelength, direction and height (widened for correlated samples: full up to 1 %, 3.3 %, 3.3° and 5 %,
nothing at twice those, a third and two thirds of what issue 29 allows the estimate to be off by), the window
covering enough encounter periods (nothing at 1.25, full from 2.25), the slope being a sea (above
``min_slope_rad``) and the last two fits agreeing. ``estimate`` answers None below ``min_confidence``;
``latest`` always answers (for logs); ``spread`` gives the NED covariance of the slope the wave does not
explain (once confident: the fit's residual; before: the sea's slope statistics, ``spread``), the
expected-roll term's input.

Blind to what one regular component cannot show (an irregular sea fits partly, with lower confidence); a
boat at rest with neither IMU nor GPS height cannot size k. Bad input (NaN, a frozen attitude, a clock going
back) is dropped or restarts the window; nothing raises or gives NaN.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from mavbridge.waves.filters import CLOCK_BACK_S, finite, smooth_step
from mavbridge.waves.heave import HEAVE_GPS, HEAVE_IMU, HEAVE_NONE
from mavbridge.waves.motion_watch import MotionWatch
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.source import MotionSample, WaveEstimate
from mavbridge.waves.spread import SlopeSpread
from mavbridge.waves.staged import AheadJob, FitStages
from mavbridge.waves.window_buffer import MotionWindow
from mavbridge.waves.window_fit import Fit, dominant_encounter_frequency, initial_guess, refine_stages
from mavbridge.waves.window_model import HullResponse, WaveParams, Window

STAGE_S = 0.09  # at most one stage of a fit per this much sample time (one per 0.1 s control step)
WARM_ITERATIONS = 2  # Gauss–Newton iterations of a fit warm-started from the last one
STALE_S = 0.5  # no valid attitude for this long: no confidence (a blind boat flies Direct)
# Standard errors at which the confidence starts to fall (it is 0 at twice them): a third of what the estimate
# may be off by when the roll term relies on it (period 3 %, wavelength 10 %, direction 10°, height 15 %)
SIGMA_PERIOD, SIGMA_LENGTH, SIGMA_HEIGHT = 0.01, 0.033, 0.05
SIGMA_DIRECTION_RAD = math.radians(3.3)


def _within(sigma: float, limit: float) -> float:
    """1 while a standard error is at most ``limit``, falling smoothly to 0 at twice it."""
    return smooth_step(2.0 - sigma / limit) if math.isfinite(sigma) else 0.0


def hull_response(s: EstimatorSettings) -> HullResponse:
    """The settings' hull response as the fit's model wants it (a lag is a negative calibrated phase)."""
    return HullResponse(s.roll_gain, -math.radians(s.roll_phase_deg), s.pitch_gain, -math.radians(s.pitch_phase_deg),
                        s.position_lag_s)


class WindowEstimator:
    """``WaveSource`` that fits one regular wave to a window of the boat's motion (see the module docstring)."""

    name = "estimated"

    def __init__(self, settings: EstimatorSettings | None = None) -> None:
        self.s = settings or EstimatorSettings()
        self.hull = hull_response(self.s)
        self._motion = MotionWindow(self.s.window_s, self.s.roll_sign, self.s.position_lag_s)
        self._t: float | None = None
        self._last_att_t = -math.inf
        self._watch = MotionWatch(self.s)
        self._spread = SlopeSpread()
        self._fit: Fit | None = None
        self._fit_t = -math.inf  # autopilot time of the last fit attempt
        self._origin = (0.0, 0.0, 0.0)  # the last fit's origin: autopilot time, north, east (m) of its window end
        self._window_origin: tuple[float, float, float] | None = None  # the origin of the window being fitted
        self._job: AheadJob | None = None  # the fit in progress
        self._stage_t = -math.inf  # sample time of its last stage
        self._previous: Fit | None = None
        self._omega_e_seen: float | None = None  # the slope's dominant encounter frequency at the last cold start
        self._confidence = 0.0
        self.fits = self.cold_starts = 0

    # ------------------------------------------------------------------ samples
    def observe(self, sample: MotionSample) -> None:
        """Take one motion sample (any rate, in time order); bad samples are dropped."""
        stamp = finite((sample.t_s,), 1)
        if stamp is None:
            return
        t = stamp[0]
        if self._t is not None and t <= self._t:
            if t >= self._t - CLOCK_BACK_S:  # a repeat, or out of order: dropped
                return
            self._forget()  # the clock went back (a reboot): the window belongs to the old clock, and this sample
            self._t, self._last_att_t = None, -math.inf  # starts the new one (not every sample dropped until then)
        dt = t - self._t if self._t is not None else 0.05
        if dt > self.s.window_s:
            self._forget()
            dt = 0.05
        self._t = t
        self._watch.navigate(sample, dt)
        att = self._watch.attitude(sample, dt)
        pos, vel = finite(sample.position_ned, 3), finite(sample.velocity_ned, 2)
        if att is None or pos is None or vel is None:
            return
        if t - self._last_att_t > STALE_S:  # the stream was bad or silent: trust the wave again only once a fit
            self._confidence = 0.0  # on data from after the fault has confirmed it
        self._last_att_t = t
        self._spread.update(att[0] * self.s.roll_sign / self.s.roll_gain, att[1] / self.s.pitch_gain, att[2], dt)
        self._motion.store(t, att, pos, vel, sample.accel_body, dt)
        self._advance_fit(t)

    def _forget(self) -> None:
        """A clock reset or a silence longer than the window: start the window again (the statistics stay)."""
        self._motion.clear()
        self._fit = self._previous = None
        self._job = self._window_origin = None
        self._confidence = 0.0
        self._fit_t = -math.inf
        self._spread.restart()
        self._watch.restart()

    # ------------------------------------------------------------------ fitting
    def _advance_fit(self, t: float) -> None:
        """One stage of the fit in progress (about one evaluation of the model over the window, a few tenths of
        a millisecond), or start the next fit when one is due: a fit is spread over several control steps (one
        stage per ``STAGE_S``) so that no step carries a whole one."""
        if self._job is None:
            interval = self.s.fit_interval_s * (2.0 if self._confidence >= self.s.min_confidence else 1.0)
            if t - self._fit_t < interval:
                return
            self._fit_t = t
            built = self._motion.window(t)  # (its stages read only it and what stays fixed until the fit ends)
            self._window_origin = built[1] if built is not None else None
            self._job = AheadJob(functools.partial(self._fit_stages, built))
        elif t - self._stage_t < STAGE_S:
            return
        self._stage_t = t
        finished, value = self._job.due()
        if finished:
            self._job = None
            self._finish(value)
        elif value is not None:  # what the stage found out, visible from its due time (not when it was worked)
            self._omega_e_seen = value.get("omega_e_seen", self._omega_e_seen)
            self.cold_starts += value.get("cold_starts", 0)

    def work_ahead(self) -> bool:
        """Do the next stage of the fit in progress now, ahead of its due time (a process of its own runs the
        estimator and calls this while no sample waits): its result is kept and takes effect only when the
        stage falls due, so the answers are the same whenever the work was done. True while more is left."""
        return self._job is not None and self._job.work_ahead()

    def _fit_stages(self, built: tuple[Window, tuple[float, float, float]] | None) -> FitStages:
        """A new fit on the window ``built`` (and its origin): warm from the last one, else cold (see
        ``refine_stages``). A stage may yield what it found out (a dict), which ``_advance_fit`` applies when the
        stage falls due. The stages read nothing of the estimator that changes before the fit ends (the last fit,
        its origin, the window's origin, the hull and settings): a copy of the estimator makes them again."""
        yield  # (the first stage: the window, built when the fit started)
        if built is None or built[0].span_s < self.s.min_window_s:
            return None
        window = built[0]
        fit = None
        if self._fit is not None and self._fit.slope_explained >= 0.5:
            fit = yield from refine_stages(window, self._moved(self._fit.wave), self.hull, WARM_ITERATIONS,
                                           self._fit.noise)
        if fit is None or fit.slope_explained < 0.5:
            seen = dominant_encounter_frequency(window, self.s.omega_min_rad_s, self.s.omega_max_rad_s)
            yield {"omega_e_seen": seen}
            start = initial_guess(window, self.s.omega_min_rad_s, self.s.omega_max_rad_s, seen)
            yield {"cold_starts": 1}
            fit = (yield from refine_stages(window, start, self.hull)) if start is not None else None
        return fit

    def _finish(self, fit: Fit | None) -> None:
        """A fit is done (None: the window showed no wave): it becomes the current one, with its confidence."""
        if fit is None and self._window_origin is None:
            return  # too little data yet: nothing fitted, nothing to forget
        self.fits += 1
        self._previous, self._fit, self._origin = self._fit, fit, self._window_origin
        self._confidence = self._score(fit) if fit is not None else 0.0

    def _moved(self, wave: WaveParams) -> WaveParams:
        """The last fit's wave referred to the new window's origin (time and place): a warm start."""
        (t0, n0, e0), (t1, n1, e1) = self._origin, self._window_origin or self._origin
        ds = (n1 - n0) * math.cos(wave.chi) + (e1 - e0) * math.sin(wave.chi)
        return wave.shifted(t1 - t0 - wave.k * ds / wave.omega)

    def _score(self, fit: Fit) -> float:
        """The confidence of a fit (see the module docstring)."""
        wave = fit.wave
        omega_e = max(abs(wave.omega - wave.k * self._mean_velocity_along(wave.chi)), 1e-3)
        cover = smooth_step(fit.span_s * omega_e / (2 * math.pi) - 1.25)
        slope = smooth_step(wave.amplitude * wave.k / max(self.s.min_slope_rad, 1e-9) - 1.0)
        errors = (_within(fit.rel_sigma_omega, SIGMA_PERIOD) * _within(fit.rel_sigma_k, SIGMA_LENGTH)
                  * _within(float(fit.sigma[2]), SIGMA_DIRECTION_RAD)
                  * _within(fit.rel_sigma_amplitude, SIGMA_HEIGHT))
        explained = smooth_step((fit.slope_explained - 0.3) / 0.5)
        conf = cover * slope * errors * explained * self._agreement(fit)
        return max(0.0, min(1.0, conf)) if math.isfinite(conf) else 0.0

    def _agreement(self, fit: Fit) -> float:
        """1 when the previous fit found the same wave (period 2 %, wavelength 5 %, direction 5°), → 0 else."""
        prev = self._previous
        if prev is None:
            return 0.0
        a, b = fit.wave, prev.wave
        return (math.exp(-((a.omega / b.omega - 1) / 0.02) ** 2) * math.exp(-((a.k / b.k - 1) / 0.05) ** 2)
                * math.exp(-(math.remainder(a.chi - b.chi, 2 * math.pi) / math.radians(5.0)) ** 2))

    def _mean_velocity_along(self, chi: float) -> float:
        v = self._watch.vel
        return v[0] * math.cos(chi) + v[1] * math.sin(chi)

    # ------------------------------------------------------------------ answers
    def _current_confidence(self) -> float:
        if (self._t or 0.0) - self._last_att_t > STALE_S:
            return 0.0
        return self._confidence

    def latest(self, t_s: float) -> WaveEstimate | None:
        """The current fit whatever its confidence (for logs); None before the first fit."""
        fit = self._fit
        if fit is None:
            return None
        wave = fit.wave
        t0, n0, e0 = self._origin  # Φ = ω (t − t0) − k ((N − n0) cos χ + (E − e0) sin χ): the absolute ε
        s0 = n0 * math.cos(wave.chi) + e0 * math.sin(wave.chi)
        eps = math.remainder(math.atan2(wave.beta, wave.alpha) - wave.omega * t0 + wave.k * s0, 2 * math.pi)
        heave = HEAVE_IMU if "accel" in fit.explained else HEAVE_GPS if "down" in fit.explained else HEAVE_NONE
        extras = {"mode": 3.0, "heave_source": heave, "fit_explained": fit.slope_explained,
                  "fit_samples": float(fit.samples),
                  "fit_span_s": fit.span_s, "sigma_period_pct": 100 * fit.rel_sigma_omega,
                  "sigma_length_pct": 100 * fit.rel_sigma_k, "sigma_dir_deg": math.degrees(float(fit.sigma[2])),
                  "encounter_freq_rad_s": wave.omega - wave.k * self._mean_velocity_along(wave.chi)}
        return WaveEstimate(2 * wave.amplitude, 2 * math.pi / wave.omega, 2 * math.pi / wave.k,
                            math.remainder(wave.chi, 2 * math.pi), eps, self._current_confidence(), extras,
                            self.s.roll_sign)

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The wave to plan against at ``t_s`` (its phase is time-invariant); None while not confident."""
        est = self.latest(t_s)
        if est is None or est.confidence < self.s.min_confidence:
            return None
        if not self.s.wavelength_min_m <= est.length_m <= self.s.wavelength_max_m:
            return None
        return est

    def spread(self, explained: bool) -> np.ndarray | None:
        """NED covariance (2×2, rad²) of the slope the wave model does not explain, None while unknown: with a
        confident estimate in use (``explained``) the fit's residual, else the sea's slope statistics; None too
        while the attitude stream is bad or silent (a blind boat flies Direct)."""
        if (self._t or 0.0) - self._last_att_t > STALE_S:
            return None
        if explained and self._fit is not None:
            return self._fit.residual_slope_cov.copy()
        return self._spread.covariance(self.s.min_slope_rad)

    def encounter_frequency(self) -> float:
        """The encounter frequency ω_e (rad/s): the fit's at the boat's mean velocity, or without a fit the slope's
        dominant one in the last window (a hull that does not heave shows it too); 0 before any window."""
        fit = self._fit
        if fit is None:
            return self._omega_e_seen or 0.0
        return fit.wave.omega - fit.wave.k * self._mean_velocity_along(fit.wave.chi)

    def diagnostics(self) -> dict[str, float]:
        """What the fit shows: ω_e, the wave's axis (° NED), the confidence, the share explained, the slope."""
        fit = self._fit
        if fit is None:
            return {"encounter_freq_rad_s": self.encounter_frequency(), "lock": 0.0, "axis_deg": 0.0,
                    "fit_quality": 0.0, "slope_amp_rad": 0.0}
        return {"encounter_freq_rad_s": self.encounter_frequency(), "lock": self._current_confidence(),
                "axis_deg": math.degrees(fit.wave.chi), "fit_quality": fit.slope_explained,
                "slope_amp_rad": fit.wave.amplitude * fit.wave.k}
