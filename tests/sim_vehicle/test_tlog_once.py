"""sim_vehicle.tlog logs a message the vehicle sends once, however many channels carry it (issue 17 item 12b)."""

from __future__ import annotations

from pathlib import Path

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.logs import TlogWriter
from sim_vehicle.mavlink.link import Channel


def _attitude(ms: int) -> mavlink.MAVLink_attitude_message:
    return mavlink.MAVLink_attitude_message(ms, 0.02, -0.01, 1.5, 0.0, 0.0, 0.0)


def _logged(path: Path) -> list[tuple[float, int, int]]:
    log = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    rows = []
    while (msg := log.recv_match(type="ATTITUDE")) is not None:
        rows.append((msg._timestamp, msg.time_boot_ms, msg.get_srcSystem()))
    return rows


def test_copies_on_several_channels_and_a_held_ticks_repeat_are_one_row(tmp_path: Path) -> None:
    now_us = [1_000_000]
    writer = TlogWriter(tmp_path / "sim.tlog", lambda: now_us[0])
    ground_station, companion = Channel("gcs", 0, 1, 1, writer.write), Channel("companion", 1, 1, 1, writer.write)
    companion.encode(_attitude(0))  # each channel numbers its frames: the copies differ in their sequence
    for _ in range(3):
        ground_station.encode(_attitude(1000))  # the ground station's channel is further on in its numbering
    now_us[0] += 1_000_000
    ground_station.encode(_attitude(1000))
    companion.encode(_attitude(1000))
    companion.encode(_attitude(1000))  # a lockstep hold repeats the tick's ATTITUDE: the same message again
    writer.close()
    assert [(stamp, ms) for stamp, ms, _ in _logged(tmp_path / "sim.tlog")] == [(1.0, 0), (1.0, 1000), (2.0, 1000)]


def test_what_arrives_is_logged_every_time(tmp_path: Path) -> None:
    writer = TlogWriter(tmp_path / "sim.tlog", lambda: 5_000_000)
    sender = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    frame = _attitude(7).pack(sender)
    receiver = Channel("udp", 0, 1, 1, writer.write)
    assert len(receiver.decode(frame) + receiver.decode(frame)) == 2  # the same bytes twice (a duplicated datagram)
    writer.close()
    assert [row[1:] for row in _logged(tmp_path / "sim.tlog")] == [(7, 255), (7, 255)]
