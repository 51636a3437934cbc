"""A hull that rides the sea, seen by a model that does not; holding a confident wave; a steady solution.

Real CasADi solves (a short-horizon rti), the real WaveGate and steadiness term; the only stand-in is a
wave source that answers what the test tells it (as a confident estimator would, then not).
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pytest

from mavbridge.companion.flight import build_nmpc
from mavbridge.companion.wave_gate import WaveGate
from mavbridge.lab.scenario import Scenario
from mavbridge.nmpc.model_state import on_mean_surface, resolve_heave_feedback
from mavbridge.waves.source import MotionSample, ScenarioTruth, WaveEstimate
from mavbridge.waves.steadiness import SolutionSteadiness
from tests.mavbridge.wave_sources import ToldSource
from vessel import CalmWater
from vessel.dynamics import rotation_body_to_ned


def _heaving_state() -> np.ndarray:
    """A boat 0.8 m above its calm waterline, rising at 0.9 m/s, rolled 8°, pitched 5°, heading 60°."""
    phi, theta, psi = math.radians(8), math.radians(5), math.radians(60)
    R = np.asarray(rotation_body_to_ned(phi, theta, psi), float)
    velocity_ned = np.array([1.2, 0.7, -0.9])
    return np.concatenate([[10.0, 20.0, -0.8, phi, theta, psi], R.T @ velocity_ned, [0.05, -0.02, 0.1]])


def test_on_mean_surface_removes_only_the_heave() -> None:
    x = _heaving_state()
    flat = on_mean_surface(x)
    R = np.asarray(rotation_body_to_ned(*x[3:6]), float)
    assert flat[2] == 0.0 and (R @ flat[6:9])[2] == pytest.approx(0.0, abs=1e-12)
    assert (R @ flat[6:9])[0:2] == pytest.approx((R @ x[6:9])[0:2])  # the NED horizontal velocity is kept
    keep = [0, 1, 3, 4, 5, 9, 10, 11]
    assert flat[keep] == pytest.approx(x[keep]) and x[2] == -0.8  # the input is not changed


@pytest.mark.parametrize(("setting", "heaves", "expected"), [("auto", True, "none"), ("auto", False, "measured"),
                                                             ("measured", True, "measured"), ("none", False, "none")])
def test_auto_heave_feedback_means_none_only_where_the_hull_heaves(setting: str, heaves: bool, expected: str) -> None:
    assert resolve_heave_feedback(setting, heaves) == expected


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    base = Scenario(name="balanced")
    return dataclasses.replace(base, controller=base.controller.replace(horizon=8, solver="rti"))


def test_the_companion_plans_a_heaving_boat_as_if_on_its_waterline(scenario: Scenario) -> None:
    """The companion's NMPC: the same input for the heaving state as for that state on the mean surface."""
    x = _heaving_state()
    with build_nmpc(scenario, ToldSource(None, "estimated")) as nmpc:
        assert nmpc.config.heave_feedback == "none"
        heaving = nmpc.solve(x, 0.0, (80.0, 80.0)).tau
        nmpc.reset()
        flat = nmpc.solve(on_mean_surface(x), 0.0, (80.0, 80.0)).tau
    assert heaving == pytest.approx(flat, abs=1e-9)
    with build_nmpc(scenario, ScenarioTruth(CalmWater())) as measured:  # simulation truth: the paper's setting
        assert measured.config.heave_feedback == "measured"
        assert measured.solve(x, 0.0, (80.0, 80.0)).tau != pytest.approx(flat, abs=1e-3)


def test_gate_holds_the_last_confident_wave_for_hold_s_then_degrades(scenario: Scenario) -> None:
    lines: list[str] = []
    wave = WaveEstimate(1.75, 6.0, 35.0, -math.pi / 2, 0.3, 0.9)
    source = ToldSource(wave)
    with build_nmpc(scenario, ScenarioTruth(CalmWater())) as nmpc:
        gate = WaveGate(source, lines.append, hold_s=2.0)
        gate.step(nmpc, 10.0)
        source.answer = None  # e.g. following seas: the estimator loses its lock
        held = []
        for t in (10.5, 11.9, 12.0):
            gate.step(nmpc, t)
            held.append(nmpc.roll_term_active)
        gate.step(nmpc, 12.1)
        assert held == [True, True, True] and not nmpc.roll_term_active
    assert gate.changes == 1 and "no longer confident" in lines[-1] and "t = 12.1 s" in lines[-1]


def _steadiness(omegas: list[float], dirs: list[float], dt: float = 0.1) -> float:
    steady = SolutionSteadiness()
    for i, (omega, chi) in enumerate(zip(omegas, dirs, strict=True)):
        value = steady.update(i * dt, omega, chi)
    return value


