"""mavbridge sweep: spec validation, executors that agree bit for bit, resuming an interrupted sweep."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mavbridge.cli import main
from mavbridge.sweep import load_spec, open_executor, run_sweep
from mavbridge.sweep.runner import deterministic_metrics

ROOT = Path(__file__).resolve().parents[2]
CALM = ROOT / "scenarios" / "calm_short.yaml"
WAIT_S = 120.0


def _spec(tmp_path: Path, body: str, name: str = "spec.yaml") -> Path:
    path = tmp_path / name
    path.write_text(f"base: {CALM}\n{body}", encoding="utf-8")
    return path


@pytest.mark.parametrize(("body", "named"), [
    ("axes: {controller.qq: [1, 2]}\n", "controller.qq"),
    ("axes: {controller.q: []}\n", "axes.controller.q: empty axis"),
    ("axes: {controller.q: {start: 1, stop: 5, step: 0}}\n", "step must be non-zero"),
    ("axes: {controller.q: [1, -3]}\n", "controller.q"),
    ("axes: {controller.q: {start: 0, stop: 99999, step: 1}, controller.s: [1, 2]}\n", "--yes"),
    ("axes: {controller.q: [1]}\nsample: {mode: lhs}\n", "sample.size"),
    ("axis: {controller.q: [1]}\n", "unknown key 'axis'"),
])
def test_bad_specs_are_one_line_and_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture, body: str,
                                           named: str) -> None:
    """Each bad spec names the field, exits 2, and runs no case (no output folder appears)."""
    out = tmp_path / "out"
    code = main(["sweep", str(_spec(tmp_path, body)), "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and named in err and len(err.splitlines()) == 1, err
    assert not out.exists()


def test_unreachable_scheduler_and_bad_executor_flag(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    """A scheduler nobody runs is one line naming --executor, exit 2, before any case runs."""
    spec = _spec(tmp_path, "axes: {controller.q: [5]}\n")
    code = main(["sweep", str(spec), "--executor", "tcp://127.0.0.1:9", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and "--executor" in err and "127.0.0.1:9" in err
    assert not (tmp_path / "o" / "cases").exists() or not any((tmp_path / "o" / "cases").iterdir())
    with pytest.raises(SystemExit) as exc:
        main(["sweep", str(spec), "--executor", "dask-cloud"])
    assert exc.value.code == 2


def test_grid_random_and_lhs_expand_as_asked(tmp_path: Path) -> None:
    """A 3 x 2 grid gives 6 distinct cases; LHS of size 4 covers each stratum of a 4-value axis once."""
    grid = load_spec(_spec(tmp_path, "axes: {controller.q: {start: 1, stop: 5, step: 2}, controller.s: [1, 2]}\n"))
    assert [c.values["controller.q"] for c in grid.cases] == [1, 1, 3, 3, 5, 5]
    assert len({c.case_id for c in grid.cases}) == 6
    lhs = load_spec(_spec(tmp_path, "axes: {controller.q: [1, 2, 3, 4]}\nsample: {mode: lhs, size: 4, seed: 3}\n",
                          "lhs.yaml"))
    assert sorted(c.values["controller.q"] for c in lhs.cases) == [1, 2, 3, 4]
    again = load_spec(_spec(tmp_path, "axes: {controller.q: [1, 2, 3, 4]}\nsample: {mode: random, size: 5}\n",
                            "r.yaml"))
    assert len(again.cases) == 5


def _results(spec_path: Path, executor: str, out: Path) -> dict[str, dict]:
    spec = load_spec(spec_path)
    with open_executor(executor, 2) as pool:
        outcome = run_sweep(spec, pool, out, say=lambda line: None)
    assert not outcome.failed and outcome.remaining == 0, outcome.failed
    return {cid: deterministic_metrics(r["metrics"]) for cid, r in outcome.results.items()}


def _wait_for_file(path: Path, what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not path.exists():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what}: {path} did not appear within {WAIT_S:.0f} s")
        time.sleep(0.1)


@pytest.fixture
def dask_scheduler(tmp_path: Path):
    """A real `dask scheduler` and one `dask worker` process on loopback; yields the scheduler address."""
    dask = Path(sys.executable).with_name("dask")
    info = tmp_path / "scheduler.json"
    common = ["--no-dashboard"]
    sched = subprocess.Popen([str(dask), "scheduler", "--host", "127.0.0.1", "--port", "0",
                              "--scheduler-file", str(info), *common],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    worker = None
    try:
        _wait_for_file(info, "dask scheduler")
        address = json.loads(info.read_text())["address"]
        worker = subprocess.Popen([str(dask), "worker", address, "--nthreads", "1", "--nworkers", "1", *common],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                  env={**os.environ, "OMP_NUM_THREADS": "1"})
        import distributed

        with distributed.Client(address, timeout=WAIT_S) as client:
            client.wait_for_workers(1, timeout=WAIT_S)
        yield address
    finally:
        for proc in (worker, sched):
            if proc is not None:
                proc.terminate()
                proc.wait(timeout=30)


@pytest.mark.integration
def test_local_dask_local_and_scheduler_agree_bit_for_bit(tmp_path: Path, dask_scheduler: str) -> None:
    """The same cases give identical metrics on a process pool, a LocalCluster and a scheduler + worker."""
    spec = _spec(tmp_path, "axes: {controller.q: [3, 5], controller.r: [0, 40], controller.solver: [nrti]}\n")
    local = _results(spec, "local", tmp_path / "local")
    dask_local = _results(spec, "dask-local:2", tmp_path / "dask-local")
    remote = _results(spec, dask_scheduler, tmp_path / "remote")
    assert len(local) == 4  # 4 cases; their R = 0 references are among them
    assert local == dask_local == remote


@pytest.mark.integration
def test_interrupted_sweep_resumes_with_only_the_missing_cases(tmp_path: Path) -> None:
    """SIGTERM after the first case: exit 130 naming what remains; the rerun keeps finished files as they were."""
    spec = _spec(tmp_path, "axes: {controller.q: [2, 3, 4, 5, 6], controller.solver: [nrti]}\n")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "mavbridge.cli", "sweep", str(spec), "--jobs", "1", "--out", str(out)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    cases = out / "cases"
    deadline = time.monotonic() + WAIT_S
    while not (cases.exists() and any(cases.glob("*.json"))):
        if time.monotonic() > deadline or proc.poll() is not None:
            proc.kill()
            raise TimeoutError(f"no case finished within {WAIT_S:.0f} s (exit {proc.poll()})")
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=WAIT_S)
    first = {p.name: p.read_bytes() for p in cases.glob("*.json")}
    assert proc.returncode == 130 and "remain" in err, err
    assert 1 <= len(first) < 5
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=WAIT_S * 2)
    assert again.returncode == 0, again.stderr
    assert f"{len(first)} case{'' if len(first) == 1 else 's'} already done" in again.stderr  # (1 case, 2 cases)
    assert {p.name: p.read_bytes() for p in cases.glob("*.json") if p.name in first} == first
    assert len(list(cases.glob("*.json"))) == 5


SHORT_WAVY = """name: short_wavy
sea: {height_m: 1.75, length_m: 35.0, period_s: 6.0, travel_dir_deg: -90.0}
start: {heading_deg: 90.0}
waypoint: {north_m: 25.0, east_m: 12.0, acceptance_radius_m: 2.0}
t_max_s: 60.0
controller: {q: 5, r: 0, s: 2, horizon: 20, solver: nrti}
"""


@pytest.mark.parametrize(("flags", "named"), [
    ([], "--min-reduction / --max-time"),
    (["--min-reduction", "1.5"], "--min-reduction"),
    (["--min-reduction", "nan"], "--min-reduction"),
    (["--max-time", "-3"], "--max-time"),
    (["--max-time", "60", "--headings", "90,x"], "--headings"),
])
def test_tune_bad_flags_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture, flags: list[str],
                                     named: str) -> None:
    """tune refuses a missing or out-of-range target before any run."""
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SHORT_WAVY, encoding="utf-8")
    code = main(["tune", str(scenario), "--out", str(tmp_path / "o"), *flags])
    err = capsys.readouterr().err.strip()
    assert code == 2 and named in err and len(err.splitlines()) == 1, err
    assert not (tmp_path / "o").exists()


@pytest.mark.integration
def test_tune_finds_weights_that_meet_the_target_and_reruns_them(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture) -> None:
    """On a short mission in the paper's sea: chosen weights cut roll by >= 15 %, arrive, and are re-run."""
    scenario = tmp_path / "s.yaml"
    scenario.write_text(SHORT_WAVY, encoding="utf-8")
    out = tmp_path / "tune"
    code = main(["tune", str(scenario), "--min-reduction", "0.15", "--jobs", "2", "--out", str(out),
                 "--headings", "90,60"])
    text = capsys.readouterr().out
    assert code == 0, text
    chosen = next(line for line in text.splitlines() if line.startswith("Chosen:"))
    reduction = float(chosen.split("(")[1].split(" %")[0])
    assert reduction >= 15, chosen
    assert "| 90 |" in text and "| 60 |" in text  # the robustness re-runs
    assert "| robustness" not in text  # ... in their own table, not among the trials (each has its own Direct)
    assert (out / "tune.md").read_text(encoding="utf-8") == text


@pytest.mark.integration
def test_cases_equal_but_for_the_sea_seed_both_run_on_dask(tmp_path: Path) -> None:
    """Two irregular-sea cases that differ only in the seed are two runs (Dask's pure default would merge them)."""
    spec = tmp_path / "seeds.yaml"
    spectrum = "{kind: jonswap, hs_m: 0.3, tp_s: 4.0, n_components: 20}"
    spec.write_text(f"base: {CALM}\naxes:\n  sea.spectrum: [{spectrum}]\n  sea.spectrum.seed: [1, 2]\n"
                    "  controller.r: [0]\n  controller.solver: [nrti]\n", encoding="utf-8")
    sweep = load_spec(spec)
    assert len({c.case_id for c in sweep.cases}) == 2
    with open_executor("dask-local:2") as pool:
        outcome = run_sweep(sweep, pool, tmp_path / "out", say=lambda line: None)
    assert outcome.ran == 2 and not outcome.failed, outcome.failed
    rolls = {r["metrics"]["avg_roll_deg"] for r in outcome.results.values()}
    assert len(rolls) == 2  # two different seas, two different runs
