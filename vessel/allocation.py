"""Propeller thrust law and thrust allocation for the Otter's two fixed propellers, both ways.

Forward: shaft speeds (rad/s, left/right) -> thrust per propeller -> (τ_X N, τ_N N·m).
Inverse: (τ_X, τ_N) -> shaft speeds, using k_pos or k_neg by the sign of each thrust (the published
allocation uses k_pos for both, which is inexact in reverse) and saturating to [n_min, n_max].
Every function works on floats, numpy arrays and CasADi symbols.
"""

from __future__ import annotations

import math
from typing import Any

from vessel.mathops import ops, where
from vessel.params import OtterParameters


def saturate_shaft_speed(params: OtterParameters, n: Any) -> Any:
    """Clip shaft speed to [n_min, n_max] rad/s."""
    mats = params.matrices()
    xp = ops(n)
    return xp.fmin(xp.fmax(n, mats.n_min), mats.n_max)


def propeller_thrust(params: OtterParameters, n: Any) -> Any:
    """Thrust in N of a propeller turning at n rad/s (saturated): k_pos·n|n| forward, k_neg·n|n| reverse."""
    mats = params.matrices()
    n_sat = saturate_shaft_speed(params, n)
    k = where(n_sat > 0, mats.k_pos, mats.k_neg)
    return k * n_sat * ops(n_sat).fabs(n_sat)


def thrust_to_tau(params: OtterParameters, thrust_left: Any, thrust_right: Any) -> tuple[Any, Any]:
    """(τ_X, τ_N) from left/right thrust: more thrust on the left turns the bow to starboard (τ_N > 0)."""
    return thrust_left + thrust_right, params.pontoon_offset * (thrust_left - thrust_right)


def shaft_speeds_to_tau(params: OtterParameters, n_left: Any, n_right: Any) -> tuple[Any, Any]:
    """(τ_X N, τ_N N·m) produced by the two shaft speeds (rad/s), each propeller's thrust scaled by its
    ``propeller_scale`` (1, 1 as modelled)."""
    port, starboard = params.propeller_scale
    return thrust_to_tau(params, port * propeller_thrust(params, n_left), starboard * propeller_thrust(params, n_right))


def _float_shaft_speed(k_pos: float, k_neg: float, n_min: float, n_max: float, thrust: float) -> float:
    """Shaft speed (rad/s, saturated to [n_min, n_max]) that gives this finite thrust (N), with the thrust
    coefficient for its sign, in plain Python: the companion converts every control step's command, and numpy's
    calls on single numbers cost ten times more."""
    k = k_pos if thrust > 0 else k_neg
    sign = 1.0 if thrust > 0 else -1.0 if thrust < 0 else 0.0  # np.sign's
    return min(max(sign * math.sqrt(abs(thrust) / k), n_min), n_max)


def tau_to_shaft_speeds(params: OtterParameters, tau_x: float, tau_n: float) -> tuple[float, float]:
    """Shaft speeds (left, right) in rad/s for surge force τ_X (N) and yaw moment τ_N (N·m), saturated."""
    if not (math.isfinite(tau_x) and math.isfinite(tau_n)):
        raise ValueError(f"tau: non-finite surge force {tau_x!r} N or yaw moment {tau_n!r} N·m")
    mats = params.matrices()
    limits = (float(mats.k_pos), float(mats.k_neg), float(mats.n_min), float(mats.n_max))
    differential = tau_n / params.pontoon_offset
    port, starboard = params.propeller_scale  # a weaker propeller is asked for more (then saturates sooner)
    left = _float_shaft_speed(*limits, float(0.5 * (tau_x + differential)) / port)
    right = _float_shaft_speed(*limits, float(0.5 * (tau_x - differential)) / starboard)
    return left, right


def tau_limits(params: OtterParameters) -> tuple[float, float, float]:
    """(max forward τ_X, max reverse τ_X magnitude, max |τ_N|) the saturated propellers can produce."""
    mats = params.matrices()
    forward = mats.k_pos * mats.n_max**2
    reverse = mats.k_neg * mats.n_min**2
    port, starboard = params.propeller_scale
    weaker = min(port, starboard)  # the yaw moment both ways: the weaker propeller limits one of them
    yaw = params.pontoon_offset * weaker * (forward + reverse)
    return (port + starboard) * forward, (port + starboard) * reverse, yaw


def achieved_tau(params: OtterParameters, tau_x: float, tau_n: float) -> tuple[float, float]:
    """(τ_X N, τ_N N·m) the two propellers give when asked for (τ_X, τ_N) through ``tau_to_shaft_speeds``: the
    command as the saturated propellers deliver it (a hard turn at speed asks for more than they have)."""
    left, right = tau_to_shaft_speeds(params, tau_x, tau_n)
    achieved_x, achieved_n = shaft_speeds_to_tau(params, left, right)
    return float(achieved_x), float(achieved_n)
