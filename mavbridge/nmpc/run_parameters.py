"""What a controller knows of the sea between solves, and the NLP's parameter vector built from it.

The wave the model predicts with (``set_wave``: a regular wave, calm water, or None = nothing known,
which zeroes the roll weight R: the Direct behaviour) and the sea's unexplained slope statistics
(``set_sea_spread``: the expected-roll term, see ``sea_spread``) are run-time parameters: no rebuild.
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.layout import PARAMS
from mavbridge.nmpc.problem import pack_parameters
from mavbridge.nmpc.sea_spread import slope_factor
from mavbridge.nmpc.wave_model import CALM_PARAMETERS, wave_parameters
from vessel import CalmWater, RegularWaves, WaveField


class SeaKnowledge:
    """The wave block, whether a wave is known, and the slope-spread factor; ``pack`` builds p."""

    def __init__(self, config: NmpcConfig, fixed_waves: WaveField | None, waves: WaveField) -> None:
        self.config, self.fixed_waves = config, fixed_waves
        self.wave = CALM_PARAMETERS.copy() if fixed_waves is not None else wave_parameters(waves)  # type: ignore[arg-type]
        self.wave_known = True
        self.factor = np.zeros(3)  # Cholesky factor of the unexplained slope covariance

    def set_wave(self, waves: RegularWaves | CalmWater | None) -> None:
        """The regular wave (or calm water) to predict with; None: nothing known (R = 0)."""
        if self.fixed_waves is not None:
            raise ValueError(f"set_wave: this controller was built with a fixed "
                             f"{type(self.fixed_waves).__name__}; only RegularWaves or CalmWater "
                             f"controllers take a run-time wave")
        self.wave = wave_parameters(waves)
        self.wave_known = waves is not None

    def set_spread(self, covariance_ned: np.ndarray | None) -> None:
        """The unexplained NED slope covariance (2×2, rad²), or None (no expected-roll term)."""
        self.factor = slope_factor(covariance_ned)

    @property
    def roll_term_active(self) -> bool:
        """R > 0 and a wave (or calm water) or the sea's spread known."""
        return (self.wave_known or bool(np.any(self.factor))) and self.config.r > 0

    def pack(self, x0: np.ndarray, t: float, waypoint: np.ndarray, u_applied: np.ndarray) -> np.ndarray:
        """The parameter vector for one solve (R = 0 while no wave is known; the spread scaled by √R)."""
        p = pack_parameters(x0, t, waypoint, u_applied, self.config.weights, self.wave,
                            math.sqrt(self.config.r) * self.factor)
        if not self.wave_known:
            p[PARAMS.index("weights", "r")] = 0.0
        return p
