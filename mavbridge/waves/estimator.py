"""The wave estimator: the dominant regular wave seen from the boat's own motion (a ``WaveSource``).

Driven only by what an ArduPilot Rover streams (``MotionSample``: ATTITUDE, GPS position/velocity,
optionally the IMU's specific force), on the autopilot's clock. Per sample (``observe``), in scalar
Python: roll and pitch are high-passed and rotated by ψ into the NED surface slope (the hull's roll and
pitch follow the slope; ``roll_sign`` says which roll sign the hull has), the vertical acceleration
a_D = (R·f)_D + g and the GPS down position are high-passed; a coarse tracker (zero crossings by default,
a normalised Belleter observer as an option) finds the encounter frequency ω_e on the slope along its
principal axis; an oscillator at ω_e demodulates every signal (recursive LMS sinusoid fits) and a
frequency-locked loop on the common rotation of the slope phasors pulls the oscillator onto ω_e (what
rotation is left is added to ω_e and undone in the phasors). The hull's own roll/pitch response to
the slope (gain, phase; ``calibration``) is divided out of the roll and pitch phasors. One convention for
roll: ``roll_sign`` alone says which way the hull rolls with the slope across it (+1 the paper's plant,
−1 geometric, a real hull), and ``roll_phase_deg`` is only the hull's dynamic lag behind roll_sign × slope
(within ±90°; the calibration measures it with the model hull rolling that way), so a sign is never also a
phase near ±180°. The estimates carry the sign, so the NMPC predicts the roll the hull has. Per estimate,
``solve`` turns the phasors into the wave: with heave (IMU, else GPS height), k = |slope|/|heave| and
the travel direction from the quadrature of slope against heave, ω = ω_e + k·(V·d); without heave (the
paper's hull), k, ω and the sign of the direction come from the Doppler line (``doppler``) once the
boat's speed along the wave has varied and settled (legs of ≈ 30 s at each speed).

Confidence (0..1) is the product of: the lock (with heave, the earth-frame solution's steadiness,
``steadiness``; without, ω_e steady, the phasors barely rotating, the trackers agreeing), the time since
the last start, gap, turn or heading jump (``settle_s``), the slope's signal-to-noise and size, the
one-wave consistency (slope in quadrature with heave), and in the Doppler case the line's standard error.
``estimate`` answers None below ``min_confidence``; ``latest`` always answers (for logs), ``diagnostics``
gives ω_e and the axis without a solution, ``spread`` the sea's slope statistics (``spread`` module).

Blind to: a boat at rest without heave (no Doppler, no k); following seas near the wave's phase speed
(ω_e → 0); waves shorter than a few hull lengths; near the roll resonance "roll = slope" is off. Bad
input (NaN, frozen attitude, heading jump, no IMU) lowers the confidence; nothing raises or gives NaN.
"""

from __future__ import annotations

import cmath
import math

import numpy as np

from mavbridge.waves.doppler import DopplerLine
from mavbridge.waves.filters import CLOCK_BACK_S, MeanRemover, SinusoidFit, lag_correction, lpf_gain
from mavbridge.waves.filters import finite as _finite
from mavbridge.waves.filters import smooth_step as _smooth_step
from mavbridge.waves.heave import HEAVE_GPS, HEAVE_IMU, HEAVE_NONE, HeaveFits
from mavbridge.waves.motion_watch import MotionWatch
from mavbridge.waves.oscillator import EncounterOscillator
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.solve import WaveSolution, phase_offset, plausible, solve_slope_only, solve_with_heave
from mavbridge.waves.source import MotionSample, WaveEstimate
from mavbridge.waves.spread import SlopeSpread
from mavbridge.waves.steadiness import SolutionSteadiness

__all__ = ["HEAVE_GPS", "HEAVE_IMU", "HEAVE_NONE", "WaveEstimator"]


