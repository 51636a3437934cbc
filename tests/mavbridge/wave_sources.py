"""A wave source for tests of what sits behind one: it answers what the test tells it."""

from __future__ import annotations

from dataclasses import dataclass

from mavbridge.waves.source import MotionSample, WaveEstimate


@dataclass
class ToldSource:
    """A wave source that answers ``answer`` (None: not confident), as the test sets it."""

    answer: WaveEstimate | None
    name: str = "told"

    def observe(self, sample: MotionSample) -> None:
        """Nothing to learn."""

    def estimate(self, t_s: float) -> WaveEstimate | None:
        return self.answer
