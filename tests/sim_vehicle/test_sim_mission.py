"""End-to-end mission protocol (upload, download, clear, set-current, timeouts) and AUTO to a waypoint."""

from __future__ import annotations

import math

from sim_vehicle.harness import SimProcess
from tests.rover import ARM, AUTO, MANUAL
from tests.waits import command, run_for, set_mode, wait_for

SIM_OPTIONS = {"speedup": 20}  # the shared ``sim`` fixture's process
HOME_LAT, HOME_LON = -35.363261, 149.165230


def _offset(north: float, east: float) -> tuple[int, int]:
    """degE7 of a point north/east of home."""
    lat = HOME_LAT + math.degrees(north / 6378137.0)
    lon = HOME_LON + math.degrees(east / (6378137.0 * math.cos(math.radians(HOME_LAT))))
    return round(lat * 1e7), round(lon * 1e7)


def _item(conn, seq: int, lat: int, lon: int, command_id: int = 16, current: int = 0):
    return conn.mav.mission_item_int_encode(
        1, 1, seq, 3, command_id, current, 1, 0, 0, 0, float("nan"), lat, lon, 0.0, 0
    )


def upload(conn, points: list[tuple[int, int]]) -> int:
    """Upload home + points answering MISSION_REQUESTs; returns the final MISSION_ACK type."""
    items = [_item(conn, 0, *_offset(0, 0), current=1)] + [
        _item(conn, i + 1, *p) for i, p in enumerate(points)
    ]
    conn.mav.mission_count_send(1, 1, len(items), 0)
    while True:
        msg = wait_for(conn, ["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], 5)
        if msg.get_type() == "MISSION_ACK":
            return msg.type
        conn.mav.send(items[msg.seq])


def download(conn) -> list:
    """Download the mission with MISSION_REQUEST_INT."""
    conn.mav.mission_request_list_send(1, 1, 0)
    count = wait_for(conn, "MISSION_COUNT", 5).count
    items = []
    for seq in range(count):
        conn.mav.mission_request_int_send(1, 1, seq, 0)
        items.append(wait_for(conn, "MISSION_ITEM_INT", 5, lambda m, seq=seq: m.seq == seq))
    conn.mav.mission_ack_send(1, 1, 0, 0)
    return items


def test_upload_download_clear(sim: SimProcess) -> None:
    """Upload two waypoints, read them back after home at seq 0, then clear to home only."""
    conn = sim.connect()
    points = [_offset(30, 0), _offset(30, 30)]
    assert upload(conn, points) == 0
    items = download(conn)
    assert len(items) == 3
    assert (items[0].x, items[0].y) == _offset(0, 0) and items[0].frame == 0
    assert [(i.x, i.y) for i in items[1:]] == points
    assert items[1].current == 1 and items[2].current == 0
    conn.mav.mission_clear_all_send(1, 1, 0)
    assert wait_for(conn, "MISSION_ACK", 5).type == 0
    assert len(download(conn)) == 1


def test_float_request_and_bad_sequence(sim: SimProcess) -> None:
    """MISSION_REQUEST gets MISSION_ITEM; a bad seq gets an error; a wrong upload seq is refused."""
    conn = sim.connect()
    assert upload(conn, [_offset(10, 10)]) == 0
    conn.mav.mission_request_send(1, 1, 1, 0)
    item = wait_for(conn, "MISSION_ITEM", 5)
    assert abs(item.x - _offset(10, 10)[0] / 1e7) < 1e-6
    conn.mav.mission_request_int_send(1, 1, 7, 0)
    assert wait_for(conn, "MISSION_ACK", 5).type == 1
    conn.mav.mission_count_send(1, 1, 2, 0)
    assert wait_for(conn, "MISSION_REQUEST", 5).seq == 0
    conn.mav.send(_item(conn, 1, *_offset(5, 5)))
    assert wait_for(conn, "MISSION_ACK", 5).type == 13  # INVALID_SEQUENCE
    other = sim.connect(source_system=77)
    other.mav.mission_count_send(1, 1, 2, 0)
    assert wait_for(other, "MISSION_ACK", 5).type == 14  # DENIED while an upload is in progress
    conn.mav.send(_item(conn, 0, *_offset(0, 0)))
    assert wait_for(conn, "MISSION_REQUEST", 5).seq == 1
    conn.mav.send(_item(conn, 1, *_offset(5, 5)))
    assert wait_for(conn, "MISSION_ACK", 5).type == 0


def test_interrupted_upload_keeps_the_stored_mission(sim: SimProcess) -> None:
    """An upload that stops half way is re-requested after 1 s, cancelled after 8 s, and changes nothing."""
    conn = sim.connect()
    assert upload(conn, [_offset(20, 0)]) == 0
    conn.mav.mission_count_send(1, 1, 4, 0)
    assert wait_for(conn, "MISSION_REQUEST", 5).seq == 0
    conn.mav.send(_item(conn, 0, *_offset(0, 0)))
    assert wait_for(conn, "MISSION_REQUEST", 5).seq == 1
    assert wait_for(conn, "MISSION_REQUEST", 5).seq == 1  # re-sent after 1 s of silence
    assert wait_for(conn, "MISSION_ACK", 10).type == 15  # OPERATION_CANCELLED
    items = download(conn)
    assert [(i.x, i.y) for i in items[1:]] == [_offset(20, 0)]


def test_auto_reaches_waypoint_50m_away(sim: SimProcess) -> None:
    """AUTO drives to a waypoint 50 m away and reports MISSION_ITEM_REACHED, then the mission is complete."""
    conn = sim.connect()
    assert set_mode(conn, MANUAL) == 0
    pos = wait_for(conn, "GLOBAL_POSITION_INT", 5)
    here_n = math.radians((pos.lat * 1e-7) - HOME_LAT) * 6378137.0
    here_e = math.radians((pos.lon * 1e-7) - HOME_LON) * 6378137.0 * math.cos(math.radians(HOME_LAT))
    target = _offset(here_n + 40.0, here_e + 30.0)
    assert upload(conn, [target]) == 0
    assert set_mode(conn, AUTO) == 0 and command(conn, ARM, 1) == 0
    current = wait_for(conn, "MISSION_CURRENT", 5)
    assert current.seq == 1 and current.mission_state == 3
    reached = wait_for(conn, "MISSION_ITEM_REACHED", 30)
    assert reached is not None and reached.seq == 1
    pos = wait_for(conn, "GLOBAL_POSITION_INT", 5)
    dn = (pos.lat - target[0]) * 1e-7 * 111_319.5
    de = (pos.lon - target[1]) * 1e-7 * 111_319.5 * math.cos(math.radians(HOME_LAT))
    assert math.hypot(dn, de) < 4.0
    wait_for(conn, "MISSION_CURRENT", 5, lambda m: m.mission_state == 5)
    run_for(conn, 1.0)
    assert command(conn, ARM, 0) == 0
