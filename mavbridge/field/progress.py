"""A progress line on stderr while a long log is read: rewritten in place on a terminal, else a line now and then.

On a terminal the line is redrawn at most every ``TTY_EVERY_S`` and ended when the reading is; elsewhere (a
pipe, a test, CI) a line is printed only every ``PIPE_EVERY_S`` of wall time, so a short log prints nothing.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO

TTY_EVERY_S = 0.2
PIPE_EVERY_S = 5.0


class ProgressLine:
    """``progress(fraction, t_s)`` for a reader; ``done()`` when it has finished."""

    def __init__(self, label: str, stream: TextIO | None = None) -> None:
        self.label = label
        self.stream = stream or sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.start = self._last = time.monotonic()
        self.drawn = False

    def __call__(self, fraction: float, t_s: float) -> None:
        now = time.monotonic()
        if now - self._last < (TTY_EVERY_S if self.tty else PIPE_EVERY_S):
            return
        self._last = now
        text = f"{self.label}: {100 * min(max(fraction, 0.0), 1.0):3.0f} % read, t = {t_s:.0f} s of the log, " \
               f"{now - self.start:.0f} s so far"
        if self.tty:
            self.stream.write("\r\x1b[K" + text)
            self.drawn = True
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def done(self) -> None:
        """End a line drawn in place (nothing to do elsewhere)."""
        if self.drawn:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self.drawn = False
