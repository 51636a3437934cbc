"""What every solver backend returns from one solve."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SolveOutcome:
    """A backend's answer: the primal/dual iterate and whether it may be applied."""

    w: np.ndarray | None
    lam_w: np.ndarray | None
    lam_g: np.ndarray | None
    usable: bool
    status: str
    iterations: int
    violation: float = float("nan")

    @classmethod
    def failed(cls, status: str) -> SolveOutcome:
        """An outcome with no iterate at all (the solver raised)."""
        return cls(w=None, lam_w=None, lam_g=None, usable=False, status=status, iterations=0)
