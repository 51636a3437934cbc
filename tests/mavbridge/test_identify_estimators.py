"""The identification's estimators against synthetic responses with known answers, with noise and gaps (seeded)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mavbridge.identify.ambient import ambient_estimates
from mavbridge.identify.analyse import Identification, frames, identify_axis
from mavbridge.identify.asymmetry import propeller_scale, straight_windows, thrust_ratio
from mavbridge.identify.decay import decay_estimates, find_decays, fit_decay
from mavbridge.identify.logdata import LogData
from mavbridge.identify.series import Stretch, stretches
from mavbridge.identify.surge import SurgePoint, fit_surge
from mavbridge.identify.yaw import Nomoto, nomoto_estimates

PERIOD_S, ZETA = 1.25, 0.12
OMEGA = 2 * math.pi / PERIOD_S


def decays_signal(rng: np.random.Generator, noise: float) -> tuple[np.ndarray, np.ndarray]:
    """Two free roll decays (6° and −4.6°) at 10 Hz with white sensor noise."""
    t = np.arange(0, 60, 0.1)
    y = np.zeros_like(t)
    for t0, amp in ((5.0, 0.1), (30.0, -0.08)):
        tau = t - t0
        on = tau >= 0
        y[on] += amp * np.exp(-ZETA * OMEGA * tau[on]) * np.cos(OMEGA * math.sqrt(1 - ZETA**2) * tau[on])
    return t, y + rng.normal(0, noise, t.size)


def test_free_decays_give_the_period_and_damping() -> None:
    t, y = decays_signal(np.random.default_rng(1), noise=0.003)
    found = find_decays(t, y, None, math.radians(1.5), 0.003)
    assert len(found) == 2
    fits = [fit_decay(t[a:b + 1], y[a:b + 1]) for a, b in found]
    period, zeta = decay_estimates([f for f in fits if f is not None], "roll")
    assert period.value == pytest.approx(PERIOD_S, rel=0.02)
    assert zeta.value == pytest.approx(ZETA, rel=0.1)
    assert period.low < PERIOD_S * 1.02 and period.high > PERIOD_S * 0.98
    assert period.fit > 0.95


def test_no_decay_is_found_while_turning_or_in_noise() -> None:
    t, y = decays_signal(np.random.default_rng(2), noise=0.003)
    assert find_decays(t, y, np.zeros(t.size, bool), math.radians(1.5), 0.003) == []  # never quiet: turning
    noise = np.random.default_rng(3).normal(0, 0.003, t.size)
    assert find_decays(t, noise, None, math.radians(1.5), 0.003) == []


def oscillator(seconds: float, rng: np.random.Generator, dt: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Roll of a hull with PERIOD_S and ZETA driven by white noise (exact discretisation), 2° RMS."""
    h = 0.01
    A = np.array([[0.0, 1.0], [-OMEGA**2, -2 * ZETA * OMEGA]])
    lam, V = np.linalg.eig(A * h)
    Ad = (V @ np.diag(np.exp(lam)) @ np.linalg.inv(V)).real
    n, every = round(seconds / h), round(dt / h)
    x, out = np.zeros(2), []
    kicks = rng.normal(0, math.sqrt(h), n)
    for k in range(n):
        x = Ad @ x + np.array([0.0, kicks[k]])
        if k % every == 0:
            out.append(x[0])
    y = np.asarray(out)
    return np.arange(y.size) * dt, y / np.std(y) * math.radians(2.0)


def test_ambient_motion_gives_the_period_and_damping_through_gaps_and_noise() -> None:
    rng = np.random.default_rng(4)
    t, y = oscillator(1200, rng)
    y = y + rng.normal(0, math.radians(0.1), y.size)
    keep = rng.random(t.size) > 0.05  # 5 % of the samples lost
    period, zeta, fit = ambient_estimates(stretches(t[keep], y[keep], 0.1, 0.4), "roll")
    assert period.value == pytest.approx(PERIOD_S, rel=0.05)
    assert zeta.value == pytest.approx(ZETA, rel=0.3)
    assert period.low < period.value < period.high
    assert fit.r2 > 0.6


def test_ambient_refuses_noise_and_short_logs() -> None:
    rng = np.random.default_rng(5)
    t = np.arange(0, 300, 0.1)
    assert isinstance(ambient_estimates(stretches(t, rng.normal(0, 0.001, t.size), 0.1, 0.4), "pitch"), str)
    short = np.arange(0, 20, 0.1)
    said = ambient_estimates(stretches(short, np.sin(OMEGA * short), 0.1, 0.4), "roll")
    assert isinstance(said, str) and "needed" in said


