"""The replay's wave source: the estimator answering as the live companion's did, with the same samples behind it.

The companion runs its estimator in a process of its own (``companion.wave_process``), and which samples a
question is answered as of depends on how it runs it: paced (`mavbridge run`, the demo) the samples go to the
process together once a step's command is out or after a watch's question (``send_held``), so a question is
answered as of the samples sent before it; unpaced (``--lockstep``) as of every sample but the newest; in the
companion's own process (``estimator_process: false``) as of every sample. ``HeldEstimator`` gives the replay
the same answers from an estimator in the replay's process, holding back the samples the live one would not
have had answered yet, and always in time (the live one, paced, may answer late on a busy machine: a ``late``
fault in its metrics.json). The estimator's answers depend on its samples alone (its ``estimate`` changes
nothing), so the emulation is exact.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.companion.state import IMU_MESSAGES
from mavbridge.link.streams import imu_rate
from mavbridge.waves.source import MotionSample, WaveEstimate

PACED, UNPACED, IN_PROCESS = "paced", "unpaced", "in-process"


def answering(estimator_process: bool, lockstep: bool) -> str:
    """How the companion with these settings had its estimator answer (see the module docstring)."""
    return IN_PROCESS if not estimator_process else UNPACED if lockstep else PACED


@dataclass
class HeldEstimator:
    """An estimator fed only the samples the companion's would have answered as of (see the module docstring)."""

    estimator: Any
    how: str = PACED
    held: list[MotionSample] = field(default_factory=list)

    @property
    def name(self) -> str:
        """The estimator's name (the logs')."""
        return str(self.estimator.name)

    def observe(self, sample: MotionSample) -> None:
        """Paced: held until ``flush``; unpaced: the one before goes now, this one is held; in-process: now."""
        if self.how == IN_PROCESS:
            self.estimator.observe(sample)
            return
        if self.how == UNPACED:
            self._send()
        self.held.append(sample)

    def flush(self) -> None:
        """Paced: the samples held go now (``send_held``: after a step's command, after a watch's question)."""
        if self.how == PACED:
            self._send()

    def _send(self) -> None:
        for sample in self.held:
            self.estimator.observe(sample)
        self.held.clear()

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The estimator's wave to plan against, as of the samples it has."""
        return self.estimator.estimate(t_s)

    def latest(self, t_s: float) -> WaveEstimate | None:
        """Its current fit whatever the confidence (for the log's columns)."""
        return self.estimator.latest(t_s)

    def spread(self, explained: bool) -> np.ndarray | None:
        """Its slope covariance the wave does not explain (the expected-roll term)."""
        return self.estimator.spread(explained)


@dataclass
class StreamRates:
    """The IMU messages per second of the log's autopilot time, counted while the first pass reads it."""

    counts: Counter[str] = field(default_factory=Counter)
    span: list[float] = field(default_factory=list)  # [first t, last t]

    def through(self, messages: Iterable[tuple[float, Any]]) -> Iterator[tuple[float, Any]]:
        """The messages unchanged, each IMU one counted."""
        for t, msg in messages:
            kind = msg.get_type()
            if kind in IMU_MESSAGES:
                self.counts[kind] += 1
                self.span[:] = [self.span[0] if self.span else t, t]
            yield t, msg

    def fastest(self) -> str | None:
        """The IMU kind the companion pins (``link.streams.imu_rate``: the fastest), None when the log has none."""
        seconds = self.span[1] - self.span[0] if len(self.span) == 2 else 0.0
        return imu_rate({k: n / seconds for k, n in self.counts.items()} if seconds > 0 else {})[0]


