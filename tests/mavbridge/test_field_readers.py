"""The field logs' readers (issue 30): DataFlash (binary and text), the Otter API's CSV and MAVLink tlogs, each
written here by the test of a motion it knows, read back into the same trial the report and replay use."""

from __future__ import annotations

import math
import os
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v10 import ardupilotmega as mav1
from pymavlink.dialects.v20 import ardupilotmega as mav

from mavbridge.field.logs import LogError, open_log
from mavbridge.field.tlog import Decoder, FrameStream, _decode
from mavbridge.field.trial import record
from tests.mavbridge.field_logs import (
    GRAVITY,
    HOME,
    OTTER_30,
    Motion,
    is_month,
    motion_frames,
    otter_rows,
    sine_motion,
    write_dataflash,
    write_otter_csv,
    write_tlog,
)
from vessel.geo import ned_from_latlon

MANUAL, HOLD, AUTO = mav.ROVER_MODE_MANUAL, mav.ROVER_MODE_HOLD, mav.ROVER_MODE_AUTO


def _avg_roll_deg(rad: np.ndarray) -> float:
    return float(np.mean(np.abs(np.degrees(rad))))


@pytest.mark.parametrize("text", [False, True], ids=["bin", "text-log"])
def test_dataflash_says_what_the_test_wrote(tmp_path: Path, text: bool) -> None:
    motion = sine_motion(60.0)
    path = tmp_path / ("trial.log" if text else "trial.bin")
    write_dataflash(path, motion, modes=[(0.0, MANUAL), (20.0, HOLD), (40.0, AUTO)], armed_at=10.0,
                    waypoints_ne=[(30.0, 40.0), (50.0, 10.0)], params={"SYSID_MYGCS": 255.0, "RC1_MIN": 1000.0},
                    text=text)
    reader = open_log(path, outputs=True)
    trial = record(reader.messages(), reader.info)
    assert reader.info.format == "dataflash" and "ArduRover" in reader.info.source and reader.info.stopped is None
    # every ATT, in degrees on disk (centidegrees in the binary), back in radians
    assert trial.attitude.shape == (motion.t.size, 4)
    np.testing.assert_allclose(trial.attitude[:, 1], motion.eta[:, 3], atol=math.radians(0.006))
    np.testing.assert_allclose(trial.attitude[:, 0], motion.t + 1.0, atol=1e-6)  # TimeUS, the log's own clock
    assert [(c.t_s, c.label) for c in trial.modes] == [
        (1.0, "MANUAL (disarmed)"), (11.0, "MANUAL (armed)"), (21.0, "HOLD (armed)"), (41.0, "AUTO (armed)")]
    local = [trial.local(p) for p in trial.waypoints]
    np.testing.assert_allclose(local, [(30.0, 40.0), (50.0, 10.0)], atol=0.05)
    assert trial.home == pytest.approx(HOME) and trial.params == {"SYSID_MYGCS": 255.0, "RC1_MIN": 1000.0}
    assert trial.imu == "SCALED_IMU"
    # the track: 1 m/s on 30°, 60 s
    assert trial.track[-1, 3] == pytest.approx(1.0, abs=0.02)
    assert math.hypot(*trial.track[-1, 1:3]) == pytest.approx(59.9, abs=0.2)


def test_a_dataflash_log_cut_short_is_read_up_to_where_it_stops(tmp_path: Path) -> None:
    motion = sine_motion(30.0)
    whole, cut = tmp_path / "whole.bin", tmp_path / "cut.bin"
    write_dataflash(whole, motion, outputs=False)
    data = whole.read_bytes()
    cut.write_bytes(data[:len(data) - 17])  # inside the last message
    reader = open_log(cut)
    trial = record(reader.messages(), reader.info)
    assert reader.info.stopped is not None and f"of {len(data) - 17}" in reader.info.stopped, reader.info.stopped
    assert motion.t.size - 2 <= trial.attitude.shape[0] <= motion.t.size


