"""The end-of-run summary a user reads, built from the run's metrics (``metrics.json``).

``mavbridge run`` prints it when it ends and ``mavbridge demo`` prints it from its companion's metrics,
so the two say the same. A figure that is None (no control step, never engaged, never confident) is
left out instead of being printed as "None". Two kinds of time appear, each named: the time *to* the
waypoint is counted from engaging; the instants of engaging and arriving are on the autopilot's clock
(``time_boot_ms``), the clock of every log line that says "t = … s (autopilot time)".
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from mavbridge.companion.notices import keep_up_summary
from mavbridge.lab.runlog import RunRecorder, run_metrics

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


def disturbance_line(figures: Mapping[str, Any]) -> str:
    """The observer's last estimate, in one line: current (speed, direction it flows to), surge force, yaw moment."""
    north, east = figures["current_north_m_s"], figures["current_east_m_s"]
    settled = f"settled at t = {figures['settled_at_s']:.1f} s" if figures.get("settled_at_s") is not None \
        else "never settled"
    surge = f", surge force {figures['surge_force_n']:+.1f} N" if figures["surge_force_n"] else ""
    return (f"disturbance (estimated): current {math.hypot(north, east):.2f} m/s to "
            f"{math.degrees(math.atan2(east, north)):.0f}°{surge}, yaw moment {figures['yaw_moment_nm']:+.2f} N·m; "
            f"{settled}")


def summary_lines(metrics: Mapping[str, Any]) -> list[str]:
    """The summary: figures and arrival, the keep-up warning if ticks were skipped, the waves line."""
    lines = [figures_line(metrics)]
    behind = keep_up_summary(metrics.get("skipped_ticks", 0), metrics.get("steps", 0), metrics.get("late") or 0)
    if behind is not None:
        lines.append(behind)
    if "waves" in metrics:
        lines.append(waves_line(metrics["waves"]))
    if metrics.get("disturbance"):
        lines.append(disturbance_line(metrics["disturbance"]))
    return lines


@dataclass
class LoopEvents:
    """What the loop counted besides the control steps (autopilot milliseconds where a time)."""

    stale: int = 0
    skipped_ticks: int = 0
    connected_at_ms: int | None = None  # the first attitude the companion saw
    engaged_at_ms: int | None = None
    arrived_at_ms: int | None = None
    rates_hz: dict[str, float] = field(default_factory=dict)
    reads: int = 0  # the loop's reads of the link (a wake-up each, after its rest)
    ticks: int = 0  # ticks a step was due at

    def ticked(self, missed: int) -> None:
        """A step is due, ``missed`` ticks after the last one that was."""
        self.ticks += 1
        self.skipped_ticks += missed


def loop_metrics(record: RunRecorder, events: LoopEvents,
                 waypoint_ne: tuple[float, float] | None = None) -> dict[str, Any]:
    """The shared figures of merit (``run_metrics``, 4 decimals) with the loop's own counters; ``waypoint_ne``
    (a one-waypoint mission) adds the overshoot past it and the loops around it, on the companion's own state."""
    arrived = (events.arrived_at_ms - events.engaged_at_ms) / 1000.0 \
        if events.arrived_at_ms is not None and events.engaged_at_ms is not None else None
    figures = {k: round(v, 4) if isinstance(v, float) else v
               for k, v in run_metrics(record, arrived, waypoint_ne).items()}
    def seconds(ms: int | None) -> float | None:
        return ms / 1000.0 if ms is not None else None

    return {**figures, "connected_at_s": seconds(events.connected_at_ms), "engaged_at_s": seconds(events.engaged_at_ms),
            "stale_states": events.stale, "skipped_ticks": events.skipped_ticks, "rates_hz": events.rates_hz,
            "link_reads_per_tick": round(events.reads / events.ticks, 2) if events.ticks else None}
