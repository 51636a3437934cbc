"""What the companion says while its loop runs, at most once per interval of wall time per kind.

Two things a user must see while they happen, not only in the summary: that the companion is waiting for the
pilot (it never engages on finding the boat armed in its mode), and that the controller cannot keep up with
its period (control ticks skipped: the boat is flown on older plans than the scenario asks for).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from mavbridge.companion.rover_modes import mode_name
from vessel.wording import counted

INTERVAL_S = 10.0  # wall seconds between two lines of one kind
KEEP_UP_WARN_SHARE = 0.01  # skipped ticks from this share on make the summary's warning


@dataclass
class LoopNotices:
    """Rate-limited loop messages: the wait for the pilot, and skipped control ticks."""

    log: Callable[[str], None]
    required_mode: int
    interval_s: float = INTERVAL_S
    clock: Callable[[], float] = time.monotonic
    progress_every_s: float = 10.0  # autopilot seconds between two progress lines while engaged
    _last: dict[str, float] = field(default_factory=dict)
    _skipped_since: int = 0
    _max_roll_rad: float = 0.0
    _next_progress_s: float | None = None

    def _due(self, kind: str) -> bool:
        now = self.clock()
        if kind in self._last and now - self._last[kind] < self.interval_s:
            return False
        self._last[kind] = now
        return True

    def waiting(self, reason: str) -> None:
        """The companion is waiting to engage (``reason``: why it has not yet, may be empty)."""
        if self._due("waiting"):
            self.log(f"waiting for the pilot to switch to {mode_name(self.required_mode)} (armed)"
                     + (f"; {reason}" if reason else ""))

    def skipped(self, missed: int, period_s: float) -> None:
        """``missed`` control ticks were skipped just now (the last step took longer than its period)."""
        self._skipped_since += missed
        if missed and self._due("skipped"):
            self.log(f"warning: the controller cannot keep up: {counted(self._skipped_since, 'control tick')} of "
                     f"{period_s:g} s skipped since the last warning (a step takes longer than the period; "
                     "try the nrti solver or a lower --speedup)")
            self._skipped_since = 0

    def progress(self, t_s: float, to_go_m: float, roll_rad: float, step_ms: float) -> None:
        """A control step at autopilot time ``t_s``: every ``progress_every_s`` of it, one line with the distance
        to go, the largest roll so far and this step's wall time."""
        self._max_roll_rad = max(self._max_roll_rad, abs(roll_rad))
        if self._next_progress_s is None:
            self._next_progress_s = t_s + self.progress_every_s
        if t_s < self._next_progress_s:
            return
        self._next_progress_s = t_s + self.progress_every_s
        self.log(f"t = {t_s:.1f} s (autopilot): {to_go_m:.0f} m to go, max roll so far "
                 f"{math.degrees(self._max_roll_rad):.1f} deg, step {step_ms:.1f} ms")


def keep_up_summary(skipped: int, steps: int, late: int = 0) -> str | None:
    """The summary's line on skipped ticks and steps past their deadline (flown on the previous plan's input);
    None when there were neither; a warning from KEEP_UP_WARN_SHARE of the ticks on (a few late ticks while a
    machine is busy elsewhere do not make another controller)."""
    if not skipped and not late:
        return None
    share = (skipped + late) / max(skipped + steps, 1)
    said = [f"{counted(skipped, 'control tick')} skipped"] if skipped else []
    said += [f"{counted(late, 'step')} past their deadline"] if late else []
    line = f"{' and '.join(said)}, {100 * share:.1f} % of the ticks"
    if share < KEEP_UP_WARN_SHARE:
        return f"note: {line}"
    return (f"warning: the controller could not keep up: {line}; the figures above are not the scenario's "
            f"controller at its period")
