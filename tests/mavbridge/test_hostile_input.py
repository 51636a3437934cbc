"""Hostile MAVLink: every ardupilotmega message type with extreme values, through the companion's handlers
and its link (real UDP sockets on loopback)."""

from __future__ import annotations

import math
import random
import socket
import time
from collections.abc import Iterator

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from bench.hostile_flood import MESSAGE_TYPES, extreme_message, hostile_packets
from mavbridge.companion.delay import FLOOD_WINDOW_S, DelayCompensator
from mavbridge.companion.mission_tracker import MissionTracker
from mavbridge.companion.state import StateEstimate
from mavbridge.companion.supervisor import Supervisor
from mavbridge.link.connection import Link
from mavbridge.link.filter import ADDRESS_FORGET_S
from mavbridge.link.reboot import RebootWatch
from sim_vehicle.harness import free_port


def decoded(count: int, seed: int) -> Iterator[object]:
    """The hostile frames as the companion's parser decodes them."""
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    for _msg_id, frame in hostile_packets(count, seed):
        yield from parser.parse_buffer(frame) or []


def test_every_message_type_is_covered_and_packs_with_a_valid_crc() -> None:
    ids = [msg.get_msgId() for msg in decoded(len(MESSAGE_TYPES), 3)]
    assert sorted(ids) == sorted(cls.id for cls in MESSAGE_TYPES)  # each decoded: the CRC was valid


def test_handlers_take_every_hostile_message_without_an_exception_and_keep_a_boats_state() -> None:
    """As if the packets came from the autopilot itself (a serial link: no address to tell them apart)."""
    state = StateEstimate()
    state.set_home(-35.363261, 149.165230)
    mission = MissionTracker(2.0, None, log=lambda _line: None)
    delay = DelayCompensator(True, False, 1.0, None)
    supervisor = Supervisor(0, 2.0, False)
    watch = RebootWatch(lambda _reason: None, log=lambda _line: None)
    seen = 0
    for i, msg in enumerate(decoded(3 * len(MESSAGE_TYPES), 5)):
        seen += 1
        state.on_message(msg)
        mission.on_message(msg)
        delay.on_message(msg)
        for heartbeat in watch.filter(msg, i * 0.01):
            supervisor.on_heartbeat(i * 0.01, bool(heartbeat.base_mode & 128), int(heartbeat.custom_mode))
        if state.ready():
            x = state.vector()
            assert np.all(np.isfinite(x)), (msg, x)
            assert np.all(np.abs(x[3:6]) <= math.pi + 0.01), (msg, x)
            state.motion_sample()
        delay.compensate(1.0)
    assert seen >= 3 * len(MESSAGE_TYPES)
    assert state.rejected > 0  # the impossible attitudes and positions were refused


def test_state_refuses_attitudes_and_velocities_no_boat_has() -> None:
    state = StateEstimate()
    for roll, rate in ((4.0, 0.0), (0.1, 40.0), (3.4e38, 0.0)):
        state.on_message(mavlink.MAVLink_attitude_message(1000, roll, 0.0, 0.0, rate, 0.0, 0.0))
    state.on_message(mavlink.MAVLink_local_position_ned_message(1000, 0, 0, 0, 3.4e38, 0.0, 0.0))
    assert state.rejected == 4 and state.attitude_ms is None and state.velocity_ms is None
    state.on_message(mavlink.MAVLink_attitude_message(1000, 0.2, 0.0, 3.1, 0.5, 0.0, 0.0))
    assert state.attitude_ms == 1000


_PACKERS: dict[tuple[int, int], mavlink.MAVLink] = {}


def _frame(src: tuple[int, int], msg: object) -> bytes:
    """``msg`` packed as ``src`` sends it (its own sequence numbers: a repeated one reads as a duplicate)."""
    packer = _PACKERS.setdefault(src, mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1]))
    frame = msg.pack(packer)  # type: ignore[attr-defined]
    packer.seq = (packer.seq + 1) % 256  # (pymavlink counts only in send())
    return frame


ROVER_HEARTBEAT = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                    1, 0, mavlink.MAV_STATE_STANDBY, 3)


def _receive(link: Link, kinds: list[str], timeout_s: float = 5.0) -> list[object]:
    """What the link passes on until nothing more arrives (each kind in ``kinds`` awaited)."""
    got: list[object] = []
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        msg = link.recv(0.2)
        if msg is not None:
            got.append(msg)
        elif all(any(m.get_type() == k for m in got) for k in kinds):  # type: ignore[attr-defined]
            break
    return got


