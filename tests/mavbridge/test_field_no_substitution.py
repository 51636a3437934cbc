"""No reader puts a number of its own where the log has none: a spreadsheet's dates read back in both forms,
cells that cannot be read left out and counted per column, repeats and placeholders not taken for data — each
on a file the test writes."""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mav

from mavbridge.field.logs import open_log
from mavbridge.field.otter_cells import Column, readings
from mavbridge.field.report import whole_log
from mavbridge.field.trial import record
from tests.mavbridge.field_logs import (
    HOME,
    otter_rows,
    sine_motion,
    spreadsheet_date,
    write_dataflash,
    write_otter_csv,
    write_tlog,
)
from vessel.geo import latlon_from_ned, ned_from_latlon


def _rms(values: list[float]) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def test_each_date_form_has_its_readings() -> None:
    assert readings("jan.45") == (1.45,)
    assert readings("-mar.5") == (-3.5,)
    assert readings("04.feb") == (4.2, 4.02)
    assert readings("03.des") == (3.12,)
    assert readings("12.dec") == readings("12.des") == (12.12,)
    assert readings("07.may") == readings("07.mai") == (7.5, 7.05)
    assert readings("02.oct") == (2.1,)
    assert readings("#VERDI!") == readings("") == readings("nan") == readings("04.foo") == ()
    assert spreadsheet_date("4.2") == spreadsheet_date("4.02") == "04.feb"  # what the spreadsheet does
    assert spreadsheet_date("1.45") == "jan.45" and spreadsheet_date("30.2") is None


