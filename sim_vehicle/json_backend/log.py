"""The JSON backend's run folder: the true-state CSV (the normal simulator's columns) and the sea record.

``state.csv`` has the state columns of ``sim_vehicle.logs`` (time, the 14 states, shaft commands, sea
surface under the boat: elevation and slope, along the travel direction and towards North and East) — the
firmware owns mode and arming, so those two are replaced by what the backend does know: the run number
(1, 2, ... after each firmware restart), the frame count and the two thruster pulses. At most one row per
PHYSICS_DT_S of simulated time (the normal simulator's rate), so a 400 Hz firmware does not quadruple the
file. ``sea.json`` records the sea, its seed and phase.
"""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from sim_vehicle.logs import CSV_COLUMNS
from sim_vehicle.physics import PHYSICS_DT_S
from vessel import OceanCurrent, WaveField

STATE_COLUMNS = CSV_COLUMNS[: CSV_COLUMNS.index("mode")]
JSON_CSV_COLUMNS = (*STATE_COLUMNS, "wave_slope_n_rad", "wave_slope_e_rad", "run", "frame_count", "servo1_us",
                    "servo3_us")


def wave_under(waves: WaveField, north: float, east: float, t: float) -> tuple[float, float, float, float]:
    """Elevation (m, up), slope along the travel direction (rad; 0 if the field has none) and the slope angles
    towards North and East (rad, ``WaveField.slope_angles``) at a point."""
    slope = waves.slope_along_travel(north, east, t) if hasattr(waves, "slope_along_travel") else 0.0
    slope_n, slope_e = waves.slope_angles(north, east, t)
    return float(waves.elevation(north, east, t)), float(slope), float(slope_n), float(slope_e)


class JsonStateCsv:
    """Rows of the true state, decimated to the normal simulator's step."""

    def __init__(self, path: Path, waves: WaveField) -> None:
        self._file = path.open("w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._file)
        self._writer.writerow(JSON_CSV_COLUMNS)
        self._waves = waves
        self._next_t = 0.0
        self._run = 0

    def new_run(self) -> None:
        """The firmware (re)started: a new run number, and the next state is written whatever its time."""
        self._run += 1
        self._next_t = -1.0

    def write(self, t: float, x: np.ndarray, n_cmd: tuple[float, float], frame_count: int,
              pwm: tuple[int, int]) -> None:
        """One row if at least PHYSICS_DT_S has passed since the last one (or a run just started)."""
        if t < self._next_t:
            return
        self._next_t = t + PHYSICS_DT_S - 1e-9
        wave = wave_under(self._waves, float(x[0]), float(x[1]), t)
        row = [f"{t:.6f}", *(repr(float(v)) for v in x), repr(n_cmd[0]), repr(n_cmd[1]),
               *(repr(w) for w in wave), self._run, frame_count, pwm[0], pwm[1]]
        self._writer.writerow(row)

    def flush(self) -> None:
        """Push buffered rows to disk."""
        self._file.flush()

    def close(self) -> None:
        """Flush and close."""
        self._file.close()


def _plain(value: Any) -> Any:
    """Dataclasses as dicts with their type name (public fields only), arrays as lists, for the record."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        fields = {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)
                  if not f.name.startswith("_")}
        return {"type": type(value).__name__, **fields}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return repr(value)


def write_sea_record(path: Path, seed: int | None, waves: WaveField, current: OceanCurrent,
                     vessel: Any, x0: np.ndarray,
                     note: str = "known to the physics only; nothing in the JSON replies carries the sea or its phase",
                     ) -> None:
    """sea.json: what the boat sails in — the seed, the wave field (with its phase), current, the plant's vessel (a
    name or its mapping, ``VesselSpec.to_config``) and start."""
    record = {
        "seed": seed,
        "waves": _plain(waves),
        "current": _plain(current),
        "vessel": vessel.to_config() if hasattr(vessel, "to_config") else vessel,
        "x0": [float(v) for v in x0],
        "note": note,
    }
    path.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
