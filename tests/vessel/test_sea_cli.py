"""The `vessel sea` record tool: its CSV, its printed comparison and plot, and one-line errors (exit 2)."""

from __future__ import annotations

import csv
import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vessel.cli import main
from vessel.sea.analysis import hm0
from vessel.sea.irregular_sea import IrregularSea

VESSEL = [sys.executable, "-m", "vessel.cli"]


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([*VESSEL, "sea", *args], capture_output=True, text=True, timeout=120)


def _figures(stdout: str, name: str) -> tuple[float, float]:
    match = re.search(rf"{re.escape(name)}\s+([-\d.]+)\s+([-\d.]+)", stdout)
    assert match, stdout
    return float(match.group(1)), float(match.group(2))


def test_record_csv_figures_and_plot(tmp_path: Path) -> None:
    out = _run("--spectrum", "jonswap", "--hs", "1.75", "--tp", "6", "--gamma", "3.3", "--dir", "-45",
               "--seed", "5", "--duration", "600", "--dt", "0.2", "--north", "30", "--east", "-20",
               "--csv", str(tmp_path / "sea.csv"), "--plot", str(tmp_path / "sea.png"))
    assert out.returncode == 0, out.stderr
    with (tmp_path / "sea.csv").open() as stream:
        rows = list(csv.reader(stream))
    assert rows[0] == ["t_s", "elevation_m", "slope_n_rad", "slope_e_rad"]
    data = np.array(rows[1:], float)
    assert data.shape == (3001, 4) and data[-1, 0] == pytest.approx(600.0)
    expected = IrregularSea(hs_m=1.75, tp_s=6.0, travel_dir_deg=-45.0, seed=5).wave_field()
    np.testing.assert_allclose(data[:, 1], expected.elevation(30.0, -20.0, data[:, 0]), atol=1e-8)
    slope_n, slope_e = expected.slope_angles(30.0, -20.0, data[:, 0])
    np.testing.assert_allclose(data[:, 2:], np.column_stack([slope_n, slope_e]), atol=1e-8)
    assert np.allclose(data[:, 2], data[:, 3] * -1, atol=1e-8)  # towards -45°: slope along (1, -1)/√2
    requested, record = _figures(out.stdout, "Hm0 (m)")
    assert requested == 1.75 and record == pytest.approx(hm0(data[:, 1]), abs=1e-3)
    tp_requested, tp_record = _figures(out.stdout, "Tp (s)")
    assert tp_requested == 6.0 and tp_record == pytest.approx(6.0, rel=0.15)
    assert (tmp_path / "sea.png").stat().st_size > 10_000


def test_sea_state_and_short_crested_sea(tmp_path: Path) -> None:
    out = _run("--sea-state", "4", "--spreading", "10", "--duration", "300", "--csv", str(tmp_path / "s.csv"))
    assert out.returncode == 0, out.stderr
    assert "sea state 4" in out.stdout and "cos-2s spreading s 10" in out.stdout
    requested, _ = _figures(out.stdout, "Hm0 (m)")
    assert requested == pytest.approx(1.875)
    data = np.loadtxt(tmp_path / "s.csv", delimiter=",", skiprows=1)
    assert np.std(data[:, 2]) > 0.1 * np.std(data[:, 3])  # waves spread: slopes north as well as east
    assert math.isclose(_figures(out.stdout, "Tp (s)")[0], 9.0)


def test_sea_state_zero_is_calm(tmp_path: Path) -> None:
    out = _run("--sea-state", "0", "--duration", "60", "--csv", str(tmp_path / "calm.csv"))
    assert out.returncode == 0, out.stderr
    data = np.loadtxt(tmp_path / "calm.csv", delimiter=",", skiprows=1)
    assert not np.any(data[:, 1:])


@pytest.mark.parametrize(("args", "words"), [
    (["--hs", "0"], ["--hs", "(0, 30] m"]),
    (["--hs", "-1"], ["--hs", "(0, 30] m"]),
    (["--hs", "abc"], ["--hs", "not a number", "(0, 30] m"]),
    (["--tp", "0.5"], ["--tp", "[1, 30] s"]),
    (["--tp", "31"], ["--tp", "[1, 30] s"]),
    (["--gamma", "0.5"], ["--gamma", "[1, 10]"]),
    (["--gamma", "12"], ["--gamma", "[1, 10]"]),
    (["--sea-state", "9"], ["--sea-state", "[0, 8]"]),
    (["--sea-state", "-1"], ["--sea-state", "[0, 8]"]),
    (["--sea-state", "4.5"], ["--sea-state", "integer", "[0, 8]"]),
    (["--spreading", "-1"], ["--spreading", ">= 0"]),
    (["--seed", "1.5"], ["--seed", "integer"]),
    (["--seed", "seven"], ["--seed", "integer"]),
    (["--seed", "-3"], ["--seed", "[0, "]),
    (["--components", "5"], ["--components", "[10, 5000]"]),
    (["--depth", "0"], ["--depth", "[0.5, 10000] m"]),
    (["--dir", "inf"], ["--dir", "[-360, 360] deg"]),
    (["--duration", "0"], ["--duration", "(0, 86400] s"]),
    (["--dt", "-0.1"], ["--dt", "(0, 10] s"]),
    (["--dt", "nan"], ["--dt", "(0, 10] s"]),
    (["--duration", "1", "--dt", "0.1"], ["--duration/--dt", "[64, "]),
    (["--spectrum", "ochi"], ["--spectrum", "jonswap", "pm"]),
    (["--hs", "12", "--tp", "3"], ["--hs", "breaks"]),
    (["--sea-state", "1"], ["--tp", "sea state 1", "[1, 30] s"]),
])
def test_bad_input_is_one_line_naming_the_flag_and_exit_code_2(args: list[str], words: list[str],
                                                                tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """In-process through the real entry point (a subprocess per case would only add start-up time)."""
    try:
        code = main(["sea", *args, "--csv", str(tmp_path / "never.csv")])
    except SystemExit as exc:  # argparse's own errors (choices) exit through OneLineParser
        code = exc.code
    stderr = capsys.readouterr().err
    assert code == 2, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    for word in words:
        assert word in lines[0], lines[0]
    assert not (tmp_path / "never.csv").exists()


def test_csv_is_required() -> None:
    out = _run("--hs", "1")
    assert out.returncode == 2 and "--csv" in out.stderr and len(out.stderr.strip().splitlines()) == 1
