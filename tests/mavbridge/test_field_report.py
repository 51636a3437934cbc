"""`mavbridge report` and `mavbridge replay` on logs the test writes (issue 30): the figures, the sea the
companion's estimator finds in them, the page and JSON, and a replay that sends nothing."""

from __future__ import annotations

import csv
import json
import math
import re
import socket
from pathlib import Path

import numpy as np
import pytest

from mavbridge.cli import main
from mavbridge.field.logs import open_log
from mavbridge.field.report import EstimatorSetup, analyse, estimator_setup
from mavbridge.field.segments import distance, engagement_windows
from mavbridge.field.spectrum import roll_spectrum
from mavbridge.lab.runlog import write_csv
from tests.mavbridge.field_logs import (
    Motion,
    motion_frames,
    otter_rows,
    plant_motion,
    sine_motion,
    write_dataflash,
    write_otter_csv,
    write_tlog,
)
from vessel import SEA_PRESETS, CalmWater

PAPER = SEA_PRESETS["paper"].waves()  # 1.75 m, 35 m, 6 s, travelling towards 270°


@pytest.fixture(scope="module")
def setup() -> EstimatorSetup:
    """The companion's estimator as the report builds it (calibrated once)."""
    return estimator_setup(None, None)


@pytest.fixture(scope="module")
def paper_motion() -> Motion:
    """The Otter model riding the paper's wave for 120 s, heading 45° (a quarter sea)."""
    return plant_motion(PAPER, 120.0)


def test_the_estimator_finds_the_wave_in_a_dataflash_log_with_its_imu(tmp_path: Path, setup: EstimatorSetup,
                                                                      paper_motion: Motion) -> None:
    path = tmp_path / "waves.bin"
    write_dataflash(path, paper_motion)
    sea = analyse(open_log(path), setup).sea.summary()
    assert sea["confident_fraction"] > 0.6, sea
    assert sea["period_s_median"] == pytest.approx(PAPER.period_s, rel=0.05)
    assert sea["height_m_median"] == pytest.approx(PAPER.height_m, rel=0.15)
    assert abs(math.remainder(sea["dir_deg_mean"] - math.degrees(PAPER.travel_dir_rad), 360.0)) < 15.0


def test_the_estimator_stays_quiet_in_calm_water(tmp_path: Path, setup: EstimatorSetup) -> None:
    path = tmp_path / "calm.bin"
    write_dataflash(path, plant_motion(CalmWater(), 90.0))
    sea = analyse(open_log(path), setup).sea.summary()
    assert sea["confident_fraction"] == 0.0 and sea["first_confident_s"] is None, sea


def test_without_heave_the_otter_csv_gives_the_encounter_period_and_no_confident_wave(
        tmp_path: Path, setup: EstimatorSetup, paper_motion: Motion) -> None:
    """The Otter API logs no heave and a steady speed has no Doppler line: the tracker sees the sea's encounter
    period (as with the IMU), but nothing can be solved, so the estimator says nothing confident."""
    bin_path, csv_path = tmp_path / "waves.bin", tmp_path / "waves.csv"
    write_dataflash(bin_path, paper_motion)
    write_otter_csv(csv_path, otter_rows(paper_motion))
    with_imu = analyse(open_log(bin_path), setup).sea.summary()
    otter = analyse(open_log(csv_path), setup).sea.summary()
    assert otter["encounter_period_s_median"] == pytest.approx(with_imu["encounter_period_s_median"], rel=0.05)
    assert otter["confident_fraction"] == 0.0, otter
    assert otter["blind"] and with_imu["blind"] is None


def test_distance_counts_travel_not_gps_jitter() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 600.0, 0.1)
    jitter = rng.normal(0.0, 0.3, (t.size, 2))
    assert distance(t, jitter[:, 0], jitter[:, 1]) < 1.0  # ten minutes at rest at 10 Hz in 0.3 m of noise
    assert distance(t, 1.5 * t + jitter[:, 0], jitter[:, 1]) == pytest.approx(900.0, rel=0.01)  # 1.5 m/s ahead
    circle = 10.0 * np.column_stack([np.cos(t / 10.0), np.sin(t / 10.0)])  # 1 m/s on a 10 m circle
    assert distance(t, circle[:, 0] + jitter[:, 0], circle[:, 1] + jitter[:, 1]) == pytest.approx(600.0, rel=0.02)


