"""MAVLink 2 signing on the companion's side: the key from a passphrase file, and checking what arrives.

The key is SHA-256 of the passphrase (as MAVProxy's `signing setup` makes it), so a passphrase already
set up on the autopilot with MAVProxy works here. Once signing is on, everything the companion sends is
signed and a packet from the autopilot must carry a valid signature (RADIO_STATUS excepted: telemetry
radios inject it unsigned). The signature is checked before its timestamp counts, so a forged frame
cannot push the autopilot's stream ahead and lock its genuine packets out.
"""

from __future__ import annotations

import hashlib
import os
import stat
import sys
import time
import types
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mavbridge.link.retry import RetrySettings, add_retry_arguments
from vessel.config import ConfigError, bounded

NEW_STREAM_SLACK = 60 * 100_000  # 10 µs ticks: a new stream may start at most a minute behind our clock
RADIO_STATUS = 109  # MAVLINK_MSG_ID_RADIO_STATUS
EPOCH_2015_S = 1_420_070_400


_warned: set[str] = set()


def key_from_file(path: str, field: str = "signing_passphrase_file (--signing-passphrase-file)") -> bytes:
    """SHA-256 of the passphrase in ``path`` (first line, surrounding whitespace removed); ConfigError naming
    ``field`` if missing or empty; a warning (once) if others may read the file."""
    try:
        text = Path(path).read_text(encoding="utf-8")
        mode = os.stat(path).st_mode
    except OSError as exc:
        raise ConfigError(f"{field}: {path}: cannot read the passphrase file ({exc.strerror or exc})") from None
    lines = text.strip().splitlines()
    passphrase = lines[0].strip() if lines else ""
    if not passphrase:
        raise ConfigError(f"{field}: {path} is empty; write the signing passphrase on its first line")
    if mode & (stat.S_IRGRP | stat.S_IROTH) and path not in _warned:
        _warned.add(path)
        sys.stderr.write(f"mavbridge: warning: {path} is readable by other users; chmod 600 it\n")
    return hashlib.sha256(passphrase.encode("utf-8")).digest()


@dataclass(frozen=True)
class LinkSettings(RetrySettings):
    """The link fields of the companion's YAML: retries (RetrySettings) and signing."""

    signing_passphrase_file: str | None = bounded(None, doc="MAVLink 2 signing: a file holding the passphrase "
                                                  "(key = SHA-256 of it, as MAVProxy's `signing setup`); unset: "
                                                  "unsigned")

    def signing_key(self) -> bytes | None:
        """The 32-byte key, or None when signing is not configured (ConfigError for a bad file)."""
        if self.signing_passphrase_file is None:
            return None
        return key_from_file(self.signing_passphrase_file)


def check_signature(codec: Any, msgbuf: bytearray, src_system: int, src_component: int) -> bool:
    """Signature first (48 bits of SHA-256(key ‖ frame but its last 6 bytes)), then the replay rules: per
    (link id, system, component) timestamps strictly increase; a new stream at most a minute behind."""
    signing = codec.signing
    if hashlib.sha256(bytes(signing.secret_key) + bytes(msgbuf[:-6])).digest()[:6] != bytes(msgbuf[-6:]):
        return False
    stream = (msgbuf[-13], src_system, src_component)
    stamp = int.from_bytes(bytes(msgbuf[-12:-6]), "little")
    last = signing.stream_timestamps.get(stream)
    if (last is not None and stamp <= last) or (last is None and stamp + NEW_STREAM_SLACK < signing.timestamp):
        return False
    signing.stream_timestamps[stream] = stamp
    signing.timestamp = max(signing.timestamp, stamp)
    return True


def ticks_now() -> int:
    """Now as a signing timestamp: 10 µs units since 2015-01-01 00:00 UTC."""
    return max(0, (time.time_ns() // 1000 - EPOCH_2015_S * 1_000_000) // 10)


def sign_link(conn: Any, key: bytes) -> None:
    """Sign everything ``conn`` (a pymavlink connection) sends; accept only signed input, RADIO_STATUS aside."""
    conn.setup_signing(key, sign_outgoing=True, allow_unsigned_callback=lambda _mav, msg_id: msg_id == RADIO_STATUS)
    conn.mav.check_signature = types.MethodType(check_signature, conn.mav)


def add_link_arguments(parser: Any) -> None:
    """--command-timeout, --command-retries and --signing-passphrase-file (run and check share them)."""
    add_retry_arguments(parser)
    parser.add_argument("--signing-passphrase-file", metavar="FILE",
                        help="MAVLink 2 signing with the passphrase in FILE (key = SHA-256, as MAVProxy's "
                             "`signing setup`; default: the YAML's signing_passphrase_file, else unsigned)")
