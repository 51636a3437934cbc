"""``mavbridge experiment``: files per run, the comparison table, and one-line errors with exit code 2."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from mavbridge.cli import main
from mavbridge.lab.runlog import LOG_COLUMNS
from mavbridge.lab.scenario import load_scenarios

TINY = {
    "name": "tiny",
    "sea": {"height_m": 1.0, "length_m": 30.0, "period_s": 5.0, "travel_dir_deg": -90.0},
    "start": {"heading_deg": 90.0, "surge_mps": 1.0},
    "waypoint": {"north_m": 0.0, "east_m": 30.0},
    "t_max_s": 2.0,
    "controller": {"q": 5, "r": 500, "s": 2, "horizon": 5},
}


def _tiny(tmp_path: Path, data: dict = TINY, name: str = "tiny.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return path


def test_experiment_writes_the_run_folder(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "out"
    assert main(["experiment", str(_tiny(tmp_path)), "--out", str(out), "--jobs", "1"]) == 0
    run = out / "tiny"
    for name in ("timeseries.csv", "metrics.json", "scenario.yaml", "path.png", "timeseries.png"):
        assert (run / name).stat().st_size > 0, name
    metrics = json.loads((run / "metrics.json").read_text())
    for key in ("avg_roll_deg", "max_roll_deg", "time_to_waypoint_s", "solve_ms_median", "solve_ms_p95",
                "solve_ms_max", "overruns", "failures"):
        assert key in metrics
    assert metrics["time_to_waypoint_s"] is None  # 2 s is too short to get there
    assert metrics["steps"] == 20
    with (run / "timeseries.csv").open() as handle:
        rows = list(csv.reader(handle))
    assert tuple(rows[0]) == LOG_COLUMNS
    assert len(rows) == 1 + 20 + 1  # header, one row per control period, the final state
    assert float(rows[-1][0]) == pytest.approx(2.0)
    (resolved,) = load_scenarios(run / "scenario.yaml")
    (original,) = load_scenarios(tmp_path / "tiny.yaml")
    assert resolved == original
    printed = capsys.readouterr().out
    assert "[tiny] done" in printed and "| tiny |" in printed


def test_experiment_set_runs_in_parallel_and_writes_table(tmp_path: Path) -> None:
    data = {"base": {**TINY, "t_max_s": 1.0},
            "runs": {"direct": {"controller": {"r": 0}, "reference": {"avg_roll_deg": 4.0}},
                     "rolly": {"controller": {"r": 1500}, "reference": {"avg_roll_deg": 2.0}}}}
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, "-m", "mavbridge.cli", "experiment", str(_tiny(tmp_path, data)),
                             "--out", str(out), "--jobs", "2"], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    table = (out / "table3.md").read_text()
    assert "| direct |" in table and "| rolly |" in table and "/ -50 %" in table
    assert (out / "direct" / "metrics.json").exists() and (out / "rolly" / "metrics.json").exists()


@pytest.mark.parametrize("args", [
    ["experiment", "does-not-exist.yaml"],
    ["experiment", "{tiny}", "--jobs", "0"],
    ["experiment", "{tiny}", "--jobs", "many"],
    ["experiment", "{tiny}", "--only", "nobody"],
    ["experiment", "{bad}"],
    ["fly"],
])
def test_bad_input_exits_2_with_one_line(tmp_path: Path, capsys: pytest.CaptureFixture, args: list[str]) -> None:
    tiny = _tiny(tmp_path)
    bad = _tiny(tmp_path, {**TINY, "controller": {"horizon": 0}}, "bad.yaml")
    args = [a.replace("{tiny}", str(tiny)).replace("{bad}", str(bad)) for a in args]
    with pytest.raises(SystemExit) as info:
        raise SystemExit(main(args))
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mavbridge"), err
    assert "Traceback" not in err


def test_a_bare_mavbridge_prints_its_usage_and_commands_and_exits_2(capsys: pytest.CaptureFixture) -> None:
    with pytest.raises(SystemExit) as info:
        raise SystemExit(main([]))
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.startswith("usage: mavbridge") and "experiment" in err
    assert "Traceback" not in err


def test_console_script_bad_file_has_no_traceback(tmp_path: Path) -> None:
    bad = _tiny(tmp_path, {**TINY, "waypoint": {"north_m": 0.0, "east_m": 1.0}}, "bad.yaml")
    result = subprocess.run([sys.executable, "-m", "mavbridge.cli", "experiment", str(bad)],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "waypoint" in result.stderr and "bad.yaml" in result.stderr
    assert not (tmp_path / "runs").exists()


def test_solver_and_plant_overrides_are_recorded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MAVBRIDGE_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "out"
    args = ["experiment", str(_tiny(tmp_path)), "--out", str(out), "--jobs", "1", "--solver", "rti",
            "--plant", "propellers"]
    assert main(args) == 0
    (resolved,) = load_scenarios(out / "tiny" / "scenario.yaml")
    assert resolved.controller.solver == "rti" and resolved.plant == "propellers"
    metrics = json.loads((out / "tiny" / "metrics.json").read_text())
    assert metrics["solver"] == "rti" and metrics["plant"] == "propellers" and metrics["failures"] == 0
    with (out / "tiny" / "timeseries.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert rows[5]["n1_rad_s"] != "" and rows[5]["status"].startswith("RTI")


def test_deadline_misses_are_counted_and_answered(tmp_path: Path) -> None:
    from mavbridge.lab.experiment import run_scenario
    from mavbridge.lab.scenario import scenario_from_mapping

    scenario = scenario_from_mapping({**TINY, "t_max_s": 1.0, "deadline_s": 1e-4}, "test")
    result = run_scenario(scenario, tmp_path / "late", plots=False)
    m = result.metrics
    assert m["late"] == m["steps"] == 10 and m["failures"] == 0
    with (tmp_path / "late" / "timeseries.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert rows[0]["fallback"] == "safe" and rows[1]["fallback"] == "previous_plan"
    assert all(row["tau_x_n"] not in ("nan", "") for row in rows[:-1])
