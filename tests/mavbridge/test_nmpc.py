"""The roll-aware NMPC: heading wrap, closed-loop behaviour on short cases, failures and fallbacks."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import scenario_from_mapping
from mavbridge.nmpc import NmpcConfig, RollAwareNmpc, heading_error
from mavbridge.nmpc.backend import SolveOutcome
from vessel import ConfigError, RegularWaves, otter_parameters

PAPER_WAVES = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)


def _state(north=0.0, east=0.0, psi=0.0, u=0.0) -> np.ndarray:
    x = np.zeros(12)
    x[0], x[1], x[5], x[6] = north, east, psi, u
    return x


def test_heading_error_wraps_across_pi() -> None:
    # Heading just below +π (South, a little West of it); bearing to a waypoint just East of South is
    # just above −π. The error is the small angle between them, not ≈ −2π.
    x = ca.DM(_state(psi=math.pi - 0.05))
    waypoint = ca.DM([-100.0, 100.0 * math.tan(0.05)])  # bearing = π − 0.05
    assert float(heading_error(x, waypoint)) == pytest.approx(0.0, abs=1e-9)
    waypoint = ca.DM([-100.0, -100.0 * math.tan(0.05)])  # bearing = −π + 0.05
    assert float(heading_error(x, waypoint)) == pytest.approx(0.10, abs=1e-9)
    x = ca.DM(_state(psi=-math.pi + 0.05))
    waypoint = ca.DM([-100.0, 100.0 * math.tan(0.05)])  # bearing = π − 0.05
    assert float(heading_error(x, waypoint)) == pytest.approx(-0.10, abs=1e-9)
    # An unwrapped heading (several turns) gives the same error.
    x = ca.DM(_state(psi=4 * math.pi + 0.3))
    assert float(heading_error(x, ca.DM([10.0, 0.0]))) == pytest.approx(-0.3, abs=1e-9)


def _calm(**controller) -> dict:
    return {
        "name": "calm_test",
        "sea": {"height_m": 0.0},
        "start": {"heading_deg": 90.0},
        "waypoint": {"north_m": 3.0, "east_m": 14.0, "acceptance_radius_m": 2.0},
        "t_max_s": 40.0,
        "controller": {"q": 5, "r": 0, "s": 2, "horizon": 15, **controller},
    }


def test_calm_water_reaches_a_near_waypoint() -> None:
    scenario = scenario_from_mapping(_calm(), "test")
    metrics = run_scenario(scenario, None, plots=False).metrics
    assert metrics["time_to_waypoint_s"] is not None
    assert metrics["time_to_waypoint_s"] < 40.0
    assert metrics["final_distance_m"] < 2.0
    assert metrics["failures"] == 0
    assert metrics["max_roll_deg"] < 2.0


def test_roll_cost_lowers_average_roll_in_beam_seas() -> None:
    # Heading North to a waypoint due North: the paper's waves (from the East) are on the beam.
    base = {
        "name": "beam",
        "sea": {"height_m": 1.75, "length_m": 35.0, "period_s": 6.0, "travel_dir_deg": -90.0},
        "start": {"heading_deg": 0.0, "surge_mps": 1.0},
        "waypoint": {"north_m": 60.0, "east_m": 0.0},
        "t_max_s": 25.0,
    }
    rolls = {}
    for r in (0.0, 2500.0):
        controller = {"q": 5, "r": r, "s": 2, "horizon": 20, "solver": "nrti"}  # the real-time solver: the cost, fast
        scenario = scenario_from_mapping({**base, "controller": controller}, "t")
        rolls[r] = run_scenario(scenario, None, plots=False).metrics["avg_roll_deg"]
    assert rolls[2500.0] < 0.8 * rolls[0.0], rolls


def test_forced_failure_uses_safe_input_and_is_reported() -> None:
    cfg = NmpcConfig(horizon=5, max_iter=0, safe_surge_n=25.0)
    nmpc = RollAwareNmpc(cfg, otter_parameters(), PAPER_WAVES)
    for k in range(3):
        result = nmpc.solve(_state(psi=math.pi / 2), 0.1 * k, (85.0, 75.0))
        assert not result.success
        assert result.fallback is not None and "failed" in result.fallback
        assert result.fallback_source == "safe"
        assert np.all(np.isfinite(result.tau))
        np.testing.assert_allclose(result.tau, [25.0, 0.0])
        assert np.all(np.isfinite(result.states))


class _FailingBackend:
    def solve(self, *args, **kwargs) -> SolveOutcome:
        return SolveOutcome(w=np.full(args[0].shape, np.nan), lam_w=None, lam_g=None, usable=False,
                            status="Invalid_Number_Detected", iterations=3)


def test_failure_after_a_good_solve_uses_the_previous_plan() -> None:
    nmpc = RollAwareNmpc(NmpcConfig(horizon=8), otter_parameters(), PAPER_WAVES)
    x = _state(psi=math.pi / 2, u=1.0)
    good = nmpc.solve(x, 0.0, (85.0, 75.0))
    assert good.success and good.fallback is None
    nmpc._backend = _FailingBackend()  # this instance only; the cached solver is untouched
    bad = nmpc.solve(good.states[1], 0.1, (85.0, 75.0))
    assert not bad.success
    assert bad.status == "Invalid_Number_Detected"
    assert bad.fallback_source == "previous_plan"
    np.testing.assert_allclose(bad.tau, good.inputs[1])
    # The plan keeps advancing while the solver keeps failing, then falls back to the safe input.
    for k in range(2, 10):
        res = nmpc.solve(good.states[1], 0.1 * k, (85.0, 75.0))
        assert np.all(np.isfinite(res.tau))
    assert res.fallback_source == "safe"


def test_late_solve_is_answered_by_the_fallback() -> None:
    nmpc = RollAwareNmpc(NmpcConfig(horizon=8), otter_parameters(), PAPER_WAVES)
    x = _state(psi=math.pi / 2, u=1.0)
    first = nmpc.solve(x, 0.0, (85.0, 75.0), deadline_s=1e-9)
    assert first.success and first.fallback.startswith("late")
    assert first.fallback_source == "safe"
    second = nmpc.solve(first.states[1], 0.1, (85.0, 75.0), deadline_s=1e-9)
    assert second.fallback_source == "previous_plan"
    np.testing.assert_allclose(second.tau, first.inputs[1])


def test_non_finite_inputs_name_the_field() -> None:
    nmpc = RollAwareNmpc(NmpcConfig(horizon=5), otter_parameters(), PAPER_WAVES)
    x = _state()
    x[3] = np.nan
    with pytest.raises(ValueError, match=r"x0\[3\] \(phi\)"):
        nmpc.solve(x, 0.0, (10.0, 0.0))
    with pytest.raises(ValueError, match=r"waypoint_ne\[1\] \(east\)"):
        nmpc.solve(_state(), 0.0, (10.0, math.inf))
    with pytest.raises(ValueError, match=r"^t"):
        nmpc.solve(_state(), math.nan, (10.0, 0.0))
    with pytest.raises(ValueError, match="x0: expected 12"):
        nmpc.solve(np.zeros(14), 0.0, (10.0, 0.0))


def test_one_solver_serves_many_weights_and_waypoints() -> None:
    params = otter_parameters()
    a = RollAwareNmpc(NmpcConfig(horizon=6, r=0.0), params, PAPER_WAVES)
    b = RollAwareNmpc(NmpcConfig(horizon=6, r=2500.0), params, PAPER_WAVES)
    assert a._functions is b._functions  # one built problem (immutable Functions) ...
    assert a._backend is not b._backend  # ... and a solver instance each
    x = _state(psi=0.0, u=1.0)
    ra = a.solve(x, 0.0, (50.0, 0.0))
    rb = b.solve(x, 0.0, (-50.0, 0.0))
    assert ra.success and rb.success
    assert not np.allclose(ra.tau, rb.tau)


def test_config_rejects_bad_values() -> None:
    with pytest.raises(ConfigError, match="q"):
        NmpcConfig(q=-1.0)
    with pytest.raises(ConfigError, match="horizon"):
        NmpcConfig(horizon=0)
    with pytest.raises(ConfigError, match="solver"):
        NmpcConfig(solver="magic")
