"""Wave estimation from the boat's own motion: a ``WaveSource`` for the companion (no I/O)."""

from .estimator import WaveEstimator
from .settings import EstimatorSettings

__all__ = ["EstimatorSettings", "WaveEstimator"]
