"""The companion's estimate of the autopilot's clock *now*, from when its messages arrive.

Every time-stamped message read as it came (ATTITUDE, GLOBAL_POSITION_INT, ...; the companion's loop does not
give it what waited in the socket during a rest, ``DelayCompensator.read``) gives a pair (our wall arrival time w,
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

import math
import time
from collections import deque
from dataclasses import dataclass, field

WINDOW_S = 10.0  # wall seconds of arrivals the fit uses
MIN_SPAN_S = 0.5  # wall seconds of arrivals before a rate is fitted (before: rate 1)
ROUND_TRIPS_KEPT = 8  # the smallest of the last this many round trips is the link's
BACKWARDS_S = 5.0  # autopilot time this far behind the newest sample: a new boot, the fit starts again
AHEAD_S = 30.0  # a stamp this far ahead of the model's "now" is not believed (a forged or corrupt one)
REFIT_S = 0.25  # wall seconds between refits of the rate; between them a faster sample moves the offset
BUCKET_S = 0.2  # wall s of arrivals of which only the fastest is kept for the offset's fit (see ``_Fastest``)
REBASE_S = 60.0  # wall s: the running sums are moved to the window's oldest sample as reference this often (kept
# relative to a recent sample, they lose no precision over hours)


@dataclass
class _Sums:
    """Running sums of the window's samples relative to a reference sample, for the least-squares rate: O(1) per
    arrival instead of a pass over the window (hundreds of samples) at each refit."""

    ref: tuple[float, float] = (0.0, 0.0)
    n: int = 0
    w: float = 0.0
    a: float = 0.0
    ww: float = 0.0
    wa: float = 0.0

    def add(self, wall_s: float, autopilot_s: float, sign: int = 1) -> None:
        """Add a sample (``sign`` −1: take one away)."""
        dw, da = wall_s - self.ref[0], autopilot_s - self.ref[1]
        self.n += sign
        self.w += sign * dw
        self.a += sign * da
        self.ww += sign * dw * dw
        self.wa += sign * dw * da

    def rebase(self, ref: tuple[float, float]) -> None:
        """The same sums relative to ``ref`` instead (O(1): expanded, not summed again)."""
        dw, da = ref[0] - self.ref[0], ref[1] - self.ref[1]
        n, w, a = self.n, self.w, self.a
        self.ww += n * dw * dw - 2.0 * dw * w
        self.wa += n * dw * da - da * w - dw * a
        self.w, self.a, self.ref = w - n * dw, a - n * da, ref

    def rate(self) -> float | None:
        """The least-squares slope of autopilot time against wall time (None when the wall times do not vary)."""
        sxx = self.ww - self.w * self.w / self.n
        sxy = self.wa - self.w * self.a / self.n
        return sxy / sxx if sxx > 0.0 else None


@dataclass
class _Fastest:
    """The window's fastest sample (the largest autopilot − rate · wall) without a pass over the window: each
    BUCKET_S of arrivals keeps only its fastest sample (at the rate when it arrived), and the fit looks at those.
    A bucket leaves the window with its fastest sample, so the window is in effect between ``window_s`` −
    BUCKET_S and ``window_s``; within that the answer errs low by at most |the rate now − the rate at arrival| ·
    BUCKET_S (0.09 ms of wall time worst in ten minutes at speedups 1 and 5, the tests' stream)."""

    buckets: deque[list[float]] = field(default_factory=deque)  # [bucket number, wall s, autopilot s]

    def add(self, wall_s: float, autopilot_s: float, rate: float) -> None:
        """A new sample: a bucket of its own, or its bucket's fastest if it came faster (an arrival out of order
        joins the newest bucket)."""
        number = math.floor(wall_s / BUCKET_S)
        newest = self.buckets[-1] if self.buckets else None
        if newest is None or number > newest[0]:
            self.buckets.append([number, wall_s, autopilot_s])
        elif autopilot_s - rate * wall_s > newest[2] - rate * newest[1]:
            newest[1], newest[2] = wall_s, autopilot_s

    def expire(self, before_wall_s: float) -> None:
        """Forget the buckets whose fastest sample is older than the window."""
        while self.buckets and self.buckets[0][1] < before_wall_s:
            self.buckets.popleft()

    def offset(self, rate: float) -> float:
        """autopilot − rate · wall of the fastest sample at ``rate`` (−inf when there is none)."""
        return max((autopilot_s - rate * wall_s for _, wall_s, autopilot_s in self.buckets), default=-math.inf)


@dataclass
class ClockModel:
    """Fits autopilot time ≈ rate · wall + offset from arrivals, plus half the smallest TIMESYNC round trip."""

    window_s: float = WINDOW_S
    samples: deque[tuple[float, float]] = field(default_factory=deque)  # (wall s, autopilot s)
    round_trips: deque[float] = field(default_factory=lambda: deque(maxlen=ROUND_TRIPS_KEPT))  # wall s
    rate: float = 1.0
    offset_s: float | None = None
    rejected: int = 0  # stamps not believed (far ahead of the model's now)
    rate_fitted: bool = False  # the rate is a fit over MIN_SPAN_S of arrivals (not the 1 assumed before)
    _fitted_wall_s: float = -math.inf  # the newest arrival at the last refit of the rate
    _sums: _Sums = field(default_factory=_Sums)
    _fastest: _Fastest = field(default_factory=_Fastest)

    def observe(self, wall_s: float, autopilot_s: float) -> None:
        """A message stamped ``autopilot_s`` arrived at ``wall_s``."""
        if self.samples:
            newest = self.samples[-1][1]
            if autopilot_s < newest - BACKWARDS_S:  # the autopilot rebooted: its clock started again
                self._forget()
            elif self.offset_s is not None and autopilot_s > self.rate * wall_s + self.offset_s + AHEAD_S:
                self.rejected += 1
                return
        if not self.samples:
            self._sums = _Sums((wall_s, autopilot_s))
        elif wall_s - self._sums.ref[0] > REBASE_S:
            self._sums.rebase(self.samples[0])
        self.samples.append((wall_s, autopilot_s))
        self._sums.add(wall_s, autopilot_s)
        self._fastest.add(wall_s, autopilot_s, self.rate)
        while self.samples[0][0] < wall_s - self.window_s:
            self._sums.add(*self.samples.popleft(), sign=-1)
        self._fastest.expire(wall_s - self.window_s)
        if self.offset_s is not None:  # a faster sample than any before moves the offset at once
            self.offset_s = max(self.offset_s, autopilot_s - self.rate * wall_s)

    def _forget(self) -> None:
        """A new boot: the fit starts again."""
        self.samples.clear()
        self.round_trips.clear()
        self._fastest.buckets.clear()
        self.offset_s = None
        self.rate_fitted = False
        self._fitted_wall_s = -math.inf

    def observe_round_trip(self, sent_wall_s: float, answered_wall_s: float) -> None:
        """A TIMESYNC request sent at ``sent_wall_s`` was answered at ``answered_wall_s``."""
        if answered_wall_s >= sent_wall_s:
            self.round_trips.append(answered_wall_s - sent_wall_s)

    def _fit(self) -> None:
        """The rate (least squares over the window, once it spans MIN_SPAN_S), at most every REFIT_S of arrivals,
        and the fastest sample's offset at it. Both from running figures kept per arrival (``_Sums``,
        ``_Fastest``): refitting at every control step once took ~7 % of the companion's time, and then a pass over
        the window every REFIT_S still cost ~0.12 ms, paced, in every 2.5th control step (issue 32)."""
        if not self.samples:
            return
        newest = self.samples[-1][0]
        if self.offset_s is not None and newest - self._fitted_wall_s < REFIT_S:
            return
        self._fitted_wall_s = newest
        if newest - self.samples[0][0] >= MIN_SPAN_S and len(self.samples) >= 3:
            slope = self._sums.rate()
            if slope is not None and slope > 0 and math.isfinite(slope):
                self.rate = slope
                self.rate_fitted = True
        offset = self._fastest.offset(self.rate)
        newest_offset = self.samples[-1][1] - self.rate * newest  # (no bucket left: arrivals far out of wall order)
        self.offset_s = offset if math.isfinite(offset) else newest_offset

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
        offset = self._fitted_offset_s()  # (first: the fit may move the rate)
        wall = time.monotonic() if wall_s is None else wall_s
        return self.rate * wall + offset + self.one_way_delay_s()

    def earliest_arrival_s(self, autopilot_s: float) -> float:
        """The earliest wall time (monotonic s) a message stamped ``autopilot_s`` can arrive: where the fastest
        sample's lateness puts it (the loop rests until then, ``DelayCompensator.pause_s``); ValueError before any
        sample."""
        offset = self._fitted_offset_s()  # (first: the fit may move the rate)
        return (autopilot_s - offset) / self.rate

    def _fitted_offset_s(self) -> float:
        """The offset after the fit is brought up to date; ValueError before any sample."""
        self._fit()
        if self.offset_s is None:
            raise ValueError("clock model: no time-stamped message has arrived yet")
        return self.offset_s

    def age_s(self, autopilot_s: float, wall_s: float | None = None) -> float:
        """How old (autopilot s) a state stamped ``autopilot_s`` is now; never negative."""
        return max(0.0, self.now_s(wall_s) - autopilot_s)
