"""The companion step's fast paths (issue 32) give what the general ones give: the delay prediction through the
compiled library's C API, the wave gate's reused field, the checks on bound buffers, the IMU's hostile fields."""

from __future__ import annotations

import math
import subprocess
import sys
from types import SimpleNamespace

import casadi as ca
import numpy as np
import pytest

from mavbridge.companion.predict import CommandHistory, StatePredictor
from mavbridge.companion.state import imu_specific_force
from mavbridge.companion.wave_gate import WaveGate
from mavbridge.nmpc import NmpcConfig, RollAwareNmpc, compile_native_function
from mavbridge.nmpc.controller import shift_duals, shift_duals_by
from mavbridge.nmpc.layout import Layout
from mavbridge.nmpc.sea_spread import slope_factor
from mavbridge.nmpc.solvers.codegen import compiler
from mavbridge.waves.source import WaveEstimate
from vessel import OceanCurrent, RegularWaves, otter_parameters

needs_cc = pytest.mark.skipif(compiler() is None, reason="no C compiler: the C API path does not exist")


@needs_cc
def test_the_native_prediction_is_casadis_bit_for_bit() -> None:
    native = StatePredictor(otter_parameters(), OceanCurrent())
    assert native._native is not None
    general = StatePredictor(otter_parameters(), OceanCurrent())
    general._native = None  # CasADi's own call on the same compiled library
    history = CommandHistory()
    history.add(0.0, np.array([80.0, 5.0]))
    history.add(0.45, np.array([-20.0, -30.0]))
    sea = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2, phase_rad=0.3)
    rng = np.random.default_rng(5)
    for _ in range(20):
        x = rng.normal(0.0, 0.3, 12)
        x[0:2] = rng.uniform(-50, 50, 2)
        for waves in (sea, None):
            a = native.predict(x, 0.1, 0.95, history, waves)
            b = general.predict(x, 0.1, 0.95, history, waves)
            assert np.array_equal(a, b) and not np.array_equal(a, x)
    column = native.predict(x.reshape(12, 1), 0.1, 0.95, history, sea)  # a column state, as CasADi took it
    assert np.array_equal(column, native.predict(x, 0.1, 0.95, history, sea))


@needs_cc
def test_a_bound_input_of_the_wrong_kind_is_refused() -> None:
    x = ca.SX.sym("x", 3)
    _, fast, _ = compile_native_function(ca.Function("twice", [x], [2 * x]))
    assert fast is not None
    for wrong in (np.zeros(2), np.zeros(3, np.float32), np.zeros(3, int)):
        with pytest.raises(ValueError, match="input 0"):
            fast.bind(wrong)
    with pytest.raises(ValueError, match="2 inputs bound"):
        fast.bind(np.zeros(3), np.zeros(3))
    given = np.array([1.0, -2.0, 3.5])
    fast.bind(given)
    assert fast.call()[0].tolist() == [2.0, -4.0, 7.0]


class _Fixed:
    """A wave source answering whatever estimate it is given."""

    name = "fixed"

    def __init__(self) -> None:
        self.answer: WaveEstimate | None = None

    def observe(self, sample: object) -> None:
        """Nothing to learn."""

    def estimate(self, t_s: float) -> WaveEstimate | None:
        return self.answer


class _Nmpc:
    def __init__(self) -> None:
        self.waves: list[object] = []

    def set_wave(self, waves: object) -> None:
        self.waves.append(waves)

    def set_sea_spread(self, covariance: object) -> None:
        """Not looked at here."""


def test_the_gate_reuses_its_field_only_for_the_very_same_wave() -> None:
    source, nmpc = _Fixed(), _Nmpc()
    gate = WaveGate(source, log=lambda line: None)
    wave = WaveEstimate(1.75, 6.0, 35.0, 0.0, 0.0, confidence=0.8)
    changes = [wave, WaveEstimate(1.75, 6.0, 35.0, 0.0, 0.0, confidence=0.95),  # confidence: same field
               WaveEstimate(1.75, 6.0, 35.0, 0.0, 1e-9, confidence=0.95),  # phase moved
               WaveEstimate(1.75, 6.0, 35.0, -0.0, 1e-9, confidence=0.95),  # −0.0: other bits
               WaveEstimate(1.75, 6.0, 35.0, -0.0, 1e-9, confidence=0.95, roll_sign=-1.0)]  # sign
    for t, est in enumerate(changes):
        source.answer = est
        gate.step(nmpc, float(t))
    fields = nmpc.waves
    assert fields[1] is fields[0]
    assert len({id(f) for f in fields}) == 4
    assert fields[2].phase_rad == 1e-9 and fields[4].paper_roll_sign is False


class _Spreading(_Fixed):
    """A source that also measures the sea's unexplained slope covariance: whatever it is given."""

    def __init__(self) -> None:
        super().__init__()
        self.covariance: np.ndarray | None = None

    def spread(self, explained: bool) -> np.ndarray | None:
        return self.covariance