def test_surge_speed_at_full_command_forward_and_reverse() -> None:
    rng = np.random.default_rng(6)
    fractions = rng.uniform(0.1, 1.0, 20)
    points = [SurgePoint(float(i), 0.0, float(s), 2.4 * s + rng.normal(0, 0.03)) for i, s in enumerate(fractions)]
    forward = fit_surge(points, reverse=False, kind="test")
    assert forward.value == pytest.approx(2.4, rel=0.03)
    assert forward.low < 2.4 < forward.high
    reverse = [SurgePoint(0.0, 0.0, -float(s), 1.1 * s) for s in fractions[:5]]
    assert fit_surge(reverse, reverse=True, kind="test").value == pytest.approx(-1.1, rel=0.02)
    said = fit_surge(points, reverse=True, kind="shaft speeds")
    assert isinstance(said, str) and "reverse speed not identifiable" in said


def test_nomoto_gain_time_constant_and_asymmetry() -> None:
    rng = np.random.default_rng(7)
    dt = 0.1
    t = np.arange(0, 600, dt)
    steering = np.repeat(rng.uniform(-100, 100, t.size // 80 + 1), 80)[: t.size]
    truth = Nomoto(K=math.radians(0.1), T=1.8, r0=math.radians(0.5), dt=dt)
    r = truth.simulate(steering, 0.0) + rng.normal(0, math.radians(0.5), t.size)
    keep = rng.random(t.size) > 0.05
    got, _ = nomoto_estimates(stretches(t[keep], np.column_stack([steering, r])[keep], dt, 0.35), "tau_N", "N·m")
    assert got["yaw_nomoto_gain"].value == pytest.approx(0.1, rel=0.05)
    assert got["yaw_nomoto_time_constant_s"].value == pytest.approx(1.8, rel=0.15)
    assert got["yaw_rate_zero_steering_deg_s"].value == pytest.approx(0.5, rel=0.15)


def test_yaw_without_turns_is_one_line() -> None:
    t = np.arange(0, 120, 0.1)
    said = nomoto_estimates(stretches(t, np.column_stack([np.zeros_like(t), np.zeros_like(t)]), 0.1, 0.35),
                            "tau_N", "N·m")
    assert isinstance(said, str) and said.startswith("no turns at steady speed")


def test_stretches_split_at_gaps_and_take_nothing_from_nothing() -> None:
    t = np.r_[np.arange(0, 10, 0.1), np.arange(12, 20, 0.1)]
    parts = stretches(t, np.sin(t), 0.1, 0.4)
    assert [round(p.duration_s) for p in parts] == [10, 8]
    assert stretches(np.empty(0), np.empty((0, 2)), 0.1, 0.4) == []


def small_decays_log(rates: bool, seed: int = 4) -> LogData:
    """A calm log at 10 Hz holding six roll decays from 0.6° (T 1.2 s, ζ 0.25): the attitude with 0.2° of white
    noise, the body rates (when ``rates``; the boat not turning) with 0.1°/s, as the simulator's ATTITUDE has them."""
    rng = np.random.default_rng(seed)
    period, zeta = 1.2, 0.25
    omega, t = 2 * math.pi / period, np.arange(0, 80, 0.1)
    roll, p = np.zeros_like(t), np.zeros_like(t)
    for k, t0 in enumerate(np.arange(5.0, 75.0, 12.0)):
        tau = t - t0
        on = tau >= 0
        x = math.radians(0.6) * (-1) ** k * np.exp(-zeta * omega * tau[on])
        wd = omega * math.sqrt(1 - zeta**2)
        roll[on] += x * np.cos(wd * tau[on])
        p[on] += x * (-zeta * omega * np.cos(wd * tau[on]) - wd * np.sin(wd * tau[on]))
    rows = np.column_stack([t, roll + rng.normal(0, math.radians(0.2), t.size), rng.normal(0, 1e-3, t.size),
                            np.zeros_like(t), p + rng.normal(0, math.radians(0.1), t.size) if rates
                            else np.full(t.size, math.nan), np.zeros_like(t),
                            rng.normal(0, math.radians(0.1), t.size) if rates else np.full(t.size, math.nan)])
    return LogData(Path("synthetic.tlog"), "tlog", "", rows, np.empty((0, 2)))


def test_small_decays_are_identified_from_the_roll_rate() -> None:
    result = Identification()
    identify_axis([frames(small_decays_log(rates=True))], "roll", result)
    assert result.decay_signal["roll"] == "roll rate"
    assert len(result.decays["roll"]) >= 4
    assert result.estimates["roll_period_s"].value == pytest.approx(1.2, rel=0.03)
    assert result.estimates["roll_damping_ratio"].value == pytest.approx(0.25, rel=0.15)


def test_small_decays_in_a_noisy_angle_alone_are_not_taken_for_decays() -> None:
    result = Identification()
    identify_axis([frames(small_decays_log(rates=False))], "roll", result)
    assert "roll" not in result.decays  # 0.6° under 0.2° noise: below the angle's threshold, no decay claimed


def test_a_decay_cut_short_by_a_turn_is_kept_up_to_the_turn() -> None:
    t, y = decays_signal(np.random.default_rng(1), noise=0.003)
    quiet = np.ones(t.size, bool)
    quiet[(t >= 5.0 + 2.2 * PERIOD_S) & (t < 25.0)] = False  # the boat turns again 2.2 periods into the first decay
    found = find_decays(t, y, quiet, math.radians(1.5), 0.003)
    assert len(found) == 2 and t[found[0][1]] < 5.0 + 2.2 * PERIOD_S  # the first one ends before the turn
    fit = fit_decay(t[found[0][0]:found[0][1] + 1], y[found[0][0]:found[0][1] + 1])
    assert fit is not None and fit.period_s == pytest.approx(PERIOD_S, rel=0.03)


def test_a_sustained_oscillation_is_not_taken_for_a_decay() -> None:
    t = np.arange(0, 2.5, 0.05)  # two cycles from a crest, as find_decays hands a run over
    noise = np.random.default_rng(5).normal(0, 0.002, t.size)
    assert fit_decay(t, 0.03 * np.cos(OMEGA * t) + noise) is None  # no damping at all
    fit = fit_decay(t, 0.03 * np.exp(-0.03 * OMEGA * t) * np.cos(OMEGA * t) + noise)  # lightly damped: kept
    assert fit is not None and fit.zeta == pytest.approx(0.03, abs=0.01)


def test_a_weaker_starboard_propeller_from_the_helm_that_holds_a_heading() -> None:
    """Windows going straight at outputs 0.3 and 0.6, the starboard motor given what makes its 15 % weaker thrust
    equal the port one's (as a heading hold does), then a turn: the ratio 0.85 and propeller_scale (1, 0.85); the
    same with both motors alike: no scale."""
    rng = np.random.default_rng(6)
    t = np.arange(0, 60, 0.1)
    port = np.where(t < 30, 0.3, 0.6) + rng.normal(0, 0.005, t.size)
    yaw_rate = rng.normal(0, math.radians(0.5), t.size)
    yaw_rate[t >= 50] = math.radians(15)  # turning: not a straight window
    for weaker, scale in ((0.85, (1.0, 0.85)), (1.0, None)):
        starboard = port / math.sqrt(weaker)
        got = thrust_ratio(straight_windows([Stretch(t, np.column_stack([port, starboard, yaw_rate]))]))
        assert not isinstance(got, str) and got.value == pytest.approx(weaker, abs=0.005)
        assert propeller_scale(got) == (pytest.approx(scale) if scale else None)
    assert isinstance(thrust_ratio([]), str)


def test_nomoto_interval_from_a_single_zigzag() -> None:
    """An identification run turns only in its zig-zag (about 70 s) after a held throttle step: 60 s blocks give
    one fit and no interval, so shorter blocks give it (above zero: yaw_time_constant is then fitted); the held
    blocks, whose fits say nothing, are left out of it."""
    rng = np.random.default_rng(3)
    dt = 0.1
    t = np.arange(0, 130, dt)
    held = 0.004 * rng.standard_normal(t.size)  # a heading hold's small corrections: no K or T in them
    steering = np.where(t < 60, held, np.where(((t - 60) // 7) % 2 == 0, 1.0, -1.0))
    truth = Nomoto(K=math.radians(40.0), T=0.6, r0=0.0, dt=dt)
    r = truth.simulate(steering, 0.0) + rng.normal(0, math.radians(0.1), t.size)
    got, _ = nomoto_estimates(stretches(t, np.column_stack([steering, r]), dt, 0.35), "thrust difference", "1")
    T = got["yaw_nomoto_time_constant_s"]
    assert math.isfinite(T.low) and math.isfinite(T.high)
    assert 0 < T.low <= T.value <= T.high < 1.0
    assert T.value == pytest.approx(0.6, rel=0.05)
    assert "of 20 s for the interval" in T.source
