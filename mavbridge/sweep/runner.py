"""Run a sweep's cases on an executor: resumable, reproducible, with progress on stderr.

Each finished case is one JSON file ``cases/<case_id>.json`` (axis values, metrics, resolved scenario),
written atomically; a rerun skips every case whose file exists, so an interrupted sweep (Ctrl-C, SIGTERM,
a killed worker) loses at most the cases in flight. Metrics of a case do not depend on the executor: the
in-process closed loop is deterministic (no solve deadline), so equal cases give bit-identical figures.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import Executor, Future, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from mavbridge.lab.scenario import Scenario
from mavbridge.sweep.spec import SweepSpec
from vessel.wording import counted

CASES_DIR = "cases"
WALL_CLOCK_KEYS = ("ms", "wall", "overruns")  # metrics that measure this computer, not the closed loop


@dataclass
class SweepOutcome:
    """What a sweep did: results by case id (read back or new), what failed, what was left."""

    results: dict[str, dict] = field(default_factory=dict)
    ran: int = 0
    skipped: int = 0
    failed: dict[str, str] = field(default_factory=dict)
    remaining: int = 0
    interrupted: bool = False


def deterministic_metrics(metrics: dict) -> dict:
    """The metrics that depend only on the closed loop (not on solve times): equal on every executor."""
    return {k: v for k, v in metrics.items() if not any(tag in k for tag in WALL_CLOCK_KEYS)}


def run_case(scenario: Scenario) -> dict:
    """One closed loop in this (worker) process; only numbers go back."""
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    from mavbridge.lab.experiment import run_scenario

    return run_scenario(scenario, out_dir=None, plots=False).metrics


def _write_atomic(path: Path, payload: dict) -> None:
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(payload, indent=1, default=float) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def read_case(path: Path) -> dict | None:
    """A finished case's record, or None if the file is unreadable (then it is run again)."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


class Progress:
    """Count, rate and ETA: one rewritten line on a terminal, a plain line per case otherwise."""

    def __init__(self, total: int, stream: TextIO = sys.stderr) -> None:
        self.total, self.done, self.stream = total, 0, stream
        self.start = time.monotonic()
        self.tty = stream.isatty()

    def tick(self, label: str) -> None:
        """One more case finished."""
        self.done += 1
        elapsed = time.monotonic() - self.start
        rate = self.done / elapsed * 60 if elapsed > 0 else 0.0
        eta = (self.total - self.done) / (self.done / elapsed) if self.done and elapsed > 0 else 0.0
        line = f"{self.done}/{self.total} cases, {rate:.1f}/min, ETA {eta:.0f} s ({label})"
        if self.tty:
            self.stream.write("\r" + line.ljust(100) + ("\n" if self.done == self.total else ""))
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _record(cid: str, scenario: Scenario, metrics: dict) -> dict:
    return {"case_id": cid, "metrics": metrics, "scenario": scenario.to_mapping()}


def _pending(spec: SweepSpec, cases_dir: Path, outcome: SweepOutcome) -> dict[str, Scenario]:
    """Scenarios still to run (cases and references, unique by id); finished ones are read into ``outcome``."""
    todo: dict[str, Scenario] = {}
    for cid, scenario in spec.all_scenarios().items():
        record = read_case(cases_dir / f"{cid}.json")
        if record is not None:
            outcome.results[cid] = record
            outcome.skipped += 1
        else:
            todo[cid] = scenario
    return todo


def run_sweep(spec: SweepSpec, executor: Executor, out: Path,
              say: Callable[[str], None] = lambda line: print(line, file=sys.stderr)) -> SweepOutcome:
    """Run every case not yet in ``out/cases``; on KeyboardInterrupt cancel the rest and say what remains."""
    cases_dir = out / CASES_DIR
    cases_dir.mkdir(parents=True, exist_ok=True)
    outcome = SweepOutcome()
    todo = _pending(spec, cases_dir, outcome)
    if outcome.skipped:
        say(f"sweep: {counted(outcome.skipped, 'case')} already done in {cases_dir}, {len(todo)} to run")
    progress = Progress(len(todo))
    futures: dict[Future, str] = {executor.submit(run_case, sc): cid for cid, sc in todo.items()}
    try:
        for future in as_completed(futures):
            cid = futures[future]
            _collect(future, cid, todo[cid], cases_dir, outcome)
            progress.tick(cid)
    except KeyboardInterrupt:
        outcome.interrupted = True
        for future in futures:
            future.cancel()
    outcome.remaining = len(todo) - outcome.ran - len(outcome.failed)
    return outcome


def _collect(future: Future, cid: str, scenario: Scenario, cases_dir: Path, outcome: SweepOutcome) -> None:
    """Store a finished run, or note why it failed (a failed run is not stored: a rerun tries again)."""
    try:
        metrics: dict[str, Any] = future.result()
    except Exception as exc:  # a worker died or the run raised: counted, reported, retried on rerun
        outcome.failed[cid] = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
        return
    record = _record(cid, scenario, metrics)
    _write_atomic(cases_dir / f"{cid}.json", record)
    outcome.results[cid] = record
    outcome.ran += 1
