"""MAVLink 2 signing in the simulator, tested on the companion's UDP channel (never channel 0, which accepts
unsigned by design): a signed ARM is acknowledged; unsigned, wrong-key and replayed frames change nothing;
the key survives a restart; SETUP_SIGNING is refused while armed; TCP (channel 0) still accepts unsigned."""

from __future__ import annotations

import hashlib
import socket
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess
from sim_vehicle.mavlink.signing import ticks_from_unix_us
from tests.rover import ACCEPTED, ARM
from tests.waits import WaitTimeoutError, command

pytestmark = pytest.mark.integration
PASSPHRASE = "otter harbour test"
KEY = hashlib.sha256(PASSPHRASE.encode()).digest()
ATTEMPTS = 10_000
FORCE_ARM = 2989


def codec(key: bytes | None, link_id: int = 1, timestamp: int | None = None) -> mavlink.MAVLink:
    """A companion-side encoder (255/191), signing with ``key`` if given."""
    c = mavlink.MAVLink(None, srcSystem=255, srcComponent=191)
    if key is not None:
        c.signing.secret_key, c.signing.sign_outgoing, c.signing.link_id = key, True, link_id
        c.signing.timestamp = timestamp if timestamp is not None else ticks_from_unix_us(int(time.time() * 1e6))
    return c


def frame(c: mavlink.MAVLink, arm: bool) -> bytes:
    """One ARM (forced) or DISARM COMMAND_LONG to 1/1, framed (and signed) by ``c``."""
    msg = c.command_long_encode(1, 1, ARM, 0, 1.0 if arm else 0.0, FORCE_ARM if arm else 0.0, 0, 0, 0, 0, 0)
    data = bytes(msg.pack(c))
    c.seq = (c.seq + 1) % 256
    return data


class Peer:
    """A UDP socket on the simulator's companion output, reading with a codec that only accepts signed frames."""

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", port))
        self.sim: Any = None
        self.reader = codec(KEY)
        self.reader.signing.allow_unsigned_callback = None
        self.reader.robust_parsing = True
        self.unsigned = 0

    def send(self, data: bytes) -> None:
        assert self.sim is not None, "wait for the simulator first"
        self.sock.sendto(data, self.sim)

    def wait(self, what: str, cond, timeout_s: float = 10.0) -> Any:
        """The first signed message satisfying ``cond``; WaitTimeoutError naming ``what`` otherwise."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            self.sock.settimeout(left)
            try:
                data, self.sim = self.sock.recvfrom(4096)
            except TimeoutError:
                break
            for msg in self.reader.parse_buffer(data) or []:
                if msg.get_type() == "BAD_DATA":
                    self.unsigned += 1
                elif cond(msg):
                    return msg
        raise WaitTimeoutError(f"no signed {what} from the simulator within {timeout_s:g} s")

    def ack(self, timeout_s: float = 10.0) -> int:
        return int(self.wait("COMMAND_ACK", lambda m: m.get_type() == "COMMAND_ACK" and m.command == ARM,
                             timeout_s).result)

    def armed(self) -> bool:
        hb = self.wait("HEARTBEAT", lambda m: m.get_type() == "HEARTBEAT")
        return bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def flood(self, frames: list[bytes]) -> None:
        """Send paced (the receive buffer must not drop them before the simulator sees them)."""
        for i, data in enumerate(frames):
            self.send(data)
            if i % 100 == 99:
                time.sleep(0.005)


def signed_sim(tmp_path: Path, *extra: str) -> SimProcess:
    return SimProcess(tmp_path / "sim", speedup=5.0, extra=list(extra), udp_outs=1)


def test_signed_arm_is_acknowledged_and_forgeries_change_nothing(tmp_path: Path) -> None:
    sim = signed_sim(tmp_path, "--wipe", "--signing-passphrase", PASSPHRASE)
    peer = Peer(sim.udp_ports[0])
    with sim:
        peer.wait("HEARTBEAT", lambda m: m.get_type() == "HEARTBEAT", 30)  # signed telemetry arrives
        good = codec(KEY)
        captured = frame(good, arm=True)
        peer.send(captured)
        assert peer.ack() == ACCEPTED and peer.armed()
        peer.send(frame(good, arm=False))
        assert peer.ack() == ACCEPTED and not peer.armed()
        unsigned, wrong = codec(None), codec(hashlib.sha256(b"not the passphrase").digest(), timestamp=2**47)
        peer.flood([frame(unsigned, True) for _ in range(ATTEMPTS)])
        peer.flood([frame(wrong, True) for _ in range(ATTEMPTS)])  # far-future stamps: must not lock us out
        peer.flood([captured] * ATTEMPTS)  # replayed: its timestamp is behind the stream's
        with pytest.raises(WaitTimeoutError):
            peer.ack(timeout_s=2.0)  # none of the 30,000 was answered
        assert not peer.armed()
        peer.send(frame(good, arm=True))  # the genuine sender still gets through
        assert peer.ack() == ACCEPTED and peer.armed()
        assert peer.unsigned == 0, "everything the simulator sends is signed once a key is set"
        tcp = sim.connect()  # channel 0: unsigned is accepted (SITL's 5760)
        assert command(tcp, ARM, 0) == ACCEPTED
    assert '"_signing"' in (tmp_path / "sim" / "params.json").read_text()


def test_the_key_survives_a_restart_and_is_not_replaced_while_armed(tmp_path: Path) -> None:
    with signed_sim(tmp_path, "--wipe", "--signing-passphrase", PASSPHRASE):
        pass
    sim = signed_sim(tmp_path)  # the same parameter store, no passphrase given
    peer = Peer(sim.udp_ports[0])
    with sim:
        peer.wait("HEARTBEAT", lambda m: m.get_type() == "HEARTBEAT", 30)
        peer.send(frame(codec(None), arm=True))
        with pytest.raises(WaitTimeoutError):
            peer.ack(timeout_s=2.0)
        good = codec(KEY)
        peer.send(frame(good, arm=True))
        assert peer.ack() == ACCEPTED
        tcp = sim.connect()
        other = hashlib.sha256(b"a new key").digest()
        tcp.mav.setup_signing_send(1, 1, list(other), ticks_from_unix_us(int(time.time() * 1e6)))
        time.sleep(1.0)
        peer.send(frame(good, arm=False))  # the old key still works: the new one was refused (armed)
        assert peer.ack() == ACCEPTED and not peer.armed()
