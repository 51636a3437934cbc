"""Sweep throughput: closed-loop Balanced-like runs per minute on local and dask-local, 1 and 2 workers.

    OMP_NUM_THREADS=1 python bench/sweep_throughput.py [--cases 32] [--solver asrti] [--executors local:1,local:2]

A fixed sweep of Balanced-like cases (R around 1550, four wave directions; each case's R = 0 reference
runs too) in the paper's sea, each run on a fresh output folder so nothing is skipped. Prints runs per
minute and per hour for each executor, the speed-up of 2 workers over 1 of the same kind (and over local
with 1 worker), and the share of the machine's CPU time the hypervisor gave to other guests meanwhile
(Linux's "steal" in /proc/stat): on a shared host a run with much steal measures the neighbours, not the code.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from mavbridge.sweep import load_spec, open_executor, run_sweep

ROOT = Path(__file__).resolve().parents[1]
EXECUTORS = {  # --executors name -> (label, executor, jobs)
    "local:1": ("local, 1 worker", "local", 1), "local:2": ("local, 2 workers", "local", 2),
    "dask-local:1": ("dask-local:1", "dask-local:1", 1), "dask-local:2": ("dask-local:2", "dask-local:2", 2),
}


def write_spec(folder: Path, cases: int, solver: str) -> Path:
    """cases = 4 directions × (cases / 4) values of R."""
    per_dir = max(1, cases // 4)
    r_values = [1200 + 100 * i for i in range(per_dir)]
    spec = folder / "throughput.yaml"
    spec.write_text(
        f"base: {ROOT / 'scenarios' / 'balanced.yaml'}\n"
        f"axes:\n  controller.r: {r_values}\n  sea.travel_dir_deg: [-100, -95, -90, -85]\n"
        f"  controller.solver: [{solver}]\n", encoding="utf-8")
    return spec


def cpu_ticks() -> tuple[int, int]:
    """(steal, total) CPU ticks of all cores since boot, from /proc/stat; (0, 0) where there is none."""
    try:
        fields = [int(v) for v in Path("/proc/stat").read_text(encoding="ascii").split("\n", 1)[0].split()[1:]]
    except (OSError, ValueError):
        return 0, 0
    steal = fields[7] if len(fields) > 7 else 0
    return steal, sum(fields[:8])


def measure(spec_path: Path, executor: str, jobs: int, out: Path) -> tuple[int, float, float]:
    """(runs, wall seconds, steal fraction) for the whole sweep, executor start-up included."""
    spec = load_spec(spec_path)
    steal_0, total_0 = cpu_ticks()
    start = time.perf_counter()
    with open_executor(executor, jobs) as pool:
        outcome = run_sweep(spec, pool, out, say=lambda line: None)
    wall = time.perf_counter() - start
    steal_1, total_1 = cpu_ticks()
    stolen = (steal_1 - steal_0) / (total_1 - total_0) if total_1 > total_0 else 0.0
    if outcome.failed:
        raise SystemExit(f"{executor}: {len(outcome.failed)} runs failed: {next(iter(outcome.failed.values()))}")
    return outcome.ran, wall, stolen


def main() -> None:
    """Print the throughput table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=32)
    parser.add_argument("--solver", default="asrti")
    parser.add_argument("--executors", default=",".join(EXECUTORS),
                        help=f"comma-separated, of {', '.join(EXECUTORS)} (default: all four, in that order)")
    args = parser.parse_args()
    chosen = [name.strip() for name in args.executors.split(",") if name.strip()]
    unknown = [name for name in chosen if name not in EXECUTORS]
    if unknown:
        parser.error(f"--executors: unknown {', '.join(unknown)}; known: {', '.join(EXECUTORS)}")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        spec = write_spec(folder, args.cases, args.solver)
        rows = []
        for label, executor, jobs in (EXECUTORS[name] for name in chosen):
            runs, wall, stolen = measure(spec, executor, jobs, folder / label.replace(" ", "_").replace(",", ""))
            rows.append((label, runs, wall, stolen))
            print(f"  {label}: {runs} runs in {wall:.1f} s, steal {100 * stolen:.0f} %", flush=True)
    print_table(rows)


def print_table(rows: list[tuple[str, int, float, float]]) -> None:
    """Markdown table; the speed-up of each executor over the 1-worker run of its own kind (local or Dask),
    and over local with 1 worker."""
    def kind(label: str) -> str:
        return label.split(",")[0].split(":")[0]

    one_worker = {kind(label): wall for label, _, wall, _ in rows if label.endswith(("1 worker", ":1"))}
    base = rows[0][2]
    print("\n| executor | runs | wall s | runs/min | runs/hour | speed-up vs its 1 worker | vs local 1 worker "
          "| CPU stolen |\n|---|---|---|---|---|---|---|---|")
    for label, runs, wall, stolen in rows:
        own = one_worker.get(kind(label), base)
        print(f"| {label} | {runs} | {wall:.1f} | {60 * runs / wall:.1f} | {3600 * runs / wall:.0f} "
              f"| {own / wall:.2f}× | {base / wall:.2f}× | {100 * stolen:.0f} % |")

if __name__ == "__main__":
    main()
