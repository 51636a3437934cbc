"""Log samples on a uniform grid, in stretches without gaps: what every estimator here works on.

Real logs sample unevenly (the Otter API at 9–10 Hz with stale repeats dropped, a tlog at the stream's rate
with lost frames); the estimators need one step. Samples are interpolated linearly onto a grid of step ``dt``
inside stretches whose gaps are at most ``max_gap_s``; a longer gap ends a stretch (nothing is made up across
it). Commands are held (zero-order) from their last sample, as an autopilot holds an output.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Stretch:
    """A gap-free stretch on a uniform grid: times ``t`` (s) and columns ``y`` (one row per time)."""

    t: np.ndarray
    y: np.ndarray

    @property
    def dt(self) -> float:
        """The grid's step (s)."""
        return float(self.t[1] - self.t[0]) if self.t.size > 1 else 0.0

    @property
    def duration_s(self) -> float:
        """Length in seconds."""
        return float(self.t[-1] - self.t[0]) if self.t.size else 0.0


def median_step(t: np.ndarray) -> float:
    """The median positive step between sample times (s); nan with fewer than two samples."""
    steps = np.diff(np.asarray(t, float))
    steps = steps[steps > 0]
    return float(np.median(steps)) if steps.size else float("nan")


def stretches(t: np.ndarray, y: np.ndarray, dt: float, max_gap_s: float, min_s: float = 0.0) -> list[Stretch]:
    """``y`` (rows per time, or one column) interpolated onto a grid of step ``dt`` in each stretch of ``t``
    without a gap longer than ``max_gap_s``; stretches shorter than ``min_s`` are left out."""
    t = np.asarray(t, float)
    if t.size < 2:
        return []
    y = np.asarray(y, float).reshape(t.size, -1)
    keep = np.isfinite(t) & np.all(np.isfinite(y), axis=1)
    t, y = t[keep], y[keep]
    if t.size < 2:
        return []
    order = np.argsort(t, kind="stable")
    t, y = t[order], y[order]
    breaks = np.flatnonzero(np.diff(t) > max_gap_s) + 1
    out = []
    for a, b in zip(np.r_[0, breaks], np.r_[breaks, t.size], strict=True):
        seg_t, seg_y = t[a:b], y[a:b]
        if seg_t.size < 2 or seg_t[-1] - seg_t[0] < max(min_s, 2 * dt):
            continue
        grid = np.arange(seg_t[0], seg_t[-1] + 1e-9, dt)
        cols = np.column_stack([np.interp(grid, seg_t, seg_y[:, k]) for k in range(seg_y.shape[1])])
        out.append(Stretch(grid, cols))
    return out


def held(t_cmd: np.ndarray, v_cmd: np.ndarray, grid: np.ndarray, stale_s: float = 2.0) -> np.ndarray:
    """A command's value at each ``grid`` time: its latest sample before (zero-order hold), nan before its first
    sample or when the latest is older than ``stale_s`` (the command stopped being logged)."""
    t_cmd, v_cmd = np.asarray(t_cmd, float), np.asarray(v_cmd, float)
    keep = np.isfinite(t_cmd) & np.isfinite(v_cmd)
    t_cmd, v_cmd = t_cmd[keep], v_cmd[keep]
    out = np.full(grid.shape, np.nan)
    if not t_cmd.size:
        return out
    i = np.searchsorted(t_cmd, grid, side="right") - 1
    ok = (i >= 0)
    ok[ok] &= (grid[ok] - t_cmd[i[ok]]) <= stale_s
    out[ok] = v_cmd[i[ok]]
    return out


def moving_average(y: np.ndarray, n: int) -> np.ndarray:
    """A centred moving average over ``n`` samples (edges over what there is): the slow part of a signal."""
    n = max(1, min(int(n), y.size))
    kernel = np.ones(n)
    total = np.convolve(y, kernel, mode="same")
    count = np.convolve(np.ones_like(y), kernel, mode="same")
    return total / count


def blocks(items: list[Stretch], block_s: float) -> list[list[Stretch]]:
    """The stretches cut into consecutive blocks of about ``block_s`` seconds (independent parts of the log for an
    interval); a block is a list of pieces."""
    out: list[list[Stretch]] = []
    current: list[Stretch] = []
    filled = 0.0
    for s in items:
        start = 0
        step = s.dt or 1.0
        while start < s.t.size - 1:
            need = max(round((block_s - filled) / step), 2)
            piece = Stretch(s.t[start:start + need + 1], s.y[start:start + need + 1])
            current.append(piece)
            filled += piece.duration_s
            start += need
            if filled >= block_s * 0.999:
                out.append(current)
                current, filled = [], 0.0
    if current and filled >= 0.5 * block_s:
        out.append(current)
    return out
