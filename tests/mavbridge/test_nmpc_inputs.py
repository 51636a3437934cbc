"""The NMPC's input space (``NmpcConfig.inputs``): τ in a box (the paper's, unchanged) or the propeller thrusts.

* ``tau`` is the code before the setting existed: the fixture holds, as float hex, the applied τ and the last
  planned input of every step of a 3 s Balanced run for each backend, recorded with the main branch at 1cd756f
  (nrti's re-recorded when its prepared QP became the last SQP iteration's; regenerate an entry only for an
  intended change of its backend or of the paper's setting). On the recording machine they agree bit for
  bit; the test allows 1e-6 (relative and absolute) so that another CPU's vectorised round-off, which IPOPT's
  iterations can amplify, does not fail it, while any change to the setting's model or cost still does.
* ``propellers`` never commands a propeller beyond its limit, over whole runs on the propeller plant: the
  plant's own allocation turns every command into shaft speeds within their limits and gives back exactly the
  commanded τ (it never had to saturate).
"""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

import mavbridge.lab.experiment as experiment
from mavbridge.lab.scenario import scenario_from_mapping
from mavbridge.nmpc import NmpcConfig
from mavbridge.nmpc.inputs import InputSpace, allocation_matrix, input_space, thrust_limits
from vessel import otter_parameters, shaft_speeds_to_tau, tau_to_shaft_speeds
from vessel.allocation import propeller_thrust, tau_limits
from vessel.config import ConfigError

GOLDEN = Path(__file__).parent / "data" / "tau_inputs_golden.json"
BALANCED = {"name": "balanced", "sea": {"height_m": 1.75, "length_m": 35.0, "period_s": 6.0,
                                        "travel_dir_deg": -90.0},
            "start": {"heading_deg": 90.0, "surge_mps": 0.0}, "waypoint": {"north_m": 85.0, "east_m": 75.0},
            "controller": {"q": 5, "r": 1550, "s": 2}}


class Watched(experiment.RunRecorder):
    """The experiment's recorder, keeping every NmpcResult it is given."""

    results: ClassVar[list[Any]] = []

    def step(self, t: float, x: np.ndarray, result: Any, **columns: Any) -> None:
        Watched.results.append(result)
        super().step(t, x, result, **columns)


def _run(monkeypatch: pytest.MonkeyPatch, t_max_s: float, plant: str, **controller: Any) -> tuple[list, dict]:
    """One in-process run of Balanced: (every NmpcResult, metrics)."""
    Watched.results = []
    monkeypatch.setattr(experiment, "RunRecorder", Watched)
    data = {**BALANCED, "t_max_s": t_max_s, "plant": plant,
            "controller": {**BALANCED["controller"], **controller}}
    result = experiment.run_scenario(scenario_from_mapping(data, "test"), None, plots=False)
    return list(Watched.results), result.metrics


def test_the_allocation_matrix_and_box_are_the_propellers() -> None:
    params = otter_parameters("published")
    space = input_space(NmpcConfig(inputs="propellers"), params)
    reverse, forward = thrust_limits(params)
    np.testing.assert_allclose(space.low, [reverse] * 2)
    np.testing.assert_allclose(space.high, [forward] * 2)
    mats = params.matrices()
    assert forward == pytest.approx(float(propeller_thrust(params, mats.n_max)))
    assert reverse == pytest.approx(float(propeller_thrust(params, mats.n_min)))
    most_forward, most_reverse, most_yaw = tau_limits(params)
    np.testing.assert_allclose(space.to_tau(space.high), [most_forward, 0.0], atol=1e-9)
    one_ahead = space.to_tau(np.array([forward, reverse]))  # left ahead, right astern: the most yaw
    np.testing.assert_allclose(one_ahead, [(most_forward - most_reverse) / 2, most_yaw])
    tau = np.array([40.0, -12.0])
    np.testing.assert_allclose(space.to_tau(space.from_tau(tau)), tau)
    left, right = space.from_tau(tau)
    n = tau_to_shaft_speeds(params, *tau)
    np.testing.assert_allclose([float(propeller_thrust(params, v)) for v in n], [left, right])
    np.testing.assert_allclose(allocation_matrix(params), [[1, 1], [0.395, -0.395]])


