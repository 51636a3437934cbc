"""What a controller knows of the sea between solves, and the NLP's parameter vector built from it.

The wave the model predicts with (``set_wave``: a regular wave, calm water, or None = nothing known,
which zeroes the roll weight R: the Direct behaviour) and the sea's unexplained slope statistics
(``set_sea_spread``: the expected-roll term, see ``sea_spread``) are run-time parameters: no rebuild. So is
the phase-resolved bank of a problem built with ``wave_components`` K > 0 (``set_bank``, see ``wave_bank``):
while it holds a sea, the roll weight acts even when no regular wave is known.
"""

from __future__ import annotations

import math

import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.layout import PARAMS
from mavbridge.nmpc.problem import NO_DISTURBANCE, pack_parameters
from mavbridge.nmpc.sea_spread import slope_factor
from mavbridge.nmpc.wave_bank import NO_FADE_S, H, bank_parameters, no_bank
from mavbridge.nmpc.wave_model import CALM_PARAMETERS, wave_parameters
from vessel import CalmWater, RegularWaves, WaveField

_CALM = CalmWater()  # frozen: the field planned with while no wave is known


class SeaKnowledge:
    """The wave block, whether a wave is known, and the slope-spread factor; ``pack`` builds p."""

    def __init__(self, config: NmpcConfig, fixed_waves: WaveField | None, waves: WaveField) -> None:
        self.config, self.fixed_waves = config, fixed_waves
        self.wave = CALM_PARAMETERS.copy() if fixed_waves is not None else wave_parameters(waves)  # type: ignore[arg-type]
        self.wave_known = True
        self.factor = np.zeros(3)  # Cholesky factor of the unexplained slope covariance
        k = config.wave_components
        self.bank: np.ndarray | None = no_bank(k) if k > 0 else None  # None: no bank block (K = 0)
        self._roll_sign = float(self.wave[-1])  # the regular wave's, unless a bank brings its own
        self._wave_of: tuple[object, np.ndarray] | None = None  # (the field last given, its block): fields are frozen
        self.disturbance = NO_DISTURBANCE.copy()  # current N, E (m/s), surge force (N), yaw moment (N·m)

    def set_wave(self, waves: RegularWaves | CalmWater | None) -> None:
        """The regular wave (or calm water) to predict with; None: nothing known (R = 0)."""
        if self.fixed_waves is not None:
            raise ValueError(f"set_wave: this controller was built with a fixed "
                             f"{type(self.fixed_waves).__name__}; only RegularWaves or CalmWater "
                             f"controllers take a run-time wave")
        if self._wave_of is None or waves is not self._wave_of[0]:  # the gate hands the same field while it holds
            self._wave_of = (waves, wave_parameters(waves))
        self.wave = self._wave_of[1].copy()  # (the bank's roll sign may be written into it)
        self.wave_known = waves is not None
        if not self.wave_known and self.bank_active:
            self.wave[-1] = self._roll_sign  # calm regular wave: the model rolls with the bank's sign

    def set_bank(self, arrays: dict[str, np.ndarray] | None, weight: float = 1.0, roll_sign: float = -1.0,
                 fade: tuple[float, float] = (0.0, NO_FADE_S)) -> None:
        """The phase-resolved sea (``PhasePredictor.bank_arrays``), its weight (0..1), the roll sign its slope
        was read with and its fade (from t s, over s; see ``wave_bank``); None: no bank (zeros). ValueError on a
        problem built without a bank (K = 0)."""
        if self.bank is None:
            raise ValueError("set_bank: the problem was built with wave_components = 0 (no bank block)")
        self.bank = bank_parameters(arrays, self.config.wave_components, weight, *fade)
        if self.bank_active:
            self._roll_sign = float(roll_sign)
            if not self.wave_known:
                self.wave[-1] = self._roll_sign

    @property
    def bank_active(self) -> bool:
        """True when the bank holds a sea (weight and some amplitude above zero)."""
        k = self.config.wave_components
        return self.bank is not None and self.bank[0] > 0 and bool(np.any(self.bank[H:H + k] > 0))

    def set_spread(self, covariance_ned: np.ndarray | None) -> None:
        """The unexplained NED slope covariance (2×2, rad²), or None (no expected-roll term)."""
        self.factor = slope_factor(covariance_ned)

    @property
    def roll_term_active(self) -> bool:
        """R > 0 and a wave (or calm water) or the sea's spread known."""
        return (self.wave_known or self.bank_active or bool(np.any(self.factor))) and self.config.r > 0

    def model_wave(self) -> np.ndarray:
        """The model step's ``wave`` input: the wave block, the bank block when there is one, the disturbance."""
        parts = [self.wave] if self.bank is None else [self.wave, self.bank]
        return np.concatenate([*parts, self.disturbance])

    def pack(self, x0: np.ndarray, t: float, waypoint: np.ndarray, u_applied: np.ndarray) -> np.ndarray:
        """The parameter vector for one solve (R = 0 while no wave is known; the spread scaled by √R)."""
        p = pack_parameters(x0, t, waypoint, u_applied, self.config.weights, self.wave,
                            math.sqrt(self.config.r) * self.factor, self.bank, self.disturbance)
        if not (self.wave_known or self.bank_active):
            p[PARAMS.index("weights", "r")] = 0.0
        return p


