"""Lockstep with the controlling system: simulated time waits at each control tick for that tick's command.

In the spirit of ArduPilot's lockstep with its physics backends, but with the roles the companion needs:
once the controller (the system whose id is SYSID_MYGCS, or the one given) has sent its first command
(RC_CHANNELS_OVERRIDE, MANUAL_CONTROL or SET_ATTITUDE_TARGET), every step that emits ATTITUDE at least
one control period after the previous tick is a tick; after it, simulated time holds until a command
from the controller arrives, or a wall-clock timeout passes (counted).

The ticks follow the controller's own grid (it ticks on the first ATTITUDE at or after its next tick
time): every command anchors the grid at the newest ATTITUDE sent before it arrived, the sample the
controller answered. Without the anchor, a first command that arrives after the next ATTITUDE has gone
out (a slow first step, a busy machine) puts the holds half a stream interval off the controller's
ticks: each hold then waits for a command the controller will only send for a sample the hold keeps
back, and every tick times out. A hold's own command anchors at the tick itself, so a steady run is
unchanged; a command between ticks (a late one, a stand-down, a restart) moves the grid to the
controller's.

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
    _last_tick_s: float | None = None
    _commands: int = 0  # commands from the controller since the last tick was released
    _missed_in_a_row: int = 0
    _last_attitude_s: float | None = None  # the newest ATTITUDE sent (the controller's sample for its command)

    def on_message(self, kind: str, src_system: int) -> None:
        """Every decoded incoming message: counts the controller's commands; the first one engages."""
        if kind not in COMMAND_MESSAGES or src_system != self.controller_sysid:
            return
        self._commands += 1
        if self._last_attitude_s is not None:
            self._last_tick_s = self._last_attitude_s  # the controller answered that sample: its grid is there
        if not self.engaged:
            self._engage(f"system {src_system} commands")

    def _engage(self, why: str) -> None:
        """From now on each tick waits for the controller's command."""
        self.engaged = True
        self._missed_in_a_row = 0
        self.stats.engagements += 1
        log.info("lockstep engaged: %s; time now waits for a command at each tick", why)

    def is_tick(self, sim_t: float, attitude_sent: bool) -> bool:
        """True if the step that ended at ``sim_t`` is a control tick to hold at (and starts its wait)."""
        if self.start_s is not None and sim_t >= self.start_s - 1e-6:
            self.start_s = None  # once: a controller that never comes is released after a few timeouts
            self._engage(f"t = {sim_t:.2f} s (--lockstep-start)")
        if attitude_sent:
            self._last_attitude_s = sim_t
        if not (self.engaged and attitude_sent):
            return False
        if self._last_tick_s is not None and sim_t < self._last_tick_s + self.period_s - 1e-6:
            return False
        self._last_tick_s = sim_t
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
            self._last_tick_s = None
            log.info("lockstep released: system %d silent for %d ticks; paced until it commands again",
                     self.controller_sysid, self._missed_in_a_row)


def _seconds_in(lo: float, hi: float, flag: str) -> Callable[[str], float]:
    """An argparse type: seconds in [lo, hi], else one line naming the flag and the range."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{flag}: expected seconds in [{lo:g}, {hi:g}], got {text!r}") from None
        if not (math.isfinite(value) and lo <= value <= hi):
            raise argparse.ArgumentTypeError(f"{flag}: {text} s is outside [{lo:g}, {hi:g}] s")
        return value

    return parse


def add_arguments(p: argparse.ArgumentParser) -> None:
    """--lockstep [PERIOD_S] and --lockstep-timeout S (simulation only: a real autopilot never waits)."""
    p.add_argument(
        "--lockstep", nargs="?", const=DEFAULT_PERIOD_S, default=None, metavar="PERIOD_S",
        type=_seconds_in(0.01, 10.0, "--lockstep"),
        help="once SYSID_MYGCS commands, hold simulated time at each control tick (the first ATTITUDE at "
             f"least PERIOD_S after the last, default {DEFAULT_PERIOD_S:g} s) until its command arrives",
    )
    p.add_argument(
        "--lockstep-timeout", type=_seconds_in(0.01, 60.0, "--lockstep-timeout"), default=DEFAULT_TIMEOUT_S,
        metavar="S", help=f"wall seconds a lockstep tick waits for its command (default {DEFAULT_TIMEOUT_S:g})",
    )
    p.add_argument(
        "--lockstep-start", type=_seconds_in(0.0, 1e6, "--lockstep-start"), default=None, metavar="S",
        help="hold from simulated time S on even before the first command (the controller's first tick, e.g. "
             "`mavbridge run --start-at S`, then sees exactly time S, however long its startup took)",
    )
