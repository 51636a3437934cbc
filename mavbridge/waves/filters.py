"""Cheap recursive filters for the wave estimator: scalar Python, one call per sample, no arrays.

* :class:`MeanRemover` — a high-pass x − LPF(x) whose known response is undone at the wave frequency;
* :class:`FrequencyTracker` — a normalised Belleter–Galeazzi–Fossen observer of the dominant
  (encounter) frequency: a critically damped second-order filter x₁ of the signal and a gradient law
  that fits ẍ₁ = θ·x₁, so that θ → −ω²; the input is divided by its running RMS so that the
  adaptation rate does not depend on the wave's amplitude (both adapt at a rate ∝ amplitude² otherwise);
* :class:`SinusoidFit` — a least-mean-squares fit of x ≈ Re(X·e^{iθ}) for a given running phase θ
  (a complex demodulator that cancels its own 2ω image), with the residual power as a noise estimate.
"""

from __future__ import annotations

import cmath
import math

import numpy as np

_PLAIN_FLOATS = (np.dtype(np.float64), np.dtype(np.float32))  # whose ``tolist`` gives Python floats
CLOCK_BACK_S = 5.0  # a sample this much older than the last: the autopilot's clock went back (a reboot)


def finite(values: object, n: int) -> tuple[float, ...] | None:
    """The first ``n`` entries as floats if all finite, else None (also for None or short input).

    Called several times for every sample: a float vector gives its numbers in one ``tolist`` (indexing an array
    makes a numpy scalar of each number), and a finite sum proves every entry finite in one pass (only a sum that
    is not, an overflow or a bad entry, looks at each).
    """
    if values is None:
        return None
    if type(values) is np.ndarray and values.ndim == 1 and values.dtype in _PLAIN_FLOATS:
        if values.shape[0] < n:
            return None
        out = tuple(values[:n].tolist())
    else:
        try:
            out = tuple(float(values[i]) for i in range(n))  # type: ignore[index]
        except (TypeError, IndexError, ValueError):
            return None
    return out if math.isfinite(sum(out)) or all(math.isfinite(v) for v in out) else None


def smooth_step(x: float) -> float:
    """0 for x ≤ 0, 1 for x ≥ 1, smooth in between."""
    x = min(1.0, max(0.0, x))
    return x * x * (3 - 2 * x)


def lpf_gain(dt: float, tau: float) -> float:
    """The exact first-order low-pass blend factor for a step ``dt`` and a time constant ``tau``."""
    return 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0


class MeanRemover:
    """y = x − m with m a first-order running mean of time constant ``tau`` s (a first-order high-pass).

    The mean starts at 0 (roll, pitch, heave acceleration and height relative to home all average
    near 0) and its time constant grows from 2 s to ``tau`` over the first seconds, so that a start
    offset does not hide the zero crossings for long.
    """

    def __init__(self, tau: float) -> None:
        self.tau = tau
        self.mean = 0.0
        self.age = 0.0

    def update(self, x: float, dt: float) -> float:
        """Feed one sample; the high-passed value."""
        self.age += dt
        self.mean += lpf_gain(dt, min(self.tau, 2.0 + self.age)) * (x - self.mean)
        return x - self.mean

    def response(self, omega: float) -> complex:
        """The high-pass's complex gain at ω rad/s: iωτ / (1 + iωτ)."""
        s = 1j * omega * self.tau
        return s / (1 + s)


class FrequencyTracker:
    """Normalised Belleter-type estimator of the dominant frequency ω (rad/s) of a scalar signal."""

    def __init__(self, omega0: float, filter_rad_s: float, gain: float, omega_min: float, omega_max: float,
                 rms_tau: float = 8.0) -> None:
        self.w_f = filter_rad_s
        self.gain = gain
        self.omega_min, self.omega_max = omega_min, omega_max
        self.rms_tau = rms_tau
        self.omega0 = omega0
        self.reset()

    def reset(self, omega: float | None = None) -> None:
        """Start again from ``omega`` (default the initial guess)."""
        w = self.omega0 if omega is None else omega
        self.x1 = 0.0
        self.x2 = 0.0
        self.theta = -w * w
        self.power = 0.0
        self._dt = -1.0
        self._y_prev = 0.0
        self._age = 0.0

    @property
    def omega(self) -> float:
        """The current estimate, kept within [omega_min, omega_max]."""
        return min(self.omega_max, max(self.omega_min, math.sqrt(abs(self.theta))))

    def _discretise(self, dt: float) -> None:
        """Exact zero-order-hold transition of the critically damped filter for step ``dt``."""
        w = self.w_f
        e = math.exp(-w * dt)
        self._p11, self._p12 = e * (1 + w * dt), e * dt
        self._p21, self._p22 = -e * w * w * dt, e * (1 - w * dt)
        self._g1, self._g2 = 1 - self._p11, -self._p21
        self._dt = dt

    def update(self, y: float, dt: float) -> float:
        """Feed one sample of the (high-passed) signal; the frequency estimate in rad/s."""
        if self.power <= 0.0:  # first sample: start the RMS (and the filter) from it
            self.power = y * y
            self.x1 = self._y_prev = 1.0 if y > 0 else -1.0 if y < 0 else 0.0
        # the RMS adapts fast at first, then settles to its time constant
        self.power += lpf_gain(dt, min(self.rms_tau, 0.5 + 0.5 * self._age)) * (y * y - self.power)
        self._age += dt
        if self.power <= 1e-18:
            return self.omega
        yn = y / math.sqrt(self.power)
        if dt != self._dt:
            self._discretise(dt)
        y_mid = 0.5 * (yn + self._y_prev)  # hold the step's mean: the filter then has no half-step lag
        self._y_prev = yn
        x1, x2 = self.x1, self.x2
        self.x1 = self._p11 * x1 + self._p12 * x2 + self._g1 * y_mid
        self.x2 = self._p21 * x1 + self._p22 * x2 + self._g2 * y_mid
        w = self.w_f
        x1dd = w * w * (yn - self.x1) - 2 * w * self.x2
        step = dt * self.gain * self.x1 * (x1dd - self.theta * self.x1)
        self.theta += max(-0.5 * abs(self.theta) - 0.05, min(0.5 * abs(self.theta) + 0.05, step))
        self.theta = max(-self.omega_max ** 2, min(-self.omega_min ** 2, self.theta))
        return self.omega