class SeaInputs:
    """What a controller is told about the sea between solves (``RollAwareNmpc``'s wave setters; it owns ``_sea``,
    a ``SeaKnowledge``, and ``waves``, the field it was last given)."""

    _sea: SeaKnowledge
    waves: WaveField

    def set_wave(self, waves: RegularWaves | CalmWater | None) -> None:
        """The wave later solves predict with; no rebuild, the stored plan stays the warm start.

        ``None`` means no confident wave knowledge: the model predicts calm water and the roll weight R
        is 0 for those solves (the Direct behaviour); ``NmpcResult.roll_term_active`` says which applied.
        A background (asrti) solve already running keeps the wave it was started with.
        """
        self._sea.set_wave(waves)
        self.waves = waves or _CALM  # one object: the delay predictor knows it from the last step's

    def model_wave(self) -> np.ndarray:
        """The model step's whole ``wave`` input as later solves use it (wave, bank, disturbance)."""
        return self._sea.model_wave()

    @property
    def wave_known(self) -> bool:
        """True when later solves predict with a known sea: a wave or calm water (``set_wave``), or a bank."""
        return self._sea.wave_known or self._sea.bank_active

    @property
    def disturbance(self) -> np.ndarray:
        """The disturbance later solves predict with (``set_disturbance``): current N, E (m/s), surge force (N),
        yaw moment (N·m)."""
        return self._sea.disturbance

    def set_disturbance(self, disturbance: np.ndarray) -> None:
        """What later solves predict the boat meets besides the waves (``disturbance.DisturbanceObserver``): the
        current's NED components (m/s), a steady surge force (N) and yaw moment (N·m); zeros: nothing. No rebuild."""
        values = np.asarray(disturbance, float)
        if values.shape != self._sea.disturbance.shape or not np.all(np.isfinite(values)):
            raise ValueError(f"set_disturbance: expected {self._sea.disturbance.size} finite numbers, got {values!r}")
        self._sea.disturbance = values.copy()

    def set_sea_spread(self, covariance_ned: np.ndarray | None) -> None:
        """The NED covariance (2×2, rad²) of the hull's roll-producing slope that the wave model does not
        explain, or None (zero): later solves add its expected roll R·E[φ²] at each predicted heading.

        An irregular sea's unpredictable part cannot be planned against wave by wave, but its expected
        roll still depends on the heading (beam seas roll the hull, head seas barely): this term is what
        lets the roll weight act on it. It is independent of ``set_wave`` and applies with R > 0 only.
        """
        self._sea.set_spread(covariance_ned)

    def set_wave_bank(self, arrays: dict[str, np.ndarray] | None, weight: float = 1.0,
                      roll_sign: float = -1.0, fade: tuple[float, float] | None = None) -> None:
        """The phase-resolved sea later solves add to the regular wave (built with ``wave_components`` K > 0):
        ``PhasePredictor.bank_arrays(K)`` (amplitude m, ω rad/s, k rad/m, direction rad NED, absolute phase rad
        on this controller's clock), its weight 0..1, the roll sign its slopes were read with and its fade (from
        t s, over s: half weight then, ``wave_bank``; None: none); None arrays: no bank.

        While it holds a sea the roll weight acts (as with a known wave); ``set_sea_spread`` stays independent
        (the caller decides what of the sea the bank leaves unexplained). ValueError when K = 0.
        """
        self._sea.set_bank(arrays, weight, roll_sign, *(() if fade is None else (fade,)))

    @property
    def bank_active(self) -> bool:
        """True when later solves plan with a phase-resolved bank (see ``set_wave_bank``)."""
        return self._sea.bank_active

    @property
    def roll_term_active(self) -> bool:
        """True when solves weight roll: R > 0 and a wave (or calm water) or the sea's spread is known."""
        return self._sea.roll_term_active
