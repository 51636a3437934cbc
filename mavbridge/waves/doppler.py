"""k and ω from the Doppler shift alone, for a hull that does not heave (the paper's own model).

Without heave only the slopes are seen: they give the axis u of the wave (up to sign) and the
encounter frequency ω_e, but neither the wavelength nor which way along u the waves travel. The
encounter frequency obeys ω_e = ω − κ·(u·V) with κ = ±k the signed wavenumber along u, so as the boat's
velocity component along u changes (speed changes, turns), a straight-line fit of ω_e against u·V
gives ω (intercept) and κ (slope): |κ| = k and sign(κ) the direction along u. A boat that holds speed
and course, or sits at rest, gives no spread in u·V and so no answer: the fit then reports no
confidence. The fit is an exponentially forgetting least-squares line, a few floats per sample.
"""

from __future__ import annotations

import math


class DopplerLine:
    """Forgetting least-squares fit of y = ω − κ·x (x = u·V m/s, y = ω_e rad/s)."""

    def __init__(self, memory_s: float, min_spread_mps: float) -> None:
        self.memory_s = memory_s
        self.min_spread = min_spread_mps
        self.reset()

    def reset(self) -> None:
        """Forget every point (e.g. when the wave axis changed)."""
        self.w = self.sx = self.sy = self.sxx = self.sxy = self.syy = 0.0

    def add(self, x: float, y: float, dt: float) -> None:
        """Add one point taken ``dt`` seconds after the previous one."""
        decay = math.exp(-dt / self.memory_s)
        self.w = self.w * decay + 1.0
        self.sx = self.sx * decay + x
        self.sy = self.sy * decay + y
        self.sxx = self.sxx * decay + x * x
        self.sxy = self.sxy * decay + x * y
        self.syy = self.syy * decay + y * y

    def fit(self) -> tuple[float, float, float] | None:
        """(ω, κ, relative standard error of κ), or None while the speed spread is too small."""
        if self.w < 5:
            return None
        mx, my = self.sx / self.w, self.sy / self.w
        var_x = max(self.sxx / self.w - mx * mx, 0.0)
        if var_x < self.min_spread ** 2:
            return None
        cov = self.sxy / self.w - mx * my
        var_y = max(self.syy / self.w - my * my, 0.0)
        slope = cov / var_x  # = −κ
        resid = max(var_y - slope * cov, 0.0)
        std_slope = math.sqrt(resid / (var_x * max(self.w - 2.0, 1.0)))
        kappa = -slope
        omega = my + kappa * mx
        rel = std_slope / abs(kappa) if kappa != 0 else math.inf
        return omega, kappa, rel
