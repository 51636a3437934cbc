"""Robustness: thousands of random and mutated packets over TCP and UDP, then the vehicle still answers."""

from __future__ import annotations

import math
import random
import socket
import time

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess
from tests.rover import ARM
from tests.waits import command, wait_for

N_PACKETS = 12000
SPECIAL = [float("nan"), float("inf"), -float("inf"), 0.0, -1.0, 1.0, 1e38, -1e38, 2989.0, 21196.0]


def _f(rng: random.Random) -> float:
    return rng.choice(SPECIAL) if rng.random() < 0.4 else rng.uniform(-1e5, 1e5)


def _valid_packet(rng: random.Random, codec: mavlink.MAVLink) -> bytes:
    """A well-formed packet with hostile field values."""
    u16 = lambda: rng.choice([0, 65535, 65534, 5000, 900, 1500, rng.randrange(65536)])  # noqa: E731
    kind = rng.randrange(9)
    if kind == 0:
        cmd = rng.choice([400, 176, 511, 510, 512, 410, 520, 300, 20, 178, 224, rng.randrange(65536)])
        msg = codec.command_long_encode(
            rng.choice([0, 1, 7]), rng.choice([0, 1]), cmd, 0, *(_f(rng) for _ in range(7))
        )
    elif kind == 1:
        msg = codec.rc_channels_override_encode(1, 1, *(u16() for _ in range(18)))
    elif kind == 2:
        q = [_f(rng) for _ in range(4)]
        msg = codec.set_attitude_target_encode(
            0, 1, 1, rng.randrange(256), q, _f(rng), _f(rng), _f(rng), _f(rng)
        )
    elif kind == 3:
        msg = codec.set_mode_encode(
            1, rng.randrange(256), rng.choice([99, 0, 4, 15, 10, 11, rng.randrange(2**32)])
        )
    elif kind == 4:
        name = rng.choice(
            [b"WP_SPEED", b"FRAME_CLASS", b"CRUISE_THROTTLE", bytes(rng.randrange(256) for _ in range(16))]
        )
        msg = codec.param_set_encode(1, 1, name, _f(rng), rng.randrange(256))
    elif kind == 5:
        msg = codec.param_request_read_encode(
            1, 1, bytes(rng.randrange(32, 127) for _ in range(16)), rng.randrange(-32768, 32768)
        )
    elif kind == 6:
        msg = codec.mission_count_encode(
            1, 1, rng.choice([0, 1, 3, 65535, rng.randrange(65536)]), rng.choice([0, 1, 2, 3, 255])
        )
    elif kind == 7:
        msg = codec.mission_item_int_encode(
            1,
            1,
            rng.randrange(5),
            rng.randrange(20),
            rng.randrange(65536),
            0,
            1,
            *(_f(rng) for _ in range(4)),
            rng.randrange(-(2**31), 2**31),
            rng.randrange(-(2**31), 2**31),
            _f(rng),
            rng.choice([0, 1, 2, 9]),
        )
    else:
        msg = codec.request_data_stream_encode(
            1, 1, rng.randrange(256), rng.randrange(65536), rng.randrange(3)
        )
    return bytes(msg.pack(codec))


def _packet(rng: random.Random, codec: mavlink.MAVLink) -> bytes:
    """Random bytes, a valid packet, or a valid packet with bytes flipped, cut or an unknown id."""
    choice = rng.random()
    if choice < 0.25:
        return bytes(rng.randrange(256) for _ in range(rng.randrange(1, 80)))
    data = bytearray(_valid_packet(rng, codec))
    if choice < 0.55:
        return bytes(data)
    if choice < 0.75:
        for _ in range(rng.randrange(1, 4)):
            data[rng.randrange(len(data))] = rng.randrange(256)  # mostly bad CRCs
    elif choice < 0.85:
        data = data[: rng.randrange(1, len(data))]
    else:
        data[7:10] = rng.randrange(20000, 2**24).to_bytes(3, "little")  # unknown message id
    return bytes(data)


def test_fuzz_then_still_answers(tmp_path) -> None:
    """≥10 000 hostile packets over TCP and UDP: no crash or traceback; heartbeat and PARAM_VALUE after."""
    rng = random.Random(20240611)
    with SimProcess(tmp_path, speedup=5, udp_outs=1) as sim:
        codec = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        tcp = socket.create_connection(("127.0.0.1", sim.tcp_port), timeout=5)
        tcp.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 16)
        udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        udp.bind(("127.0.0.1", sim.udp_ports[0]))
        udp.settimeout(5)
        _, sim_addr = udp.recvfrom(65536)  # the vehicle's UDP output talks to us first
        tcp.setblocking(False)
        for i in range(N_PACKETS):
            packet = _packet(rng, codec)
            if i % 2:
                udp.sendto(packet, sim_addr)
            else:
                try:
                    tcp.sendall(packet)
                except BlockingIOError:
                    time.sleep(0.01)
                try:
                    while tcp.recv(65536):  # keep the vehicle's replies flowing
                        pass
                except (BlockingIOError, OSError):
                    pass
            if i % 500 == 0:
                time.sleep(0.02)
        tcp.close()
        udp.close()
        assert sim.proc is not None and sim.proc.poll() is None
        conn = sim.connect()
        heartbeat = wait_for(conn, "HEARTBEAT", 5, lambda m: m.get_srcSystem() == 1)
        assert heartbeat.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
        conn.mav.param_request_read_send(1, 1, b"SYSID_THISMAV", -1)
        value = wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "SYSID_THISMAV")
        assert value.param_value == 1
        assert command(conn, ARM, 0, 21196) == 0
        err = sim.stop()
    assert "Traceback" not in err, err[-2000:]
    assert not math.isnan(value.param_value)
