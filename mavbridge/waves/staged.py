"""A computation in stages that can be worked ahead of its schedule without changing what it gives, or when.

The window estimator spreads a fit over several control steps, one stage per ``STAGE_S`` of sample time
(``window_fit.Stages``). In the companion the estimator runs in a process of its own
(``mavbridge.companion.wave_process``), which has time between samples: ``AheadJob.work_ahead`` does the next
stage then and keeps its outcome; ``due`` hands the outcomes over in order at the times the schedule says, and
works a stage itself only if none is ready. A stage's outcome is what it yielded (None, or a dict of what it
found out) or, for the last, the computation's result; the estimator applies each when it is due, so its
answers at any sample time are the same whether the work was done early or on time.

A job can be copied (``copy.deepcopy``, as ``mavbridge.lab.watch`` copies an estimator a watch left): a generator
cannot, so the copy makes its stages again from a copy of what they are made from (``make``, a callable of no
arguments: its stages may read only what stays fixed while the job runs) and works as many as the job has worked,
their outcomes dropped (the job's own, already handed over or kept, are what the copy hands over).
"""

from __future__ import annotations

import copy
from collections import deque
from collections.abc import Callable, Generator
from typing import Any

from mavbridge.waves.window_fit import Fit

FitStages = Generator[dict[str, Any] | None, None, Fit | None]
_END = object()  # (a stage made again beyond the last)


class AheadJob:
    """One fit's stages, worked when due (``due``) or ahead of time (``work_ahead``)."""

    def __init__(self, make: Callable[[], FitStages]) -> None:
        self._make = make
        self._stages: FitStages | None = make()
        self._ready: deque[tuple[bool, Any]] = deque()  # outcomes worked ahead, oldest first
        self._ended = False  # the last stage has been worked (its outcome may still wait in _ready)
        self._worked = 0  # stages worked so far

    def __deepcopy__(self, memo: dict[int, Any]) -> AheadJob:
        """The same job, its stages made again (from a copy of ``make``) and worked as far as this one's when the
        copy is first asked for a stage: not at once, as what they read may itself be in the middle of a copy."""
        twin = AheadJob.__new__(AheadJob)
        memo[id(self)] = twin
        twin._make = copy.deepcopy(self._make, memo)
        twin._stages = None
        twin._ready, twin._ended, twin._worked = copy.deepcopy(self._ready, memo), self._ended, self._worked
        return twin

    def _next(self) -> dict[str, Any] | None:
        """The next stage's outcome (StopIteration after the last); a copy first makes its stages again."""
        if self._stages is None:
            self._stages = self._make()
            for _ in range(self._worked):
                if next(self._stages, _END) is _END:
                    raise RuntimeError("AheadJob: a copy's stages ended before the original's had")
        return next(self._stages)

    def _work(self) -> tuple[bool, Any]:
        """(False, what the stage yielded), or (True, the result) for the last stage."""
        try:
            outcome: tuple[bool, Any] = (False, self._next())
        except StopIteration as end:
            self._ended = True
            outcome = (True, end.value)
        self._worked += 1
        return outcome

    def work_ahead(self) -> bool:
        """Work the next stage now and keep its outcome; True while stages are left to work."""
        if self._ended:
            return False
        self._ready.append(self._work())
        return not self._ended

    def due(self) -> tuple[bool, Any]:
        """The outcome of the stage now due: the one worked ahead, else worked here."""
        return self._ready.popleft() if self._ready else self._work()
