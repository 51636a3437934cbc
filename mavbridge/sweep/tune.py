"""``mavbridge tune``: the paper's tuning procedure as an algorithm, run as batches of sweep cases.

The paper (and the README's "Tuning") tunes by hand: (1) Q and S for a good direct path (R = 0);
(2) raise R until the wanted behaviour appears or the boat stops aiming for the waypoint; (3) if it stops
aiming for the waypoint, raise Q; (4) if progress is slow, raise S. Here each step is one batch of
closed loops on the chosen executor:

1. *direct*: Q × S on a small grid with R = 0; the fastest arrival is the direct tuning (Q₀, S₀) and
   the reference every reduction is measured against;
2. *roll weight*: R over a geometric ladder with (Q₀, S₀), extended upwards (× 2, 4, 8, 16, again from the new
   top, up to ``R_MAX``) while no rung meets the roll target and the top one still arrives: in a gentle sea the
   roll is small and so is R·φ², and the paper's ladder would stop before the roll term acts ("raise R until the
   wanted behaviour appears or the boat stops aiming for the waypoint");
3. *repair*: for each R that meets the roll target but does not arrive, Q raised; for each that arrives
   but is slower than the time target (or than the best so far), S raised;
4. *refine*: R ± 10 %, ± 20 % around the best candidate, with its Q and S.

The answer is the fastest-arriving weights that meet the target (``min_reduction`` and/or ``max_time``),
with every run that led there; then the chosen weights are re-run from several start headings (each
against its own direct reference) and the mean and worst case are reported.

An irregular sea is one draw of its spectrum: weights tuned on one (its ``sea.spectrum.seed``) fit that draw's
waves. With ``sea_seeds`` every trial is flown on each of those draws, a draw being the sea's components and the
sensor noise (``estimation.seed``), both from the seed, as ``bench/wave_estimation.py`` draws them: its roll is the
mean over them, its reduction the mean of each draw's reduction against the direct tuning on the same draw, and
it arrives only if it arrives on every draw (its arrival is the latest). Tuned on sea seed 1 alone, NATO sea state
4's weights cut 29 % there and 21 % on average over seeds 1–10 (``bench/wave_estimation.py --weights``).
"""

from __future__ import annotations

import copy
import statistics
from collections.abc import Callable, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path

from mavbridge.lab.scenario import Scenario, scenario_from_mapping
from mavbridge.sweep.runner import run_sweep
from mavbridge.sweep.spec import Case, SweepSpec, case_id
from vessel.wording import counted

DIRECT_Q = (3.0, 5.0, 8.0)
DIRECT_S = (1.0, 2.0, 4.0)
R_LADDER = (250.0, 500.0, 750.0, 1000.0, 1250.0, 1550.0, 2000.0, 2500.0, 3200.0, 4000.0)
# Beyond the ladder (a gentle sea: the roll term R·φ² is small where φ is, so the paper's R barely acts): while
# no rung meets the roll target and the top one still arrives, R is raised by these factors of the top rung
EXTEND = (2.0, 4.0, 8.0, 16.0)
R_MAX = 1e6  # the ladder's extension stops here (R·φ² then outweighs the distance term a thousandfold)
RAISE = (1.5, 2.0)
REFINE = (0.8, 0.9, 1.1, 1.2)
ROBUST_HEADINGS_DEG = (90.0, 60.0, 120.0, 30.0, 150.0)


@dataclass(frozen=True)
class Target:
    """What the tuning must achieve: a roll reduction against Direct and/or an arrival time."""

    min_reduction: float | None = None
    max_time_s: float | None = None


@dataclass(frozen=True)
class Trial:
    """One closed loop of the procedure: weights, step, figures."""

    step: str
    q: float
    r: float
    s: float
    avg_roll_deg: float
    arrival_s: float | None
    reduction: float | None
    rolls: tuple[float, ...] = ()  # the average roll on each sea seed flown (one entry without ``sea_seeds``)


@dataclass
class TuneResult:
    """The chosen weights (None if no trial met the target), the trials, and the robustness re-runs."""

    direct: Trial
    best: Trial | None
    trials: list[Trial] = field(default_factory=list)
    robustness: list[tuple[float, Trial]] = field(default_factory=list)
    sea_seeds: tuple[int, ...] = ()  # the sea draws every trial was flown on (empty: the scenario's own)