def test_the_gate_gives_the_sea_spread_again_only_when_its_bits_change() -> None:
    """The spread changes only when a fit completes: the same bits are not given to the NMPC again (issue 32), and
    the NMPC always plans with the spread the source measures now (its slope factor), another NMPC included."""
    source = _Spreading()
    given: list[object] = []
    with RollAwareNmpc(NmpcConfig(horizon=4, solver="ipopt")) as nmpc, \
            RollAwareNmpc(NmpcConfig(horizon=4, solver="ipopt")) as other:
        for controller in (nmpc, other):
            inner = controller.set_sea_spread
            controller.set_sea_spread = lambda c, inner=inner: (given.append(c), inner(c))  # type: ignore[method-assign]
        gate = WaveGate(source, log=lambda line: None)
        a, b = np.array([[4e-4, 1e-4], [1e-4, 2e-4]]), np.array([[1e-4, 0.0], [0.0, 1e-4]])
        steps = ((a, nmpc, True), (a.copy(), nmpc, False), (b, nmpc, True), (None, nmpc, True), (a, nmpc, True),
                 (a, other, True), (-a, other, True), (-a, other, True))  # (−a is refused: given each time)
        for step, (covariance, controller, again) in enumerate(steps):
            source.covariance = covariance
            before = len(given)
            gate.step(controller, float(step))
            assert (len(given) > before) is again, step
            want = slope_factor(covariance) if covariance is None or covariance[0, 0] >= 0 else np.zeros(3)
            assert np.array_equal(controller._sea.factor, want), step


def test_an_imu_field_that_is_no_number_makes_the_sample_unusable() -> None:
    good = SimpleNamespace(time_boot_ms=1000, xacc=10, yacc=-5, zacc=-1000)
    assert imu_specific_force(good)[0] == 1000
    for bad in (None, "x", float("nan")):
        assert imu_specific_force(SimpleNamespace(time_boot_ms=1000, xacc=bad, yacc=0, zacc=-1000)) is None


@pytest.mark.parametrize("solver", ["asrti", "nrti"])
def test_a_deferred_preparation_plans_as_an_immediate_one(solver: str) -> None:
    """The companion starts the next period's preparation after sending the command (defer_advance, then
    advance): the same plans as starting it inside solve; a forgotten advance is started by the next solve."""
    sea = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2, phase_rad=0.3)
    cfg = NmpcConfig(horizon=8, solver=solver, rti_codegen="off" if solver == "asrti" else "auto")
    taus: dict[str, list[np.ndarray]] = {}
    for mode in ("inside", "deferred", "forgotten"):
        with RollAwareNmpc(cfg, otter_parameters(), sea) as nmpc:
            x = np.zeros(12)
            x[5], x[6] = math.pi / 2, 1.0
            nmpc.prepare(x, 0.0, (85.0, 75.0))
            taus[mode] = []
            for k in range(8):
                result = nmpc.solve(x, 0.1 * k, (85.0, 75.0), defer_advance=mode != "inside")
                if mode == "deferred":
                    nmpc.advance()
                assert result.success
                taus[mode].append(result.tau)
                x = result.states[1]
            if k and solver == "asrti":
                assert result.stats["background"] == "used"
    assert np.array_equal(np.array(taus["inside"]), np.array(taus["deferred"]))
    assert np.array_equal(np.array(taus["inside"]), np.array(taus["forgotten"]))


