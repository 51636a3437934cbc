"""How long `mavbridge identify` takes on an hour's log: the issue's ≤ 30 s.

Run: python bench/identify_speed.py [--minutes 60] [--keep DIR]

Writes an Otter API CSV of ``--minutes`` of the vessel model (a known hull: roll kicks let free to decay, steady
shaft speeds, steering steps, sensor noise, 3 % of the rows lost; tests/mavbridge/identify_logs.py) at 10 Hz,
then runs ``mavbridge identify`` on it in this process and prints the wall time of the identification alone.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mavbridge.cli.main import main  # noqa: E402
from tests.mavbridge.identify_logs import write_identify_log  # noqa: E402
from vessel import otter_parameters  # noqa: E402


def run(minutes: float, keep: str | None) -> float:
    """Write the log, identify it; the identification's wall time (s)."""
    folder = Path(keep) if keep else Path(tempfile.mkdtemp(prefix="identify-speed-"))
    folder.mkdir(parents=True, exist_ok=True)
    log = folder / "otter-hour.csv"
    hull = otter_parameters().replace(gyration_roll=0.6, zeta_roll=0.12, max_speed=2.5)
    started = time.perf_counter()
    write_identify_log(log, hull, minutes * 60.0, seed=1)
    print(f"wrote {log} ({log.stat().st_size / 1e6:.1f} MB, {minutes:g} min) in {time.perf_counter() - started:.1f} s")
    out = folder / f"out-{time.strftime('%H%M%S')}"
    started = time.perf_counter()
    code = main(["identify", str(log), "--out", str(out)])
    seconds = time.perf_counter() - started
    print(f"identify: exit {code}, {seconds:.1f} s for {minutes:g} min of log (limit 30 s)")
    return seconds


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=60.0, help="log length in minutes (default 60)")
    parser.add_argument("--keep", help="folder for the log and the outputs (default a temporary one)")
    args = parser.parse_args()
    run(args.minutes, args.keep)
