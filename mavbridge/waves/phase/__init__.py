"""Phase-resolved prediction of an irregular sea from the boat's own motion (issue 33): the individual waves the
hull will meet over the next seconds, not only the sea's statistics.

``predictor`` (``PhasePredictor``: samples in, predicted slope and height at any future time and NED position out,
with how far ahead its measured skill trusts them) fits the bank of long-crested components of ``bank``; ``skill``
holds its settings and the scoring of its past predictions. Not yet wired into the NMPC.

May import: ``vessel``, ``vessel.sea`` and ``mavbridge.waves``. Imported by ``mavbridge.waves``' users (the companion,
the lab) and the benches.
"""

from mavbridge.waves.phase.predictor import PhasePredictor
from mavbridge.waves.phase.skill import PredictorSettings

__all__ = ["PhasePredictor", "PredictorSettings"]
