"""The companion's MAVLink link: one autopilot, heartbeats, requests with retries, a .tlog of both ways
(stamped on the autopilot's clock, ``mavbridge.tlog``).

Only messages from the autopilot found by the first ArduPilot Rover/boat HEARTBEAT are passed on;
garbage, bad CRCs and other systems or components are counted and dropped. On a UDP server port
pymavlink writes to every address that ever sent a datagram; we send only to the autopilot's address,
so a stray sender on the port never receives our commands. That address is pinned at the autopilot's
first heartbeat, and a datagram from any other address is foreign even when it carries the autopilot's
system and component id (anyone can write those): another address takes over only with an autopilot
heartbeat after ADDRESS_FORGET_S without a word from the pinned one (a restarted simulator). On a
serial link there is no address to go by; MAVLink 2 signing is the defence there.
"""

from __future__ import annotations

import os
import select
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

from .retry import IN_PROGRESS_FACTOR, RetryPolicy, RetrySettings, ask, give_up_line
from .signing import LinkSettings, sign_link
from .tlog import AutopilotClockTlog

mavlink = mavutil.mavlink
MAV_AUTOPILOT_INVALID = 8
ROVER_TYPES = {mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_TYPE_SURFACE_BOAT}
MAV_COMP_ID_ONBOARD_COMPUTER = 191
SEQ_FORGET_S = 0.5  # wall seconds without a message from the autopilot after which its sequence restarts
SEQ_WINDOW = 64  # sequence numbers remembered for spotting duplicates (they wrap at 256)
ADDRESS_FORGET_S = 1.0  # wall seconds of silence from the autopilot's UDP address before another may take over


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

Handler = Callable[[Any], None]


def command_name(command: int) -> str:
    """MAV_CMD_... name of a command number (the number if the dialect has none)."""
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else str(command)


class LinkError(RuntimeError):
    """The link cannot do what was asked (no autopilot, no answer); one line for the user."""


