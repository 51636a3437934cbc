"""Wave estimation from the boat's own motion: a ``WaveSource`` for the companion (no I/O)."""

from .estimator import EstimatorSettings, WaveEstimator

__all__ = ["EstimatorSettings", "WaveEstimator"]