def test_link_passes_only_the_autopilots_address_even_for_its_own_ids() -> None:
    port = free_port(socket.SOCK_DGRAM)
    link = Link(f"udpin:127.0.0.1:{port}", log=lambda _line: None)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as autopilot, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as hostile:
        try:
            autopilot.sendto(_frame((1, 1), ROVER_HEARTBEAT), ("127.0.0.1", port))
            assert [m.get_type() for m in _receive(link, ["HEARTBEAT"])] == ["HEARTBEAT"]
            forged = extreme_message(mavlink.MAVLink_attitude_message, random.Random(1))
            hostile.sendto(_frame((1, 1), forged), ("127.0.0.1", port))
            hostile.sendto(_frame((1, 1), ROVER_HEARTBEAT), ("127.0.0.1", port))  # not silent long enough
            autopilot.sendto(_frame((1, 1), mavlink.MAVLink_attitude_message(500, 0.1, 0, 0, 0, 0, 0)),
                             ("127.0.0.1", port))
            got = _receive(link, ["ATTITUDE"])
            assert [(m.get_type(), getattr(m, "time_boot_ms", None)) for m in got] == [("ATTITUDE", 500)]
            assert link.counts["foreign"] == 2
            time.sleep(ADDRESS_FORGET_S + 0.1)  # the autopilot falls silent (a restarted simulator, a new port)
            hostile.sendto(_frame((1, 1), ROVER_HEARTBEAT), ("127.0.0.1", port))
            assert [m.get_type() for m in _receive(link, ["HEARTBEAT"])] == ["HEARTBEAT"]
        finally:
            link.close()


@pytest.mark.parametrize("seed", [1, 2])
def test_flood_generator_is_seeded(seed: int) -> None:
    a = [frame for _, frame in hostile_packets(50, seed)]
    assert a == [frame for _, frame in hostile_packets(50, seed)]
    assert a != [frame for _, frame in hostile_packets(50, seed + 10)]


def _fitted(comp: DelayCompensator) -> float:
    """A second of arrivals at rate 1 ending now (the newest stamped 50.99 s); returns the wall time now."""
    now = time.monotonic()
    for i in range(100):
        comp.clock.observe(now - 0.99 + i * 0.01, 50.0 + i * 0.01)
    comp.clock.now_s()  # (the fit runs when asked)
    return now


def test_the_loops_read_takes_every_frame_of_a_datagram_and_does_not_rest_after_a_flood() -> None:
    """A datagram of several frames (ArduPilot packs them) is read whole, not one frame a read: after a rest the
    rest of it would wait a period. After a read that refused a flood the loop does not rest: ~200 datagrams
    fill the socket's buffer, and the autopilot's own would be dropped."""
    port = free_port(socket.SOCK_DGRAM)
    link = Link(f"udpin:127.0.0.1:{port}", log=lambda _line: None)
    comp = DelayCompensator(True, False, 1.0, None)
    seen: list[int] = []
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as autopilot, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as hostile:
        try:
            autopilot.sendto(_frame((1, 1), ROVER_HEARTBEAT), ("127.0.0.1", port))
            assert [m.get_type() for m in _receive(link, ["HEARTBEAT"])] == ["HEARTBEAT"]
            link.handlers.append(lambda m: seen.append(m.time_boot_ms) if m.get_type() == "ATTITUDE" else None)
            packed = b"".join(_frame((1, 1), mavlink.MAVLink_attitude_message(600 + i, 0, 0, 0, 0, 0, 0))
                              for i in range(3))
            autopilot.sendto(packed, ("127.0.0.1", port))  # (on loopback it is in the socket when sendto returns)
            comp.read(link, None, 0.1)
            assert seen == [600, 601, 602]
            for _ in range(40):
                hostile.sendto(_frame((7, 1), ROVER_HEARTBEAT), ("127.0.0.1", port))
            comp.read(link, None, 0.1)
            assert link.counts["foreign"] == 40
            assert comp.flooding
            attitude = mavlink.MAVLink_attitude_message(700, 0, 0, 0, 0, 0, 0)
            _fitted(comp)
            assert comp.pause_s(51.5, 1.0) > 0.0  # a rest is due (a 1 s period: a slow test still finds it due) ...
            autopilot.sendto(_frame((1, 1), attitude), ("127.0.0.1", port))
            comp.read(link, 51.5, 1.0)
            assert seen[-1] == 700 and not comp._overslept  # ... but not taken during the flood (none timed)
            time.sleep(FLOOD_WINDOW_S)  # a window of no refused message ...
            comp.read(link, None, 0.1)
            assert not comp.flooding  # ... ends it
            _fitted(comp)
            attitude.time_boot_ms = 701
            autopilot.sendto(_frame((1, 1), attitude), ("127.0.0.1", port))
            comp.read(link, 51.5, 1.0)  # this one rests, then reads what waited
            assert seen[-1] == 701 and len(comp._overslept) == 1
        finally:
            link.close()
