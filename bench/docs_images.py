"""The docs' generated pictures, regenerated from one run: the estimator over time and the path over the crests.

    python bench/docs_images.py [--out docs/images] [--keep DIR]

Runs ``mavbridge experiment scenarios/estimated_heading90.yaml`` (in-process, deterministic: the sea seed is the
scenario's own) into a temporary folder and copies two of its figures, at the run's own size and dpi:

* ``wave_estimate.png`` -> ``estimator-over-time.png`` (docs/explanation/estimator.md)
* ``path.png`` -> ``path-over-crests.png`` (docs/explanation/sea.md)

Each must stay under 200 kB (the docs are a git repository's pages); a larger one is an error.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "estimated_heading90.yaml"
NAME = "estimated_heading90"  # the scenario's name: its run's folder under --out
IMAGES = {"wave_estimate.png": "estimator-over-time.png", "path.png": "path-over-crests.png"}
MAX_BYTES = 200_000


def regenerate(out: Path, keep: Path | None = None) -> dict[str, int]:
    """Run the scenario and copy its figures to ``out``; returns each picture's size in bytes."""
    with tempfile.TemporaryDirectory(prefix="docs-images-") as tmp:
        run_root = keep if keep is not None else Path(tmp) / "run"
        command = [sys.executable, "-m", "mavbridge.cli", "experiment", str(SCENARIO), "--out", str(run_root),
                   "--jobs", "1"]
        print("$ mavbridge experiment", SCENARIO.relative_to(ROOT), "--out", run_root, "--jobs 1", flush=True)
        subprocess.run(command, check=True, cwd=ROOT)
        out.mkdir(parents=True, exist_ok=True)
        sizes = {}
        for source, target in IMAGES.items():
            made = run_root / NAME / source
            size = made.stat().st_size
            if size > MAX_BYTES:
                raise SystemExit(f"{made}: {size} bytes, more than the docs' {MAX_BYTES}")
            shutil.copyfile(made, out / target)
            sizes[target] = size
    return sizes


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "images",
                        help="where the pictures go (default: docs/images)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the whole run in this folder (default: a temporary one, removed)")
    args = parser.parse_args(argv)
    for name, size in regenerate(args.out, args.keep).items():
        print(f"{args.out / name}: {size / 1000:.0f} kB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