def _otter_file(tmp_path: Path, columns: list[str] | None = None, spreadsheet: bool = False) -> tuple[Path, list]:
    rows = otter_rows(sine_motion(40.0, rate_hz=9.0), repeats_every=7, no_fix_every=11)
    path = tmp_path / "2024-03-22_12-45-31.csv"
    write_otter_csv(path, rows, **({"columns": columns} if columns else {}), spreadsheet=spreadsheet)
    return path, rows


@pytest.mark.parametrize("columns", [None, OTTER_30], ids=["41-columns", "30-columns"])
def test_otter_csv_quirks_are_handled_and_said(tmp_path: Path, columns: list[str] | None) -> None:
    path, rows = _otter_file(tmp_path, columns, spreadsheet=True)
    reader = open_log(path)  # found from its header: --format otter-csv is not needed
    trial = record(reader.messages(), reader.info)
    assert reader.info.format == "otter-csv"
    repeated = [i > 0 and r.attitude_deg == rows[i - 1].attitude_deg for i, r in enumerate(rows)]
    fresh = [r for r, again in zip(rows, repeated, strict=True) if any(r.attitude_deg) and not again]
    repeats = sum(1 for r, again in zip(rows, repeated, strict=True) if any(r.attitude_deg) and again)
    no_fix = sum(1 for r in rows if r.lat == 0.0)
    notes = "\n".join(reader.info.notes)
    assert f"{repeats} rows repeating the previous attitude" in notes
    assert "1 row without attitude (all zero: a placeholder; nothing taken from them)" in notes
    assert f"{no_fix} rows without a position fix" in notes
    assert trial.attitude.shape[0] == len(fresh)
    assert _avg_roll_deg(trial.attitude[:, 1]) == pytest.approx(np.mean([abs(r.attitude_deg[0]) for r in fresh]),
                                                                abs=1e-9)
    assert trial.track.shape[0] == len(rows) - no_fix - 1  # the placeholder's position goes with its bogus speed
    np.testing.assert_allclose(trial.attitude[:, 0], [r.t for r in fresh], atol=2e-6)  # s since the first row
    mangled = sum(1 for r in rows for v in (*r.attitude_deg, *r.rates_deg_s) if is_month(v))
    assert mangled > 20 and f"{mangled} numbers a spreadsheet had turned into dates read back" in notes
    assert "unreadable, left out" not in notes


def test_spreadsheet_dates_are_read_back_as_the_numbers_they_were(tmp_path: Path) -> None:
    path, rows = _otter_file(tmp_path, spreadsheet=True)
    text = path.read_text()
    mangled = [r for r in rows if is_month(r.rates_deg_s[0])]
    assert mangled and any(f";{m}." in text for m in ("jan", "feb", "mar"))
    reader = open_log(path)
    rates = {round(m.time_boot_ms / 1000.0, 3): m.rollspeed for _, m in reader.messages()
             if m.get_type() == "ATTITUDE"}
    checked = [row for row in mangled if round(row.t, 3) in rates]  # (a repeated row carries no new sample)
    assert len(checked) > 20
    for row in checked:
        assert math.degrees(rates[round(row.t, 3)]) == pytest.approx(row.rates_deg_s[0], abs=1e-9)


def test_format_flag_must_match_the_file(tmp_path: Path) -> None:
    csv_path, _ = _otter_file(tmp_path)
    tlog = tmp_path / "a.tlog"
    write_tlog(tlog, motion_frames(sine_motion(5.0)))
    with pytest.raises(LogError, match=r"^--format tlog: .* is not a tlog log \(it looks like otter-csv\)"):
        open_log(csv_path, "tlog")
    with pytest.raises(LogError, match=r"^--format otter-csv: .* is not a otter-csv log \(it looks like tlog\)"):
        open_log(tlog, "otter-csv")
    text = tmp_path / "notes.txt"
    text.write_text("time;speed\n1;2\n")
    with pytest.raises(LogError, match=r"^LOG: .*notes.txt is not a log this reads"):
        open_log(text)
    with pytest.raises(LogError, match="empty"):
        (tmp_path / "empty.tlog").write_bytes(b"")
        open_log(tmp_path / "empty.tlog")
    with pytest.raises(LogError, match=r"--sysid: applies to MAVLink \.tlog logs only"):
        open_log(csv_path, sysid=1)


