"""Which datagrams on the companion's link are the autopilot's: the UDP address it speaks from, and the MAVLink
sequence numbers that give away a duplicated or late datagram.

On a UDP server port pymavlink writes to every address that ever sent a datagram; ``AutopilotAddress`` makes the
link write only to the autopilot's, so a stray sender on the port never receives our commands. That address is
pinned at the autopilot's first heartbeat, and a datagram from any other address is foreign even when it carries
the autopilot's system and component id (anyone can write those): another address takes over only with an
autopilot heartbeat after ADDRESS_FORGET_S without a word from the pinned one (a restarted simulator). On a
serial link there is no address to go by; MAVLink 2 signing is the defence there.
"""

from __future__ import annotations

import os
import time
from collections import deque
from typing import Any

os.environ.setdefault("MAVLINK20", "1")  # before pymavlink is imported (as in mavbridge.link.connection)
from pymavlink import mavutil

mavlink = mavutil.mavlink
ROVER_TYPES = {mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_TYPE_SURFACE_BOAT}
SEQ_FORGET_S = 0.5  # wall seconds without a message from the autopilot after which its sequence restarts
SEQ_WINDOW = 64  # sequence numbers remembered for spotting duplicates (they wrap at 256)
ADDRESS_FORGET_S = 1.0  # wall seconds of silence from the autopilot's UDP address before another may take over


def is_autopilot_heartbeat(msg: Any) -> bool:
    """An ArduPilot Rover or boat's HEARTBEAT (a gimbal, radio or GCS on the link is not the autopilot)."""
    return (msg.get_type() == "HEARTBEAT" and msg.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
            and msg.type in ROVER_TYPES)


class _AddressRecordingSocket:
    """Wraps a UDP socket so the sender of the last datagram read is known (pymavlink keeps only a set)."""

    def __init__(self, sock: Any) -> None:
        self._sock = sock
        self.last_sender: Any = None

    def recvfrom(self, size: int) -> tuple[bytes, Any]:
        data, address = self._sock.recvfrom(size)
        self.last_sender = address
        return data, address

    def __getattr__(self, name: str) -> Any:
        return getattr(self._sock, name)


class AutopilotAddress:
    """The autopilot's UDP address on a server port (pinned, re-pinned after silence) and the only one we write to.

    On any other connection (a client URL, a serial device) every datagram passes and nothing is pinned.
    """

    def __init__(self, conn: Any) -> None:
        self._conn = conn
        self.udp_server = isinstance(conn, mavutil.mavudp) and conn.udp_server
        if self.udp_server:
            conn.port = _AddressRecordingSocket(conn.port)
        self.address: Any = None
        self._seen = 0.0  # wall time of the last datagram from that address

    def admits(self, msg: Any) -> bool:
        """True unless, on a UDP server port, the datagram came from another address than the autopilot's
        (pinned at its first heartbeat; re-pinned by an autopilot heartbeat after ADDRESS_FORGET_S of silence)."""
        if not self.udp_server:
            return True
        sender, now = self._conn.port.last_sender, time.monotonic()
        if sender != self.address and is_autopilot_heartbeat(msg) and \
                (self.address is None or now - self._seen >= ADDRESS_FORGET_S):
            self.address = sender
        if sender != self.address:
            return False
        self._seen = now
        return True

    def pin(self) -> None:
        """Before a send on a UDP server port: write only to the autopilot's address (once it is known)."""
        if self.udp_server and self.address is not None:
            self._conn.clients = {self.address}
            self._conn.clients_last_alive[self.address] = time.time()


class SequenceFilter:
    """Spots datagrams the link duplicated or delivered late, by the autopilot's MAVLink sequence numbers."""

    def __init__(self) -> None:
        self._last_seq: int | None = None
        self._last_wall = 0.0
        self._recent: deque[int] = deque(maxlen=SEQ_WINDOW)

    def out_of_order(self, msg: Any) -> bool:
        """A datagram the link duplicated (its MAVLink sequence number among the last SEQ_WINDOW seen), or a
        HEARTBEAT delivered late (its number behind the newest): a stale one from before arming must not read
        as a disarm. Other late messages still count (an ACK is an ACK; telemetry carries its own time).
        After SEQ_FORGET_S of silence (an outage, a reboot) numbering starts afresh."""
        seq, now = msg.get_seq(), time.monotonic()
        if now - self._last_wall >= SEQ_FORGET_S:
            self._recent.clear()
            self._last_seq = None
        self._last_wall = now
        if seq in self._recent:
            return True
        self._recent.append(seq)
        behind = self._last_seq is not None and (seq - self._last_seq) % 256 >= 128
        if not behind:
            self._last_seq = seq
        return behind and msg.get_type() == "HEARTBEAT"
