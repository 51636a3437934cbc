"""The `vessel maneuver` command: outputs, and one-line errors with exit code 2 for bad input."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

from vessel import ConfigError, load_parameters

VESSEL = [sys.executable, "-m", "vessel.cli"]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*VESSEL, *args], capture_output=True, text=True, timeout=120)


def test_maneuver_writes_csv_plot_and_figures(tmp_path: Path) -> None:
    out = _run("maneuver", "--left", "70", "--right", "30", "--duration", "2", "--dt", "0.01",
               "--csv", str(tmp_path / "run.csv"), "--plot", str(tmp_path / "run.png"))
    assert out.returncode == 0, out.stderr
    assert "yaw_rate_rad_s" in out.stdout and "turning_radius_m" in out.stdout
    with (tmp_path / "run.csv").open() as stream:
        rows = list(csv.reader(stream))
    assert rows[0] == ["t_s", "north_m", "east_m", "down_m", "roll_rad", "pitch_rad", "yaw_rad", "u_m_s", "v_m_s",
                       "w_m_s", "p_rad_s", "q_rad_s", "r_rad_s", "n1_rad_s", "n2_rad_s"]
    assert len(rows) == 1 + 201  # one row per step from t = 0
    assert float(rows[1][0]) == 0.0 and float(rows[-1][0]) == pytest.approx(2.0)
    assert float(rows[-1][13]) > float(rows[-1][14]) > 0  # left shaft faster than right
    assert (tmp_path / "run.png").stat().st_size > 10_000


def test_roll_decay_preset_prints_period_and_decrement() -> None:
    out = _run("maneuver", "--preset", "roll-decay", "--integrator", "euler", "--dt", "0.01")
    assert out.returncode == 0, out.stderr
    assert "roll_damped_period_s" in out.stdout and "roll_log_decrement" in out.stdout


@pytest.mark.parametrize(("args", "names"), [
    (["--left", "70", "--right", "70", "--duration", "-1"], ["--duration", "(0, 3600]"]),
    (["--left", "70", "--right", "70", "--dt", "0"], ["--dt", "(0, 0.1]"]),
    (["--left", "150", "--right", "70"], ["--left", "[-100, 100]"]),
    (["--left", "70", "--right", "-101"], ["--right", "[-100, 100]"]),
    (["--left", "0", "--right", "0", "--roll-deg", "61"], ["--roll-deg", "[-60, 60]"]),
    (["--left", "0", "--right", "0", "--pitch-deg", "-75"], ["--pitch-deg", "[-60, 60]"]),
    (["--left", "nan", "--right", "0"], ["--left", "finite"]),
    (["--left", "70"], ["--right", "required"]),
    (["--left", "70", "--right", "70", "--integrator", "heun"], ["--integrator"]),
    (["--left", "70", "--right", "70", "--params", "/nonexistent/otter.yaml"], ["/nonexistent/otter.yaml",
                                                                               "cannot read"]),
])
def test_bad_input_is_one_line_and_exit_code_2(args: list[str], names: list[str]) -> None:
    out = _run("maneuver", *args)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert "Traceback" not in out.stderr
    for name in names:
        assert name in lines[0]


@pytest.mark.parametrize(("text", "names"), [
    ("hull_mass: -3\n", ["hull_mass", "[1, 1000] kg"]),
    ("hull_mass: .nan\n", ["hull_mass", "[1, 1000] kg"]),
    ("hull_masss: 50\n", ["unknown key 'hull_masss'"]),
    ("base: heavy\n", ["base", "published, corrected"]),
    ("payload_position: [0, 0]\n", ["payload_position", "3 numbers"]),
    ("munk_moment: 3\n", ["munk_moment", "true or false"]),
    ("hull_mass: [55\n", ["not valid YAML"]),
    ("- 1\n- 2\n", ["mapping"]),
])
def test_parameter_file_errors_name_the_field(tmp_path: Path, text: str, names: list[str]) -> None:
    path = tmp_path / "otter.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_parameters(path)
    message = str(info.value)
    assert str(path) in message and "\n" not in message
    for name in names:
        assert name in message
    out = _run("maneuver", "--left", "1", "--right", "1", "--duration", "0.1", "--params", str(path))
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1


def test_parameter_file_overrides_a_base_set(tmp_path: Path) -> None:
    path = tmp_path / "otter.yaml"
    path.write_text("base: corrected\npayload_mass: 10\n")
    params = load_parameters(path)
    assert params.payload_mass == 10 and params.payload_load_term is False
    assert params.matrices().m_total == pytest.approx(65.0)
