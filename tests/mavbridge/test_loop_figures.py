"""The in-process closed loop gives the figures it gave before it was made faster.

Speed work on the loop (the preparation inline, compiled plant periods, allocation-free hot paths) must change
nothing a user reads: the figures below were recorded from the code as it stood before the first speed commit,
and every run must give them again — metrics equal to 1e-9 relative and the same arrival step.

    python -m tests.mavbridge.test_loop_figures --record   # only when a change of *results* is intended

Three realistic runs (estimator, hidden phase, sensors, nrti, the disturbance observer) in the paper's sea, a
JONSWAP sea and NATO sea state 4, and the paper's set-up as a sweep flies it (asrti on the true wave).
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any

import pytest

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import Scenario, load_scenarios

ROOT = Path(__file__).resolve().parents[2]
FIGURES = Path(__file__).with_name("data") / "loop_figures.json"
REL_TOL = 1e-9
CASES = {  # case -> (scenario file, run name, solver, R or None for the run's own)
    "paper-sea-balanced": ("scenarios/estimated.yaml", "balanced", "nrti", None),
    "jonswap-direct": ("scenarios/jonswap_estimated.yaml", "direct", "nrti", None),
    "nato-ss4-balanced": ("scenarios/nato_ss4_estimated.yaml", "nato_ss4_estimated", "nrti", 1550.0),
    "paper-setup-sweep": ("scenarios/balanced.yaml", "balanced", "asrti", None),
}


def case_scenario(case: str) -> Scenario:
    """The scenario of one case, its solver (and R) set as the case says."""
    path, run, solver, r = CASES[case]
    scenario = {sc.name: sc for sc in load_scenarios(ROOT / path)}[run]
    controller = scenario.controller.replace(solver=solver, **({"r": r} if r is not None else {}))
    return dataclasses.replace(scenario, controller=controller)


def _timing(key: str) -> bool:
    """Keys that measure the machine, not the run (wall and solve times, deadline overruns)."""
    return "_ms" in key or "wall" in key or key in ("overruns", "late")


def figures(metrics: dict[str, Any]) -> dict[str, Any]:
    """What a run's metrics say about the run itself, timing left out."""
    return {key: (figures(value) if isinstance(value, dict) else value)
            for key, value in metrics.items() if not _timing(key)}


def run_case(case: str) -> dict[str, Any]:
    """The figures of one case, flown in-process as ``mavbridge experiment`` flies it (no files)."""
    return figures(run_scenario(case_scenario(case), None, plots=False).metrics)


def differences(expected: Any, got: Any, where: str = "") -> list[str]:
    """Every place where ``got`` differs from ``expected`` beyond REL_TOL (numbers) or at all (the rest)."""
    if isinstance(expected, dict) and isinstance(got, dict):
        out = [f"{where}.{key}: missing" for key in expected if key not in got]
        out += [f"{where}.{key}: not recorded" for key in got if key not in expected]
        for key in expected.keys() & got.keys():
            out += differences(expected[key], got[key], f"{where}.{key}")
        return out
    if isinstance(expected, list) and isinstance(got, list) and len(expected) == len(got):
        pairs = enumerate(zip(expected, got, strict=True))
        return [d for i, (e, g) in pairs for d in differences(e, g, f"{where}[{i}]")]
    numbers = (int, float)
    if isinstance(expected, numbers) and isinstance(got, numbers) and not isinstance(expected, bool):
        if math.isclose(expected, got, rel_tol=REL_TOL, abs_tol=1e-12):
            return []
    elif expected == got:
        return []
    return [f"{where}: recorded {expected!r}, now {got!r}"]


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_loop_gives_the_recorded_figures(case: str) -> None:
    recorded = json.loads(FIGURES.read_text(encoding="utf-8"))[case]
    got = run_case(case)
    assert got["steps"] == recorded["steps"], "the arrival step changed"
    assert not differences(recorded, got), "\n".join(differences(recorded, got))


def test_differences_sees_a_change_at_the_tolerance() -> None:
    recorded = {"avg_roll_deg": 2.5, "notes": ["a"], "disturbance": {"updates": 10}}
    close, far = 2.5 * (1 + 1e-11), 2.5 * (1 + 1e-8)
    assert not differences(recorded, {"avg_roll_deg": close, "notes": ["a"], "disturbance": {"updates": 10}})
    assert differences(recorded, {"avg_roll_deg": far, "notes": ["a"], "disturbance": {"updates": 10}})
    assert differences(recorded, {"avg_roll_deg": 2.5, "notes": ["b"], "disturbance": {"updates": 10}})
    assert differences(recorded, {"avg_roll_deg": 2.5, "notes": ["a"], "disturbance": {"updates": 11}})


if __name__ == "__main__" and "--record" in sys.argv:
    FIGURES.write_text(json.dumps({case: run_case(case) for case in sorted(CASES)}, indent=1) + "\n",
                       encoding="utf-8")
    print(f"recorded {len(CASES)} cases in {FIGURES}")
