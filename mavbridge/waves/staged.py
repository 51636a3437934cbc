"""A computation in stages that can be worked ahead of its schedule without changing what it gives, or when.

The window estimator spreads a fit over several control steps, one stage per ``STAGE_S`` of sample time
(``window_fit.Stages``). In the companion the estimator runs in a process of its own
(``mavbridge.companion.wave_process``), which has time between samples: ``AheadJob.work_ahead`` does the next
stage then and keeps its outcome; ``due`` hands the outcomes over in order at the times the schedule says, and
works a stage itself only if none is ready. A stage's outcome is what it yielded (None, or a dict of what it
found out) or, for the last, the computation's result; the estimator applies each when it is due, so its
answers at any sample time are the same whether the work was done early or on time.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Generator
from typing import Any

from mavbridge.waves.window_fit import Fit

FitStages = Generator[dict[str, Any] | None, None, Fit | None]


class AheadJob:
    """One fit's stages, worked when due (``due``) or ahead of time (``work_ahead``)."""

    def __init__(self, stages: FitStages) -> None:
        self._stages = stages
        self._ready: deque[tuple[bool, Any]] = deque()  # outcomes worked ahead, oldest first
        self._ended = False  # the last stage has been worked (its outcome may still wait in _ready)

    def _work(self) -> tuple[bool, Any]:
        """(False, what the stage yielded), or (True, the result) for the last stage."""
        try:
            return False, next(self._stages)
        except StopIteration as end:
            self._ended = True
            return True, end.value

    def work_ahead(self) -> bool:
        """Work the next stage now and keep its outcome; True while stages are left to work."""
        if self._ended:
            return False
        self._ready.append(self._work())
        return not self._ended

    def due(self) -> tuple[bool, Any]:
        """The outcome of the stage now due: the one worked ahead, else worked here."""
        return self._ready.popleft() if self._ready else self._work()
