"""The sections of a scenario that describe the boat's world, shared by the simulator and the controller.

``SeaState`` (waves and current) and ``Start`` (initial pose and velocity) are read from scenario YAML
by both ``sim_vehicle --scenario`` and ``mavbridge``; degrees only in fields whose names end in ``_deg``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .config import bounded
from .dynamics import OceanCurrent
from .waves import CalmWater, RegularWaves


@dataclass(frozen=True)
class SeaState:
    """The paper's regular waves; height 0 is calm water."""

    height_m: float = bounded(1.75, 0.0, 30.0, "m", "crest-to-trough height H")
    length_m: float = bounded(35.0, 1.0, 2000.0, "m", "wavelength λ")
    period_s: float = bounded(6.0, 0.5, 60.0, "s", "wave period T")
    travel_dir_deg: float = bounded(-90.0, -360.0, 360.0, "deg", "direction the waves travel to (0 = North)")
    current_speed_mps: float = bounded(0.0, 0.0, 5.0, "m/s", "uniform current speed")
    current_dir_deg: float = bounded(0.0, -360.0, 360.0, "deg", "direction the current flows to")

    def waves(self) -> RegularWaves | CalmWater:
        """The wave field (radians inside)."""
        if self.height_m == 0:
            return CalmWater()
        return RegularWaves(self.height_m, self.length_m, self.period_s, math.radians(self.travel_dir_deg))

    def current(self) -> OceanCurrent:
        """The ocean current."""
        return OceanCurrent(self.current_speed_mps, math.radians(self.current_dir_deg))


@dataclass(frozen=True)
class Start:
    """Initial pose and body velocity."""

    north_m: float = bounded(0.0, -1e5, 1e5, "m")
    east_m: float = bounded(0.0, -1e5, 1e5, "m")
    heading_deg: float = bounded(90.0, -360.0, 360.0, "deg", "ψ, 0 = North, 90 = East")
    surge_mps: float = bounded(0.0, -5.0, 10.0, "m/s", "u")
    sway_mps: float = bounded(0.0, -5.0, 5.0, "m/s", "v")
    yaw_rate_deg_s: float = bounded(0.0, -180.0, 180.0, "deg/s", "r")

    def state(self) -> np.ndarray:
        """The 12 rigid-body states."""
        x = np.zeros(12)
        x[0], x[1], x[5] = self.north_m, self.east_m, math.radians(self.heading_deg)
        x[6], x[7], x[11] = self.surge_mps, self.sway_mps, math.radians(self.yaw_rate_deg_s)
        return x
