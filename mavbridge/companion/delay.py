"""Delay compensation for the companion: how old the state is, and the state when the command will act.

Put together from ``ClockModel`` (the autopilot's time now, from arrivals and TIMESYNC round trips) and
``StatePredictor`` (the NMPC's model run forward with the commands in flight). Each control step:

* the state's **age** = the autopilot's time now (estimated) − the newest ATTITUDE's time_boot_ms;
* when compensating, the state is predicted to *now + the uplink's one-way delay* (when the command
  reaches the boat) and the NMPC plans from there, at that time; the command is remembered with that
  time, so later predictions know what the boat was executing.

TIMESYNC requests (tc1 = 0, ts1 = our monotonic ns) go out once a wall second from the link's idle hook;
ArduPilot, and the simulator, answer with tc1 = their time. Only the answer to one of our own requests
counts (its ts1 is ours).

In lockstep (``sim-vehicle --lockstep``) the age is zero by construction: the autopilot's time waits at
each tick for the command, so the state acted on is always the newest; nothing is measured or predicted.
Off (``delay_compensation: false``) the age is still measured and logged, for comparison.
"""

from __future__ import annotations

import math
import time
from collections import deque
from typing import Any

import numpy as np

from mavbridge.companion.predict import CommandHistory, StatePredictor
from mavbridge.link.clock_model import ClockModel

TIMESYNC_PERIOD_S = 1.0  # wall seconds between our TIMESYNC requests
PENDING_KEPT = 16  # unanswered requests remembered (a lost one is forgotten)
CLOCK_MESSAGES = ("ATTITUDE", "GLOBAL_POSITION_INT")
MAX_CLOCK_RATE = 1000.0  # the simulator's fastest --speedup
PAUSE_MARGIN_S = 0.0005  # wall s the loop wakes before a tick's earliest arrival (the clock fit's error, the timer's)
OVERSLEPT_KEPT = 32  # rests: the loop wakes early by the most the last this many overran (see ``overslept``)
TICK_LAGS_KEPT = 32  # ticks (a few seconds, past the 1 Hz streams): the smallest lag of the ATTITUDE is rested to
FLOOD_READ = 32  # messages refused (foreign, bad, unsigned, stale) in one read, or a period on average over a
# FLOOD_WINDOW_S: no rest until a window without, so that a flood cannot fill the socket's buffer (~200 datagrams)
# during a rest and crowd out the autopilot's own
FLOOD_WINDOW_S = 2.0  # wall s over which refused messages are counted
REFUSED = ("foreign", "bad", "unsigned", "stale")  # the link's counts of refused messages
ROUND_TRIP_WATCH_S = 0.5  # wall s after a TIMESYNC request the loop reads at once: the answer's arrival is the figure


