"""Stretches of a trial and their figures: per mode (and arming), per engagement of our companion.

A mode segment runs from one change of the autopilot's mode or arming to the next (the last to the end of the
log); a log without modes (the Otter API's) is one segment. An engagement is a stretch in which our companion
commanded: its rows in ``companion.csv`` (the run folder's log of every control step, on the autopilot's
clock) that follow each other within ``ENGAGEMENT_GAP_S``. The companion's run folder is found beside the
log: the log's own folder (``companion.tlog``), or a ``companion/`` folder in it or beside it (a demo's
``sim/sim_vehicle.tlog``).

Per stretch: duration, distance (the positions averaged over ``DISTANCE_BLOCK_S``, then counted in steps of at
least ``DISTANCE_STEP_M``, so that GPS jitter at rest adds nothing), mean speed (distance over duration),
average and maximum |roll| over its attitude samples.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.field.trial import Trial

DISTANCE_STEP_M = 1.0
DISTANCE_BLOCK_S = 2.0
ENGAGEMENT_GAP_S = 2.0  # control steps further apart than this (autopilot time) belong to two engagements
COMPANION_LOG = "companion.csv"


@dataclass(frozen=True)
class Segment:
    """One stretch of a trial and its figures (SI; roll in degrees, as printed)."""

    label: str
    start_s: float
    end_s: float
    duration_s: float
    distance_m: float | None
    mean_speed_m_s: float | None
    avg_roll_deg: float | None
    max_roll_deg: float | None
    samples: int

    def row(self) -> dict[str, Any]:
        """For report.json (4 decimals)."""
        return {k: round(v, 4) if isinstance(v, float) else v for k, v in asdict(self).items()}

    def line(self) -> str:
        """One line for the terminal."""
        roll = (f"avg roll {self.avg_roll_deg:.2f} deg, max {self.max_roll_deg:.2f} deg"
                if self.avg_roll_deg is not None else "no attitude")
        speed = f" at {self.mean_speed_m_s:.2f} m/s" if self.mean_speed_m_s is not None else ""
        moved = f"{self.distance_m:.1f} m{speed}" if self.distance_m is not None else "no position"
        return (f"{self.label:<22} t {self.start_s:8.1f} .. {self.end_s:8.1f} s  {self.duration_s:7.1f} s  "
                f"{moved}  {roll}")


def distance(t: np.ndarray, north: np.ndarray, east: np.ndarray, step_m: float = DISTANCE_STEP_M) -> float:
    """Path length of the positions averaged over DISTANCE_BLOCK_S blocks, counted from anchor to anchor, a new
    anchor once the boat is ``step_m`` from the last."""
    if north.size == 0:
        return 0.0
    block = np.floor((t - t[0]) / DISTANCE_BLOCK_S).astype(int)
    count = np.bincount(block)
    kept = count > 0
    north, east = (np.bincount(block, weights=v)[kept] / count[kept] for v in (north, east))
    total, anchor_n, anchor_e = 0.0, float(north[0]), float(east[0])
    for n, e in zip(north.tolist(), east.tolist(), strict=True):
        d = math.hypot(n - anchor_n, e - anchor_e)
        if d >= step_m:
            total, anchor_n, anchor_e = total + d, n, e
    return total


def segment(trial: Trial, label: str, start_s: float, end_s: float) -> Segment:
    """The figures of ``trial`` between ``start_s`` and ``end_s``."""
    att, track = trial.attitude, trial.track
    in_att = (att[:, 0] >= start_s) & (att[:, 0] <= end_s)
    roll = np.degrees(np.abs(att[in_att, 1]))
    in_track = (track[:, 0] >= start_s) & (track[:, 0] <= end_s)
    duration = max(end_s - start_s, 0.0)
    dist = distance(track[in_track, 0], track[in_track, 1], track[in_track, 2]) if in_track.any() else None
    return Segment(label, start_s, end_s, duration, dist,
                   dist / duration if dist is not None and duration > 0 else None,
                   float(roll.mean()) if roll.size else None, float(roll.max()) if roll.size else None,
                   int(roll.size))


def mode_segments(trial: Trial) -> list[Segment]:
    """One segment per mode (and arming) the autopilot was in; the whole log when it says no modes."""
    if not trial.modes:
        return [segment(trial, "whole log (no modes)", trial.start_s, trial.end_s)]
    out = []
    for i, change in enumerate(trial.modes):
        end = trial.modes[i + 1].t_s if i + 1 < len(trial.modes) else trial.end_s
        if end > change.t_s or i + 1 == len(trial.modes):  # a mode left at once (then armed) is no segment
            out.append(segment(trial, change.label, change.t_s, end))
    return out


def companion_folder(log: Path) -> Path | None:
    """Our companion's run folder beside ``log`` (see the module docstring), None when there is none."""
    here = log.resolve().parent
    for folder in (here, here / "companion", here.parent / "companion"):
        if (folder / COMPANION_LOG).is_file():
            return folder
    return None


def engagement_windows(folder: Path) -> list[tuple[float, float, bool]]:
    """(start, end, sent) of each engagement in a companion run folder (autopilot seconds); sent is False for a
    dry run (planned, nothing sent)."""
    windows: list[list[float]] = []
    sent = True
    with (folder / COMPANION_LOG).open(newline="", encoding="utf-8") as handle:
        for row in csv.DictReader(handle):
            try:
                t = float(row["t_s"])
            except (KeyError, TypeError, ValueError):
                continue
            sent = sent and row.get("sent", "1") != "0"
            if windows and t - windows[-1][1] <= ENGAGEMENT_GAP_S:
                windows[-1][1] = t
            else:
                windows.append([t, t])
    return [(a, b, sent) for a, b in windows]


def engagements(trial: Trial, folder: Path) -> list[Segment]:
    """The companion's engagements (from its run folder) that overlap the trial, with the trial's figures."""
    output = ""
    metrics = folder / "metrics.json"
    if metrics.is_file():
        try:
            output = str(json.loads(metrics.read_text()).get("output", ""))
        except (OSError, ValueError):
            output = ""
    out = []
    for i, (start, end, sent) in enumerate(engagement_windows(folder), start=1):
        if end < trial.start_s or start > trial.end_s:
            continue
        what = ", ".join(x for x in (output, "" if sent else "dry run") if x)
        out.append(segment(trial, f"engagement {i}" + (f" ({what})" if what else ""), start, end))
    return out