def _with(base: Scenario, q: float, r: float, s: float, heading_deg: float | None = None,
          sea_seed: int | None = None) -> Scenario:
    data = copy.deepcopy(base.to_mapping())
    data["controller"].update(q=q, r=r, s=s)
    if heading_deg is not None:
        data["start"]["heading_deg"] = heading_deg
    if sea_seed is not None:  # a draw: the sea's components and the sensor noise
        data["sea"]["spectrum"]["seed"] = sea_seed
        data["estimation"]["seed"] = sea_seed
    draw = "" if sea_seed is None else f"-seed{sea_seed}"
    return scenario_from_mapping(data, "tune", f"q{q:g}-r{r:g}-s{s:g}{draw}")


def reductions_by_seed(rolls: Sequence[float], reference: Sequence[float]) -> list[float] | None:
    """1 − roll / the reference's roll on the same sea seed, per seed; None without a reference."""
    if not reference or len(reference) != len(rolls) or not all(reference):
        return None
    return [1 - roll / ref for roll, ref in zip(rolls, reference, strict=True)]


def reduction_against(rolls: Sequence[float], reference: Sequence[float]) -> float | None:
    """The mean over sea seeds of ``reductions_by_seed``; None without a reference."""
    each = reductions_by_seed(rolls, reference)
    return statistics.fmean(each) if each else None


def _trial(step: str, weights: tuple[float, float, float], metrics: Sequence[dict],
           direct_rolls: Sequence[float]) -> Trial:
    """One weight set's runs (one per sea seed) as a trial: mean roll, latest arrival (None unless all arrive)."""
    rolls = tuple(float(m["avg_roll_deg"]) for m in metrics)
    arrivals = [m["time_to_waypoint_s"] for m in metrics]
    arrival = None if any(a is None for a in arrivals) else max(arrivals)
    return Trial(step, *weights, statistics.fmean(rolls), arrival, reduction_against(rolls, direct_rolls), rolls)


def _meets(trial: Trial, target: Target) -> bool:
    if trial.arrival_s is None:
        return False
    if target.min_reduction is not None and (trial.reduction is None or trial.reduction < target.min_reduction):
        return False
    return target.max_time_s is None or trial.arrival_s <= target.max_time_s


Flight = tuple[tuple[float, float, float], float | None]  # (Q, R, S), start heading (deg) or None: the base's


class Procedure:
    """Runs batches of scenarios through the sweep runner (resumable in ``out``) and keeps the trials."""

    def __init__(self, base: Scenario, executor: Executor, out: Path, say: Callable[[str], None],
                 sea_seeds: Sequence[int] = ()) -> None:
        self.base, self.executor, self.out, self.say = base, executor, out, say
        self.sea_seeds: tuple[int | None, ...] = tuple(sea_seeds) or (None,)  # None: the scenario's own sea
        self.trials: list[Trial] = []
        self.direct_rolls: tuple[float, ...] = ()  # the direct tuning's roll on each sea seed, once chosen

    def batch(self, step: str, weights: Sequence[tuple[float, float, float]],
              heading_deg: float | None = None, keep: bool = True) -> list[Trial]:
        """Run every (Q, R, S) of a batch on every sea seed; a trial per weight set, in order (kept among the
        procedure's trials unless ``keep`` is False: the robustness re-runs, measured against their own
        heading's Direct, are reported apart)."""
        found = self.flights(step, [(w, heading_deg) for w in weights])
        trials = [trial for trial in found if trial is not None]
        if keep:
            self.trials.extend(trials)
        self.say(f"tune: {step}: {counted(len(trials), 'trial')} of {counted(len(self.sea_seeds), 'run')} each, "
                 + _best_line(trials))
        return trials

    def flights(self, step: str, items: Sequence[Flight]) -> list[Trial | None]:
        """Each (weights, start heading or None) on every sea seed, all in one sweep (the executor's workers kept
        busy to its end): a trial per item, in order, None where a run failed (reported by the runner)."""
        runs = [[_with(self.base, q, r, s, heading, seed) for seed in self.sea_seeds] for (q, r, s), heading in items]
        spec = SweepSpec(f"tune:{step}", {}, [Case({}, sc) for group in runs for sc in group])
        outcome = run_sweep(spec, self.executor, self.out, say=self.say)
        if outcome.interrupted:
            raise KeyboardInterrupt
        trials: list[Trial | None] = []
        for (w, _), group in zip(items, runs, strict=True):
            records = [outcome.results.get(case_id(sc)) for sc in group]
            failed = any(record is None for record in records)
            trials.append(None if failed else _trial(step, w, [record["metrics"] for record in records],
                                                     self.direct_rolls))
        return trials


