"""Benchmark: how much CPU sim-vehicle needs in real time, and how fast it can run unpaced.

Run: python bench/sim_cpu.py [--seconds S]. Prints the CPU share at --speedup 1 and 20 in the paper's waves
with the default streams going out on both UDP outputs and the TCP server open, and the unpaced speed factor.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _run(args: list[str]) -> tuple[float, float]:
    """Run sim-vehicle to completion; returns (wall s, CPU s) of the child."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.monotonic()
    subprocess.run([sys.executable, "-m", "sim_vehicle.cli", *args], check=True, stdout=subprocess.DEVNULL)
    wall = time.monotonic() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def main() -> None:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seconds", type=float, default=5.0, help="simulated seconds of the real-time run")
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        common = ["--no-tcp", "--no-out", "--params-store", str(Path(tmp) / "p.json")]
        for speedup in (1, 20):
            sim_s = opts.seconds * speedup
            wall, cpu = _run(["--no-tcp", "--params-store", str(Path(tmp) / "q.json"), "--sea", "paper",
                              "--speedup", str(speedup), "--duration", str(sim_s)])
            print(
                f"--speedup {speedup}, paper waves, default streams to both UDP outputs: {sim_s:g} s simulated in "
                f"{wall:.2f} s wall, CPU {cpu:.2f} s ({100 * cpu / wall:.0f} % of one core, includes start-up)"
            )
        for waves in ("calm", "paper"):
            sim_s = 300.0
            wall, cpu = _run(
                [
                    *common,
                    "--speedup",
                    "0",
                    "--duration",
                    str(sim_s),
                    "--sea",
                    waves,
                    "--log-dir",
                    str(Path(tmp) / waves),
                ]
            )
            print(
                f"unpaced, {waves}, with CSV+tlog: {sim_s:g} s simulated in {wall:.2f} s wall "
                f"-> {sim_s / wall:.0f}x real time ({1e6 * cpu / (sim_s * 100):.0f} µs CPU per 10 ms step)"
            )


if __name__ == "__main__":
    main()