class DelayCompensator:
    """Measures the state's age on the link and predicts the state forward over the delay."""

    def __init__(self, enabled: bool, lockstep: bool, max_prediction_s: float,
                 predictor: StatePredictor | None) -> None:
        self.enabled, self.lockstep, self.max_prediction_s = enabled, lockstep, max_prediction_s
        self.predictor = predictor
        self.clock = ClockModel()
        self.history = CommandHistory()
        self.ages_s: list[float] = []
        self.horizons_s: list[float] = []
        self._pending: deque[int] = deque(maxlen=PENDING_KEPT)
        self._last_request = -TIMESYNC_PERIOD_S
        self._last_stamp = -1  # our newest request's ts1
        self._tick_lags: deque[float] = deque(maxlen=TICK_LAGS_KEPT)  # autopilot s from each tick to its ATTITUDE
        self._overslept: deque[float] = deque(maxlen=OVERSLEPT_KEPT)  # wall s each rest ended late
        self.flooding = False  # refused messages come too fast to rest (see FLOOD_READ)
        self._flood_mark = (0, -math.inf)  # (refused messages so far, wall s) when the window began
        self.backlog = False  # the loop is reading what waited in the socket (after a rest or a step): not timed

    def attach(self, link: Any) -> None:
        """Watch the link's time-stamped messages and TIMESYNC answers; ask for round trips when idle."""
        if self.lockstep:
            return
        link.handlers.append(self.on_message)
        link.idle_hooks.append(lambda: self.request_round_trip(link))

    def on_message(self, msg: Any) -> None:
        """An arrival for the clock fit (not while ``backlog``: it waited in the socket, when it came is not known),
        or the answer to one of our TIMESYNC requests (also in the backlog while the loop does not rest for it,
        within ROUND_TRIP_WATCH_S of our newest request: it waited at most as long as the read it came in, and
        skipping the answers read with others would keep only the slower ones)."""
        kind, now = msg.get_type(), time.monotonic()
        if kind in CLOCK_MESSAGES:
            if not self.backlog:
                self.clock.observe(now, int(msg.time_boot_ms) / 1000.0)
        elif kind == "TIMESYNC" and msg.tc1 != 0 and msg.ts1 in self._pending:
            self._pending.remove(msg.ts1)
            if not self.backlog or (msg.ts1 == self._last_stamp and now - self._last_request < ROUND_TRIP_WATCH_S):
                self.clock.observe_round_trip(msg.ts1 / 1e9, now)

    def request_round_trip(self, link: Any) -> None:
        """A TIMESYNC request, once every TIMESYNC_PERIOD_S of wall time."""
        now = time.monotonic()
        if link.target is None or now - self._last_request < TIMESYNC_PERIOD_S:
            return
        self._last_request = now
        stamp = time.monotonic_ns()
        self._pending.append(stamp)
        self._last_stamp = stamp
        link.send("timesync", 0, stamp)

    def wall_seconds(self, autopilot_s: float) -> float:
        """``autopilot_s`` seconds of autopilot time in wall seconds: over the clock's fitted rate (1 until fitted;
        a simulator's speedup), taken in [1, MAX_CLOCK_RATE] so a bad fit never grants more than real time."""
        return autopilot_s / min(max(self.clock.rate, 1.0), MAX_CLOCK_RATE)

    def ticked(self, lag_s: float) -> None:
        """A step was due: its ATTITUDE was stamped ``lag_s`` (autopilot s) after the tick (the stream's phase)."""
        self._tick_lags.append(lag_s)

    def pause_s(self, next_tick_s: float | None, longest_s: float) -> float:
        """Wall seconds the loop may rest before reading the link again, at most ``longest_s``: until the earliest
        arrival of the next tick's ATTITUDE on the clock model (stamped the tick (autopilot s) plus the smallest of
        the recent lags ``ticked``, at most half of ``longest_s`` in autopilot time), less PAUSE_MARGIN_S and the
        most the recent rests overran (``overslept``: the sleep's lateness, milliseconds on a busy computer
        without real-time priority, and reading what waited, up to milliseconds when the 1 Hz streams come: the
        tick's ATTITUDE must not wait for either). Resting, the loop takes the
        period's messages together instead of waking for each (a dozen a period; each wake-up costs the step its
        caches, issue 32), and the tick's ATTITUDE as soon as it is there. What waited in the socket is not timed
        (``backlog``): timed, the rest's own lateness would move the clock model's line later, and the next rest
        with it. 0, reading at once: in lockstep, with no tick or no fitted clock rate yet (a simulator's speedup
        would make a rest too long), when nothing was timed for two periods (the line may be behind the link's:
        the next arrival then moves it), and for ROUND_TRIP_WATCH_S after our newest TIMESYNC request while it
        waits for its answer (its round trip is measured on its arrival)."""
        if self.lockstep or next_tick_s is None or not self.clock.ready():
            return 0.0
        lag = min(min(self._tick_lags, default=0.0), 0.5 * longest_s * self.clock.rate)
        arrival = self.clock.earliest_arrival_s(next_tick_s + max(lag, 0.0))  # (the fit is brought up to date)
        now = time.monotonic()
        if not self.clock.rate_fitted or now - self.clock.samples[-1][0] > 2.0 * longest_s or (
                now - self._last_request < ROUND_TRIP_WATCH_S and self._last_stamp in self._pending):
            return 0.0  # (nothing timed for two periods: the model may be behind the link; read at once till it is not)
        overran = min(max(self._overslept, default=0.0), 0.5 * longest_s)  # (a rare long one never ends the rests)
        rest = arrival - PAUSE_MARGIN_S - overran - now
        return min(rest, longest_s) if rest > 0.0 else 0.0

    def overslept(self, late_s: float) -> None:
        """A rest and the reading of what waited ended ``late_s`` wall seconds after the rest was due to end."""
        self._overslept.append(max(late_s, 0.0))

    def read(self, link: Any, next_tick_s: float | None, period_s: float) -> None:
        """The loop's read of ``link``: a rest first (``pause_s``, at most ``period_s`` of autopilot time; none
        while ``flooding``), then what waited meanwhile (``backlog``), the next message (0.05 s at
        most) and everything that came; the newest state is acted on, never a backlog. What other reads take (a
        mission's download, a command's answer) is timed as it comes."""
        pause = 0.0 if self.flooding else self.pause_s(next_tick_s, self.wall_seconds(period_s))
        due = time.monotonic() + pause
        if pause > 0.0:
            time.sleep(pause)
        refused = sum(link.counts.get(kind, 0) for kind in REFUSED)
        self.backlog = link.pending()
        try:
            link.recv(0.05)
            link.drain()
            if pause > 0.0 and self.backlog:
                self.overslept(time.monotonic() - due)
        finally:
            self.backlog = False
        self.judge_flood(sum(link.counts.get(kind, 0) for kind in REFUSED), refused, self.wall_seconds(period_s),
                         time.monotonic())

    def judge_flood(self, refused: int, before: int, period_wall_s: float, now: float) -> None:
        """``refused`` messages refused so far (``before`` when the read began): ``flooding`` from a read that
        refused more than FLOOD_READ for a window at least; at the end of each window, whether it refused more
        than FLOOD_READ a period on average."""
        if refused - before > FLOOD_READ:
            self.flooding, self._flood_mark = True, (refused, now)
        elif now - self._flood_mark[1] >= FLOOD_WINDOW_S:
            window_s = now - self._flood_mark[1]
            self.flooding = refused - self._flood_mark[0] > FLOOD_READ * window_s / period_wall_s
            self._flood_mark = (refused, now)

    def compensate(self, state_s: float) -> tuple[float, float]:
        """(the state's age, the time to plan at) for a state stamped ``state_s`` (autopilot s)."""
        if self.lockstep or not self.clock.ready():
            self.ages_s.append(0.0)
            self.horizons_s.append(0.0)
            return 0.0, state_s
        now_s = self.clock.now_s()
        age = max(0.0, now_s - state_s)
        self.ages_s.append(age)
        if not self.enabled or self.predictor is None:
            self.horizons_s.append(0.0)
            return age, state_s
        horizon = min(age + self.clock.one_way_delay_s(), self.max_prediction_s)
        self.horizons_s.append(horizon)
        return age, state_s + horizon

    def command_delay_s(self, state_s: float) -> float | None:
        """From a state stamped ``state_s`` (autopilot s) to when a command sent now acts: the state's age
        (recorded, as ``compensate`` records it) plus the uplink's one-way delay (half the smallest TIMESYNC round
        trip), what a real boat's companion measures too; None in lockstep (the autopilot's time waits for the
        command) and before any time-stamped message. The autopilot's loop and the motors' lag are not in it."""
        age, _ = self.compensate(state_s)
        if self.lockstep or not self.clock.ready():
            return None
        return age + self.clock.one_way_delay_s()

    def predict(self, x: np.ndarray, state_s: float, plan_s: float, waves: Any,
                disturbance: np.ndarray | None = None) -> np.ndarray:
        """The state at ``plan_s`` from ``x`` at ``state_s`` (x itself when not compensating), with the NMPC's wave
        and estimated disturbance."""
        if self.predictor is None or plan_s <= state_s:
            return x
        if disturbance is None:
            return self.predictor.predict(x, state_s, plan_s, self.history, waves)
        return self.predictor.predict(x, state_s, plan_s, self.history, waves, disturbance)

    def sent(self, plan_s: float, tau: np.ndarray) -> None:
        """The command planned for ``plan_s`` went out: the boat executes it from then on."""
        self.history.add(plan_s, tau)

    def summary(self) -> dict[str, Any]:
        """metrics.json's ``delay``: the age's distribution (s), the prediction horizon, the link's delay."""
        ages = np.asarray(self.ages_s, float)
        horizons = np.asarray(self.horizons_s, float)
        rtt = self.clock.round_trip_s
        figures = {"state_age_s_median": float(np.median(ages)) if ages.size else None,
                   "state_age_s_p95": float(np.percentile(ages, 95)) if ages.size else None,
                   "state_age_s_max": float(np.max(ages)) if ages.size else None,
                   "prediction_s_median": float(np.median(horizons)) if horizons.size else None,
                   "round_trip_autopilot_s": None if rtt is None else self.clock.rate * rtt,
                   "clock_rate": self.clock.rate}
        return {"compensation": "lockstep (age zero by construction)" if self.lockstep else
                ("on" if self.enabled else "off"),
                **{k: round(v, 4) if isinstance(v, float) else v for k, v in figures.items()}}


def make_compensator(config: Any, nmpc: Any) -> DelayCompensator:
    """The companion's compensator from its settings (``delay_compensation``, ``max_prediction_s``,
    ``lockstep``) and its NMPC, whose model and current the prediction uses."""
    predictor = None
    if config.delay_compensation and not config.lockstep:
        predictor = StatePredictor(nmpc.params, nmpc.current, None if nmpc.takes_waves else nmpc.waves)
    return DelayCompensator(config.delay_compensation, config.lockstep, config.max_prediction_s, predictor)
