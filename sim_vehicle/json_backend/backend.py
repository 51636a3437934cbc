"""``sim-vehicle --json-backend``: the Otter's physics for the real ArduPilot Rover firmware, in lockstep.

ArduPilot SITL started with ``--model JSON:HOST`` sends a servo packet per physics frame and waits for
the sensor reply (see ``json_backend_protocol`` for the format). The rules here:

- a new frame_count steps the plant by 1/frame_rate with SERVO1/SERVO3 as left/right thrusters;
- the same frame_count again (the firmware re-sends after a second without a reply) is answered
  with the last state, without stepping;
- a lower frame_count means the firmware restarted: the run starts again from the initial state;
- a gap (frames the firmware counted but we never saw) is counted; the plant still steps once;
- a packet of the wrong size or magic, or with a frame rate outside 1–2000 Hz, is counted and never
  answered. The first of each kind is logged in one line.

No MAVLink here: the firmware speaks MAVLink itself (TCP 5760, and MAVProxy's UDP outputs).
"""

from __future__ import annotations

import logging
import socket
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field

from sim_vehicle.json_backend.log import JsonStateCsv
from sim_vehicle.json_backend.model import JsonPhysics
from sim_vehicle.json_backend.protocol import (
    LEFT_CHANNEL,
    RIGHT_CHANNEL,
    BadPacketError,
    encode_reply,
    motor_outputs,
    parse_servo_packet,
)

log = logging.getLogger("sim_vehicle")
RECV_TIMEOUT_S = 0.2
CSV_FLUSH_S = 1.0
MAX_DATAGRAM = 2048


@dataclass
class BackendStats:
    """What the backend did with the packets it received."""

    stepped: int = 0
    repeats: int = 0
    resets: int = 0
    skipped: int = 0
    rate_changes: int = 0
    bad: Counter[str] = field(default_factory=Counter)

    def summary(self, t: float) -> str:
        """One line for the log at shutdown."""
        bad = ", ".join(f"{k} {v}" for k, v in sorted(self.bad.items())) or "none"
        return (f"json-backend: {self.stepped} frames stepped (t = {t:.6f} s), {self.repeats} repeats, "
                f"{self.resets} resets, {self.skipped} skipped, {self.rate_changes} rate changes, "
                f"bad packets: {bad}")


class JsonBackend:
    """The lockstep rules, from datagram to reply; no sockets, so tests can drive it directly too."""

    def __init__(self, physics: JsonPhysics, state_csv: JsonStateCsv | None = None) -> None:
        self.physics = physics
        self.csv = state_csv
        self.stats = BackendStats()
        self.last_count: int | None = None
        self.last_rate: int | None = None
        self.last_reply: bytes | None = None

    def handle(self, data: bytes) -> bytes | None:
        """The reply to one datagram, or None when it is not a servo packet we can use."""
        try:
            frame = parse_servo_packet(data)
        except BadPacketError as exc:
            if self.stats.bad[exc.reason] == 0:
                log.warning("json-backend: ignoring a bad packet (%s); further ones are only counted", exc)
            self.stats.bad[exc.reason] += 1
            return None
        if frame.frame_count == self.last_count and self.last_reply is not None:
            self.stats.repeats += 1
            return self.last_reply
        self._new_frame(frame.frame_count, frame.frame_rate_hz)
        outputs = motor_outputs(frame)
        self.physics.step(outputs, frame.dt_s)
        self.stats.stepped += 1
        self.last_count = frame.frame_count
        self.last_reply = encode_reply(self.physics.reply_values())
        if self.csv is not None:
            pwm = (frame.pwm_us[LEFT_CHANNEL], frame.pwm_us[RIGHT_CHANNEL])
            self.csv.write(self.physics.time, self.physics.state, self.physics.n_cmd, frame.frame_count, pwm)
        return self.last_reply

    def _new_frame(self, count: int, rate: int) -> None:
        """Bookkeeping before a step: restart, gap and frame-rate change."""
        if self.last_count is None or count < self.last_count:
            if self.last_count is not None:
                log.info("json-backend: frame count fell from %d to %d: firmware restarted, run reset",
                         self.last_count, count)
                self.stats.resets += 1
                self.physics.reset()
            if self.csv is not None:
                self.csv.new_run()
        elif count > self.last_count + 1:
            self.stats.skipped += count - self.last_count - 1
        if self.last_rate is not None and rate != self.last_rate:
            log.info("json-backend: frame rate %d Hz -> %d Hz", self.last_rate, rate)
            self.stats.rate_changes += 1
        self.last_rate = rate


def open_socket(host: str, port: int) -> socket.socket:
    """The UDP socket the firmware sends to; OSError (e.g. the port is in use) propagates."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.bind((host, port))
    except OSError:
        sock.close()
        raise
    sock.settimeout(RECV_TIMEOUT_S)
    return sock


def serve(backend: JsonBackend, sock: socket.socket, running: Callable[[], bool],
          duration_s: float | None = None) -> None:
    """Answer servo packets until ``running()`` is false or ``duration_s`` of physics time has passed."""
    last_flush = time.monotonic()
    while running():
        if duration_s is not None and backend.physics.time >= duration_s:
            break
        try:
            data, address = sock.recvfrom(MAX_DATAGRAM)
        except TimeoutError:
            continue
        except ConnectionResetError:  # an ICMP "port unreachable" from a previous reply (some OSes)
            continue
        reply = backend.handle(data)
        if reply is not None:
            sock.sendto(reply, address)
        if backend.csv is not None and time.monotonic() - last_flush > CSV_FLUSH_S:
            backend.csv.flush()
            last_flush = time.monotonic()
