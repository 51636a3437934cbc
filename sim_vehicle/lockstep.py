"""Lockstep with the controlling system: simulated time waits at each control tick for that tick's command.

In the spirit of ArduPilot's lockstep with its physics backends, but with the roles the companion needs:
once the controller (the system whose id is SYSID_MYGCS, or the one given) has sent its first command
(RC_CHANNELS_OVERRIDE, MANUAL_CONTROL or SET_ATTITUDE_TARGET), every step that emits ATTITUDE at least
one control period after the previous tick is a tick; after it, simulated time holds until a command
from the controller arrives, or a wall-clock timeout passes (counted).

The ticks are on a grid both sides know without telling each other: the first ATTITUDE at or after
each whole multiple of the period on the autopilot clock (0.1, 0.2, ... s), which is how `mavbridge run`
schedules its steps too. A grid taken from the controller's first command instead (the first ATTITUDE
after it arrived) is half a stream interval off whenever that command arrives after the next ATTITUDE has
gone out (a slow first step, a busy machine, the stand-down around a mission download): every hold then
waits for a command the controller only sends for a sample the hold keeps back (each tick timed out), or
is released by the command for the sample before it. A command that arrives between ticks (a late one,
a stand-down) releases nothing: the count starts again at each tick.

With a start time (``--lockstep-start S``, for runs that must repeat), the ticks are held from simulated
time S on even before the first command, so the controller's first tick is exactly at S. Before the
controller speaks (or S), and again after ``MAX_MISSED_IN_A_ROW`` timeouts in a row (it stopped
commanding: arrived, released, exited), time runs at the normal pace: the companion's startup (parameters,
mission, stream rates measured per autopilot second, arming) needs simulated time to pass while it
sends no command.
"""

from __future__ import annotations

import argparse
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

log = logging.getLogger("sim_vehicle")
COMMAND_MESSAGES = frozenset({"RC_CHANNELS_OVERRIDE", "MANUAL_CONTROL", "SET_ATTITUDE_TARGET"})
MAX_MISSED_IN_A_ROW = 3  # timeouts in a row after which the controller counts as silent (paced again)
DEFAULT_PERIOD_S = 0.1  # the paper's control period T
DEFAULT_TIMEOUT_S = 1.0  # wall seconds a tick waits for its command


@dataclass
class LockstepStats:
    """What lockstep did over a run: ticks held, commands that released them, timeouts."""

    ticks: int = 0
    released: int = 0
    timeouts: int = 0
    engagements: int = 0
    hold_wall_s: float = 0.0

    def summary(self) -> str:
        """One line for the simulator's log at exit."""
        return (f"lockstep: {self.ticks} ticks held, {self.released} released by a command, "
                f"{self.timeouts} timed out, {self.engagements} engagement(s), "
                f"{self.hold_wall_s:.1f} s wall held")


@dataclass
class Lockstep:
    """The state machine deciding, after each physics step, whether to hold for the controller's command."""

    period_s: float = DEFAULT_PERIOD_S
    timeout_s: float = DEFAULT_TIMEOUT_S
    controller_sysid: int = 255
    start_s: float | None = None  # engage at this simulated time even before the controller's first command
    engaged: bool = False
    stats: LockstepStats = field(default_factory=LockstepStats)
    _next_tick_s: float | None = None  # the grid point the next tick is at or after (None: the next one)
    _commands: int = 0  # commands from the controller since the last tick was released
    _missed_in_a_row: int = 0

    def on_message(self, kind: str, src_system: int) -> None:
        """Every decoded incoming message: counts the controller's commands; the first one engages."""
        if kind not in COMMAND_MESSAGES or src_system != self.controller_sysid:
            return
        self._commands += 1
        if not self.engaged:
            self._engage(f"system {src_system} commands")

    def _engage(self, why: str) -> None:
        """From now on each tick waits for the controller's command."""
        self.engaged = True
        self._next_tick_s = None  # the next grid point from here
        self._missed_in_a_row = 0
        self.stats.engagements += 1
        log.info("lockstep engaged: %s; time now waits for a command at each tick", why)

    def is_tick(self, sim_t: float, attitude_sent: bool) -> bool:
        """True if the step that ended at ``sim_t`` is a control tick to hold at (and starts its wait)."""
        if self.start_s is not None and sim_t >= self.start_s - 1e-6:
            self.start_s = None  # once: a controller that never comes is released after a few timeouts
            self._engage(f"t = {sim_t:.2f} s (--lockstep-start)")
        if not (self.engaged and attitude_sent):
            return False
        if self._next_tick_s is None:
            self._next_tick_s = math.ceil(sim_t / self.period_s - 1e-6) * self.period_s
        if sim_t < self._next_tick_s - 1e-6:
            return False
        self._next_tick_s = (math.floor(sim_t / self.period_s + 1e-6) + 1) * self.period_s
        self._commands = 0
        self.stats.ticks += 1
        return True

    def command_arrived(self) -> bool:
        """True once a command from the controller has arrived since the current tick began."""
        return self._commands > 0

    def released(self, wall_s: float) -> None:
        """The tick's command came after ``wall_s`` of holding."""
        self.stats.released += 1
        self.stats.hold_wall_s += wall_s
        self._missed_in_a_row = 0

    def timed_out(self, sim_t: float, wall_s: float) -> None:
        """No command within the timeout: counted, logged; after a few in a row, back to paced time."""
        self.stats.timeouts += 1
        self.stats.hold_wall_s += wall_s
        self._missed_in_a_row += 1
        log.warning("lockstep: no command for the tick at t = %.2f s within %.2f s (wall)", sim_t, self.timeout_s)
        if self._missed_in_a_row >= MAX_MISSED_IN_A_ROW:
            self.engaged = False
            self._next_tick_s = None
            log.info("lockstep released: system %d silent for %d ticks; paced until it commands again",
                     self.controller_sysid, self._missed_in_a_row)


def _seconds_in(lo: float, hi: float) -> Callable[[str], float]:
    """An argparse type: seconds in [lo, hi], else the range (argparse puts the flag's name in front)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected seconds in [{lo:g}, {hi:g}], got {text!r}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text} is not finite: seconds in [{lo:g}, {hi:g}] are allowed")
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"{text} s is outside [{lo:g}, {hi:g}] s")
        return value

    return parse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """--lockstep [PERIOD_S] and --lockstep-timeout S (simulation only: a real autopilot never waits)."""
    p.add_argument(
        "--lockstep", nargs="?", const=DEFAULT_PERIOD_S, default=None, metavar="PERIOD_S",
        type=_seconds_in(0.01, 10.0),
        help="once SYSID_MYGCS commands, hold simulated time at each control tick (the first ATTITUDE at "
             f"least PERIOD_S after the last, default {DEFAULT_PERIOD_S:g} s) until its command arrives",
    )
    p.add_argument(
        "--lockstep-timeout", type=_seconds_in(0.01, 60.0), default=DEFAULT_TIMEOUT_S,
        metavar="S", help=f"wall seconds a lockstep tick waits for its command (default {DEFAULT_TIMEOUT_S:g})",
    )
    p.add_argument(
        "--lockstep-start", type=_seconds_in(0.0, 1e6), default=None, metavar="S",
        help="hold from simulated time S on even before the first command (the controller's first tick, e.g. "
             "`mavbridge run --start-at S`, then sees exactly time S, however long its startup took); S in "
             "[0, 1e6] s (default: none, held from the controller's first command on)",
    )