def test_engagements_are_the_companions_runs_of_control_steps(tmp_path: Path) -> None:
    rows = [{"t_s": t, "phase": "ENGAGED", "sent": 1} for t in np.arange(10.0, 20.0, 0.1)]
    rows += [{"t_s": t, "phase": "ENGAGED", "sent": 1} for t in np.arange(40.0, 45.0, 0.3)]  # after a link loss
    write_csv(tmp_path / "companion.csv", rows)
    windows = engagement_windows(tmp_path)
    assert [(round(a, 1), round(b, 1), sent) for a, b, sent in windows] == [(10.0, 19.9, True), (40.0, 44.8, True)]


def test_roll_spectrum_peak_and_variance() -> None:
    t = np.arange(0.0, 300.0, 0.05)
    roll = 3.0 * np.sin(2 * math.pi * 0.7 * t)
    spectrum = roll_spectrum(t, roll)
    assert spectrum is not None and spectrum.peak_hz == pytest.approx(0.7, abs=1 / spectrum.window_s)
    variance = float(np.sum(spectrum.psd_deg2_hz) * (spectrum.freq_hz[1] - spectrum.freq_hz[0]))
    assert variance == pytest.approx(4.5, rel=0.05)  # A²/2
    assert roll_spectrum(t[:100], roll[:100]) is None  # 5 s: too short


