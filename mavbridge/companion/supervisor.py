"""When the companion may command the boat: armed, in its mode, link alive, not yet arrived.

The human always wins: once the companion has been engaged, a mode change it did not ask for (or a
disarm) ends its run for good — it never re-engages behind a pilot's back, because in MANUAL the
pilot's sticks would be overridden. Consent to engage is a change into armed + mode seen after the
companion started (or the companion arming / switching mode itself when told to): finding the boat
already armed in MANUAL — a pilot driving, or a restart mid-run — is not consent. Link loss only
suspends it; it resumes when heartbeats return.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from mavbridge.companion.rover_modes import mode_name


class Phase(enum.Enum):
    """The companion's phases; TAKEN_OVER, ARRIVED and STOPPED are final."""

    WAITING = "waiting for armed + mode"
    ENGAGED = "engaged"
    LINK_LOST = "link lost"
    TAKEN_OVER = "pilot took over"
    ARRIVED = "waypoint reached"
    STOPPED = "stopped"

    @property
    def final(self) -> bool:
        """True once the run is over."""
        return self in (Phase.TAKEN_OVER, Phase.ARRIVED, Phase.STOPPED)


@dataclass
class Supervisor:
    """Tracks heartbeats (wall clock) and decides whether commands may go out."""

    required_mode: int
    link_timeout_s: float = 2.0
    dry_run: bool = False
    phase: Phase = Phase.WAITING
    armed: bool = False
    mode: int | None = None
    last_heartbeat_s: float | None = None
    reason: str = ""
    expected_mode: int | None = None  # a mode change the companion itself asked for
    self_commanded: bool = False  # the companion arms / sets the mode itself: that is consent
    seen_not_ready: bool = False  # a heartbeat not armed-in-mode was seen since the start
    mode_changes: int = 0  # heartbeats whose mode differed from the one before (any cause)

    def on_heartbeat(self, now_s: float, armed: bool, mode: int) -> Phase:
        """Feed the autopilot's HEARTBEAT; returns the phase after it."""
        self.last_heartbeat_s = now_s
        changed_by_other = (self.mode is not None and mode != self.mode and mode != self.expected_mode)
        self.mode_changes += int(self.mode is not None and mode != self.mode)
        self.armed, self.mode = armed, mode
        if self.phase.final:
            return self.phase
        if self.phase in (Phase.ENGAGED, Phase.LINK_LOST) and not self.dry_run:
            if changed_by_other or mode != self.required_mode:
                return self._finish(Phase.TAKEN_OVER, f"mode changed to {mode_name(mode)} by someone else")
            if not armed:
                return self._finish(Phase.TAKEN_OVER, "vehicle disarmed")
        if not self._ready():
            self.seen_not_ready = True
        elif self.phase == Phase.LINK_LOST or self.seen_not_ready or self.self_commanded or self.dry_run:
            self.phase = Phase.ENGAGED
        elif self.phase == Phase.WAITING:
            self.reason = "already armed in the mode at start: switch out of it and back to engage"
        return self.phase

    def _ready(self) -> bool:
        return self.dry_run or (self.armed and self.mode == self.required_mode)

    def tick(self, now_s: float) -> Phase:
        """Check the link; returns the phase now."""
        if self.phase.final:
            return self.phase
        lost = self.last_heartbeat_s is None or now_s - self.last_heartbeat_s > self.link_timeout_s
        if lost and self.phase == Phase.ENGAGED:
            self.phase = Phase.LINK_LOST
            self.reason = f"no heartbeat for {self.link_timeout_s:g} s"
        elif not lost and self.phase == Phase.LINK_LOST and self._ready():
            self.phase = Phase.ENGAGED
        return self.phase

    def outage_s(self, now_s: float) -> float:
        """How long the link has been lost (0 unless in LINK_LOST)."""
        if self.phase != Phase.LINK_LOST or self.last_heartbeat_s is None:
            return 0.0
        return now_s - self.last_heartbeat_s

    def may_command(self) -> bool:
        """True while commands may be sent (or, in a dry run, computed)."""
        return self.phase == Phase.ENGAGED

    def rebooted(self, reason: str) -> None:
        """The autopilot rebooted: back to waiting, and only a fresh change into armed + mode engages again
        (consent given to the previous boot, the companion's own arming included, does not carry over)."""
        if self.phase.final:
            return
        self.phase, self.reason = Phase.WAITING, reason
        self.self_commanded = self.seen_not_ready = False
        self.mode = self.expected_mode = None

    def arrived(self) -> None:
        """The waypoint is reached: the run ends."""
        self._finish(Phase.ARRIVED, "waypoint reached")

    def stop(self, reason: str) -> None:
        """Stop on request (signal, error)."""
        self._finish(Phase.STOPPED, reason)

    def _finish(self, phase: Phase, reason: str) -> Phase:
        if not self.phase.final:
            self.phase, self.reason = phase, reason
        return self.phase
