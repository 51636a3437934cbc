"""Named layouts of the NLP's two vectors: the decision vector w and the parameter vector p.

Every piece of code that reads or writes a block of ``w`` or ``p`` goes through these objects, so no
index arithmetic (``p[NX + 3:NX + 5]``) is spread over the solvers. Both layouts are immutable.

Parameter vector p (one built solver serves any run, time, tuning and regular wave):
    x0 (12)        measured rigid-body state [x y z φ θ ψ u v w p q r], NED position, body velocities
    t (1)          time of stage 0, s (the wave's clock)
    waypoint (2)   target (north, east), m, NED
    u_prev (2)     the model input u applied in the previous period (τ_X N, τ_N N·m; or the two thrusts, N)
    weights (5)    Q, R, S, W11, W22
    wave (7)       the dominant regular wave the model predicts with (see ``wave_model``)
    roll_spread (3) √R × the lower Cholesky factor L of the NED slope covariance the wave model does not
                   explain (l_nn, l_en, l_ee): the expected roll cost R·E[φ²] = ‖Lᵀy‖², y the body y axis
    disturbance (4) what the boat meets that the model lacks, as estimated in flight (``disturbance``): the
                   current's NED components (m/s) and a steady surge force (N) and yaw moment (N·m), body axes
    bank (3 + 6K)  only when ``NmpcConfig.wave_components`` K > 0: a phase-resolved sea of K long-crested
                   components added to the regular wave (see ``wave_bank``): its weight, the time it fades
                   from and the fade time, then K amplitudes, ω, k, cos μ, sin μ and phases. Appended last,
                   so every other block keeps its index and K = 0 is exactly the layout above (``PARAMS``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from vessel import NX_RIGID

NX = NX_RIGID
NU = 2
WEIGHT_NAMES = ("q", "r", "s", "w_dtau_x", "w_dtau_n")
WAVE_NAMES = ("height_m", "wavenumber_rad_per_m", "frequency_rad_per_s", "cos_travel_dir", "sin_travel_dir",
              "phase_rad", "roll_sign")


ROLL_SPREAD_NAMES = ("l_nn", "l_en", "l_ee")
DISTURBANCE_NAMES = ("current_north_mps", "current_east_mps", "surge_force_n", "yaw_moment_nm")
BANK_HEADER = ("weight", "fade_from_s", "fade_s")  # the bank block's scalars before its 6 K-vectors


MEMBERS = {"weights": WEIGHT_NAMES, "wave": WAVE_NAMES, "roll_spread": ROLL_SPREAD_NAMES,
           "disturbance": DISTURBANCE_NAMES}


def members(block: str, values: Any) -> dict[str, Any]:
    """The elements of the ``weights``, ``wave``, ``roll_spread`` or ``disturbance`` block (numbers or symbols)."""
    return {name: values[i] for i, name in enumerate(MEMBERS[block])}


@dataclass(frozen=True)
class ParameterBlocks:
    """The blocks of one parameter vector (numbers or CasADi symbols); scalars for one-element blocks."""

    x0: Any
    t: Any
    waypoint: Any
    u_prev: Any
    weights: Any
    wave: Any
    roll_spread: Any
    disturbance: Any
    bank: Any = None  # the wave bank block, None in a layout without one (K = 0)


@dataclass(frozen=True)
class ParameterLayout:
    """Where each named block lives in the parameter vector p (order fixed, sizes in ``blocks``)."""

    blocks: tuple[tuple[str, int], ...] = (("x0", NX), ("t", 1), ("waypoint", 2), ("u_prev", NU),
                                           ("weights", len(WEIGHT_NAMES)), ("wave", len(WAVE_NAMES)),
                                           ("roll_spread", len(ROLL_SPREAD_NAMES)),
                                           ("disturbance", len(DISTURBANCE_NAMES)))

    @functools.cached_property
    def _slices(self) -> dict[str, slice]:
        slices, start = {}, 0
        for block, n in self.blocks:
            slices[block] = slice(start, start + n)
            start += n
        return slices

    @property
    def size(self) -> int:
        """Length of p."""
        return sum(n for _, n in self.blocks)

    def slice(self, name: str) -> slice:
        """The slice of block ``name`` in p."""
        try:
            return self._slices[name]
        except KeyError:
            raise KeyError(f"no parameter block {name!r} (blocks: {', '.join(self._slices)})") from None

    def index(self, name: str, member: str | None = None) -> int:
        """The index in p of a one-element block, or of ``member`` of the weights or wave block."""
        where = self.slice(name)
        if member is None:
            if where.stop - where.start != 1:
                raise KeyError(f"parameter block {name!r} has {where.stop - where.start} elements: name a member")
            return where.start
        names = MEMBERS.get(name, ())
        if member not in names:
            raise KeyError(f"parameter block {name!r} has no member {member!r}")
        return where.start + names.index(member)

    def get(self, p: Any, name: str) -> Any:
        """Block ``name`` of p (a scalar for one-element blocks)."""
        where = self.slice(name)
        return p[where.start] if where.stop - where.start == 1 else p[where]

    def wave_input(self, p: Any) -> Any:
        """What the model's step takes as its ``wave`` input: the ``wave`` block, the ``bank`` block when the layout
        has one, then the ``disturbance`` block (numpy arrays concatenated, CasADi symbols stacked)."""
        parts = [self.get(p, "wave"), *([self.get(p, "bank")] if "bank" in self._slices else []),
                 self.get(p, "disturbance")]
        return np.concatenate(parts) if isinstance(p, np.ndarray) else ca.vertcat(*parts)

    def unpack(self, p: Any) -> ParameterBlocks:
        """All blocks of p, by name."""
        return ParameterBlocks(**{name: self.get(p, name) for name, _ in self.blocks})

    def pack(self, **values: Any) -> np.ndarray:
        """The numeric p from one value per block (keyword per block name; every block required)."""
        if len(values) != len(self.blocks):
            names = {name for name, _ in self.blocks}
            raise KeyError(f"pack: missing blocks {sorted(names - set(values))}, unknown blocks "
                           f"{sorted(set(values) - names)}")
        p = np.empty(self.size)
        start = 0
        for name, n in self.blocks:  # plain slice assignments: this runs every control step
            value = values[name]
            count = _count(value)
            if count != n:
                raise ValueError(f"pack: block {name!r} needs {n} numbers, got {count}")
            p[start:start + n] = value
            start += n
        return p


def _count(value: Any) -> int:
    """How many numbers ``value`` holds (cheap: no conversion to an array)."""
    if isinstance(value, np.ndarray):
        return value.size
    if isinstance(value, (int, float, np.floating)):
        return 1
    return len(value)


PARAMS = ParameterLayout()
NP = PARAMS.size


def bank_size(components: int) -> int:
    """Numbers in the ``bank`` block of K components (``BANK_HEADER`` + 6 per component); 0 for K = 0 (no block)."""
    return len(BANK_HEADER) + 6 * components if components > 0 else 0


def wave_input_size(components: int) -> int:
    """Length of the model's ``wave`` input: the regular wave block, the bank block when K > 0, the disturbance."""
    return len(WAVE_NAMES) + bank_size(components) + len(DISTURBANCE_NAMES)


