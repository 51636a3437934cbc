"""The preflight check's last item: the configured NMPC's solve time on this computer."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from mavbridge.nmpc import RollAwareNmpc
from mavbridge.nmpc.model_state import resolve_heave_feedback
from mavbridge.preflight.report import FAIL, PASS, WARN, Report


def solve_time(scenario: Any, solves: int, report: Report, log: Callable[[str], None] = print) -> None:
    """Time ``solves`` closed-loop solves of the scenario's NMPC (following its own plan, so warm as in flight)."""
    if solves <= 0:
        return
    period_s = float(scenario.controller.period_s)
    log(f"timing {solves} NMPC solves ({scenario.controller.solver})...")
    x, t, walls = scenario.start.state(), 0.0, []
    target = (scenario.waypoint.north_m, scenario.waypoint.east_m)
    controller = scenario.controller.replace(heave_feedback=resolve_heave_feedback(scenario.controller.heave_feedback,
                                                                                   True))  # as the companion flies
    with RollAwareNmpc(controller, scenario.model_params(), scenario.sea.waves()) as nmpc:
        for _ in range(solves):
            result = nmpc.solve(x, t, target)
            walls.append(result.wall_time_s)
            x, t = np.asarray(result.states)[1], t + period_s
    steady = np.array(walls[min(5, len(walls) - 1):]) * 1e3
    median, p95, worst = np.median(steady), np.percentile(steady, 95), np.max(steady)
    period_ms = period_s * 1e3
    actual = f"median {median:.1f}, p95 {p95:.1f}, max {worst:.1f} ms ({len(walls)} solves)"
    expected = f"p95 < {period_ms:g} ms (period)"
    item = f"NMPC solve time ({scenario.controller.solver})"
    fix = "use solver rti (--solver rti / controller.solver), a shorter horizon, or a faster computer"
    if p95 >= period_ms:
        report.add(FAIL, item, expected, actual, fix)
    elif worst >= period_ms or p95 >= 0.5 * period_ms:
        report.add(WARN, item, expected, actual, "late solves fall back to the previous plan; " + fix)
    else:
        report.add(PASS, item, expected, actual)