class Link:
    """A pymavlink connection to one autopilot, with message filtering, logging and request helpers."""

    def __init__(self, url: str, system_id: int = 255, component_id: int = MAV_COMP_ID_ONBOARD_COMPUTER,
                 tlog_path: str | Path | None = None, baud: int = 921600, settings: RetrySettings | None = None,
                 log: Callable[[str], None] = print) -> None:
        try:
            self.conn = mavutil.mavlink_connection(url, source_system=system_id, source_component=component_id,
                                                   baud=baud, autoreconnect=True, dialect="ardupilotmega")
        except Exception as exc:  # pymavlink raises many kinds for bad URLs, ports and devices
            raise LinkError(f"connection {url!r}: {exc}") from None
        self.url = url
        self.mav = self.conn.mav
        self.target: tuple[int, int] | None = None
        self._autopilot_address: Any = None
        self._autopilot_seen = 0.0  # wall time of the last datagram from that address
        self._udp_server = isinstance(self.conn, mavutil.mavudp) and self.conn.udp_server
        if self._udp_server:
            self.conn.port = _AddressRecordingSocket(self.conn.port)
        self.system_id = system_id
        self.retry = settings.retry_policy() if settings is not None else RetryPolicy()
        key = settings.signing_key() if isinstance(settings, LinkSettings) else None
        self.signed = key is not None  # we sign, and accept only signed packets from the autopilot
        if key is not None:
            sign_link(self.conn, key)
        self.log = log  # give-up lines (one per abandoned request)
        try:
            self._tlog = AutopilotClockTlog(tlog_path) if tlog_path else None
        except OSError as exc:
            self.conn.close()
            raise LinkError(f"{tlog_path}: cannot write the log ({exc.strerror or exc})") from None
        self.mav.set_send_callback(self._log_sent)
        self.handlers: list[Handler] = []
        self.idle_hooks: list[Callable[[], None]] = []  # run between messages (never inside a handler)
        self.counts = {"accepted": 0, "foreign": 0, "bad": 0, "unsigned": 0, "stale": 0, "retries": 0}
        self._last_seq: int | None = None
        self._last_seq_wall = 0.0
        self._recent_seqs: deque[int] = deque(maxlen=SEQ_WINDOW)
        self.rates: dict[str, int] = {}
        self._last_heartbeat_sent = 0.0

    # -- logging ----------------------------------------------------------------------------------
    def _write_tlog(self, data: bytes) -> None:
        if self._tlog is not None:
            self._tlog.write(data)

    def _log_sent(self, msg: Any, *args: Any, **kwargs: Any) -> None:
        self._write_tlog(msg.get_msgbuf())

    def close(self) -> None:
        """Close the connection and the log."""
        if self._tlog is not None:
            self._tlog.close()
            self._tlog = None
        self.conn.close()

    # -- receiving --------------------------------------------------------------------------------
    def _is_autopilot_heartbeat(self, msg: Any) -> bool:
        """An ArduPilot Rover or boat (a gimbal, radio or GCS on the link is not the autopilot)."""
        return (msg.get_type() == "HEARTBEAT" and msg.autopilot == mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
                and msg.type in ROVER_TYPES)

    def recv(self, timeout_s: float) -> Any | None:
        """The next message from the autopilot (after handlers ran), or None on timeout or a dropped one.

        ``timeout_s`` 0 does not wait at all.
        """
        try:
            msg = self.conn.recv_match(blocking=timeout_s > 0, timeout=timeout_s if timeout_s > 0 else None)
        except Exception:  # a malformed frame must never kill the companion
            self.counts["bad"] += 1
            return None
        if msg is None:
            return None
        if msg.get_type() == "BAD_DATA":
            self.counts["unsigned" if "signature" in str(getattr(msg, "reason", "")) else "bad"] += 1
            return None
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.target is None and self._is_autopilot_heartbeat(msg):
            self.target = source
        if source != self.target or not self._from_autopilot_address(msg):
            self.counts["foreign"] += 1
            return None
        if self._out_of_order(msg):
            self.counts["stale"] += 1
            return None
        if self._tlog is not None:
            self._tlog.heard(msg)  # its time_boot_ms is the tlog's clock (on the autopilot's time)
        self._write_tlog(msg.get_msgbuf())
        self.counts["accepted"] += 1
        self.rates[msg.get_type()] = self.rates.get(msg.get_type(), 0) + 1
        for handler in self.handlers:
            handler(msg)
        return msg

    def _from_autopilot_address(self, msg: Any) -> bool:
        """True unless, on a UDP server port, the datagram came from another address than the autopilot's
        (pinned at its first heartbeat; re-pinned by an autopilot heartbeat after ADDRESS_FORGET_S of silence)."""
        if not self._udp_server:
            return True
        sender, now = self.conn.port.last_sender, time.monotonic()
        if sender != self._autopilot_address and self._is_autopilot_heartbeat(msg) and \
                (self._autopilot_address is None or now - self._autopilot_seen >= ADDRESS_FORGET_S):
            self._autopilot_address = sender
        if sender != self._autopilot_address:
            return False
        self._autopilot_seen = now
        return True

    def _out_of_order(self, msg: Any) -> bool:
        """A datagram the link duplicated (its MAVLink sequence number among the last SEQ_WINDOW seen), or a
        HEARTBEAT delivered late (its number behind the newest): a stale one from before arming must not read
        as a disarm. Other late messages still count (an ACK is an ACK; telemetry carries its own time).
        After SEQ_FORGET_S of silence (an outage, a reboot) numbering starts afresh."""
        seq, now = msg.get_seq(), time.monotonic()
        if now - self._last_seq_wall >= SEQ_FORGET_S:
            self._recent_seqs.clear()
            self._last_seq = None
        self._last_seq_wall = now
        if seq in self._recent_seqs:
            return True
        self._recent_seqs.append(seq)
        behind = self._last_seq is not None and (seq - self._last_seq) % 256 >= 128
        if not behind:
            self._last_seq = seq
        return behind and msg.get_type() == "HEARTBEAT"

    def pending(self) -> bool:
        """True if bytes wait in the socket or device (pymavlink's own buffer may hold a partial frame: ignored)."""
        fd = getattr(self.conn, "fd", None)
        if fd is None:
            return False
        try:
            return bool(select.select([fd], [], [], 0)[0])
        except (OSError, ValueError):
            return False

    def drain(self, limit: int = 5000) -> int:
        """Process everything already received (handlers run); returns how many reads it took."""
        reads = 0
        while reads < limit and self.pending():
            self.recv(0)
            reads += 1
        return reads

    def wait_for(self, predicate: Callable[[Any], bool], timeout_s: float) -> Any | None:
        """Receive until ``predicate(msg)`` holds or the timeout passes; other messages still reach handlers."""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            self.heartbeat_if_due()
            msg = self.recv(min(left, 0.1))
            if msg is not None and predicate(msg):
                return msg
        return None

    def wait_autopilot(self, timeout_s: float) -> tuple[int, int]:
        """Block until an autopilot's heartbeat arrives; returns its (system, component)."""
        if self.wait_for(lambda m: m.get_type() == "HEARTBEAT", timeout_s) is None or self.target is None:
            raise LinkError(f"no autopilot heartbeat on {self.url} within {timeout_s:g} s")
        return self.target

    # -- sending ----------------------------------------------------------------------------------
    def _pin(self) -> None:
        """On a UDP server port, write only to the autopilot's address."""
        if self._udp_server and self._autopilot_address is not None:
            self.conn.clients = {self._autopilot_address}
            self.conn.clients_last_alive[self._autopilot_address] = time.time()

    def send(self, name: str, *args: Any) -> None:
        """Send message ``name`` (e.g. 'rc_channels_override') with its fields in order."""
        self._pin()
        getattr(self.mav, f"{name}_send")(*args)

    def heartbeat_if_due(self, period_s: float = 1.0) -> None:
        """Our 1 Hz HEARTBEAT as an onboard controller (wall clock: it is a link-level signal); the idle hooks
        run first (this is called between messages, from the loop and from every wait)."""
        for hook in self.idle_hooks:
            hook()
        now = time.monotonic()
        if now - self._last_heartbeat_sent >= period_s:
            self._last_heartbeat_sent = now
            self.send("heartbeat", mavlink.MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID, 0, 0,
                      mavlink.MAV_STATE_ACTIVE)

    def _count_retry(self) -> None:
        self.counts["retries"] += 1

    def command_long(self, command: int, params: tuple[float, ...], policy: RetryPolicy | None = None) -> int | None:
        """COMMAND_LONG to the autopilot, resent (``confirmation`` + 1) until a COMMAND_ACK for it arrives.

        After MAV_RESULT_IN_PROGRESS nothing is resent; the final ACK is awaited ten timeouts. Returns the
        result, or None after the last try (one line says so).
        """
        assert self.target is not None, "wait_autopilot() first"
        policy = policy or self.retry
        target = self.target
        p = list(params) + [0.0] * (7 - len(params))
        name = command_name(command)
        self.drain()  # a late or duplicated ACK of an earlier command must not stand for this one

        def is_ack(m: Any) -> bool:
            return (m.get_type() == "COMMAND_ACK" and m.command == command
                    and getattr(m, "target_system", 0) in (0, self.system_id))

        ack, tries = ask(lambda attempt: self.send("command_long", target[0], target[1], command, min(attempt, 255),
                                                   *p), self.wait_for, is_ack, policy, self._count_retry)
        if ack is not None and ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
            wait_s = policy.timeout_s * IN_PROGRESS_FACTOR
            ack = self.wait_for(lambda m: is_ack(m) and m.result != mavlink.MAV_RESULT_IN_PROGRESS, wait_s)
            if ack is None:
                self.log(f"link: COMMAND_LONG {name}: IN_PROGRESS, then no final COMMAND_ACK within {wait_s:g} s")
                return None
        if ack is None:
            self.log(give_up_line(f"COMMAND_LONG {name}", "COMMAND_ACK", tries, policy.timeout_s))
            return None
        return int(ack.result)

    def read_optional_parameter(self, name: str) -> float | None:
        """A parameter that older firmware (or a simulator) may not have: asked briefly, silent if absent."""
        return self.read_parameter(name, self.retry.for_optional(), quiet=True)

    def read_parameter(self, name: str, policy: RetryPolicy | None = None, quiet: bool = False) -> float | None:
        """PARAM_REQUEST_READ by name, resent on each timeout; the value, or None when no answer came."""
        assert self.target is not None, "wait_autopilot() first"
        policy = policy or self.retry
        target = self.target
        reply, tries = ask(lambda _attempt: self.send("param_request_read", target[0], target[1], name.encode(), -1),
                           self.wait_for, lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, policy,
                           (lambda: None) if quiet else self._count_retry)  # absent optional ones are no retries
        if reply is None:
            if not quiet:
                self.log(give_up_line(f"PARAM_REQUEST_READ {name}", "PARAM_VALUE", tries, policy.timeout_s))
            return None
        return float(reply.param_value)

    def set_mode(self, custom_mode: int) -> int | None:
        """MAV_CMD_DO_SET_MODE with the custom-mode flag; returns the ACK result."""
        return self.command_long(mavlink.MAV_CMD_DO_SET_MODE,
                                 (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom_mode))

    def arm(self) -> int | None:
        """MAV_CMD_COMPONENT_ARM_DISARM p1 = 1 (with the autopilot's checks); returns the ACK result."""
        return self.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))

    def request_message_interval(self, msg_id: int, rate_hz: float) -> bool:
        """SET_MESSAGE_INTERVAL via MAV_CMD_SET_MESSAGE_INTERVAL; True if ACCEPTED."""
        result = self.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, 1e6 / rate_hz))
        return result == mavlink.MAV_RESULT_ACCEPTED

    def request_data_stream(self, stream_id: int, rate_hz: int) -> None:
        """The older REQUEST_DATA_STREAM (ArduPilot's SRn_ rates); no answer exists for it."""
        assert self.target is not None
        self.send("request_data_stream", self.target[0], self.target[1], stream_id, rate_hz, 1)

    def rc_override(self, channels: dict[int, int]) -> None:
        """RC_CHANNELS_OVERRIDE of some of channels 1-8 ({channel: PWM}, 0 releases); others unchanged."""
        assert self.target is not None
        keep = 65535  # UINT16_MAX: "leave unchanged" on channels 1-8
        values = [channels.get(n, keep) for n in range(1, 9)]
        self.send("rc_channels_override", self.target[0], self.target[1], *values)

    def attitude_target(self, time_boot_ms: int, quaternion: tuple[float, float, float, float], thrust: float,
                        type_mask: int) -> None:
        """SET_ATTITUDE_TARGET (GUIDED): heading from the quaternion, thrust as a fraction of WP_SPEED."""
        assert self.target is not None
        self.send("set_attitude_target", time_boot_ms, self.target[0], self.target[1], type_mask,
                  list(quaternion), 0.0, 0.0, 0.0, thrust)