@functools.lru_cache(maxsize=8)
def parameter_layout(components: int) -> ParameterLayout:
    """The parameter layout of a problem with K bank components: ``PARAMS`` itself for K = 0."""
    if components <= 0:
        return PARAMS
    return ParameterLayout((*PARAMS.blocks, ("bank", bank_size(components))))


@dataclass(frozen=True)
class Layout:
    """Where each stage's x and u live in the decision vector w = [x_0, u_0, x_1, u_1, …, x_P]."""

    horizon: int

    @property
    def n_w(self) -> int:
        """Number of decision variables."""
        return (self.horizon + 1) * NX + self.horizon * NU

    def x_index(self, k: int) -> slice:
        """Slice of x_k in w."""
        start = k * (NX + NU)
        return slice(start, start + NX)

    def u_index(self, k: int) -> slice:
        """Slice of u_k in w."""
        start = k * (NX + NU) + NX
        return slice(start, start + NU)

    def split(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(X (P+1)×12, U P×2) from a decision vector."""
        w = np.asarray(w, float).ravel()
        P = self.horizon
        stages = w[:P * (NX + NU)].reshape(P, NX + NU)
        X = np.empty((P + 1, NX))  # (filled in place: vstack's own calls cost as much again, every step)
        X[:P] = stages[:, :NX]
        X[P] = w[P * (NX + NU):]
        return X, stages[:, NX:].copy()

    def join(self, X: np.ndarray, U: np.ndarray) -> np.ndarray:
        """Decision vector from X and U."""
        P = self.horizon
        return np.concatenate([np.hstack([X[:P], U]).ravel(), X[P]])

    def shift(self, w: np.ndarray) -> np.ndarray:
        """The plan one period later: stage k takes stage k+1, the last stage is repeated."""
        w = np.asarray(w, float)
        P, m = self.horizon, NX + NU
        out = np.empty_like(w)
        out[:(P - 1) * m] = w[m:P * m]
        out[(P - 1) * m:(P - 1) * m + NX] = w[P * m:]  # x_{P-1} <- x_P
        out[(P - 1) * m + NX:P * m] = w[(P - 1) * m + NX:P * m]  # u_{P-1} repeated
        out[P * m:] = w[P * m:]  # x_P repeated
        return out
