"""What the computer does to a control step, for the benches that time one (``bench/step_under_load.py``).

* ``spinners``: processes that burn a CPU each beside the step (a companion computer's cameras and loggers);
* ``load``: the 1-minute load average, printed before and after;
* ``collections_timed``: every pass of the garbage collector while inside (is it in the step's tail?);
* ``cold_factor``: how much dearer the same small piece of Python is after the process has slept a control period
  than at its fastest run again at once. A paced step runs once every 100 ms; on a computer whose caches (and
  branch predictors, and a virtual machine's translations) are taken by others meanwhile, every part of it costs
  several times its hot cost. Measured on two computers, the factors say how their step figures compare.
"""

from __future__ import annotations

import gc
import math
import os
import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

_PIECE = struct.Struct("<17d")  # (the size of a motion sample's message)


@contextmanager
def spinners(count: int) -> Iterator[None]:
    """``count`` processes that burn a CPU each at normal priority, stopped by their handles."""
    procs = [subprocess.Popen([sys.executable, "-c", "while True: pass"],  # SCHED_OTHER whatever the caller's is
                              preexec_fn=lambda: os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0)))
             for _ in range(count)]
    try:
        time.sleep(1.0)  # let them take the CPUs
        yield
    finally:
        for proc in procs:
            proc.kill()
            proc.wait()


def load() -> str:
    """The 1-minute load average."""
    return f"{os.getloadavg()[0]:.1f}"


@contextmanager
def collections_timed() -> Iterator[list[float]]:
    """The wall ms of every cyclic garbage collection while inside (is the collector in the step's tail?)."""
    spans: list[float] = []
    started = [0.0]

    def timed(phase: str, _info: dict) -> None:
        if phase == "start":
            started[0] = time.perf_counter()
        else:
            spans.append((time.perf_counter() - started[0]) * 1e3)

    gc.callbacks.append(timed)
    try:
        yield spans
    finally:
        gc.callbacks.remove(timed)


def _piece(values: list[float]) -> float:
    """A few microseconds of the kind of work a step does: floats packed, a small array made and summed, a dict."""
    packed = _PIECE.pack(*values)
    array = np.array(values[:12])
    row = {"a": math.fsum(values[:6]), "b": float(array.sum()), "n": len(packed)}
    return row["a"] + row["b"]


def _timed_piece(values: list[float]) -> float:
    """One ``_piece``, its wall µs."""
    start = time.perf_counter_ns()
    _piece(values)
    return (time.perf_counter_ns() - start) / 1e3


def _spin(seconds: float) -> None:
    """Burn this CPU for ``seconds`` (touching next to nothing: the clock)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


def cold_factor(asleep_s: float = 0.1, times: int = 20, spin: bool = False) -> tuple[float, float]:
    """(µs of the piece at its fastest run again at once (of five), µs after ``asleep_s`` asleep, or spinning with
    ``spin``), medians over ``times`` of each (about ``times`` × ``asleep_s`` seconds in all)."""
    values = [0.1 * k for k in range(17)]
    hot, cold = [], []
    for _ in range(times):
        (_spin if spin else time.sleep)(asleep_s)
        cold.append(_timed_piece(values))
        hot.append(min(_timed_piece(values) for _ in range(5)))
    return float(np.median(hot)), float(np.median(cold))


def cold_table(gaps_s: tuple[float, ...] = (0.0002, 0.001, 0.003, 0.01, 0.1)) -> list[str]:
    """Lines: the piece's cost after each gap, asleep and spinning (is it the sleep, or the time?)."""
    lines = [f"{'gap ms':>8} {'hot µs':>8} {'asleep µs':>10} {'spinning µs':>12}"]
    for gap in gaps_s:
        hot, asleep = cold_factor(gap, times=20)
        _, spinning = cold_factor(gap, times=20, spin=True)
        lines.append(f"{gap * 1e3:>8.1f} {hot:>8.1f} {asleep:>10.1f} {spinning:>12.1f}")
    return lines


def cold_line(asleep_s: float = 0.1) -> str:
    """One line: the piece's cost hot and after a control period asleep, and their ratio."""
    hot, cold = cold_factor(asleep_s)
    return (f"this computer: a piece of a step's Python costs {hot:.1f} µs at its fastest, {cold:.1f} µs after "
            f"{asleep_s * 1e3:.0f} ms asleep ({cold / hot:.1f}× hot)")
