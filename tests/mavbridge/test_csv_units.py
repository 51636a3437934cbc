"""Every CSV the project writes names the unit in each column (issue 17 item 12c): ``north_m``, ``roll_rad``.

The headers are read from files written by the real writers (the commands for the vessel CLI). A column
without a unit suffix must be listed in UNITLESS with what it holds, so a new unitless column is a choice,
not an accident.
"""

from __future__ import annotations

import csv
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mavbridge.lab.runlog import write_csv as write_run_csv
from mavbridge.sweep.spec import load_spec
from mavbridge.sweep.summary import METRIC_COLUMNS, case_rows
from mavbridge.sweep.summary import write_csv as write_sweep_csv
from sim_vehicle.json_backend.log import JsonStateCsv
from sim_vehicle.logs import StateCsv
from vessel import CalmWater

# SI (and deg at the edge; µs for PWM), then perhaps a statistic: solve_ms_p99
UNIT = re.compile(r"_(s|ms|us|m|m_s|rad|rad_s|deg|n|nm|frac)(_(median|mean|max|min|p\d\d))?$")
UNITLESS = {
    "phase": "text: the companion's phase", "status": "text: the solver's status",
    "fallback": "text: where a fallback input came from", "fallback_reason": "text: why",
    "sent": "flag: 1 when the command went out", "iterations": "count: SQP iterations",
    "wave_confidence": "fraction in [0, 1]", "mode": "Rover's mode number", "armed": "flag: 1 armed",
    "run": "count: firmware runs", "frame_count": "count: the firmware's frame counter",
    "case_id": "text: the case's hash", "failures": "count: steps with no usable plan",
    "roll_reduction": "fraction: 1 - avg roll / the reference's",
    "wave_bank_on": "flag: 1 while the NMPC plans on the phase predictor's bank",
}
ROOT = Path(__file__).resolve().parents[2]


def _header(path: Path) -> list[str]:
    with path.open(newline="") as stream:
        return next(csv.reader(stream))


def _without_unit(columns: list[str]) -> list[str]:
    return [name for name in columns if not UNIT.search(name) and name not in UNITLESS]


def _vessel(tmp_path: Path, *args: str) -> Path:
    out = tmp_path / "out.csv"
    done = subprocess.run([sys.executable, "-m", "vessel.cli", *args, "--csv", str(out)], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return out


def _state_csv(tmp_path: Path) -> Path:
    StateCsv(tmp_path / "state.csv").close()
    return tmp_path / "state.csv"


def _json_backend_csv(tmp_path: Path) -> Path:
    JsonStateCsv(tmp_path / "state.csv", CalmWater()).close()
    return tmp_path / "state.csv"


def _run_csv(tmp_path: Path) -> Path:
    write_run_csv(tmp_path / "companion.csv", [])  # companion.csv and timeseries.csv: one writer, one header
    return tmp_path / "companion.csv"


def _sweep_csv(tmp_path: Path) -> Path:
    spec = load_spec(ROOT / "scenarios" / "sweep-example.yaml")
    metrics = {name: 1.0 for name in METRIC_COLUMNS}
    results = {case.case_id: {"metrics": metrics} for case in spec.cases}
    rows = case_rows(spec, results)
    write_sweep_csv(tmp_path / "summary.csv", rows)
    assert rows and set(spec.axes) <= set(rows[0])
    return tmp_path / "summary.csv"


WRITERS = {
    "vessel maneuver --csv": lambda tmp: _vessel(tmp, "maneuver", "--left", "50", "--right", "50",
                                                 "--duration", "0.1"),
    "vessel sea --csv": lambda tmp: _vessel(tmp, "sea", "--duration", "10", "--dt", "0.1"),
    "sim-vehicle state.csv": _state_csv,
    "sim-vehicle --json-backend state.csv": _json_backend_csv,
    "companion.csv / timeseries.csv": _run_csv,
    "sweep summary.csv": _sweep_csv,
}


@pytest.mark.parametrize("name", list(WRITERS))
def test_every_column_names_its_unit(name: str, tmp_path: Path) -> None:
    columns = _header(WRITERS[name](tmp_path))
    if name == "sweep summary.csv":  # the axes are the scenario's own field paths (units in their names there)
        columns = [c for c in columns if "." not in c]
    assert columns and not _without_unit(columns), f"{name}: no unit in {_without_unit(columns)}"


def test_the_maneuver_csv_uses_the_simulators_names(tmp_path: Path) -> None:
    """One name per quantity in every file: the maneuver's states are named as in state.csv."""
    maneuver = _header(WRITERS["vessel maneuver --csv"](tmp_path))
    state = _header(_state_csv(tmp_path))
    assert maneuver == state[:len(maneuver)] and maneuver[:2] == ["t_s", "north_m"]
    data = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)
    assert data.shape[1] == len(maneuver)
