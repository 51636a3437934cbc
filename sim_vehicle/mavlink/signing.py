"""MAVLink 2 signing as ArduPilot does it: SETUP_SIGNING, a stored key, signed output, checked input.

SETUP_SIGNING (refused while armed) stores {key, timestamp} with the parameters and applies to every
channel: from then on everything sent is signed, and what arrives must carry a valid signature — except
on channel 0 (the TCP port, SITL's 5760: USB on a flight controller), and for RADIO_STATUS, which a
telemetry radio injects unsigned. An all-zero key with timestamp 0 switches signing off.

Timestamps are 10 µs units since 2015-01-01 UTC. The stored one is refreshed every STORE_EVERY_S of
simulated time and raised by 60 s when loaded (the clock must never repeat a value after a restart);
it is also raised to the simulated wall clock. The signature is checked before the timestamp is
taken into account, so a forged frame cannot push a stream's timestamp ahead and lock the sender out.
"""

from __future__ import annotations

import hashlib
import logging
import time
import types
from collections.abc import Callable, Iterable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.rover.params import ParamTable
from vessel.config import ConfigError

EPOCH_2015_S = 1_420_070_400
TICKS_PER_S = 100_000  # 10 µs
LOAD_MARGIN = 60 * TICKS_PER_S
NEW_STREAM_SLACK = 60 * TICKS_PER_S  # a new stream may start at most a minute behind our clock
STORE_EVERY_S = 30.0
UNSIGNED_CHANNEL = 0
log = logging.getLogger("sim_vehicle")


def key_from_passphrase(passphrase: str) -> bytes:
    """The 32-byte key MAVProxy's `signing setup` makes from a passphrase: SHA-256 of its UTF-8 bytes."""
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


def ticks_from_unix_us(unix_us: int) -> int:
    """A signing timestamp for a Unix time in µs."""
    return max(0, (unix_us - EPOCH_2015_S * 1_000_000) // 10)


def check_signature(codec: mavlink.MAVLink, msgbuf: bytearray, src_system: int, src_component: int) -> bool:
    """Signature first (first 48 bits of SHA-256(key ‖ frame without its last 6 bytes)), then replay rules:
    a stream's (link id, system, component) timestamps strictly increase; a new stream at most a minute behind."""
    signing = codec.signing
    digest = hashlib.sha256(bytes(signing.secret_key) + bytes(msgbuf[:-6])).digest()[:6]
    if digest != bytes(msgbuf[-6:]):
        return False
    stream = (msgbuf[-13], src_system, src_component)
    stamp = int.from_bytes(bytes(msgbuf[-12:-6]), "little")
    last = signing.stream_timestamps.get(stream)
    if (last is not None and stamp <= last) or (last is None and stamp + NEW_STREAM_SLACK < signing.timestamp):
        return False
    signing.stream_timestamps[stream] = stamp
    signing.timestamp = max(signing.timestamp, stamp)
    return True


def store_signing_passphrase(params: ParamTable, passphrase: str) -> None:
    """`sim-vehicle --signing-passphrase`: the setup SETUP_SIGNING would make, stored before start."""
    if not passphrase:
        raise ConfigError("--signing-passphrase: empty; give the passphrase (at least one character)")
    params.save_storage("signing", {"key": key_from_passphrase(passphrase).hex(),
                                    "timestamp": ticks_from_unix_us(int(time.time() * 1e6))})


class Signing:
    """The vehicle's signing state, applied to each channel's codec."""

    def __init__(self, params: ParamTable, armed: Callable[[], bool], text: Callable[[int, str], None],
                 unix_us: Callable[[], int]) -> None:
        self.params, self.armed, self.text, self.unix_us = params, armed, text, unix_us
        record = params.storage.get("signing") or {}
        try:
            self.key: bytes | None = bytes.fromhex(record["key"]) if record else None
            self.timestamp = int(record.get("timestamp", 0)) + (LOAD_MARGIN if record else 0)
        except (KeyError, TypeError, ValueError):
            log.warning("stored signing record unreadable: signing off")
            self.key, self.timestamp = None, 0
        self._stored_at_s = 0.0
        self._applied: dict[int, bytes | None] = {}

    @property
    def enabled(self) -> bool:
        """True once a key is set."""
        return self.key is not None

    def handle_setup(self, channel: Any, msg: mavlink.MAVLink_message) -> None:
        """SETUP_SIGNING: store and apply the key (or switch off with an all-zero key and timestamp 0)."""
        if self.armed():
            self.text(mavlink.MAV_SEVERITY_WARNING, "Signing: refused while armed")
            return
        key = bytes(msg.secret_key)
        if not any(key) and msg.initial_timestamp == 0:
            self.key, self.timestamp = None, 0
            self.params.save_storage("signing", None)
            self.text(mavlink.MAV_SEVERITY_INFO, "Signing: disabled")
            return
        self.key = key
        self.timestamp = max(self.timestamp, int(msg.initial_timestamp), ticks_from_unix_us(self.unix_us()))
        self._store()
        self.text(mavlink.MAV_SEVERITY_INFO, "Signing: key set")

    def _store(self) -> None:
        self.params.save_storage("signing", {"key": self.key.hex() if self.key else "", "timestamp": self.timestamp})

    def update(self, channels: Iterable[Any], now_s: float) -> None:
        """Apply the key to channels that do not have it yet; store the timestamp every STORE_EVERY_S."""
        for channel in channels:
            if self._applied.get(id(channel.codec), b"unset") != self.key:
                self._apply(channel)
        if self.key is not None and now_s - self._stored_at_s >= STORE_EVERY_S:
            self._stored_at_s = now_s
            codec_stamps = [c.codec.signing.timestamp for c in channels if c.codec.signing.secret_key is not None]
            self.timestamp = max([self.timestamp, ticks_from_unix_us(self.unix_us()), *codec_stamps])
            self._store()

    def _apply(self, channel: Any) -> None:
        codec, index = channel.codec, channel.index
        signing = codec.signing
        signing.secret_key = self.key
        signing.sign_outgoing = self.key is not None
        signing.link_id = index % 256
        signing.timestamp = max(signing.timestamp, self.timestamp, ticks_from_unix_us(self.unix_us()))
        signing.stream_timestamps = {}
        if index == UNSIGNED_CHANNEL:
            signing.allow_unsigned_callback = lambda _mav, _msg_id: True
        else:
            signing.allow_unsigned_callback = lambda _mav, msg_id: msg_id == mavlink.MAVLINK_MSG_ID_RADIO_STATUS
        codec.check_signature = types.MethodType(check_signature, codec)
        self._applied[id(codec)] = self.key