def test_tau_space_is_the_config_box() -> None:
    space = input_space(NmpcConfig(), None)
    assert space.matrix is None
    np.testing.assert_array_equal(space.low, [-150.0, -73.6])
    np.testing.assert_array_equal(space.high, [150.0, 73.6])
    with pytest.raises(ValueError, match="vessel parameters"):
        input_space(NmpcConfig(inputs="propellers"), None)


@pytest.mark.parametrize("solver", ["nrti", "asrti", "rti", "ipopt"])
def test_tau_inputs_are_as_before(solver: str, monkeypatch: pytest.MonkeyPatch) -> None:
    expected = np.array([[float.fromhex(v) for v in row] for row in
                         json.loads(GOLDEN.read_text(encoding="utf-8"))[solver]])
    results, _ = _run(monkeypatch, 3.0, "tau", solver=solver, roll_fade_m=0.0,
                      heading_limit_deg=0.0)  # the cost it was recorded with
    got = np.array([[*r.tau, *r.inputs[-1]] for r in results])
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=1e-6, atol=1e-6)


@pytest.mark.slow
@pytest.mark.parametrize("solver", ["nrti", "asrti"])
def test_propeller_inputs_never_command_a_propeller_beyond_its_limit(solver: str,
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    params = otter_parameters("published")
    reverse, forward = thrust_limits(params)
    B_inv = np.linalg.inv(allocation_matrix(params))
    results, metrics = _run(monkeypatch, 180.0, "propellers", solver=solver, inputs="propellers")
    assert metrics["time_to_waypoint_s"] is not None and metrics["failures"] == 0
    commanded = np.array([r.tau for r in results])
    applied = commanded @ B_inv.T  # (left, right) thrust of every command
    planned = np.vstack([r.inputs for r in results]) @ B_inv.T  # and of every planned input
    tol = 1e-9  # N: round-off of τ = B·u and back
    for name, thrusts in (("applied", applied), ("planned", planned)):
        assert thrusts.min() >= reverse - tol, f"{name}: {thrusts.min():.6f} N below {reverse:.6f} N"
        assert thrusts.max() <= forward + tol, f"{name}: {thrusts.max():.6f} N above {forward:.6f} N"
    assert applied.max() > forward - 1.0  # the limit is used, not avoided by a margin
    mats = params.matrices()  # the plant's side: its allocation never saturates a command
    speeds = np.array([tau_to_shaft_speeds(params, *tau) for tau in commanded])
    assert speeds.max() <= mats.n_max + 1e-9 and speeds.min() >= mats.n_min - 1e-9
    given = np.array([shaft_speeds_to_tau(params, *n) for n in speeds], float)
    worst = int(np.abs(given - commanded).max(axis=1).argmax())
    np.testing.assert_allclose(given, commanded, atol=1e-6,
                               err_msg=f"the plant gave another tau than commanded at step {worst}: saturated")


@pytest.mark.parametrize("box", [{"tau_x_max_n": 100.0}, {"tau_x_min_n": -50.0}, {"tau_n_max_nm": 40.0}])
def test_a_tau_box_with_propeller_inputs_is_refused_not_ignored(box: dict[str, float]) -> None:
    (name,) = box
    with pytest.raises(ConfigError, match=f"^{name}: does not apply with inputs: propellers"):
        NmpcConfig(inputs="propellers", **box)
    assert NmpcConfig(inputs="tau", **box).inputs == "tau"  # the paper's setting takes it


def test_one_input_is_clipped_bit_for_bit_as_numpy_clips() -> None:
    """The step clips one input in plain floats (issue 32): np.clip's answer bit for bit, signed zeros at a bound of
    zero, NaN and infinities included."""
    values = [0.0, -0.0, 1.0, -1.0, math.nan, math.inf, -math.inf, 5.0, -5.0]
    boxes = [(0.0, 1.0), (-1.0, 0.0), (-0.0, 0.0), (0.0, -0.0), (-2.0, 2.0), (-math.inf, math.inf)]
    for first, second in itertools.product(boxes, repeat=2):
        space = InputSpace("tau", None, np.array([first[0], second[0]]), np.array([first[1], second[1]]))
        for u in itertools.product(values, repeat=2):
            got, want = space.clip(np.array(u)), np.clip(np.array(u), space.low, space.high)
            assert np.array_equal(got, want, equal_nan=True) and np.array_equal(np.signbit(got), np.signbit(want))
