"""Where the companion's commands leave it: one output path, and whether anything is still commanding.

Every command goes through ``send`` (a plan with a non-finite input is never sent: the boat holds its
heading with zero thrust instead, and that neutral counts as commanding). What is commanding is
released on a mode change, a take-over, the end of the run and a stale state (``stand_down``: neutral
first, so the boat is never left to a last command), and ``stale`` says when no fresh step came for
three periods.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

STALE_PERIODS = 3  # no fresh step for this many control periods: stop pushing


class CommandChannel:
    """The output path plus the commanding flag and the wall time of the last command."""

    def __init__(self, output: Any, log: Callable[[str], None]) -> None:
        self.output, self.log = output, log
        self.commanding = False
        self.last_wall = 0.0

    def release(self, link: Any) -> None:
        """Hand the sticks back (RC override released / no more targets)."""
        self.output.release(link)
        self.commanding = False

    def stand_down(self, link: Any, state: Any) -> None:
        """Neutral, then release: the boat is never left to a last command."""
        self.output.neutral(link, state)
        self.release(link)

    def send(self, link: Any, result: Any, now_ms: int, state: Any) -> dict[str, Any] | None:
        """Send the plan's input; its log columns, or None when the plan was not finite (neutral sent)."""
        try:
            columns = self.output.command(link, result, now_ms)
        except ValueError as exc:  # a non-finite plan: stop in place rather than send NaN
            self.log(f"warning: {exc}; holding heading with zero thrust")
            self.output.neutral(link, state)
            columns = None
        # the neutral command is a command too: released on a mode change or at the end, refreshed each step
        self.commanding = self.output.sends
        self.last_wall = time.monotonic()
        return columns

    def stale(self, period_s: float) -> bool:
        """Commanding, but no command for ``STALE_PERIODS`` periods of wall time."""
        return self.commanding and time.monotonic() - self.last_wall > STALE_PERIODS * period_s
