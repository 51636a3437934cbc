"""The end-of-run summary a user reads, built from the run's metrics (``metrics.json``).

``mavbridge run`` prints it when it ends and ``mavbridge demo`` prints it from its companion's metrics,
so the two say the same. A figure that is None (no control step, never engaged, never confident) is
left out instead of being printed as "None". Two kinds of time appear, each named: the time *to* the
waypoint is counted from engaging; the instants of engaging and arriving are on the autopilot's clock
(``time_boot_ms``), the clock of every log line that says "t = … s (autopilot time)".
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from mavbridge.companion.notices import keep_up_summary

_FIGURES = (("average roll", "avg_roll_deg", "deg"), ("max roll", "max_roll_deg", "deg"),
            ("solve median", "solve_ms_median", "ms"))


def arrival_text(metrics: Mapping[str, Any]) -> str:
    """'time to waypoint 95.7 s (since engaging at t = 45.9 s, reached at t = 141.6 s, autopilot time)', or
    why there is none."""
    to_go, engaged = metrics.get("time_to_waypoint_s"), metrics.get("engaged_at_s")
    if to_go is None:
        return "waypoint not reached" + ("" if engaged is not None else " (never engaged)")
    if engaged is None:
        return f"time to waypoint {to_go:g} s (since engaging)"
    return (f"time to waypoint {to_go:g} s (since engaging at t = {engaged:.1f} s, reached at "
            f"t = {engaged + to_go:.1f} s, autopilot time)")


def figures_line(metrics: Mapping[str, Any]) -> str:
    """Roll, solve time and arrival in one line; the figures that are None left out."""
    said = [f"{name} {metrics[key]:g} {unit}" for name, key, unit in _FIGURES if metrics.get(key) is not None]
    return ", ".join([*said, arrival_text(metrics)])


def confident_text(waves: Mapping[str, Any]) -> str | None:
    """When the estimate first became confident: from the first motion sample (autopilot time) when both are
    known, and whether that was before engaging (``time_to_confident_s`` 0: the first step had it); None when
    it never was."""
    first, confident = waves.get("first_sample_at_s"), waves.get("first_confident_at_s")
    if first is not None and confident is not None:
        when = " (before engaging)" if waves.get("time_to_confident_s") == 0 else ""
        return f"first confident {confident - first:.1f} s after its first motion sample{when}"
    if waves.get("time_to_confident_s") is not None:
        return f"first confident {waves['time_to_confident_s']:g} s after engaging"
    return None


def waves_line(waves: Mapping[str, Any]) -> str:
    """What the wave source did: roll-term share, first confidence, estimator cost (None parts left out)."""
    parts = []
    if waves.get("roll_term_fraction") is not None:
        parts.append(f"roll term on {round(100 * waves['roll_term_fraction'], 1):g} % of the steps")
    confident = confident_text(waves)
    if confident is not None:
        parts.append(confident)
    elif waves.get("roll_term_fraction") is not None:
        parts.append("never confident")
    if waves.get("estimator_ms_median") is not None:
        parts.append(f"estimator {waves['estimator_ms_median']:g} ms per step (median)")
    return f"waves ({waves.get('source', 'unknown')}): " + (", ".join(parts) or "no control step")


def summary_lines(metrics: Mapping[str, Any]) -> list[str]:
    """The summary: figures and arrival, the keep-up warning if ticks were skipped, the waves line."""
    lines = [figures_line(metrics)]
    behind = keep_up_summary(metrics.get("skipped_ticks", 0), metrics.get("steps", 0), metrics.get("late") or 0)
    if behind is not None:
        lines.append(behind)
    if "waves" in metrics:
        lines.append(waves_line(metrics["waves"]))
    return lines
