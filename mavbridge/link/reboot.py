"""Noticing that the autopilot rebooted mid-run, and what the companion does about it.

A reboot is a gap in the autopilot's heartbeats (at least ``GAP_S`` of wall time: a boot is silent)
followed by ``time_boot_ms`` more than ``BACKWARDS_MS`` behind the newest value seen. Either alone is
not enough: a lossy radio makes gaps, and a reordering one makes time step back a little.

The first heartbeat after a gap is held back from the supervisor until a time-stamped message says
whether the autopilot rebooted (a rebooted ArduPilot comes up disarmed, which the supervisor would
otherwise take for the pilot disarming and end the run). On a reboot the companion

* goes back to waiting for consent (``Supervisor.rebooted``): the --arm / --set-mode it was started
  with was consent for the previous boot; only the pilot arming in the mode again engages it. The
  loop stops commanding and releases the outputs;
* asks for its streams again (a reboot forgets SET_MESSAGE_INTERVAL), from the loop, not the handler;
* says so in its log, and counts it in metrics.json (link.reboots).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mavbridge.link.streams import request_streams

GAP_S = 1.5  # wall seconds without a heartbeat before one that may come from a new boot
BACKWARDS_MS = 5000  # time_boot_ms this far behind the newest seen: a new boot (as StateEstimate judges it)
DECIDE_S = 3.0  # wall seconds a held heartbeat waits for a time-stamped message before it is let through

@dataclass
class RebootWatch:
    """Decides, message by message, what the wrapped heartbeat handler sees, and whether a reboot happened."""

    on_reboot: Callable[[str], None]  # given the reason (the supervisor's reset)
    log: Callable[[str], None] = print
    newest_ms: int | None = None
    last_heartbeat_s: float | None = None
    held: Any = None  # the newest heartbeat since a gap, not yet passed on
    held_at_s: float = 0.0
    gap_s: float = 0.0
    streams_due: bool = False
    reboots: int = 0

    def filter(self, msg: Any, now_s: float) -> list[Any]:
        """The heartbeats to pass on now, given ``msg`` (a held one comes out once it is decided)."""
        if msg.get_type() == "HEARTBEAT":
            return self._heartbeat(msg, now_s)
        stamp = getattr(msg, "time_boot_ms", None)
        if stamp is None:
            return self._release() if self.held is not None and now_s - self.held_at_s > DECIDE_S else []
        stamp = int(stamp)
        if self.newest_ms is not None and stamp < self.newest_ms - BACKWARDS_MS:
            if self.held is None and self.last_heartbeat_s is not None and now_s - self.last_heartbeat_s >= GAP_S:
                self.gap_s = now_s - self.last_heartbeat_s  # the new boot's first heartbeat is not in yet
            if self.held is not None or self.gap_s >= GAP_S:
                self._rebooted(stamp)
            else:
                self.log(f"warning: time_boot_ms went back {self.newest_ms} -> {stamp} without a heartbeat gap; "
                         "not taken for a reboot")
            self.newest_ms = stamp
        elif self.newest_ms is None or stamp > self.newest_ms:
            self.newest_ms = stamp
        return self._release()

    def _heartbeat(self, msg: Any, now_s: float) -> list[Any]:
        previous, self.last_heartbeat_s = self.last_heartbeat_s, now_s
        if self.held is None and previous is not None and now_s - previous >= GAP_S:
            self.held, self.held_at_s, self.gap_s = msg, now_s, now_s - previous
            return []
        if self.held is not None:
            self.held = msg
            return self._release() if now_s - self.held_at_s > DECIDE_S else []
        return [msg]

    def _rebooted(self, stamp: int) -> None:
        self.reboots += 1
        reason = f"autopilot rebooted (no heartbeat for {self.gap_s:.1f} s, time_boot_ms {self.newest_ms} -> {stamp})"
        self.log(f"{reason}: released; asking for the streams again; not commanding until the pilot engages "
                 "again (arm in the mode, or switch out of it and back)")
        self.streams_due = True
        self.on_reboot(reason)

    def _release(self) -> list[Any]:
        held, self.held, self.gap_s = self.held, None, 0.0
        return [held] if held is not None else []


def watch_reboots(link: Any, companion: Any) -> RebootWatch:
    """Put a RebootWatch in front of the companion's heartbeat handler (already in ``link.handlers``).

    On a reboot the supervisor goes back to waiting and the engagement's start is forgotten (arrival time
    counts from the re-engagement, on the new boot's clock); the stream request runs from the link's idle
    hook (between messages, never inside a handler).
    """

    def rebooted(reason: str) -> None:
        companion.supervisor.rebooted(reason)
        companion.events.engaged_at_ms = None
        companion.deferred_start = None  # a lockstep start's deferred switch was consent to the old boot

    watch = RebootWatch(rebooted, companion.log)
    heartbeat_handler = companion._on_heartbeat

    def handle(msg: Any) -> None:
        for heartbeat in watch.filter(msg, time.monotonic()):
            heartbeat_handler(heartbeat)

    def idle() -> None:
        if watch.streams_due:
            watch.streams_due = False
            request_streams(link, companion.period_s, companion.log)
        link.counts["reboots"] = watch.reboots

    link.handlers[link.handlers.index(heartbeat_handler)] = handle
    link.counts["reboots"] = 0
    link.idle_hooks.append(idle)
    return watch