def test_tlog_autopilot_is_the_first_heartbeat_that_names_one_or_sysid(tmp_path: Path) -> None:
    ours, theirs = sine_motion(20.0, roll_deg=4.0), sine_motion(20.0, roll_deg=9.0, period_s=5.0)
    gcs = [(float(t), mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3), 255, 190)
           for t in np.arange(0.0, 20.0, 1.0)]
    frames = sorted(gcs + motion_frames(ours, sysid=1) + motion_frames(theirs, sysid=2), key=lambda f: f[0])
    path = tmp_path / "two-boats.tlog"
    write_tlog(path, frames)
    first = open_log(path)
    trial = record(first.messages(), first.info)
    assert first.info.source == "autopilot 1/1 (ArduPilot, surface boat)"
    assert _avg_roll_deg(trial.attitude[:, 1]) == pytest.approx(_avg_roll_deg(ours.eta[:, 3]), rel=1e-6)
    assert any("255/190" in n and "2/1" in n for n in first.info.notes), first.info.notes
    second = open_log(path, sysid=2)
    trial2 = record(second.messages(), second.info)
    assert _avg_roll_deg(trial2.attitude[:, 1]) == pytest.approx(_avg_roll_deg(theirs.eta[:, 3]), rel=1e-6)
    np.testing.assert_allclose(trial2.attitude[:, 0], theirs.t + 5.0, atol=1e-9)  # the autopilot's own clock
    with pytest.raises(LogError, match="no autopilot HEARTBEAT and no ATTITUDE of system 7"):
        open_log(path, sysid=7)


def _imu_frames(motion: Motion, kind: str, rate_hz: float, start_s: float) -> list[tuple[float, Any, int, int]]:
    """The autopilot's IMU stream of ``kind`` at ``rate_hz`` from ``start_s`` (ArduPilot's milli-g, mrad/s)."""
    frames, every = [], max(1, round(20.0 / rate_hz))
    for i in range(0, motion.t.size, every):
        t = float(motion.t[i])
        if t < start_s:
            continue
        ms = round(t * 1000) + 5000
        acc = [round(float(a) / GRAVITY * 1000) for a in motion.accel[i]]
        gyro = [round(float(r) * 1000) for r in motion.rates[i]]
        msg = (mav.MAVLink_scaled_imu_message(ms, *acc, *gyro, 0, 0, 0) if kind == "SCALED_IMU"
               else mav.MAVLink_raw_imu_message(ms * 1000, *acc, *gyro, 0, 0, 0))
        frames.append((t, msg, 1, 1))
    return frames


def test_a_fast_imu_stream_that_starts_late_is_the_one_used(tmp_path: Path) -> None:
    """A ground station's log begins before a companion asks for SCALED_IMU: Rover's 1 Hz RAW_IMU comes
    first, the 20 Hz stream 20 s later. The trial follows the fastest stream, as the companion does (before,
    the first seconds decided for the whole log and the estimator saw one heave sample a second)."""
    motion = sine_motion(60.0)
    frames = motion_frames(motion) + _imu_frames(motion, "RAW_IMU", 1.0, 0.0)
    path = tmp_path / "late-imu.tlog"
    write_tlog(path, sorted(frames + _imu_frames(motion, "SCALED_IMU", 20.0, 20.0), key=lambda f: f[0]))
    log = open_log(path)
    assert record(log.messages(), log.info).imu == "SCALED_IMU"
    only_slow = tmp_path / "slow-imu.tlog"
    write_tlog(only_slow, sorted(frames, key=lambda f: f[0]))
    log = open_log(only_slow)
    assert record(log.messages(), log.info).imu == "RAW_IMU"