@pytest.mark.parametrize(("cells", "expected"), [
    (["3.0", "03.feb", "3.04"], 3.02),  # the neighbours say 3.02
    (["3.15", "03.feb", "3.25"], 3.2),
    (["3.11", "03.feb", "3.11"], math.nan),  # half way between 3.02 and 3.2: not decided, left out
    (["03.feb"], math.nan),  # no neighbour
])
def test_a_day_month_date_is_read_by_its_neighbours_or_left_out(cells: list[str], expected: float) -> None:
    column = Column("current_orientation_2")
    for text in cells:
        column.add(text)
    column.decide(np.arange(len(cells)) * 0.1)
    middle = column.values[len(cells) // 2]
    assert (math.isnan(middle) and math.isnan(expected)) or middle == pytest.approx(expected, abs=1e-12)
    assert column.counts["unreadable"] == (1 if math.isnan(expected) else 0)


def test_pitch_rms_from_a_file_with_both_date_forms_is_the_truth(tmp_path: Path) -> None:
    """A 4° pitch: many values a spreadsheet turns into day.month dates (some of them d.0m) and month.year ones."""
    rows = otter_rows(sine_motion(120.0, rate_hz=9.0, pitch_deg=4.0, period_s=5.3))
    path = tmp_path / "spreadsheet.csv"
    write_otter_csv(path, rows, spreadsheet=True)
    pitch_cells = [line.split(";")[13] for line in path.read_text().splitlines()[1:]]
    day_forms = [c for c in pitch_cells if re.fullmatch(r"\d\d\.[a-z]{3}", c)]
    assert len(day_forms) > 10 and any(re.fullmatch(r"[a-z]{3}\.\d\d", c) for c in pitch_cells)
    assert any(r.attitude_deg[1] % 1 < 0.1 and spreadsheet_date(repr(r.attitude_deg[1])) for r in rows)  # d.0m
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    truth = [r.attitude_deg[1] for r in rows[1:]]  # every row but the placeholder is a fresh sample here
    assert trial.attitude.shape[0] == len(truth)
    np.testing.assert_allclose(np.degrees(trial.attitude[:, 2]), truth, atol=1e-9)
    assert whole_log(trial)["pitch_rms_deg"] == round(_rms(truth), 4)
    assert not any("unreadable, left out" in note for note in reader.info.notes)


def test_unreadable_cells_are_left_out_and_counted_per_column(tmp_path: Path) -> None:
    rows = otter_rows(sine_motion(30.0, rate_hz=9.0, pitch_deg=3.0))
    path = tmp_path / "damaged.csv"
    write_otter_csv(path, rows)
    lines = path.read_text().splitlines()
    damaged = {40: (13, "#VERDI!"), 80: (13, "#VERDI!"), 120: (13, "x"), 160: (15, "abc")}  # line: (cell, text)
    for line, (cell, text) in damaged.items():
        cells = lines[line].split(";")
        cells[cell] = text
        lines[line] = ";".join(cells)
    path.write_text("\n".join(lines) + "\n")
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    notes = reader.info.notes
    assert "pitch: 3 cells unreadable, left out (e.g. '#VERDI!')" in notes
    assert "roll rate: 1 cell unreadable, left out (e.g. 'abc')" in notes
    assert any(n.startswith("4 rows whose attitude or rates could not all be read") for n in notes)
    kept = [r.attitude_deg[1] for i, r in enumerate(rows) if i and i + 1 not in damaged]  # line i + 1 is row i
    np.testing.assert_allclose(np.degrees(trial.attitude[:, 2]), kept, atol=1e-9)  # no 0.0 stands in
    assert whole_log(trial)["pitch_rms_deg"] == round(_rms(kept), 4)


def test_a_repeated_position_is_no_fix_and_its_zero_speed_no_speed(tmp_path: Path) -> None:
    """The API repeats the last position with a speed of 0.0 when the GPS has not updated."""
    rows = otter_rows(sine_motion(20.0, rate_hz=9.0, speed_m_s=1.5))
    stale = [dataclasses.replace(r, lat=rows[i - 1].lat, lon=rows[i - 1].lon, speed=0.0) if i > 1 and i % 2 else r
             for i, r in enumerate(rows)]
    path = tmp_path / "stale.csv"
    write_otter_csv(path, stale)
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    repeats = sum(1 for i in range(2, len(rows)) if i % 2)
    assert f"{repeats} rows repeating the previous position (not a new fix; their speed 0.0 is not measured)" \
        in reader.info.notes
    assert trial.track.shape[0] == len(rows) - 1 - repeats
    assert trial.track[:, 3] == pytest.approx(1.5, abs=0.01)  # no 0.0 among the speeds


def test_the_controller_figures_and_target_are_said_where_the_row_has_them(tmp_path: Path) -> None:
    observer = latlon_from_ned(*HOME, -20.0, 5.0)
    rows = otter_rows(sine_motion(20.0, rate_hz=9.0), no_fix_every=10)
    rows = [rows[0], *(dataclasses.replace(r, extra=(
        ("n1", 500.0 + i), ("n2", 480.0), ("tau_X", 60.0), ("tau_N", -4.0 + 0.01 * i), ("yaw_setpoint", 0.5),
        ("distance_to_target", 5530976.6 if r.lat == 0 else 7.0), ("observer_lat", observer[0]),
        ("observer_lon", observer[1]), ("target_north_from_observer", 30.0 - 0.1 * i),
        ("target_east_from_observer", -10.0))) for i, r in enumerate(rows[1:]))]
    path = tmp_path / "controller.csv"
    write_otter_csv(path, rows)
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    n = len(rows) - 1
    assert trial.named["n1"][:, 1].tolist() == [500.0 + i for i in range(n)]
    assert trial.named["tau_N"][:, 1] == pytest.approx([-4.0 + 0.01 * i for i in range(n)])
    assert trial.named["yaw_sp"][:, 1] == pytest.approx(0.5)
    fixes = sum(1 for r in rows[1:] if r.lat != 0)
    assert trial.named["tgt_dist"].shape[0] == fixes and trial.named["tgt_dist"][:, 1].max() == 7.0
    first = ned_from_latlon(*trial.origin, *latlon_from_ned(*observer, 30.0, -10.0))
    assert trial.targets.shape[0] == n and trial.targets[0, 1:] == pytest.approx(first, abs=0.02)


def test_a_dataflash_att_without_rates_is_left_out_not_given_zero_rates(tmp_path: Path) -> None:
    path = tmp_path / "no-imu.bin"
    write_dataflash(path, sine_motion(10.0), imu=False)
    reader = open_log(path)
    attitudes = [m for _, m in reader.messages() if m.get_type() == "ATTITUDE"]
    assert any(n.startswith("1 ATT without an IMU sample beside it") for n in reader.info.notes)
    assert len(attitudes) == sine_motion(10.0).t.size - 1
    assert all(a.rollspeed or a.pitchspeed for a in attitudes)  # angles' rate of change, never a made-up 0


def test_a_tlog_never_places_untimed_messages_at_zero(tmp_path: Path) -> None:
    beat = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_SURFACE_BOAT, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 4, 3)
    path = tmp_path / "beats.tlog"
    write_tlog(path, [(float(t), beat, 1, 1) for t in range(5)])
    reader = open_log(path)
    assert list(reader.messages()) == []
    assert any(n.startswith("5 messages without a time of their own") for n in reader.info.notes)
