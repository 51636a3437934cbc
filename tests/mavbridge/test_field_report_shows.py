"""The report shows what a log holds and nothing it does not: the Otter's controller figures drawn, the sea one
line when the log cannot show one, no tracker figure at its limit, the spectrum saying what of the log it used."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from mavbridge.cli.main import main
from mavbridge.field.figures_log import panels
from mavbridge.field.logs import open_log
from mavbridge.field.sea import sea_line, tracker
from mavbridge.field.spectrum import roll_spectrum
from mavbridge.field.trial import record
from tests.mavbridge.field_logs import HOME, otter_rows, sine_motion, write_otter_csv


def _otter_with_controller(path: Path) -> None:
    rows = otter_rows(sine_motion(40.0, rate_hz=9.0))
    write_otter_csv(path, [rows[0], *(dataclasses.replace(r, extra=(
        ("n1", 500.0), ("n2", 480.0), ("tau_X", 60.0), ("tau_N", -4.0), ("yaw_setpoint", 0.5),
        ("distance_to_target", 7.0), ("observer_lat", HOME[0]), ("observer_lon", HOME[1]),
        ("target_north_from_observer", 30.0), ("target_east_from_observer", -10.0))) for r in rows[1:])])


def test_an_otter_csv_report_draws_what_it_holds_and_says_why_there_is_no_sea(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "otter.csv"
    _otter_with_controller(log)
    reader = open_log(log)
    trial = record(reader.messages(), reader.info)
    assert [name for name, _ in panels(trial)] == ["heading", "speed", "shaft speed (rpm)", "surge force (N)",
                                                   "yaw moment (N·m)", "to target (m)"]
    assert main(["report", str(log), "--out", str(tmp_path / "out")]) == 0
    text = capsys.readouterr().out
    sea = [line for line in text.splitlines() if line.startswith("sea")]
    assert len(sea) == 1 and sea[0].startswith("sea: not shown: the log holds no heave"), text
    assert re.search(r"roll spectrum: peak .*, 2 windows of 32 s over 1 stretch \(t 3\.0-42\.\d s\): 40 s of 40 s$",
                     text, re.M), text
    page = (tmp_path / "out" / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 4  # path, attitude, the log over time, spectrum: no sea panels
    entry = json.loads((tmp_path / "out" / "report.json").read_text())["logs"][0]
    assert entry["sea"]["summary"]["blind"] and entry["spectrum"]["used_s"] == pytest.approx(40.0, abs=0.2)


def test_a_tracker_at_its_limit_gives_no_encounter_period() -> None:
    pinned = tracker(np.r_[np.full(40, 20.74), np.full(10, 6.0)])
    assert "encounter_period_s_median" not in pinned and pinned["encounter_at_limit_fraction"] == 0.8
    line = sea_line({"confident_fraction": 0.0, "solution_fraction": 0.0, "confidence_max": None,
                     "first_confident_s": None, "blind": None, **pinned})
    assert "20.7" not in line and "sat at its limits" in line and "no encounter period" in line
    assert tracker(np.r_[np.full(10, 20.74), np.full(40, 6.0)])["encounter_period_s_median"] == 6.0


def test_the_spectrum_uses_every_stretch_it_can_and_says_why_not_the_rest() -> None:
    """A 277 s log cut by three gaps into stretches of 36, 80, 100 and 55 s: not one window of 36 s."""
    dt = 0.1
    pieces, t0 = [], 0.0
    for length in (36.0, 80.0, 100.0, 55.0):
        pieces.append(np.arange(t0, t0 + length + dt / 2, dt))
        t0 += length + 2.0
    t = np.concatenate(pieces)
    spec = roll_spectrum(t, 3.0 * np.sin(2 * np.pi * 0.8 * t))
    assert spec is not None and spec.window_s == pytest.approx(32.0, abs=0.1)
    assert len(spec.stretches) == 4 and spec.used_s == pytest.approx(271.0, abs=0.5)
    assert spec.peak_hz == pytest.approx(0.8, abs=0.04)
    said = spec.used()
    assert "over 4 stretches" in said and "271 s of 277 s" in said and "3 gaps over 0.5 s" in said, said
    assert re.search(r"\b1 windows\b|\b1 stretches\b", said) is None