def _best_line(trials: Sequence[Trial]) -> str:
    arrived = [t for t in trials if t.arrival_s is not None]
    if not arrived:
        return "none arrived"
    t = min(arrived, key=lambda t: t.arrival_s)
    return f"fastest Q, R, S = {t.q:g}, {t.r:g}, {t.s:g} at {t.arrival_s:.1f} s"


def _direct_step(proc: Procedure) -> Trial:
    trials = proc.batch("direct", [(q, 0.0, s) for q in DIRECT_Q for s in DIRECT_S])
    arrived = [t for t in trials if t.arrival_s is not None]
    if not arrived:
        raise RuntimeError("tune: no direct tuning (R = 0) reached the waypoint; check the mission")
    direct = min(arrived, key=lambda t: t.arrival_s)
    proc.direct_rolls = direct.rolls
    return direct


def _repair_weights(trials: Sequence[Trial], target: Target, best_time: float | None) -> list[tuple]:
    """Step 3: raise Q where the roll target is met without arriving; raise S where progress is slow."""
    out: list[tuple[float, float, float]] = []
    for t in trials:
        rolls_ok = target.min_reduction is None or (t.reduction or 0) >= target.min_reduction
        slow = t.arrival_s is not None and (
            (target.max_time_s is not None and t.arrival_s > target.max_time_s)
            or (best_time is not None and t.arrival_s > best_time))
        if rolls_ok and t.arrival_s is None:
            out += [(t.q * k, t.r, t.s) for k in RAISE]
        elif rolls_ok and slow:
            out += [(t.q, t.r, t.s * k) for k in RAISE]
    return list(dict.fromkeys(out))


def _extend_ladder(proc: Procedure, ladder: list[Trial], target: Target, q0: float, s0: float) -> list[Trial]:
    """Step 2 continued: higher R (``EXTEND`` × the top rung, repeatedly) while no rung meets the roll target, the
    top one arrived and R stays within ``R_MAX``; the trials added."""
    added: list[Trial] = []
    rungs = ladder
    while target.min_reduction is not None and rungs and not any(_meets(t, target) for t in ladder + added):
        top = max(rungs, key=lambda t: t.r)
        higher = [top.r * k for k in EXTEND if top.r * k <= R_MAX]
        if top.arrival_s is None or not higher:
            break
        rungs = proc.batch("roll weight, higher", [(q0, r, s0) for r in higher])
        added += rungs
    return added


def _choose(trials: Sequence[Trial], target: Target) -> Trial | None:
    ok = [t for t in trials if _meets(t, target)]
    return min(ok, key=lambda t: (t.arrival_s, -(t.reduction or 0))) if ok else None


def tune(base: Scenario, target: Target, executor: Executor, out: Path,
         say: Callable[[str], None] = print, headings_deg: Sequence[float] = ROBUST_HEADINGS_DEG,
         sea_seeds: Sequence[int] = ()) -> TuneResult:
    """Run the procedure (each trial on every one of ``sea_seeds``, when given: an irregular sea's draws); then
    the robustness re-runs of the chosen weights from ``headings_deg``."""
    proc = Procedure(base, executor, out, say, sea_seeds)
    direct = _direct_step(proc)
    q0, s0 = direct.q, direct.s
    ladder = proc.batch("roll weight", [(q0, r, s0) for r in R_LADDER])
    ladder += _extend_ladder(proc, ladder, target, q0, s0)
    best = _choose(proc.trials, target)
    repairs = _repair_weights(ladder, target, best.arrival_s if best else None)
    if repairs:
        proc.batch("repair", repairs)
        best = _choose(proc.trials, target)
    if best is not None:
        proc.batch("refine", [(best.q, best.r * k, best.s) for k in REFINE])
        best = _choose(proc.trials, target)
    result = TuneResult(direct, best, proc.trials, sea_seeds=tuple(sea_seeds))
    if best is not None:
        result.robustness = _robustness(proc, direct, best, headings_deg)
    return result


