"""The companion's estimate of the autopilot's clock *now*, from when its messages arrive.

Every time-stamped message (ATTITUDE, GLOBAL_POSITION_INT, ...) gives a pair (our wall arrival time w,
the autopilot's time a it was stamped with). The autopilot's clock runs at ``rate`` autopilot seconds
per wall second (1 on a real boat; the simulator's ``--speedup`` in simulation), so

    a = rate · (w − d) + offset,     d ≥ d_min the one-way delay of that message (wall seconds).

Jitter only ever makes a sample look *older* (it arrives later, never earlier, than the fastest one), so
over a sliding window the rate is the least-squares slope of a against w and the offset comes from the
sample that came fastest: the *minimum* of the lateness (rate·w − a), i.e. the maximum of (a − rate·w).
That gives the autopilot's time minus the minimum one-way delay, ``rate · d_min``.

A constant one-way delay is invisible in one-way traffic: a boat 400 ms away whose messages all arrive
400 ms late looks exactly like a boat whose clock is 400 ms behind. Only a round trip shows it. ArduPilot
answers a TIMESYNC request (tc1 = 0, ts1 = our time) at once with its own time in tc1 and our ts1 echoed;
the round trip's wall time, halved, is the one-way delay (assuming the link is as slow both ways). The
smallest recent round trip is taken, for the same reason the smallest offset is: jitter adds, never takes
away. Without an answer the delay is taken as zero and ``round_trip_s`` says None.
"""

from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

WINDOW_S = 10.0  # wall seconds of arrivals the fit uses
MIN_SPAN_S = 0.5  # wall seconds of arrivals before a rate is fitted (before: rate 1)
ROUND_TRIPS_KEPT = 8  # the smallest of the last this many round trips is the link's
BACKWARDS_S = 5.0  # autopilot time this far behind the newest sample: a new boot, the fit starts again
AHEAD_S = 30.0  # a stamp this far ahead of the model's "now" is not believed (a forged or corrupt one)
REFIT_S = 0.25  # wall seconds between full fits over the window; between them a faster sample moves the offset


@dataclass
class ClockModel:
    """Fits autopilot time ≈ rate · wall + offset from arrivals, plus half the smallest TIMESYNC round trip."""

    window_s: float = WINDOW_S
    samples: deque[tuple[float, float]] = field(default_factory=deque)  # (wall s, autopilot s)
    round_trips: deque[float] = field(default_factory=lambda: deque(maxlen=ROUND_TRIPS_KEPT))  # wall s
    rate: float = 1.0
    offset_s: float | None = None
    rejected: int = 0  # stamps not believed (far ahead of the model's now)
    _dirty: bool = True
    _fitted_wall_s: float = -np.inf  # the newest arrival at the last full fit

    def observe(self, wall_s: float, autopilot_s: float) -> None:
        """A message stamped ``autopilot_s`` arrived at ``wall_s``."""
        if self.samples:
            newest = self.samples[-1][1]
            if autopilot_s < newest - BACKWARDS_S:  # the autopilot rebooted: its clock started again
                self.samples.clear()
                self.round_trips.clear()
                self.offset_s = None
                self._fitted_wall_s = -np.inf
            elif self.offset_s is not None and autopilot_s > self.rate * wall_s + self.offset_s + AHEAD_S:
                self.rejected += 1
                return
        self.samples.append((wall_s, autopilot_s))
        while self.samples and self.samples[0][0] < wall_s - self.window_s:
            self.samples.popleft()
        if self.offset_s is not None:  # a faster sample than any before moves the offset at once
            self.offset_s = max(self.offset_s, autopilot_s - self.rate * wall_s)
        self._dirty = True

    def observe_round_trip(self, sent_wall_s: float, answered_wall_s: float) -> None:
        """A TIMESYNC request sent at ``sent_wall_s`` was answered at ``answered_wall_s``."""
        if answered_wall_s >= sent_wall_s:
            self.round_trips.append(answered_wall_s - sent_wall_s)

    def _fit(self) -> None:
        """Rate (least squares over the window, once it spans MIN_SPAN_S) and the minimum offset; at most every
        REFIT_S of arrivals (a window holds thousands of samples at speedup 10: refitting at every control step
        took ~7 % of the companion's time)."""
        if not self._dirty or not self.samples:
            return
        newest = self.samples[-1][0]
        if self.offset_s is not None and newest - self._fitted_wall_s < REFIT_S:
            return
        self._fitted_wall_s = newest
        wall = np.fromiter((w for w, _ in self.samples), float)
        auto = np.fromiter((a for _, a in self.samples), float)
        if wall[-1] - wall[0] >= MIN_SPAN_S and len(wall) >= 3:
            w0 = wall - wall.mean()
            slope = float(np.dot(w0, auto - auto.mean()) / np.dot(w0, w0))
            if slope > 0 and np.isfinite(slope):
                self.rate = slope
        self.offset_s = -float(np.min(self.rate * wall - auto))  # the fastest sample: least late
        self._dirty = False

    @property
    def round_trip_s(self) -> float | None:
        """The smallest recent TIMESYNC round trip (wall s), None before the first answer."""
        return min(self.round_trips) if self.round_trips else None

    def one_way_delay_s(self) -> float:
        """The one-way delay in autopilot seconds: half the smallest round trip (0 without one)."""
        rtt = self.round_trip_s
        return 0.0 if rtt is None else self.rate * rtt / 2.0

    def ready(self) -> bool:
        """True once a message has arrived (so that ``now_s`` means something)."""
        return bool(self.samples)

    def now_s(self, wall_s: float | None = None) -> float:
        """The autopilot's time (s) at wall time ``wall_s`` (default: now); ValueError before any sample."""
        self._fit()
        if self.offset_s is None:
            raise ValueError("clock model: no time-stamped message has arrived yet")
        wall = time.monotonic() if wall_s is None else wall_s
        return self.rate * wall + self.offset_s + self.one_way_delay_s()

    def age_s(self, autopilot_s: float, wall_s: float | None = None) -> float:
        """How old (autopilot s) a state stamped ``autopilot_s`` is now; never negative."""
        return max(0.0, self.now_s(wall_s) - autopilot_s)