class ZeroCrossingTracker:
    """Dominant frequency from the spacing of zero crossings (with hysteresis): fast to acquire, robust.

    A crossing counts once the signal has gone past ±``hysteresis``·RMS on the new side; its time is
    interpolated between the two samples around the sign change. ω = π / (mean of the last
    ``halves`` half-periods).
    """

    def __init__(self, omega0: float, omega_min: float, omega_max: float, halves: int = 4,
                 hysteresis: float = 0.4, rms_tau: float = 8.0) -> None:
        self.omega0, self.omega_min, self.omega_max = omega0, omega_min, omega_max
        self.halves, self.hysteresis, self.rms_tau = halves, hysteresis, rms_tau
        self.reset()

    def reset(self, omega: float | None = None) -> None:
        """Start again from ``omega`` (default the initial guess)."""
        self._omega = self.omega0 if omega is None else omega
        self.power = 0.0
        self._side = 0
        self._prev: tuple[float, float] | None = None
        self._candidate: float | None = None
        self._last_crossing: float | None = None
        self._intervals: list[float] = []
        self._t = 0.0

    @property
    def omega(self) -> float:
        """The current estimate in rad/s."""
        return self._omega

    @property
    def crossings(self) -> int:
        """How many half-periods the estimate rests on."""
        return len(self._intervals)

    def update(self, y: float, dt: float) -> float:
        """Feed one sample of the (high-passed) signal; the frequency estimate in rad/s."""
        self._t += dt
        self.power += lpf_gain(dt, min(self.rms_tau, 0.5 + 0.5 * self._t)) * (y * y - self.power)
        if self._prev is not None and (self._prev[1] < 0) != (y < 0) and y != self._prev[1]:
            t0, y0 = self._prev
            self._candidate = t0 + (self._t - t0) * (-y0) / (y - y0)
        self._prev = (self._t, y)
        level = self.hysteresis * math.sqrt(self.power)
        side = 1 if y > level else -1 if y < -level else 0
        if side != 0 and side != self._side:
            self._confirm(side)
        return self._omega

    def _confirm(self, side: int) -> None:
        """The signal reached the other side: the last sign change was a crossing."""
        crossing = self._candidate
        if self._side != 0 and crossing is not None:
            if self._last_crossing is not None:
                half = crossing - self._last_crossing
                if math.pi / self.omega_max <= half <= math.pi / self.omega_min:
                    self._intervals = [*self._intervals[-(self.halves - 1):], half]
                    self._omega = math.pi * len(self._intervals) / sum(self._intervals)
            self._last_crossing = crossing
        self._side = side


class SinusoidFit:
    """Recursive LMS fit of x(t) ≈ Re(X·e^{iθ(t)}): X the complex amplitude, time constant ``tau`` s."""

    def __init__(self, tau: float) -> None:
        self.tau = tau
        self.reset()

    def reset(self) -> None:
        """Forget the fit."""
        self.X = 0j
        self.residual_power = 0.0
        self.power = 0.0
        self.samples = 0

    def update(self, x: float, rotor: complex, dt: float) -> None:
        """Feed a sample x at the oscillator's rotor e^{iθ} (unit complex)."""
        mu = lpf_gain(dt, self.tau)
        err = x - (self.X * rotor).real
        self.X += mu * 2.0 * err * rotor.conjugate()
        self.residual_power += mu * (err * err - self.residual_power)
        self.power += mu * (x * x - self.power)
        self.samples += 1

    def noise_variance(self, dt: float) -> float:
        """Variance of X caused by white residual noise: 2σ²·dt/τ (one first-order stage)."""
        return 2.0 * self.residual_power * dt / self.tau

    def snr(self, dt: float) -> float:
        """|X|² over the variance noise puts into X (large: a clean sinusoid)."""
        return abs(self.X) ** 2 / max(self.noise_variance(dt), 1e-30)


def lag_correction(omega: float, lag_s: float) -> complex:
    """Multiply a phasor measured ``lag_s`` late by this to bring it to the present: e^{iωτ}."""
    return cmath.exp(1j * omega * lag_s)
