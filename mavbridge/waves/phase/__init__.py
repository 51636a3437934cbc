"""Phase-resolved prediction of an irregular sea from the boat's own motion (issue 33): the individual waves the
hull will meet over the next seconds, not only the sea's statistics, and their way into the NMPC.

``bank`` (the maths: a ridge fit of long-crested components with absolute phases) and ``predictor``
(``PhasePredictor``: samples in, a fitted bank, predictions at any future time and NED position, and how far ahead
its measured skill trusts them; ``skill`` holds its settings and the scoring of its past predictions);
``bank_compress`` (the fit squeezed into the K components the NMPC's model carries, over its horizon) and
``bank_source`` (the estimator plus the predictor as the in-process wave source ``estimation.waves: predicted``,
and the per-step feed of the NMPC's ``bank`` block).

May import: ``vessel``, ``vessel.sea`` and ``mavbridge.waves``. Imported by ``mavbridge.waves`` (``inloop``),
``mavbridge.lab`` and the benches.
"""