def _robustness(proc: Procedure, direct: Trial, best: Trial, headings_deg: Sequence[float]) -> list[tuple]:
    """The chosen weights from each start heading, each against the direct tuning from the same heading: every
    heading's pair in one sweep."""
    pairs = [item for heading in headings_deg
             for item in (((direct.q, 0.0, direct.s), heading), ((best.q, best.r, best.s), heading))]
    flown = proc.flights("robustness", pairs)
    rows = []
    for i, heading in enumerate(headings_deg):
        ref, chosen = flown[2 * i], flown[2 * i + 1]
        if ref is None or chosen is None:
            continue  # a run failed (reported by the runner)
        rows.append((heading, Trial("robustness", best.q, best.r, best.s, chosen.avg_roll_deg, chosen.arrival_s,
                                    reduction_against(chosen.rolls, ref.rolls), chosen.rolls)))
    proc.say(f"tune: robustness: {counted(len(rows), 'start heading')} of {len(headings_deg)} flown")
    return rows


def report(result: TuneResult, target: Target) -> str:
    """Markdown: the choice, the robustness re-runs (mean and worst), and every trial."""
    d = result.direct
    lines = [f"Direct tuning: Q, S = {d.q:g}, {d.s:g}: avg roll {d.avg_roll_deg:.2f}°, arrival {_t(d.arrival_s)}", ""]
    b = result.best
    if b is None:
        lines.append(f"No trial met the target ({_target(target)}).")
    else:
        lines.append(f"Chosen: Q, R, S = {b.q:g}, {b.r:g}, {b.s:g}: avg roll {b.avg_roll_deg:.2f}° "
                     f"({100 * (b.reduction or 0):.0f} % below Direct), arrival {_t(b.arrival_s)} "
                     f"(target: {_target(target)})")
    if result.sea_seeds:
        lines.append(f"\nEvery trial flown on sea seeds {', '.join(map(str, result.sea_seeds))}: its roll is the mean, "
                     "its reduction the mean of each seed's against the direct tuning on that seed, its arrival the "
                     "latest (it arrives only if it arrives on every seed).")
        each = reductions_by_seed(b.rolls, d.rolls) if b is not None else None
        if each:
            cuts = ", ".join(f"{seed}: {100 * cut:.0f} %" for seed, cut in zip(result.sea_seeds, each, strict=True))
            lines.append(f"The chosen weights by sea seed: {cuts}.")
    if result.robustness:
        reds = [t.reduction for _, t in result.robustness if t.reduction is not None]
        times = [t.arrival_s for _, t in result.robustness]
        reached = [x for x in times if x is not None]
        lines += ["", "| start heading ° | avg roll ° | reduction vs Direct from there | arrival s |",
                  "|---|---|---|---|"]
        lines += [f"| {h:g} | {t.avg_roll_deg:.2f} | {100 * (t.reduction or 0):.0f} % | {_t(t.arrival_s)} |"
                  for h, t in result.robustness]
        if reds:
            timing = f", mean {sum(reached) / len(reached):.1f} s, worst {max(reached):.1f} s" if reached else ""
            lines.append(f"\nReduction mean {100 * sum(reds) / len(reds):.0f} %, worst {100 * min(reds):.0f} %; "
                         f"arrived {len(reached)}/{len(times)}{timing}")
    lines += ["", "| step | Q | R | S | avg roll ° | reduction | arrival s |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {t.step} | {t.q:g} | {t.r:g} | {t.s:g} | {t.avg_roll_deg:.2f} | "
              f"{'' if t.reduction is None else f'{100 * t.reduction:.0f} %'} | {_t(t.arrival_s)} |"
              for t in result.trials]
    return "\n".join(lines) + "\n"


def _t(value: float | None) -> str:
    return "not reached" if value is None else f"{value:.1f} s"


def _target(target: Target) -> str:
    parts = []
    if target.min_reduction is not None:
        parts.append(f"reduction >= {100 * target.min_reduction:.0f} %")
    if target.max_time_s is not None:
        parts.append(f"arrival <= {target.max_time_s:g} s")
    return ", ".join(parts)