def test_a_steady_solution_earns_the_lock_and_a_wandering_one_does_not() -> None:
    n = 300  # 30 s at 10 Hz
    t = np.arange(n) * 0.1
    assert _steadiness([1.05] * n, [-1.57] * n) > 0.9
    wobbling = list(1.05 * (1 + 0.15 * np.sin(1.0 * t)))  # ±15 %: the phase would be off by 50° at 4 s
    assert _steadiness(wobbling, [-1.57] * n) < 0.3
    swinging = list(-1.57 + 0.4 * np.sin(1.0 * t))  # the direction swinging ±23°
    assert _steadiness([1.05] * n, swinging) < 0.3
    assert _steadiness([1.05] * 50, [-1.57] * 50) < 0.5  # steadiness is earned over seconds, not given


def test_steadiness_takes_each_stamp_once() -> None:
    steady = SolutionSteadiness()
    for i in range(100):
        steady.update(i * 0.1, 1.05, 0.0)
    before = steady.value
    for _ in range(50):  # a log asking again at the same time, with another answer, changes nothing
        assert steady.update(9.9, 2.0, 1.0) == before


def test_a_held_wave_is_dropped_when_the_autopilot_clock_goes_back(scenario: Scenario) -> None:
    """After a reboot the old estimate's phase belongs to the old boot clock: never held across it."""
    source = ToldSource(WaveEstimate(1.75, 6.0, 35.0, -math.pi / 2, 0.3, 0.9))
    with build_nmpc(scenario, ScenarioTruth(CalmWater())) as nmpc:
        gate = WaveGate(source, lambda line: None, hold_s=20.0)
        gate.step(nmpc, 3600.0)
        source.answer = None
        gate.step(nmpc, 5.0)  # the autopilot rebooted
        assert not nmpc.roll_term_active
        gate.step(nmpc, 6.0)
        assert not nmpc.roll_term_active


def test_the_watch_asks_again_after_the_autopilot_clock_goes_back() -> None:
    """Before engaging the gate asks every 0.1 s whether the sea is known; after a reboot (the clock starts again
    near 0) it must not wait for the new clock to pass the old one to ask again."""
    lines: list[str] = []
    source = ToldSource(None)
    gate = WaveGate(source, lines.append)
    gate.watch(3600.0)  # asked: not known yet
    source.answer = WaveEstimate(1.75, 6.0, 35.0, -math.pi / 2, 0.3, 0.9)
    gate.watch(5.0)  # the autopilot rebooted: asked again, and known
    assert gate.watched_confident_s == 5.0 and len(lines) == 1 and "before engaging" in lines[0], lines


def test_steadiness_after_a_gap_or_a_nan_is_earned_again() -> None:
    steady = SolutionSteadiness()
    for i in range(300):
        steady.update(i * 0.1, 1.05, 0.0)
    assert steady.value > 0.9
    assert steady.update(29.9 + 15.0, 1.05, 0.0) < 0.5  # one answer after a 15 s gap is a first answer
    for i in range(300):
        steady.update(50.0 + i * 0.1, 1.05, 0.0)
    assert steady.update(90.0, math.nan, 0.0) == 0.0
    assert math.isfinite(steady.update(90.1, 1.05, 0.0)) and steady.value < 0.5


class _SlowToObserve(ToldSource):
    """A source whose every sample costs a known wall time (at least ``observe_s``)."""

    observe_s: float = 0.005

    def observe(self, sample: MotionSample) -> None:
        time.sleep(self.observe_s)


def test_the_samples_of_a_spell_without_steps_are_no_steps_cost(scenario: Scenario) -> None:
    """The gate counts the samples' cost since the last step in the next step's (metrics.json's estimator_ms); after a
    spell without steps (the pilot had the boat) that spell's samples are not one step's cost."""
    gate = WaveGate(_SlowToObserve(None), lambda line: None)
    sample = MotionSample(0.0, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    with build_nmpc(scenario, ScenarioTruth(CalmWater())) as nmpc:
        gate.step(nmpc, 10.0)
        for _ in range(2):  # a period's two samples
            gate.observe(sample)
        gate.step(nmpc, 10.1)
        assert gate.cost_ms[-1] >= 2 * 5.0  # (each slept at least 5 ms)
        for _ in range(100):  # 5 s with the pilot: 0.5 s of samples' cost at least
            gate.observe(sample)
        gate.step(nmpc, 15.1)
        assert gate.cost_ms[-1] < 250.0, gate.cost_ms
