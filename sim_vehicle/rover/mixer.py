"""ArduPilot's skid-steer mixer and output scaling: steering/throttle -> motors -> PWM -> shaft speed."""

from __future__ import annotations

import math


def skid_mix(
    steering: float, throttle: float, str_thr_mix: float = 0.5, asym: float = 1.0
) -> tuple[float, float]:
    """Steering and throttle in [-1, 1] -> (left, right) motor outputs in [-1, 1], as AP_MotorsUGV mixes.

    Positive steering (turn right) speeds up the left motor. When |t| + |s| exceeds 1 the mix
    parameter decides which of the two gives way.
    """
    s = min(1.0, max(-1.0, steering))
    t = min(1.0, max(-1.0, throttle))
    total = abs(s) + abs(t)
    if total > 1.0:
        mix = min(1.0, max(0.0, str_thr_mix))
        fair = 1.0 / total
        if mix >= 0.5:
            s *= fair + (1.0 - fair) * (mix - 0.5) / 0.5
            t = math.copysign(1.0 - abs(s), t)
        else:
            t *= fair + (1.0 - fair) * (0.5 - mix) / 0.5
            s = math.copysign(1.0 - abs(t), s)
    return _asymmetric(t + s, asym), _asymmetric(t - s, asym)


def _asymmetric(out: float, asym: float) -> float:
    """Apply MOT_THST_ASYM: the reverse range is limited to -1/a and then stretched back to -1."""
    a = max(1.0, asym) if math.isfinite(asym) else 1.0
    out = min(1.0, max(-1.0 / a, out))
    return out * a if out < 0 else out


def output_to_pwm(out: float, pwm_min: float, trim: float, pwm_max: float, reversed_: bool) -> int:
    """Motor output in [-1, 1] -> servo PWM (µs) about SERVOn_TRIM."""
    out = min(1.0, max(-1.0, -out if reversed_ else out))
    pwm = trim + out * (pwm_max - trim) if out >= 0 else trim + out * (trim - pwm_min)
    return round(pwm)


def pwm_to_output(pwm: int, pwm_min: float, trim: float, pwm_max: float, reversed_: bool) -> float:
    """What the ESC makes of a PWM: the motor output in [-1, 1]; 0 µs (no pulse) means stopped."""
    if pwm <= 0:
        return 0.0
    if pwm >= trim:
        out = (pwm - trim) / (pwm_max - trim) if pwm_max > trim else 0.0
    else:
        out = (pwm - trim) / (trim - pwm_min) if trim > pwm_min else 0.0
    out = min(1.0, max(-1.0, out))
    return -out if reversed_ else out


def output_to_shaft_speed(out: float, n_max: float, n_min: float) -> float:
    """Motor output -> commanded shaft speed (rad/s): +1 is n_max, -1 is full reverse |n_min|."""
    return out * n_max if out >= 0 else out * abs(n_min)
