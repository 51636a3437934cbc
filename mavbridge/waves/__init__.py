"""Wave estimation from the boat's own motion: a ``WaveSource`` for the companion (no I/O).

The interface the companion and the lab see is ``source`` (``WaveSource``, ``MotionSample``,
``WaveEstimate``); the estimator and its parts (filters, oscillator, heave, Doppler, solve, steadiness,
spread, calibration) and the in-process sensed plant (``inloop``) sit beside it; the phase-resolved predictor of
an irregular sea has its own room, ``phase`` (issue 33, not yet wired into the NMPC).

May import: ``vessel`` and ``mavbridge.waves``. Imported by ``mavbridge.companion`` and ``mavbridge.lab``.
"""

from mavbridge.waves.estimator import WaveEstimator
from mavbridge.waves.settings import EstimatorSettings
from mavbridge.waves.window_estimator import WindowEstimator

__all__ = ["EstimatorSettings", "WaveEstimator", "WindowEstimator", "make_estimator"]


def make_estimator(settings: EstimatorSettings | None = None) -> WaveEstimator | WindowEstimator:
    """The estimator ``settings.method`` names: the window fit (default) or the recursive one."""
    settings = settings or EstimatorSettings()
    return WindowEstimator(settings) if settings.method == "window" else WaveEstimator(settings)
