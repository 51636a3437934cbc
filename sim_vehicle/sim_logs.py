"""What the simulator writes to ``--log-dir``: the .tlog of every MAVLink frame, ``state.csv`` of the true
state after each step, and once ``sea.json`` (the sea the simulator knows and never sends).

These files outlive a reboot (as SITL's do); without a log directory nothing is written and every call is a
no-op, so the loop never asks whether it logs.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sim_vehicle.json_backend.log import write_sea_record
from sim_vehicle.logs import StateCsv, TlogWriter
from sim_vehicle.physics import Physics
from sim_vehicle.rover.vehicle import Vehicle
from vessel import World

CSV_FLUSH_S = 1.0  # wall seconds between flushes of state.csv (a killed run keeps all but the last second)


class SimLogs:
    """The simulator's log files in ``log_dir`` (None: none); the tlog stamps frames with ``clock_us``."""

    def __init__(self, log_dir: Path | None, clock_us: Callable[[], int]) -> None:
        self.log_dir = log_dir
        self.tlog = TlogWriter(log_dir / "sim_vehicle.tlog", clock_us) if log_dir else None
        self.csv = StateCsv(log_dir / "state.csv") if log_dir else None
        self._last_flush = time.monotonic()

    def write_sea(self, physics: Physics, world: World, seed: int | None) -> None:
        """``sea.json``: the simulator's sea (its waves, current, vessel and start), for analysis only."""
        if self.log_dir is None:
            return
        write_sea_record(self.log_dir / "sea.json", seed, physics.plant.waves, physics.plant.current, world.vessel,
                         world.plant_state(), note="known to the simulator only; nothing it sends over MAVLink "
                         "carries the sea")

    def first_state(self, physics: Physics, n_cmd: tuple[float, float], vehicle: Vehicle) -> None:
        """The row before the first step (the wave at the origin at t = 0); the flush clock starts here."""
        self._last_flush = time.monotonic()
        if self.csv is not None:
            plant = physics.plant
            self.csv.write(plant.time, plant.state, n_cmd, physics.wave_at(0.0, 0.0, 0.0), int(vehicle.mode),
                           vehicle.armed)

    def state(self, physics: Physics, x: np.ndarray, n_cmd: tuple[float, float], vehicle: Vehicle) -> None:
        """One ``state.csv`` row of the true state ``x`` after a step, with the wave elevation at its position."""
        if self.csv is None:
            return
        t = physics.plant.time
        wave = physics.wave_at(float(x[0]), float(x[1]), t)
        self.csv.write(t, x, n_cmd, wave, int(vehicle.mode), vehicle.armed)

    def flush_if_due(self) -> None:
        """Flush ``state.csv`` every CSV_FLUSH_S of wall time."""
        if self.csv is not None and time.monotonic() - self._last_flush > CSV_FLUSH_S:
            self.csv.flush()
            self._last_flush = time.monotonic()

    def close(self) -> None:
        """Close the files (after the links, whose last frames the tlog still records)."""
        if self.csv is not None:
            self.csv.close()
        if self.tlog is not None:
            self.tlog.close()