def test_tlog_cut_short_damaged_and_rebooted_is_read_and_said(tmp_path: Path) -> None:
    motion = sine_motion(20.0)
    frames = motion_frames(motion)
    reboot = [(t + 20.0, m, s, c) for t, m, s, c in motion_frames(motion)]  # the same again: time_boot_ms restarts
    whole = tmp_path / "whole.tlog"
    write_tlog(whole, frames + reboot)
    data = whole.read_bytes()
    junk_at = len(data) // 3
    damaged = tmp_path / "damaged.tlog"
    damaged.write_bytes(data[:junk_at] + b"\x00garbage!" * 5 + data[junk_at:len(data) - 9])
    reader = open_log(damaged)
    trial = record(reader.messages(), reader.info)
    notes = "\n".join(reader.info.notes)
    assert "bytes that are not MAVLink frames skipped" in notes and "rebooted 1 time;" in notes, notes
    assert reader.info.stopped is not None and "ends inside a message" in reader.info.stopped
    attitudes = sum(1 for _, m, _, _ in frames + reboot if m.get_type() == "ATTITUDE")
    assert attitudes - 2 <= trial.attitude.shape[0] <= attitudes  # at most the frame cut and the one hit by junk
    assert np.all(np.diff(trial.attitude[:, 0]) > 0)  # the timeline goes on across the reboot
    assert trial.attitude[-1, 0] == pytest.approx(45.0, abs=0.5)


def test_tlog_of_mavlink_1_frames_and_the_fast_decoder_agree_with_pymavlink(tmp_path: Path) -> None:
    motion = sine_motion(5.0)
    v1 = mav1.MAVLink(None, srcSystem=1, srcComponent=1)
    path = tmp_path / "v1.tlog"
    with path.open("wb") as handle:
        for t, msg, _, _ in motion_frames(motion):
            handle.write(int((1.7e9 + t) * 1e6).to_bytes(8, "big") + msg.pack(v1))
        handle.write(int(1.7e9 * 1e6).to_bytes(8, "big") + mav.MAVLink_scaled_imu_message(
            10, -12, 30, -1005, 1, 2, 3, 0, 0, 0, 4100).pack(mav.MAVLink(None, 1, 1)))
    decode, parser, seen = Decoder(), mav.MAVLink(None), Counter[str]()
    with path.open("rb") as handle:
        for frame in FrameStream(handle):
            fast, slow = decode(frame), _decode(parser, frame)
            assert fast.to_dict() == slow.to_dict()
            seen[fast.get_type()] += 1
    assert seen == {"ATTITUDE": motion.t.size, "GLOBAL_POSITION_INT": motion.t.size // 2, "HEARTBEAT": 5,
                    "SCALED_IMU": 1}
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    assert trial.attitude.shape[0] == motion.t.size


def test_a_log_without_attitude_is_one_line(tmp_path: Path) -> None:
    path = tmp_path / "heartbeats.tlog"
    write_tlog(path, [(float(t), mav.MAVLink_heartbeat_message(11, 3, 0, 0, 4, 3), 1, 1) for t in range(10)])
    reader = open_log(path)
    with pytest.raises(LogError, match=r"^LOG: .*heartbeats.tlog: no attitude in this tlog log: nothing to report$"):
        record(reader.messages(), reader.info)


def test_positions_are_metres_from_the_first_fix(tmp_path: Path) -> None:
    motion = sine_motion(30.0, speed_m_s=2.0, heading_deg=90.0)
    path = tmp_path / "east.tlog"
    write_tlog(path, motion_frames(motion))
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    assert trial.origin == pytest.approx(HOME, abs=1e-7)
    end = ned_from_latlon(*HOME, *motion.latlon(motion.t.size - 2))
    assert trial.track[-1, 1:3] == pytest.approx(end, abs=0.02)
    assert trial.track[-1, 3] == pytest.approx(2.0, abs=0.01)


def test_an_otter_csv_cut_inside_a_row_is_read_up_to_it(tmp_path: Path) -> None:
    path, rows = _otter_file(tmp_path)
    text = path.read_text()
    path.write_text(text[:len(text) - 40])  # the last row loses its end (and its newline)
    reader = open_log(path)
    trial = record(reader.messages(), reader.info)
    assert reader.info.stopped is not None and "ends inside a row" in reader.info.stopped
    assert trial.attitude[-1, 0] < rows[-1].t
