"""Run logs: a ``.tlog`` of every MAVLink frame in and out, and a CSV of the true physical state."""

from __future__ import annotations

import csv
import struct
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np

from vessel import STATE_COLUMNS
from vessel.folders import fresh_folder

CSV_COLUMNS = (
    "t_s",
    *STATE_COLUMNS,  # north_m ... r_rad_s, then the actual shaft speeds n1_rad_s, n2_rad_s
    "n1_cmd_rad_s",
    "n2_cmd_rad_s",
    "wave_elevation_m",
    "wave_slope_rad",
    "mode",  # Rover's mode number (HEARTBEAT.custom_mode), no unit
    "armed",  # 1 armed, 0 disarmed
    "wave_slope_n_rad",
    "wave_slope_e_rad",
)


def said(frame: bytes) -> bytes:
    """What a frame says, whatever channel it went out on: the frame without its sequence number, checksum
    and signature (each channel numbers and signs its own frames), i.e. length, flags, ids and payload."""
    if frame[:1] == b"\xfd" and len(frame) >= 10:  # MAVLink 2: seq at byte 4, payload after the 10-byte header
        return frame[1:4] + frame[5:10 + frame[1]]
    if frame[:1] == b"\xfe" and len(frame) >= 6:  # MAVLink 1: seq at byte 2, payload after the 6-byte header
        return frame[1:2] + frame[3:6 + frame[1]]
    return frame


class TlogWriter:
    """MAVProxy-style telemetry log: each frame preceded by its time as a big-endian uint64 in µs.

    Every frame received is logged. A message sent is logged once, however many channels carry it: the
    vehicle's telemetry goes to each output (two UDP outputs and a TCP client each get their own copy of the
    same ATTITUDE whenever their streams fall due together), and a lockstep hold repeats its tick's ATTITUDE
    to the controller (``sim_hold.LockstepHold._repeat_tick``); logging each copy filled the log with identical rows at
    one time_boot_ms. Copies are told apart by what they say (``said``) at the same stamp.
    """

    def __init__(self, path: Path, clock_us: Callable[[], int]) -> None:
        self._file: IO[bytes] = path.open("wb")
        self._clock_us = clock_us
        self._stamp_us: int | None = None  # the stamp of the messages in _sent
        self._sent: set[bytes] = set()  # what was sent (and logged) at that stamp

    def write(self, frame: bytes, outgoing: bool = False) -> None:
        """Append one raw frame with the current (simulated Unix) time; an outgoing copy of a message already
        logged at this time is left out."""
        stamp = self._clock_us()
        if outgoing:
            if stamp != self._stamp_us:
                self._stamp_us, self._sent = stamp, set()
            content = said(frame)
            if content in self._sent:
                return
            self._sent.add(content)
        self._file.write(struct.pack(">Q", stamp) + frame)

    def close(self) -> None:
        """Flush and close."""
        self._file.close()


class StateCsv:
    """The plant's true state at every physics step, with the sea surface under the boat."""

    def __init__(self, path: Path) -> None:
        self._file = path.open("w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._file)
        self._writer.writerow(CSV_COLUMNS)

    def write(
        self,
        t: float,
        x: np.ndarray,
        n_cmd: tuple[float, float],
        wave: tuple[float, float, float, float],
        mode: int,
        armed: bool,
    ) -> None:
        """One row; floats with enough digits to compare exactly with float32 telemetry.

        ``wave``: the true elevation (m), slope along travel (rad), slope angles N and E (rad) at the boat.
        """
        row = (
            [f"{t:.3f}"]
            + [repr(float(v)) for v in x]
            + [repr(n_cmd[0]), repr(n_cmd[1]), repr(wave[0]), repr(wave[1]), mode, int(armed),
               repr(wave[2]), repr(wave[3])]
        )
        self._writer.writerow(row)

    def flush(self) -> None:
        """Push buffered rows to disk (so a reader sees a recent state)."""
        self._file.flush()

    def close(self) -> None:
        """Flush and close."""
        self._file.close()


def fresh_log_dir(path: Path, say: Callable[[str], None]) -> Path:
    """A log folder that holds no earlier run (``vessel.folders.fresh_folder``, said through ``say``).
    OSError when a folder cannot be made; FileExistsError when ``path`` is a file."""
    return fresh_folder(path, "--log-dir", say)