def _report(args: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    code = main(["report", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_report_prints_writes_a_self_contained_page_and_never_overwrites(tmp_path: Path,
                                                                        capsys: pytest.CaptureFixture[str]) -> None:
    motion = sine_motion(60.0, roll_deg=4.0)
    log = tmp_path / "trial.bin"
    write_dataflash(log, motion, modes=[(0.0, 0), (30.0, 4)], armed_at=5.0, waypoints_ne=[(40.0, 30.0)])
    out = tmp_path / "report"
    code, text, err = _report([str(log), "--out", str(out)], capsys)
    assert code == 0, err
    expected = float(np.mean(np.abs(np.round(np.degrees(motion.eta[:, 3]), 2))))  # ATT holds centidegrees
    found = re.search(r"^average roll \(whole log\) ([0-9.]+) deg", text, re.M)
    assert found and float(found.group(1)) == pytest.approx(expected, abs=5.1e-4), text
    assert "MANUAL (armed)" in text and "HOLD (armed)" in text and "sea: " in text
    page = (out / "report.html").read_text()
    assert page.count("data:image/png;base64,") == 5 and not re.search(r"(src|href)=\"(https?:|file:|/)", page)
    data = json.loads((out / "report.json").read_text())
    entry = data["logs"][0]
    assert entry["avg_roll_deg"] == pytest.approx(expected, abs=1e-4)
    assert [m["label"] for m in entry["modes"]] == ["MANUAL (disarmed)", "MANUAL (armed)", "HOLD (armed)"]
    assert entry["waypoints"][0]["north_m"] == pytest.approx(40.0, abs=0.05)
    assert len(entry["sea"]["series"]["t_s"]) == pytest.approx(60, abs=2)
    code, text, _ = _report([str(log), "--out", str(out)], capsys)
    assert code == 0 and (tmp_path / "report-2" / "report.html").is_file() and (out / "report.json").read_text() \
        == json.dumps(data, indent=1) + "\n"


def test_a_tlog_cut_short_is_reported_up_to_where_it_stops(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "cut.tlog"
    write_tlog(log, motion_frames(sine_motion(30.0)))
    data = log.read_bytes()
    log.write_bytes(data[:len(data) - 20])
    code, text, err = _report([str(log), "--out", str(tmp_path / "r")], capsys)
    assert code == 0, err
    assert re.search(rf"^  cut short: the file ends inside a message at byte \d+ of {len(data) - 20} \(cut short\): "
                     r"read up to t = 3\d\.\d s$", text, re.M), text
    entry = json.loads((tmp_path / "r" / "report.json").read_text())["logs"][0]
    assert "ends inside a message" in entry["cut_short"]
    assert f"made by <code>mavbridge report {log} --out {tmp_path / 'r'}</code>" in \
        (tmp_path / "r" / "report.html").read_text()


def test_report_of_several_logs_leaves_out_one_without_attitude(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    good, empty = tmp_path / "good.csv", tmp_path / "empty.csv"
    write_otter_csv(good, otter_rows(sine_motion(30.0, rate_hz=9.0)))
    write_otter_csv(empty, otter_rows(sine_motion(10.0, rate_hz=9.0, roll_deg=0.0))[:1])  # the placeholder only
    code, _, err = _report([str(good), str(empty), "--out", str(tmp_path / "r")], capsys)
    assert code == 0 and "left out" in err and "empty.csv: no attitude" in err
    assert [e["log"] for e in json.loads((tmp_path / "r" / "report.json").read_text())["logs"]] == [str(good)]
    code, _, err = _report([str(empty), "--out", str(tmp_path / "s")], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "no attitude" in err
    assert not (tmp_path / "s").exists()


def test_a_file_that_is_not_a_log_stops_the_report_before_anything_is_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good, bad = tmp_path / "good.tlog", tmp_path / "photo.jpg"
    write_tlog(good, motion_frames(sine_motion(10.0)))
    bad.write_bytes(bytes(range(256)) * 8)
    code, text, err = _report([str(good), str(bad), "--out", str(tmp_path / "r")], capsys)
    assert code == 2 and err.strip().splitlines() == [
        f"mavbridge: error: LOG: {bad} is not a log this reads (expected a MAVLink .tlog, an ArduPilot DataFlash "
        ".bin/.log or an Otter API .csv; --format names one)"]
    assert not (tmp_path / "r").exists() and text == ""


def test_replay_commands_from_the_log_beside_what_the_boat_did_and_sends_nothing(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    log = tmp_path / "trial.bin"
    params = {"SYSID_MYGCS": 255.0, "RCMAP_ROLL": 1.0, "RCMAP_THROTTLE": 3.0, "PILOT_STEER_TYPE": 0.0,
              "FRAME_CLASS": 2.0, "SERVO1_FUNCTION": 73.0, "SERVO3_FUNCTION": 74.0,
              **{f"RC{ch}_{k}": v for ch in (1, 3) for k, v in (("MIN", 1100.0), ("TRIM", 1500.0), ("MAX", 1900.0),
                                                                ("DZ", 30.0), ("REVERSED", 0.0))}}
    write_dataflash(log, sine_motion(40.0, speed_m_s=1.5), modes=[(0.0, 0), (30.0, 4)], armed_at=2.0,
                    waypoints_ne=[(200.0, 0.0)], params=params)

    def refuse(*args: object, **kwargs: object) -> None:
        raise AssertionError("the replay tried to send")

    for name in ("connect", "send", "sendto", "sendall"):
        monkeypatch.setattr(socket.socket, name, refuse)
    # The log's motion is a sine the test draws, not the boat's answer to any command: a disturbance observer would
    # take the difference for a current, so this companion flies on its model alone (disturbance: none)
    (tmp_path / "companion.yaml").write_text("disturbance: none\n")
    code = main(["replay", str(log), "--from", "10", "--to", "35", "--out", str(tmp_path / "replay"), "--plan-all",
                 "--config", str(tmp_path / "companion.yaml")])
    out, err = capsys.readouterr()
    assert code == 0, err  # (--plan-all: the HOLD steps too, where the companion would plan nothing)
    assert "nothing was sent" in out and "RC: steering ch1, throttle ch3" in out
    with (tmp_path / "replay" / "replay.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    t = np.array([float(r["t_s"]) for r in rows])
    assert t[0] == pytest.approx(10.0, abs=0.06) and t[-1] == pytest.approx(35.0, abs=0.11)
    assert np.allclose(np.diff(t), 0.1, atol=0.051)  # the controller's period, on the log's clock
    would = {r["mode"]: r["would_command"] for r in rows}
    assert would == {"MANUAL": "1", "HOLD": "0"}  # armed in MANUAL only: the companion's mode
    # the boat's motors from RCOU (1700 left, 1650 right about 1500 in 1100..1900): throttle 0.4375, steering 0.0625
    assert {r["boat_throttle"] for r in rows} == {"0.4375"} and {r["boat_steering"] for r in rows} == {"0.0625"}
    assert all(1100 <= int(r["throttle_pwm_us"]) <= 1900 and math.isfinite(float(r["cmd_throttle"])) for r in rows)
    assert float(rows[-1]["cmd_throttle"]) > 0.3  # the waypoint is 200 m ahead: the plan drives on
    assert (tmp_path / "replay" / "replay.png").stat().st_size > 10_000


def test_a_log_without_a_parameter_the_commands_need_is_refused_naming_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The replay configures the companion's output from the log's parameters as the link's reads would: one the
    commands depend on and the log lacks (here RCMAP_ROLL) is a refusal, in one line, never an assumed value."""
    log = tmp_path / "trial.bin"
    params = {"SYSID_MYGCS": 255.0, "RCMAP_THROTTLE": 3.0, "PILOT_STEER_TYPE": 0.0, "FRAME_CLASS": 2.0,
              "SERVO1_FUNCTION": 73.0, "SERVO3_FUNCTION": 74.0}
    write_dataflash(log, sine_motion(20.0, speed_m_s=1.5), modes=[(0.0, 0)], armed_at=2.0,
                    waypoints_ne=[(200.0, 0.0)], params=params)
    code = main(["replay", str(log), "--out", str(tmp_path / "replay")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "RCMAP_ROLL" in err and len(err.splitlines()) == 1, err


def test_the_replay_arrives_at_the_attitude_the_boat_enters_the_radius_between_its_steps(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A companion that skipped a tick steps on attitudes off the replay's 0.1 s grid and may arrive at one of
    them: the replay sees the boat inside the acceptance radius (2 m) at that attitude, not only at its own next
    step. Here the boat (North at 1.5 m/s) is 2.04 m short at the step at 31.0 s of the log (the log's clock is
    the motion's + 1 s) and 1.965 m at the attitude 50 ms later; the step after would be at 31.1 s."""
    log = tmp_path / "trial.bin"
    params = {"SYSID_MYGCS": 255.0, "RCMAP_ROLL": 1.0, "RCMAP_THROTTLE": 3.0, "PILOT_STEER_TYPE": 0.0,
              "FRAME_CLASS": 2.0, "SERVO1_FUNCTION": 73.0, "SERVO3_FUNCTION": 74.0,
              **{f"RC{ch}_{k}": v for ch in (1, 3) for k, v in (("MIN", 1100.0), ("TRIM", 1500.0), ("MAX", 1900.0),
                                                                ("DZ", 30.0), ("REVERSED", 0.0))}}
    write_dataflash(log, sine_motion(32.0, speed_m_s=1.5, heading_deg=0.0), modes=[(0.0, 0)], armed_at=2.0,
                    waypoints_ne=[(47.04, 0.0)], params=params)
    assert main(["replay", str(log), "--from", "25", "--out", str(tmp_path / "replay")]) == 0
    found = re.search(r"^replay: the last waypoint reached at t = ([0-9.]+) s of the log$", capsys.readouterr().out,
                      re.M)
    assert found and float(found.group(1)) == pytest.approx(31.05, abs=0.001), found


def test_an_intermediate_waypoint_is_reached_at_a_step_not_between_steps(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Only the last waypoint counts between steps: an intermediate one the boat is inside only at an attitude
    between two steps (1.975 m at 21.05 s, 2.026 m at the steps at 21.0 and 21.1 s) is not dropped there, as the
    companion, which looks at its steps, would not; the replay keeps flying to it and never arrives."""
    log = tmp_path / "trial.bin"
    params = {"SYSID_MYGCS": 255.0, "RCMAP_ROLL": 1.0, "RCMAP_THROTTLE": 3.0, "PILOT_STEER_TYPE": 0.0,
              "FRAME_CLASS": 2.0, "SERVO1_FUNCTION": 73.0, "SERVO3_FUNCTION": 74.0,
              **{f"RC{ch}_{k}": v for ch in (1, 3) for k, v in (("MIN", 1100.0), ("TRIM", 1500.0), ("MAX", 1900.0),
                                                                ("DZ", 30.0), ("REVERSED", 0.0))}}
    write_dataflash(log, sine_motion(40.0, speed_m_s=9.0, heading_deg=0.0), modes=[(0.0, 0)], armed_at=2.0,
                    waypoints_ne=[(180.45, 1.975), (300.0, 0.0)], params=params)
    assert main(["replay", str(log), "--from", "15", "--out", str(tmp_path / "replay")]) == 0
    out = capsys.readouterr().out
    assert "nothing was sent" in out and "last waypoint reached" not in out, out[-600:]
