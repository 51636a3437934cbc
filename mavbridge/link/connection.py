"""The companion's MAVLink link: one autopilot, heartbeats, requests with retries, a .tlog of both ways
(stamped on the autopilot's clock, ``mavbridge.link.tlog``).

Only messages from the autopilot found by the first ArduPilot Rover/boat HEARTBEAT are passed on;
garbage, bad CRCs and other systems or components are counted and dropped. Which datagrams are the
autopilot's (its pinned UDP address, duplicates and late heartbeats by sequence number) is decided in
``mavbridge.link.filter``; the retrying requests (COMMAND_LONG, PARAM_REQUEST_READ) are in
``mavbridge.link.requests``. ``Link`` holds those parts and keeps the one interface the companion uses.
"""

from __future__ import annotations

import os
import select
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

from mavbridge.link import requests as link_requests
from mavbridge.link.filter import AutopilotAddress, SequenceFilter, is_autopilot_heartbeat
from mavbridge.link.param_reads import ParamBudget
from mavbridge.link.retry import RETRY_KINDS, RetryPolicy, RetrySettings
from mavbridge.link.signing import LinkSettings, sign_link
from mavbridge.link.tlog import AutopilotClockTlog

mavlink = mavutil.mavlink
MAV_AUTOPILOT_INVALID = 8
MAV_COMP_ID_ONBOARD_COMPUTER = 191

Handler = Callable[[Any], None]


class LinkError(RuntimeError):
    """The link cannot do what was asked (no autopilot, no answer); one line for the user."""


def _connect(url: str, system_id: int, component_id: int, baud: int) -> Any:
    """pymavlink's connection for ``url`` as (system_id, component_id); a bad URL, port or device is a LinkError."""
    try:
        return mavutil.mavlink_connection(url, source_system=system_id, source_component=component_id,
                                          baud=baud, autoreconnect=True, dialect="ardupilotmega")
    except Exception as exc:  # pymavlink raises many kinds for bad URLs, ports and devices
        raise LinkError(f"connection {url!r}: {exc}") from None


def _open_tlog(tlog_path: str | Path | None, conn: Any) -> AutopilotClockTlog | None:
    """The .tlog of both ways (None without a path); a file that cannot be written closes ``conn``: LinkError."""
    try:
        return AutopilotClockTlog(tlog_path) if tlog_path else None
    except OSError as exc:
        conn.close()
        raise LinkError(f"{tlog_path}: cannot write the log ({exc.strerror or exc})") from None


class Link:
    """A pymavlink connection to one autopilot, with message filtering, logging and request helpers."""

    def __init__(self, url: str, system_id: int = 255, component_id: int = MAV_COMP_ID_ONBOARD_COMPUTER,
                 tlog_path: str | Path | None = None, baud: int = 921600, settings: RetrySettings | None = None,
                 log: Callable[[str], None] = print) -> None:
        self.conn = _connect(url, system_id, component_id, baud)
        self.url = url
        self.mav = self.conn.mav
        self.target: tuple[int, int] | None = None
        self._address = AutopilotAddress(self.conn)  # on a UDP server port: the autopilot's, the only one we write to
        self._sequence = SequenceFilter()
        self.system_id = system_id
        self.retry = settings.retry_policy() if settings is not None else RetryPolicy()
        # all parameter reads that decide the commands share it (``mavbridge.link.param_reads``)
        self.param_budget = ParamBudget(settings.param_budget_s if settings is not None else 60.0)
        key = settings.signing_key() if isinstance(settings, LinkSettings) else None
        self.signed = key is not None  # we sign, and accept only signed packets from the autopilot
        if key is not None:
            sign_link(self.conn, key)
        self.log = log  # give-up lines (one per abandoned request)
        self._tlog = _open_tlog(tlog_path, self.conn)
        self.mav.set_send_callback(self._log_sent)
        self.handlers: list[Handler] = []
        self.idle_hooks: list[Callable[[], None]] = []  # run between messages (never inside a handler)
        self.counts = {"accepted": 0, "foreign": 0, "bad": 0, "unsigned": 0, "stale": 0, "retries": 0,
                       **{f"retries_{kind}": 0 for kind in RETRY_KINDS}}
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
    def recv(self, timeout_s: float) -> Any | None:
        """The next message from the autopilot (after handlers ran), or None on timeout or a dropped one.

        ``timeout_s`` 0 does not wait at all.
        """
        try:
            msg = self.conn.recv_match(blocking=timeout_s > 0, timeout=timeout_s if timeout_s > 0 else None)
        except LinkError:  # a stop request (SIGTERM, Ctrl-C) raised by the signal handler while blocked here
            raise
        except Exception:  # a malformed frame must never kill the companion
            self.counts["bad"] += 1
            return None
        if msg is None:
            return None
        if msg.get_type() == "BAD_DATA":
            self.counts["unsigned" if "signature" in str(getattr(msg, "reason", "")) else "bad"] += 1
            return None
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.target is None and is_autopilot_heartbeat(msg):
            self.target = source
        if source != self.target or not self._address.admits(msg):
            self.counts["foreign"] += 1
            return None
        if self._sequence.out_of_order(msg):
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

    def pending(self) -> bool:
        """True if bytes wait in the socket or device, or pymavlink's own buffer holds what may be a whole frame (a
        datagram of several frames gives one per read: the rest stays there; a partial frame is ignored)."""
        mav = getattr(self.conn, "mav", None)
        if mav is not None and mav.buf_len() >= max(mav.expected_length, 1):
            return True
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
    def send(self, name: str, *args: Any) -> None:
        """Send message ``name`` (e.g. 'rc_channels_override') with its fields in order."""
        self._address.pin()  # on a UDP server port: to the autopilot's address only
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

    # -- requests that wait for an answer (mavbridge.link.requests) ----------------------------------
    def command_long(self, command: int, params: tuple[float, ...], policy: RetryPolicy | None = None) -> int | None:
        """COMMAND_LONG, resent until its COMMAND_ACK (``link_requests.command_long``); the result or None."""
        return link_requests.command_long(self, command, params, policy)

    def read_parameter(self, name: str, policy: RetryPolicy | None = None) -> float | None:
        """PARAM_REQUEST_READ by name, resent on each timeout (``link_requests.read_parameter``); value or None."""
        return link_requests.read_parameter(self, name, policy)

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
                        type_mask: int, body_yaw_rate: float = 0.0) -> None:
        """SET_ATTITUDE_TARGET (GUIDED): heading from the quaternion or the body yaw rate (rad/s), as
        ``type_mask`` says; thrust as a fraction of WP_SPEED."""
        assert self.target is not None
        self.send("set_attitude_target", time_boot_ms, self.target[0], self.target[1], type_mask,
                  list(quaternion), 0.0, 0.0, body_yaw_rate, thrust)
