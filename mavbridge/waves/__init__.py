"""Wave estimation from the boat's own motion: a ``WaveSource`` for the companion (no I/O).

The interface the companion and the lab see is ``source`` (``WaveSource``, ``MotionSample``,
``WaveEstimate``); the estimator and its parts (filters, oscillator, heave, Doppler, solve, steadiness,
spread, calibration) and the in-process sensed plant (``inloop``) sit beside it.

May import: ``vessel`` and ``mavbridge.waves``. Imported by ``mavbridge.companion`` and ``mavbridge.lab``.
"""

from mavbridge.waves.estimator import WaveEstimator
from mavbridge.waves.settings import EstimatorSettings

__all__ = ["EstimatorSettings", "WaveEstimator"]
