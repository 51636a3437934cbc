"""companion.tlog on the autopilot's clock (issue 17 item 12a), read back with pymavlink as a user would."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from pymavlink import mavutil

from mavbridge.link import tlog as tlog_module
from mavbridge.link.tlog import AutopilotClockTlog

mavlink = mavutil.mavlink
EPOCH_US = 1_700_000_000_000_000  # the autopilot's boot on the Unix clock (as its SYSTEM_TIME says)


def _codec() -> mavlink.MAVLink:
    return mavlink.MAVLink(None, srcSystem=1, srcComponent=1)


def _send(log: AutopilotClockTlog, msg: mavlink.MAVLink_message, heard: bool = True) -> None:
    """What Link does with a message from the autopilot: the clock first, then the frame."""
    frame = msg.pack(_codec())
    if heard:
        log.heard(msg)
    log.write(frame)


def _read(path: Path) -> list[tuple[float, str, int | None]]:
    log = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    rows = []
    while (msg := log.recv_match()) is not None:
        rows.append((msg._timestamp, msg.get_type(), getattr(msg, "time_boot_ms", None)))
    return rows


def _attitude(ms: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_attitude_message(ms, 0.01, 0.0, 1.0, 0.0, 0.0, 0.0)


def test_frames_are_stamped_with_the_autopilots_unix_time(tmp_path: Path) -> None:
    log = AutopilotClockTlog(tmp_path / "c.tlog")
    _send(log, mavlink.MAVLink_heartbeat_message(10, 3, 0, 0, 0, 3), heard=False)  # before any time: held
    _send(log, _attitude(41_000))
    _send(log, mavlink.MAVLink_system_time_message(EPOCH_US + 41_000_500, 41_000))  # the epoch: flushes
    for ms in range(41_020, 42_000, 20):  # 1 s of autopilot time, written in no wall time at all
        _send(log, _attitude(ms))
    log.close()
    rows = _read(tmp_path / "c.tlog")
    assert rows[0][1] == "HEARTBEAT" and rows[0][0] == (EPOCH_US + 500) / 1e6  # no autopilot time heard yet
    for stamp, kind, ms in rows[1:]:
        assert kind in ("ATTITUDE", "SYSTEM_TIME") and abs(stamp - (EPOCH_US + 500 + ms * 1000) / 1e6) < 1e-6
    assert rows[-1][0] - rows[1][0] == pytest.approx((41_980 - 41_000) / 1000, abs=1e-6)


def test_without_a_unix_time_the_wall_clock_at_the_first_sample_is_the_epoch(tmp_path: Path) -> None:
    log = AutopilotClockTlog(tmp_path / "c.tlog")
    before = time.time()
    _send(log, mavlink.MAVLink_system_time_message(0, 5_000))  # no GPS: time_unix_usec 0
    after = time.time()
    _send(log, _attitude(6_000))
    log.close()
    (first, _, _), (second, _, _) = _read(tmp_path / "c.tlog")
    assert before - 1e-3 <= first <= after + 1e-3  # the message heard then is stamped then
    assert second - first == pytest.approx(1.0, abs=1e-6)  # and the next on the autopilot's clock


def test_a_reboot_takes_a_new_epoch(tmp_path: Path) -> None:
    log = AutopilotClockTlog(tmp_path / "c.tlog")
    _send(log, mavlink.MAVLink_system_time_message(EPOCH_US + 100_000_000, 100_000))
    _send(log, _attitude(100_020))
    later = EPOCH_US + 200_000_000  # booted again, 200 s after the first boot
    _send(log, mavlink.MAVLink_system_time_message(later + 1_000_000, 1_000))
    _send(log, _attitude(1_020))
    log.close()
    stamps = [stamp for stamp, _, _ in _read(tmp_path / "c.tlog")]
    assert stamps == [(EPOCH_US + 100_000_000) / 1e6, (EPOCH_US + 100_020_000) / 1e6,
                      (later + 1_000_000) / 1e6, (later + 1_020_000) / 1e6]


def test_frames_are_held_no_longer_than_pending_max(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(tlog_module, "PENDING_MAX", 2)  # an autopilot that never sends a Unix time
    log = AutopilotClockTlog(tmp_path / "c.tlog")
    _send(log, _attitude(2_000))
    assert log.epoch_us is None  # held: SYSTEM_TIME may still come
    _send(log, _attitude(2_020))
    assert log.epoch_us is not None  # given up waiting: the wall clock's epoch, and the frames written
    log.close()
    assert [ms for _, _, ms in _read(tmp_path / "c.tlog")] == [2_000, 2_020]
