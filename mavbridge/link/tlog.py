"""``companion.tlog`` on the autopilot's clock, so that it lines up with the autopilot's own log at any speed.

A tlog (pymavlink, MAVProxy) is each raw MAVLink frame preceded by its time as a big-endian uint64 of
microseconds since the Unix epoch. Stamping with the companion's wall clock would put a run at
``--speedup 10`` into a tenth of the autopilot's time, and nothing would line up with ``sim_vehicle.tlog``.
So every frame, in or out, is stamped

    stamp = the autopilot's boot epoch + the newest autopilot time heard (time_boot_ms of what it sent),

which is the autopilot's own idea of Unix time: a message stamped time_boot_ms = T gets the stamp
``epoch + T``, exactly as the simulator stamps its copy. The boot epoch comes from the autopilot's
SYSTEM_TIME (``time_unix_usec − time_boot_ms``: GPS time on a boat, simulated Unix time in SITL), once
per boot. Until it is known, frames wait in memory (at most PENDING_MAX of them or PENDING_WALL_S); an
autopilot that never sends a Unix time (no GPS) gets the companion's wall clock at the first time-stamped
message as its epoch instead. A clock that jumps back by more than BACKWARDS_S is a reboot: a new epoch.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import IO, Any

PENDING_MAX = 20000  # frames held while the boot epoch is unknown
PENDING_WALL_S = 5.0  # wall seconds to wait for SYSTEM_TIME before taking the wall clock as the epoch
BACKWARDS_S = 5.0  # autopilot time this far behind the newest heard: the autopilot rebooted


class AutopilotClockTlog:
    """Appends frames to a tlog, stamped on the autopilot's clock (see the module's description)."""

    def __init__(self, path: str | Path) -> None:
        self._file: IO[bytes] = open(path, "ab")
        self.epoch_us: int | None = None  # the autopilot's boot time on the Unix clock
        self.newest_us = 0  # the newest autopilot time heard (µs since its boot)
        self._anchor_us: int | None = None  # wall µs minus autopilot µs at the first stamped message of a boot
        self._pending: list[tuple[int, bytes]] = []  # (autopilot µs, frame) while the epoch is unknown
        self._pending_since = 0.0

    def heard(self, msg: Any) -> None:
        """A message from the autopilot: its time_boot_ms moves the clock on; SYSTEM_TIME gives the epoch."""
        boot_ms = getattr(msg, "time_boot_ms", None)
        if not isinstance(boot_ms, int):
            return
        now_us = boot_ms * 1000
        if now_us < self.newest_us - BACKWARDS_S * 1e6:  # a new boot: its own epoch
            self._flush()
            self.epoch_us, self._anchor_us = None, None
            self.newest_us = now_us
        self.newest_us = max(self.newest_us, now_us)
        if self._anchor_us is None:
            self._anchor_us = round(time.time() * 1e6) - now_us
        unix_us = getattr(msg, "time_unix_usec", 0) if msg.get_type() == "SYSTEM_TIME" else 0
        if self.epoch_us is None and unix_us > 0:
            self.epoch_us = unix_us - now_us
            self._flush()

    def write(self, frame: bytes) -> None:
        """One frame, in or out, at the autopilot time heard last."""
        if not frame:
            return
        if self.epoch_us is not None:
            self._file.write(struct.pack(">Q", self.epoch_us + self.newest_us) + bytes(frame))
            return
        if not self._pending:
            self._pending_since = time.monotonic()
        self._pending.append((self.newest_us, bytes(frame)))
        if len(self._pending) >= PENDING_MAX or time.monotonic() - self._pending_since > PENDING_WALL_S:
            self._flush()

    def _flush(self) -> None:
        """Write the held frames; without a Unix time from the autopilot, its epoch is taken from the wall."""
        if not self._pending:
            return
        if self.epoch_us is None:
            self.epoch_us = self._anchor_us if self._anchor_us is not None else round(time.time() * 1e6)
        for autopilot_us, frame in self._pending:
            self._file.write(struct.pack(">Q", self.epoch_us + autopilot_us) + frame)
        self._pending = []

    def close(self) -> None:
        """Write what is held, then close."""
        self._flush()
        self._file.close()
