"""Run logs: a ``.tlog`` of every MAVLink frame in and out, and a CSV of the true physical state."""

from __future__ import annotations

import csv
import struct
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np

CSV_COLUMNS = (
    "t_s",
    "north_m",
    "east_m",
    "down_m",
    "roll_rad",
    "pitch_rad",
    "yaw_rad",
    "u_m_s",
    "v_m_s",
    "w_m_s",
    "p_rad_s",
    "q_rad_s",
    "r_rad_s",
    "n1_rad_s",
    "n2_rad_s",
    "n1_cmd_rad_s",
    "n2_cmd_rad_s",
    "wave_elevation_m",
    "wave_slope_rad",
    "mode",
    "armed",
    "wave_slope_n_rad",
    "wave_slope_e_rad",
)


class TlogWriter:
    """MAVProxy-style telemetry log: each frame preceded by its time as a big-endian uint64 in µs."""

    def __init__(self, path: Path, clock_us: Callable[[], int]) -> None:
        self._file: IO[bytes] = path.open("wb")
        self._clock_us = clock_us

    def write(self, frame: bytes) -> None:
        """Append one raw frame with the current (simulated Unix) time."""
        self._file.write(struct.pack(">Q", self._clock_us()) + frame)

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
    """A log folder that holds no earlier run: ``path`` when it is new or empty, else the first free
    ``path-2``, ``path-3``, … (said in one line through ``say``), created here. Logs are never overwritten.
    OSError when a folder cannot be made; FileExistsError when ``path`` is a file."""
    candidate, number = path, 1
    while True:
        try:
            candidate.mkdir(parents=True)
            break
        except FileExistsError:
            if candidate.is_dir() and not any(candidate.iterdir()):
                break  # an empty folder: nothing to lose
            if candidate == path and not path.is_dir():
                raise
        number += 1
        candidate = path.with_name(f"{path.name}-{number}")
    if candidate != path:
        say(f"--log-dir: {path} already holds a run; writing this one to {candidate} instead")
    return candidate
