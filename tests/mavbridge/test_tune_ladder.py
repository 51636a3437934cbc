"""`mavbridge tune`'s roll-weight ladder goes on upwards in a gentle sea (the decision logic, on a model of the runs:
the real closed loops of the procedure are in test_sweep)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from mavbridge.sweep.tune import R_LADDER, R_MAX, Procedure, Target, Trial, _extend_ladder


class _Runs(Procedure):
    """A procedure whose runs follow ``reduction(R)`` and arrive while R is at most ``arrives_below``."""

    def __init__(self, reduction: Callable[[float], float], arrives_below: float = float("inf")) -> None:
        self.trials: list[Trial] = []
        self.reduction, self.arrives_below = reduction, arrives_below
        self.batches: list[list[float]] = []

    def batch(self, step: str, weights: Sequence[tuple[float, float, float]],
              heading_deg: float | None = None) -> list[Trial]:
        self.batches.append([r for _, r, _ in weights])
        trials = [Trial(step, q, r, s, 1.0 - self.reduction(r), 60.0 if r <= self.arrives_below else None,
                        self.reduction(r)) for q, r, s in weights]
        self.trials += trials
        return trials


def _ladder(proc: _Runs) -> list[Trial]:
    return proc.batch("roll weight", [(3.0, r, 4.0) for r in R_LADDER])


def test_a_gentle_sea_raises_r_until_the_roll_target_is_met() -> None:
    proc = _Runs(lambda r: min(0.9, r / 100_000))  # 25 % needs R = 25 000: beyond the paper's ladder
    added = _extend_ladder(proc, _ladder(proc), Target(min_reduction=0.25), 3.0, 4.0)
    assert proc.batches[1] == [8000.0, 16000.0, 32000.0, 64000.0]  # × 2, 4, 8, 16 of the top rung
    assert len(proc.batches) == 2 and any(t.reduction >= 0.25 for t in added)


def test_the_ladder_stops_when_the_top_rung_no_longer_arrives_or_at_r_max() -> None:
    stops = _Runs(lambda r: r / 1e9, arrives_below=20_000)
    _extend_ladder(stops, _ladder(stops), Target(min_reduction=0.25), 3.0, 4.0)
    assert len(stops.batches) == 2  # the top of the first extension (64 000) did not arrive
    capped = _Runs(lambda r: 0.0)
    _extend_ladder(capped, _ladder(capped), Target(min_reduction=0.25), 3.0, 4.0)
    assert max(max(b) for b in capped.batches) <= R_MAX and len(capped.batches) <= 6


def test_a_met_target_or_a_time_only_target_adds_nothing() -> None:
    met = _Runs(lambda r: r / 4000)
    assert _extend_ladder(met, _ladder(met), Target(min_reduction=0.25), 3.0, 4.0) == []
    timed = _Runs(lambda r: 0.0)
    assert _extend_ladder(timed, _ladder(timed), Target(max_time_s=100.0), 3.0, 4.0) == []
