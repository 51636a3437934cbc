"""Nothing logged is lost (issue 17): a second run into the folder of a first goes to a new numbered folder,
says which, and leaves every file of the first run byte for byte as it was. Real processes throughout."""

from __future__ import annotations

import socket
import subprocess
import sys
from pathlib import Path

import pytest

from sim_vehicle.harness import SimProcess, free_port, sim_vehicle_command

HOME = "--home=-35.363261,149.165230,584,90"
pytestmark = pytest.mark.slow


def _snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (relative path -> contents)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _sim(log_dir: Path, workdir: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*sim_vehicle_command(), "--tcp", str(free_port()), "--no-out", "--sea", "paper",
                           "--speedup", "10", "--duration", "3", "--log-dir", str(log_dir), "--params-store",
                           str(workdir / "params.json"), "--seed", "0"], capture_output=True, text=True, timeout=120)


def test_sim_vehicle_log_dir_is_never_overwritten(tmp_path: Path) -> None:
    logs = tmp_path / "logs"
    first = _sim(logs, tmp_path)
    assert first.returncode == 0, first.stderr
    before = _snapshot(logs)
    assert {"state.csv", "sim_vehicle.tlog"} <= set(before) and len(before["state.csv"]) > 1000
    second = _sim(logs, tmp_path)
    assert second.returncode == 0, second.stderr
    assert f"--log-dir: {logs} already holds a run; writing this one to {logs}-2 instead" in second.stderr
    assert _snapshot(logs) == before
    assert len((tmp_path / "logs-2" / "state.csv").read_bytes()) > 1000


def test_sim_vehicle_log_dir_that_is_a_file_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "a-file"
    path.write_text("keep me\n")
    done = _sim(path, tmp_path)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "--log-dir" in done.stderr, done.stderr
    assert path.read_text() == "keep me\n"


def test_companion_run_folder_is_never_overwritten(tmp_path: Path) -> None:
    """A first (shadow) run against the simulator, then a second `--out` the same folder that finds no autopilot."""
    out = tmp_path / "run"
    with SimProcess(tmp_path / "sim", speedup=5, waves="calm", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        first = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--connect",
                                f"udpin:127.0.0.1:{sim.udp_ports[0]}", "--dry-run", "--waypoint", "85,75",
                                "--max-time", "12", "--out", str(out)], capture_output=True, text=True, timeout=180)
    assert first.returncode == 0, first.stdout[-2000:] + first.stderr
    assert "phase: shadow (dry run: planning, sending nothing)" in first.stdout  # not "engaged": nothing is sent
    assert "phase: engaged" not in first.stdout
    assert [line for line in first.stdout.splitlines() if " m to go, max roll so far " in line], first.stdout
    before = _snapshot(out)
    assert {"companion.csv", "companion.tlog", "metrics.json", "config.yaml"} <= set(before)
    assert len(before["companion.csv"]) > 1000
    config = tmp_path / "impatient.yaml"
    config.write_text("connect_timeout_s: 0.5\n")
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        silent = s.getsockname()[1]
    second = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--config", str(config), "--connect",
                             f"udpin:127.0.0.1:{silent}", "--out", str(out)], capture_output=True, text=True,
                            timeout=180)
    assert second.returncode == 1, second.stdout + second.stderr  # no autopilot answered
    assert f"--out: {out} already holds a run; writing this one to {out}-2 instead" in second.stdout
    assert _snapshot(out) == before
    assert (tmp_path / "run-2" / "metrics.json").exists()


def test_experiment_out_is_never_overwritten(tmp_path: Path) -> None:
    out = tmp_path / "exp"
    cmd = [sys.executable, "-m", "mavbridge.cli", "experiment", "scenarios/calm_short.yaml", "--solver", "asrti",
           "--jobs", "1", "--out", str(out)]
    repo = Path(__file__).resolve().parents[2]
    first = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=repo)
    assert first.returncode == 0, first.stderr
    before = _snapshot(out)
    assert any(name.endswith("metrics.json") for name in before)
    second = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=repo)
    assert second.returncode == 0, second.stderr
    assert f"writing this one to {out}-2 instead" in second.stdout
    assert _snapshot(out) == before
    assert _snapshot(tmp_path / "exp-2").keys() == before.keys()