def test_the_loop_finds_the_interpreter_set_for_it() -> None:
    """``ready_for_loop`` (`mavbridge run` and the step bench call it once all is built): the loop's switch interval,
    and what was built kept out of the collector's passes. In a fresh interpreter: it changes the process's."""
    code = ("import gc, sys; from mavbridge.companion.flight import GIL_SWITCH_S, ready_for_loop; "
            "before = gc.get_freeze_count(); ready_for_loop(); "
            "print(sys.getswitchinterval() == GIL_SWITCH_S, before == 0, gc.get_freeze_count() > 10_000)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.split() == ["True", "True", "True"], done.stderr


def _nrti_run(feedback_only: bool, deadline_s: float | None = None) -> tuple[list[tuple], int, int]:
    """((τ, plan, status, fallback, the stored multipliers at steps 6 and 15) of 16 paced-like nrti steps, how many
    took the feedback-only step, the native feedback's calls), with or without it (``RollAwareNmpc._feedback_only``):
    steps 7 and 12 without a prepared QP (its job dropped: an SQP step from the warm start), step 10 with the native
    feedback failing on its QP (an SQP step from the prepared plan). Steps 1-6 leave six shifts to be made at once
    (more than the horizon) of multipliers not yet shifted to their end (nrti passes them on: after as many shifts
    as the horizon they no longer change)."""
    sea = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2, phase_rad=0.3)
    out, fast, calls = [], [0], [0]
    with RollAwareNmpc(NmpcConfig(horizon=4, solver="nrti"), otter_parameters(), sea) as nmpc:
        backend, failing = nmpc._backend, [False]
        assert nmpc._prepared_feedback is not None
        feedback = backend.feedback

        def tried(*args: object) -> object:
            calls[0] += 1
            return None if failing[0] else feedback(*args)
        backend.feedback = tried
        prepared = nmpc._prepared_feedback

        def counted(p: np.ndarray) -> object:
            outcome = prepared(p)
            fast[0] += outcome is not None
            return outcome
        nmpc._prepared_feedback = counted if feedback_only else None  # None: every step the full one
        x = np.zeros(12)
        x[5], x[6] = math.pi / 2, 1.0
        nmpc.prepare(x, 0.0, (85.0, 75.0))
        for k in range(16):
            if k in (7, 12):
                backend.advanced.cancel()
            failing[0] = k == 10
            result = nmpc.solve(x, 0.1 * k, (85.0, 75.0), deadline_s=deadline_s, defer_advance=True)
            nmpc.advance()
            duals = [d.copy() for d in nmpc._stored_duals()] if k in (6, 15) else []  # (the shifts left made now)
            out.append((result.tau, result.states, result.status, result.fallback, duals))
            x = result.states[1] + 0.01  # (not quite the plan: the feedback has something to do)
    return out, fast[0], calls[0]


@needs_cc
@pytest.mark.parametrize("deadline_s", [None, 1e-12])
def test_the_feedback_only_step_plans_as_the_full_one(deadline_s: float | None) -> None:
    """nrti's step makes no warm start while its QP was prepared (issue 32: shifting the plan and its multipliers
    cost as much as the feedback, paced); the multipliers' shifts are made when a later step needs them: the same
    commands, plans and multipliers bit for bit, with steps that needed them between, a failed feedback tried once,
    and with every answer late (the previous plan's next input)."""
    (fast, fast_steps, fast_calls), (full, none, full_calls) = _nrti_run(True, deadline_s), _nrti_run(False, deadline_s)
    assert fast_steps == 13 and none == 0  # all but the two without a QP and the failed feedback
    assert fast_calls == full_calls == 15  # prepare's, and every step with a QP once (a failed one not again)
    statuses = [status for _, _, status, *_ in full]
    assert statuses.count("NRTI") == 13 and all(statuses[k].startswith("RTI") for k in (7, 10, 12)), statuses
    for k, (a, b) in enumerate(zip(fast, full, strict=True)):
        (tau_a, plan_a, status_a, late_a, duals_a), (tau_b, plan_b, status_b, late_b, duals_b) = a, b
        assert status_a == status_b and (late_a is None) == (late_b is None), k  # (its text has the wall time)
        assert len(duals_a) == len(duals_b), k
        assert all(np.array_equal(u, v) for u, v in zip(duals_a, duals_b, strict=True)), k
        assert np.array_equal(tau_a, tau_b) and np.array_equal(plan_a, plan_b), k
    assert all(late is not None for *_, late, _ in fast) == (deadline_s is not None)


def test_shifting_the_multipliers_k_stages_at_once_is_shifting_them_k_times() -> None:
    """``_stored_duals`` makes the shifts left to it in one go (``shift_duals_by``): the same numbers, bit for bit,
    for any count, beyond the horizon too (where they no longer change)."""
    layout = Layout(6)
    rng = np.random.default_rng(3)
    lam_w, lam_g = rng.normal(size=layout.n_w), rng.normal(size=12 * 7)
    gaps = lam_g[12:].reshape(6, 12)  # one shift by hand: stage k takes stage k + 1, the last repeated
    once_g = np.concatenate([-gaps[0], gaps[1:].ravel(), gaps[-1]])
    assert np.array_equal(shift_duals(layout, lam_w, lam_g)[1], once_g)
    assert np.array_equal(shift_duals(layout, lam_w, lam_g)[0], layout.shift(lam_w))
    stepwise = [(lam_w, lam_g)]
    for _ in range(6 + 4):
        stepwise.append(shift_duals(layout, *stepwise[-1]))
    for k, (want_w, want_g) in enumerate(stepwise):
        got_w, got_g = shift_duals_by(layout, lam_w, lam_g, k)
        assert np.array_equal(got_w, want_w) and np.array_equal(got_g, want_g), k
    assert not np.array_equal(stepwise[6][1], stepwise[5][1])  # still moving at the horizon ...
    assert all(np.array_equal(stepwise[7][1], later[1]) for later in stepwise[8:])  # ... and then no longer
    assert shift_duals_by(layout, None, lam_g, 3) == (None, None) == shift_duals(layout, None, lam_g)