class WaveEstimator:
    """``WaveSource`` that fits the dominant regular wave to the boat's motion (see the module docstring)."""

    name = "estimated"

    def __init__(self, settings: EstimatorSettings | None = None) -> None:
        self.s = settings or EstimatorSettings()
        s = self.s
        self._hp = {key: MeanRemover(s.mean_tau_s) for key in ("roll", "pitch")}
        self._osc = EncounterOscillator(s)
        self._fit = {key: SinusoidFit(s.fit_tau_s) for key in ("sn", "se", "roll", "pitch")}
        self._heave = HeaveFits(s)
        self._heading = (1.0, 0.0)  # low-passed (cos ψ, sin ψ)
        self._doppler = DopplerLine(s.doppler_memory_s, s.doppler_spread_mps)
        self._steady, self._steady_t = SolutionSteadiness(), -math.inf
        self._t: float | None = None
        self._dt = 0.05
        self._watch = MotionWatch(s)
        self._quiet_since = 0.0
        self._last_att_t = -math.inf
        self._doppler_t = -math.inf
        self._spread = SlopeSpread()  # the sea's slope statistics (the expected-roll term)

    def observe(self, sample: MotionSample) -> None:
        """Take one motion sample (any rate, in time order); bad samples only lower the confidence."""
        stamp = _finite((sample.t_s,), 1)
        t = stamp[0] if stamp is not None else None
        if t is None:
            return
        if self._t is not None and t <= self._t:
            if t >= self._t - CLOCK_BACK_S:  # a repeat, or out of order: dropped
                return
            self.__init__(self.s)  # the clock went back (a reboot): all it knew is on the old clock (the fits'
            # phases, the Doppler and settling times); this sample starts again
        if self._t is None or t - self._t > self.s.max_gap_s:
            self._restart(t)
            return
        dt = t - self._t
        self._t, self._dt = t, dt
        self._watch.navigate(sample, dt)
        att = self._watch.attitude(sample, dt)
        if att is None:  # not finite, or frozen: a stale stream restarts the settling clock
            self._quiet_since = t
            return
        self._last_att_t = t
        if self._watch.manoeuvring(att[2], dt):  # a turn or a jump changes ω_e
            self._quiet_since = t
        roll, pitch, slope_n, slope_e = self._slopes(att, dt)
        self._spread.update(att[0] * self.s.roll_sign / self.s.roll_gain, att[1] / self.s.pitch_gain, att[2], dt)
        self._osc.advance(slope_n, slope_e, dt, self._fit_quality())
        prev = (self._fit["sn"].X, self._fit["se"].X)
        rotor = cmath.exp(1j * self._osc.theta)
        for key, value in (("sn", slope_n), ("se", slope_e), ("roll", roll), ("pitch", pitch)):
            self._fit[key].update(value, rotor, dt)
        self._heave.update(sample, att, rotor, t, dt)
        self._osc.update_lock(prev, (self._fit["sn"].X, self._fit["se"].X), dt)
        self._update_doppler(t)
        self._update_steadiness(t)

    def _restart(self, t: float) -> None:
        """First sample, or after a long silence: keep the fits, restart the settling clock."""
        self._t = t
        self._quiet_since = t
        self._spread.restart()
        self._steady.reset()
        self._watch.restart()

    def _slopes(self, att: tuple[float, ...], dt: float) -> tuple[float, float, float, float]:
        """High-passed slope across and along the hull (roll × roll_sign, pitch) and rotated by ψ into NED."""
        roll = self._hp["roll"].update(att[0], dt) * self.s.roll_sign
        pitch = self._hp["pitch"].update(att[1], dt)
        c, s = math.cos(att[2]), math.sin(att[2])
        g = lpf_gain(dt, self.s.fit_tau_s)
        self._heading = (self._heading[0] + g * (c - self._heading[0]), self._heading[1] + g * (s - self._heading[1]))
        return roll, pitch, pitch * c - roll * s, pitch * s + roll * c

    def _slope_phasors(self, comp: complex) -> tuple[complex, complex]:
        """NED slope phasors from the hull's roll and pitch phasors, the hull's response undone.

        The hull's roll and pitch follow the surface slope through its own dynamics: near ω_e the
        ratio attitude/slope is (``roll_gain``, ``roll_phase_deg``) and (``pitch_gain``,
        ``pitch_phase_deg``), which ``calibration`` measures on the vessel model (1, 0°: exact following).
        """
        s = self.s
        roll = self._fit["roll"].X * comp / cmath.rect(s.roll_gain, math.radians(s.roll_phase_deg))
        pitch = self._fit["pitch"].X * comp / cmath.rect(s.pitch_gain, math.radians(s.pitch_phase_deg))
        c, sn = self._heading
        norm = math.hypot(c, sn) or 1.0
        c, sn = c / norm, sn / norm
        return pitch * c - roll * sn, pitch * sn + roll * c

    def _update_doppler(self, t: float) -> None:
        """Once a second, when locked: a point (u·V, ω_e) for the slope-only Doppler fit."""
        if t - self._doppler_t < 1.0 or self._osc.lock_quality() < 0.7 or t - self._quiet_since < self.s.settle_s:
            return
        u = self._osc.axis
        dt = t - self._doppler_t if math.isfinite(self._doppler_t) else 1.0
        v1, v = self._watch.vel_two
        if math.hypot(v1[0] - v[0], v1[1] - v[1]) > 0.05 or not self._osc.steady():
            return  # speed or ω_e still settling: no point
        self._doppler.add(u[0] * v[0] + u[1] * v[1], self._osc.w_mean, dt)
        self._doppler_t = t

    def _update_steadiness(self, t: float) -> None:
        """Every 0.1 s of samples, the heave solve into the steadiness (else reset): what the boat did decides."""
        if t - self._steady_t < 0.1 or not self._osc.w_mean > 0:
            return
        self._steady_t, (sol, extras) = t, self._solve(self._osc.w_mean)
        if sol is not None and extras.get("mode") == 1.0:
            self._steady.update(t, sol.omega, sol.travel_dir_rad)
        else:
            self._steady.reset()  # steadiness is the heave solve's: earned again when it comes back

    def _fit_quality(self) -> float:
        """Share of the slope signal the sinusoid fits explain (0 = none .. 1 = all)."""
        fit_n, fit_e = self._fit["sn"], self._fit["se"]
        power = fit_n.power + fit_e.power
        if power <= 0:
            return 0.0
        return max(0.0, min(1.0, 1.0 - (fit_n.residual_power + fit_e.residual_power) / power))

    # ----------------------------------------------------------------- estimate
    def _compensation(self, omega_e: float) -> complex:
        """Undo the fits' lag on a rotating phasor and the high-pass's response at ω_e."""
        return (1 + 1j * self._osc.dw * self.s.fit_tau_s) / self._hp["roll"].response(omega_e)

    def _solve(self, omega_e: float) -> tuple[WaveSolution | None, dict[str, float]]:
        """The wave from the phasors: with heave if the heave is real, else from the Doppler line."""
        comp = self._compensation(omega_e)
        sn, se = self._slope_phasors(comp * lag_correction(omega_e, self.s.attitude_lag_s))
        extras = {"mode": 0.0, "heave_source": HEAVE_NONE}
        elev = self._heave.elevation(self._t or 0.0, omega_e, comp)
        if elev is not None and 2 * abs(elev[0]) >= self.s.min_height_m:
            v = self._watch.vel_two[1]  # averaged like ω_e (two 2 s stages): ω = ω_e + k·(V·d) pairs them
            sol = solve_with_heave(sn, se, elev[0], omega_e, v[0], v[1], self._osc.theta)
            if sol is not None and plausible(sol, self.s.wavelength_min_m, self.s.wavelength_max_m):
                extras.update(mode=1.0, heave_source=elev[1])
                return sol, extras
        fit = self._doppler.fit()
        if fit is None:
            return None, extras
        omega, kappa, rel = fit
        u = self._osc.axis
        chi = math.atan2(u[1], u[0]) + (0.0 if kappa > 0 else math.pi)
        sol = solve_slope_only(sn, se, chi, abs(kappa), omega, self._osc.theta)
        extras.update(mode=2.0, doppler_rel_err=rel)
        ok = sol is not None and plausible(sol, self.s.wavelength_min_m, self.s.wavelength_max_m)
        return (sol if ok else None), extras

    def _confidence(self, sol: WaveSolution, extras: dict[str, float]) -> float:
        """Product of lock (with heave: the solution's steadiness), settling, slope SNR and one-wave consistency."""
        t = self._t or 0.0
        if t - self._last_att_t > 0.5:
            return 0.0
        settle = _smooth_step((t - self._quiet_since - self.s.settle_s) / max(self.s.settle_s, 1.0))
        fit_n, fit_e = self._fit["sn"], self._fit["se"]
        snr = (abs(fit_n.X) ** 2 + abs(fit_e.X) ** 2) / max(
            fit_n.noise_variance(self._dt) + fit_e.noise_variance(self._dt), 1e-30)
        slope_amp = math.hypot(abs(fit_n.X), abs(fit_e.X))
        strong = _smooth_step(slope_amp / max(self.s.min_slope_rad, 1e-9) - 1.0)
        lock = self._steady.value if extras.get("mode") == 1.0 else self._osc.lock_quality()
        conf = lock * settle * (snr / (snr + 100.0)) * strong
        conf *= math.exp(-((sol.consistency / 0.3) ** 2))
        if extras.get("mode") == 2.0:
            conf *= math.exp(-((extras.get("doppler_rel_err", 1.0) / 0.15) ** 2))
        extras.update(lock=lock, settle=settle, snr=snr, consistency=sol.consistency)
        return max(0.0, min(1.0, conf)) if math.isfinite(conf) else 0.0

    def latest(self, t_s: float) -> WaveEstimate | None:
        """The current fit whatever its confidence (for logs); None when nothing can be solved yet."""
        if self._t is None:
            return None
        omega_e = self._osc.w_mean
        if not omega_e > 0:
            return None
        sol, extras = self._solve(omega_e)
        axis = self._osc.axis
        extras.update(encounter_freq_rad_s=omega_e, axis_deg=math.degrees(math.atan2(axis[1], axis[0])))
        if sol is None:
            return None
        conf = self._confidence(sol, extras)
        lag = self.s.position_lag_s
        north, east = self._watch.pos[0] + self._watch.vel[0] * lag, self._watch.pos[1] + self._watch.vel[1] * lag
        eps = phase_offset(sol, self._t, north, east)
        return WaveEstimate(2 * sol.amplitude_m, 2 * math.pi / sol.omega, 2 * math.pi / sol.wavenumber,
                            math.remainder(sol.travel_dir_rad, 2 * math.pi), eps, conf, extras, self.s.roll_sign)

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The wave to plan against at ``t_s`` (its phase is time-invariant); None while not confident."""
        est = self.latest(t_s)
        if est is None or est.confidence < self.s.min_confidence:
            return None
        return est

    def spread(self, explained: bool) -> np.ndarray | None:
        """NED covariance (2×2, rad²) of the slope the hull follows that the wave model does not explain,
        None while unknown: all of it, or with a confident estimate in use (``explained``) the share the
        sinusoid fits leave (an irregular sea's remainder; near zero in a regular sea). None too while the
        attitude stream is bad (NaN, frozen) or silent: a blind boat flies Direct."""
        c = self._spread.covariance(self.s.min_slope_rad) if (self._t or 0.0) - self._last_att_t <= 0.5 else None
        return c * (1.0 - self._fit_quality()) if c is not None and explained else c

    def encounter_frequency(self) -> float:
        """The tracked (averaged) encounter frequency ω_e in rad/s."""
        return self._osc.w_mean

    def diagnostics(self) -> dict[str, float]:
        """What is seen even without a wave solution: ω_e, the slope axis (° NED, mod 180), lock, slope."""
        fit_n, fit_e = self._fit["sn"], self._fit["se"]
        return {"encounter_freq_rad_s": self._osc.w_mean, "lock": self._osc.lock_quality(),
                "axis_deg": math.degrees(math.atan2(self._osc.axis[1], self._osc.axis[0])),
                "fit_quality": self._fit_quality(), "slope_amp_rad": math.hypot(abs(fit_n.X), abs(fit_e.X))}
