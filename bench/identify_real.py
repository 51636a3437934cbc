"""Benchmark: the real Otter's API logs identified per day, and the demo flown on each identified boat.

Run: OMP_NUM_THREADS=1 python bench/identify_real.py LOGDIR [--keep DIR]

LOGDIR holds the Otter API's CSV logs (public repository LSJohnsen/Otter-USV, `Otter API/logs/*.csv`; read them
from a local copy, never commit them). Per day (the date in each log's own start): `mavbridge identify` on that
day's logs (its per-log figures are in identify.json's ``per_log``); then the demo's scenario (scenarios/balanced
.yaml: the paper's sea, waypoint and weights) in-process on a simulated hull that is that day's identified boat
(``vessel:`` its vessel.yaml), with the estimation the demo has (heading_limit.yaml's: the estimate, hidden phase,
heave, default sensors, a 30 s watch, nrti, sea seed 1), once with ``controller.model`` published and once with the
identified vessel.yaml, and Direct (R = 0, the identified model) as the reference of the cuts.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from collections import defaultdict
from pathlib import Path
from typing import Any

import yaml

from mavbridge.lab.experiment import run_scenario
from mavbridge.lab.scenario import load_scenarios

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ("roll_period_s", "roll_damping_ratio", "surge_speed_full_forward_m_s", "yaw_nomoto_gain",
           "yaw_nomoto_time_constant_s")


def by_day(folder: Path) -> dict[str, list[Path]]:
    """The CSV logs by the day their file name starts with (YYYY-MM-DD)."""
    days: dict[str, list[Path]] = defaultdict(list)
    for path in sorted(folder.glob("*.csv")):
        days[path.name[:10]].append(path)
    return dict(days)


def identify_day(day: str, logs: list[Path], out: Path) -> dict[str, Any] | None:
    """`mavbridge identify` on one day's logs; its JSON (None when the day identifies nothing)."""
    done = subprocess.run([sys.executable, "-m", "mavbridge.cli", "identify", *map(str, logs), "--out", str(out)],
                          capture_output=True, text=True, timeout=1200)
    (out.parent / f"{day}.log").write_text(done.stdout + done.stderr)
    if done.returncode != 0:
        print(f"{day}: identify exit {done.returncode}: {done.stderr.strip()[-300:]}", flush=True)
        return None
    return json.loads((out / "identify.json").read_text())


def scenario(folder: Path, name: str, hull: str, model: str, direct: bool) -> Any:
    """balanced.yaml's world and mission with heading_limit.yaml's estimation, on ``hull`` with ``model``."""
    demo = yaml.safe_load((ROOT / "scenarios" / "balanced.yaml").read_text())
    realistic = yaml.safe_load((ROOT / "scenarios" / "heading_limit.yaml").read_text())["base"]
    data = {key: demo[key] for key in ("sea", "start", "waypoint", "plant")}
    data.update({"name": name, "vessel": hull, "t_max_s": realistic["t_max_s"],
                 "controller": {**realistic["controller"], "r": 0 if direct else demo["controller"]["r"],
                                "model": model},
                 "estimation": {**realistic["estimation"], "seed": 1}})
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return load_scenarios(path)[0]


def fly_day(folder: Path, identified: Path) -> dict[str, dict[str, Any]]:
    """Direct (identified model), Balanced with the published model and with the identified one."""
    hull = str(identified.resolve())
    runs = {"direct": ("direct", hull, True), "published": ("balanced-published", "published", False),
            "identified": ("balanced-identified", hull, False)}
    return {label: run_scenario(scenario(folder, name, hull, model, direct), None, plots=False).metrics
            for label, (name, model, direct) in runs.items()}


def cell(data: dict[str, Any], name: str) -> str:
    """value [low, high] of one figure, or a dash."""
    got = data.get(name)
    return f"{got['value']:.3g} [{got['low']:.3g}, {got['high']:.3g}]" if got else "—"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("logs", type=Path, help="folder of the Otter API CSV logs")
    p.add_argument("--keep", type=Path, help="write the outputs under this (new) folder")
    args = p.parse_args()
    root = args.keep or Path(tempfile.mkdtemp(prefix="identify-real-"))
    root.mkdir(parents=True, exist_ok=True)
    print("day | logs | " + " | ".join(FIGURES))
    days = {}
    for day, logs in by_day(args.logs).items():
        data = identify_day(day, logs, root / day)
        if data is None:
            continue
        days[day] = data
        print(f"{day} | {len(logs)} | " + " | ".join(cell(data, name) for name in FIGURES), flush=True)
        print(f"    vessel.yaml: {data['vessel_fields']}", flush=True)
    print("\nthe demo on each identified boat (avg roll deg, max roll deg, arrival s; cut % against Direct)")
    for day in days:
        runs = fly_day(root / day, root / day / "vessel.yaml")
        direct = runs["direct"]["avg_roll_deg"]
        for label in ("direct", "published", "identified"):
            m = runs[label]
            cut = "" if label == "direct" else f"  cut {100 * (1 - m['avg_roll_deg'] / direct):5.1f} %"
            what = "Direct, identified model" if label == "direct" else f"Balanced, {label} model"
            print(f"{day} {what:>27}: {m['avg_roll_deg']:.3f} {m['max_roll_deg']:.2f} "
                  f"{m.get('time_to_waypoint_s')}{cut}", flush=True)
    print(f"(outputs in {root})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
