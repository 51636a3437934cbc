"""The expected roll of the sea the wave model does not explain, as numbers for the ``roll_spread`` block.

A deterministic wave model predicts the wave it knows; an irregular sea's remainder (the components the
estimator cannot follow wave by wave) is known only by its statistics. For a hull whose roll follows the
slope across it, E[φ²] at heading ψ is yᵀ C y, y = (−sin ψ, cos ψ) the body y axis in NED and C the NED
slope covariance: beam seas roll the hull, head and following seas barely. With C = L Lᵀ that is ‖Lᵀy‖²,
a sum of two squares, so every solver (IPOPT's cost, the Gauss–Newton residuals) takes it unchanged.
"""

from __future__ import annotations

import math

import numpy as np


def slope_factor(covariance_ned: np.ndarray | None) -> np.ndarray:
    """(l_nn, l_en, l_ee): the lower Cholesky factor of a 2×2 NED covariance (rad²); zeros for None.

    Semi-definite covariances (a long-crested sea: rank one) factor too. Raises ValueError for a
    covariance that is not finite, not symmetric or not positive semi-definite.
    """
    if covariance_ned is None:
        return np.zeros(3)
    c = np.asarray(covariance_ned, float)
    if c.shape != (2, 2):
        raise ValueError(f"sea spread: expected a finite 2x2 covariance, got {c.tolist()}")
    (c_nn, c_ne), (c_en, c_ee) = c.tolist()  # plain floats: the companion factors one each control step
    if not (math.isfinite(c_nn) and math.isfinite(c_ne) and math.isfinite(c_en) and math.isfinite(c_ee)):
        raise ValueError(f"sea spread: expected a finite 2x2 covariance, got {c.tolist()}")
    if abs(c_ne - c_en) > 1e-12 * max(1.0, abs(c_nn), abs(c_ne), abs(c_en), abs(c_ee)):
        raise ValueError(f"sea spread: covariance {c.tolist()} is not symmetric")
    if c_nn < 0 or c_ee < 0 or c_en * c_en > c_nn * c_ee * (1 + 1e-9) + 1e-18:
        raise ValueError(f"sea spread: covariance {c.tolist()} is not positive semi-definite")
    l_nn = math.sqrt(c_nn)
    l_en = c_en / l_nn if l_nn > 0 else 0.0
    l_ee = math.sqrt(max(c_ee - l_en * l_en, 0.0))
    return np.array([l_nn, l_en, l_ee])
