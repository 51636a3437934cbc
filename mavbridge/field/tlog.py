"""A ground station's (or the companion's) ``.tlog``, streamed: the autopilot's messages on its own clock.

A tlog (MAVProxy, QGroundControl, Mission Planner, pymavlink, ``mavbridge run``) is every MAVLink frame the
station heard or sent, each after its arrival time as a big-endian uint64 of Unix microseconds. The file is
read in chunks and framed here (MAVLink 1 and 2, signed or not), so that only the frames a report needs are
decoded, by pymavlink's own parser (CRC and fields): the report of an hour's log never holds it in memory.

The autopilot is the sender of the first HEARTBEAT that names an autopilot (not MAV_AUTOPILOT_INVALID, which
ground stations, companions and MAVSDK send), or of ``--sysid``'s; its own messages are passed on, and the
mission items other stations send it (an upload). Everything else is counted and said in the notes.
The timeline is the autopilot's clock (time_boot_ms), continued across a reboot from the arrival times;
messages without a time of their own (HEARTBEAT, PARAM_VALUE ...) take the autopilot time heard last (held
until one is heard; left out, and said, when none ever is). Also passed on: NAMED_VALUE_FLOAT (an autopilot
script's figures) and POSITION_TARGET_GLOBAL_INT (where the autopilot steers).
"""

from __future__ import annotations

import struct
from collections import Counter
from collections.abc import Callable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, BinaryIO, NamedTuple

from pymavlink.generator.mavcrc import mcrf4xx, x25crc

from mavbridge.field.logs import LogError, LogInfo, Progress, TimedMessage
from mavbridge.link.connection import MAV_AUTOPILOT_INVALID, mavlink
from vessel.wording import counted

STAMP = struct.Struct(">Q")
V1, V2 = 0xFE, 0xFD
CHUNK = 1 << 20
PLAUSIBLE_US = (6.3e14, 4.1e15)  # a tlog stamp is Unix µs between 1990 and 2100
WANTED = {mavlink.MAVLINK_MSG_ID_HEARTBEAT, mavlink.MAVLINK_MSG_ID_ATTITUDE,
          mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
          mavlink.MAVLINK_MSG_ID_SCALED_IMU, mavlink.MAVLINK_MSG_ID_RAW_IMU, mavlink.MAVLINK_MSG_ID_SCALED_IMU2,
          mavlink.MAVLINK_MSG_ID_HOME_POSITION, mavlink.MAVLINK_MSG_ID_MISSION_ITEM_INT,
          mavlink.MAVLINK_MSG_ID_MISSION_ITEM, mavlink.MAVLINK_MSG_ID_MISSION_COUNT,
          mavlink.MAVLINK_MSG_ID_NAMED_VALUE_FLOAT, mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT}
IMU_KINDS = (mavlink.MAVLINK_MSG_ID_SCALED_IMU, mavlink.MAVLINK_MSG_ID_RAW_IMU, mavlink.MAVLINK_MSG_ID_SCALED_IMU2)
OUTPUTS = {mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, mavlink.MAVLINK_MSG_ID_RC_CHANNELS,
           mavlink.MAVLINK_MSG_ID_PARAM_VALUE}  # what the boat did, and its parameters: for a replay
FLAT = (mavlink.MAVLINK_MSG_ID_HEARTBEAT, mavlink.MAVLINK_MSG_ID_ATTITUDE, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
        mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, *IMU_KINDS, mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,
        mavlink.MAVLINK_MSG_ID_RC_CHANNELS)
TO_AUTOPILOT = {mavlink.MAVLINK_MSG_ID_MISSION_ITEM_INT, mavlink.MAVLINK_MSG_ID_MISSION_ITEM,
                mavlink.MAVLINK_MSG_ID_MISSION_COUNT}  # an upload: another station's, addressed to the autopilot
SENT = {mavlink.MAVLINK_MSG_ID_RC_CHANNELS_OVERRIDE}  # what a companion sent (in its own tlog): for a replay
REBOOT_MS = 5000  # the autopilot's clock this far behind the newest heard: it rebooted
PENDING_MAX = 10000  # untimed messages held until the first timed one


class Frame(NamedTuple):
    """One frame of the log: arrival stamp (Unix µs), where it starts in the file, its header and its bytes."""

    stamp_us: int
    offset: int
    msgid: int
    sysid: int
    compid: int
    raw: bytes


Keep = Callable[[int, int, int], bool]  # (msgid, sysid, compid): is the frame wanted
PAD = bytes(32)  # after the end of the file: never a frame, and every header read stays inside the buffer


def _frame_at(data: bytes, i: int) -> tuple[int, int, int, int, int] | None:
    """(stamp µs, size with the stamp, msgid, sysid, compid) of the frame whose stamp starts at ``i``; None when no
    plausible frame starts there. Needs 18 bytes from ``i``."""
    stx = data[i + 8]
    if stx == V2:
        size = 20 + data[i + 9] + (13 if data[i + 10] & 1 else 0)
        msgid, sysid, compid = data[i + 15] | data[i + 16] << 8 | data[i + 17] << 16, data[i + 13], data[i + 14]
    elif stx == V1:
        size, msgid, sysid, compid = 16 + data[i + 9], data[i + 13], data[i + 11], data[i + 12]
    else:
        return None
    stamp = STAMP.unpack_from(data, i)[0]
    return (stamp, size, msgid, sysid, compid) if PLAUSIBLE_US[0] <= stamp <= PLAUSIBLE_US[1] else None


def looks_like_tlog(head: bytes) -> bool:
    """True when the file starts with two tlog frames (or one that fills it)."""
    padded = head + PAD
    first = _frame_at(padded, 0) if len(head) >= 16 else None
    if first is None or first[1] > len(head):
        return False
    return first[1] + 16 > len(head) or _frame_at(padded, first[1]) is not None


class FrameStream:
    """The frames of a tlog in order; what could not be read is counted (``skipped_bytes``) or, at the end,
    said (``cut``: the file ends inside a frame)."""

    def __init__(self, handle: BinaryIO, keep: Keep | None = None) -> None:
        self.handle, self.keep = handle, keep
        self.bytes_read = 0
        self.skipped_bytes = 0
        self.first_skip: int | None = None
        self.cut: int | None = None  # file offset of an incomplete last frame

    def __iter__(self) -> Iterator[Frame]:
        data, end, base, i, eof = b"", 0, 0, 0, False  # data[end:] is PAD once the file is read to its end
        keep = self.keep
        while True:
            if end - i < 300 and not eof:
                more = self.handle.read(CHUNK)
                self.bytes_read += len(more)
                data, base, i = data[i:end] + more, base + i, 0
                end, eof = len(data), not more
                data += PAD if eof else b""
            if end - i < 16:  # less than the smallest frame is left
                self.cut = base + i if end > i else None
                return
            found = _frame_at(data, i)
            if found is None:
                i = self._resync(data, i, base, end)
                continue
            stamp, size, msgid, sysid, compid = found
            if i + size > end:  # only at the end of the file: a frame cut short
                self.cut = base + i
                return
            if keep is None or keep(msgid, sysid, compid):
                yield Frame(stamp, base + i, msgid, sysid, compid, data[i + 8:i + size])
            i += size

    def _resync(self, data: bytes, i: int, base: int, end: int) -> int:
        """Skip bytes that are not a frame, up to the next plausible stamp and start byte (or the buffer's end)."""
        if self.first_skip is None:
            self.first_skip = base + i
        j = i + 1
        while j + 16 <= end and _frame_at(data, j) is None:
            j += 1
        self.skipped_bytes += j - i
        return j


class BootClock:
    """The log's timeline from the autopilot's time_boot_ms: its clock in the first boot, continued after a
    reboot by the arrival times in between (``reboots`` counts them)."""

    def __init__(self) -> None:
        self.newest_ms: int | None = None
        self.offset_s = 0.0
        self.last_t: float | None = None
        self.last_stamp_s = 0.0
        self.reboots = 0

    def at(self, boot_ms: int, stamp_s: float) -> float:
        """The timeline time of a message stamped ``boot_ms`` by the autopilot, arrived at ``stamp_s``."""
        if self.newest_ms is not None and boot_ms < self.newest_ms - REBOOT_MS and self.last_t is not None:
            self.offset_s = self.last_t + max(stamp_s - self.last_stamp_s, 0.0) - boot_ms / 1000.0
            self.newest_ms = boot_ms
            self.reboots += 1
        self.newest_ms = boot_ms if self.newest_ms is None else max(self.newest_ms, boot_ms)
        t = boot_ms / 1000.0 + self.offset_s
        self.last_t = t if self.last_t is None else max(self.last_t, t)
        self.last_stamp_s = stamp_s
        return t


def _is_autopilot(msg: Any) -> bool:
    return msg.get_type() == "HEARTBEAT" and msg.autopilot != MAV_AUTOPILOT_INVALID


def describe_autopilot(msg: Any) -> str:
    """'ArduPilot, surface boat' from a HEARTBEAT's autopilot and type."""
    def name(enum: str, value: int) -> str:
        entry = mavlink.enums[enum].get(value)
        return entry.name.removeprefix(f"{enum}_").replace("_", " ").lower() if entry else f"{value}"

    known = {mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA: "ArduPilot", mavlink.MAV_AUTOPILOT_PX4: "PX4"}
    return f"{known.get(msg.autopilot) or name('MAV_AUTOPILOT', msg.autopilot)}, {name('MAV_TYPE', msg.type)}"


class TlogReader:
    """``LogReader`` for a MAVLink .tlog (see the module docstring); ``sysid`` picks the autopilot; ``outputs``: also
    the RC inputs, servo outputs and parameters (for a replay)."""

    def __init__(self, path: Path, sysid: int | None = None, outputs: bool = False) -> None:
        self.path, self.sysid = path, sysid
        self.info = LogInfo(path, "tlog", size_bytes=path.stat().st_size)
        self.autopilot = self._find_autopilot()
        self.untimed = 0  # messages without a time of their own heard before any autopilot time, left out
        # Every IMU kind is read: the fastest stream often starts only when a companion asks for it, minutes
        # into a ground station's log (the trial follows the fastest kind window by window).
        self.wanted = WANTED | (OUTPUTS if outputs else set())
        self.to_autopilot = TO_AUTOPILOT | (SENT if outputs else set())

    def _find_autopilot(self) -> tuple[int, int]:
        """(sysid, compid) of the autopilot: the sender of the first autopilot HEARTBEAT (of ``sysid``), else of
        the first ATTITUDE; LogError when there is neither."""
        parser = mavlink.MAVLink(None)
        attitude_sender: tuple[int, int] | None = None
        with self.path.open("rb") as handle:
            frames = iter(FrameStream(handle, lambda m, s, c: self.sysid is None or s == self.sysid))
            for frame in frames:
                if frame.msgid == mavlink.MAVLINK_MSG_ID_ATTITUDE and attitude_sender is None:
                    attitude_sender = (frame.sysid, frame.compid)
                msg = _decode(parser, frame) if frame.msgid == mavlink.MAVLINK_MSG_ID_HEARTBEAT else None
                if msg is not None and _is_autopilot(msg):
                    self.info.source = f"autopilot {frame.sysid}/{frame.compid} ({describe_autopilot(msg)})"
                    return frame.sysid, frame.compid
        which = f" of system {self.sysid}" if self.sysid is not None else ""
        if attitude_sender is None:
            raise LogError(f"LOG: {self.path}: no autopilot HEARTBEAT and no ATTITUDE{which} in this tlog: "
                           "nothing to report")
        self.info.source = f"system {attitude_sender[0]}/{attitude_sender[1]} (sent ATTITUDE; no autopilot HEARTBEAT)"
        return attitude_sender

    def messages(self, progress: Progress | None = None) -> Iterator[TimedMessage]:
        """The autopilot's messages (and mission items sent to it) on the autopilot's clock."""
        decode, clock, others = Decoder(), BootClock(), Counter[tuple[int, int]]()
        self.untimed = 0
        pending: list[Any] = []
        crc_errors, next_progress = 0, 0.0
        autopilot, wanted, to_autopilot = self.autopilot, self.wanted, self.to_autopilot

        def keep(msgid: int, sysid: int, compid: int) -> bool:
            if (sysid, compid) == autopilot:
                return msgid in wanted
            others[(sysid, compid)] += 1
            return msgid in to_autopilot

        with self.path.open("rb") as handle:
            stream = FrameStream(handle, keep)
            for frame in stream:
                msg = decode(frame)
                if msg is None:
                    crc_errors += 1
                    continue
                if (frame.sysid, frame.compid) != autopilot and getattr(msg, "target_system", -1) != autopilot[0]:
                    continue
                if not self.info.start_text:
                    self.info.start_text = _utc(frame.stamp_us)
                yield from self._timed(msg, frame, clock, pending)
                if progress is not None and stream.bytes_read >= next_progress:
                    progress(stream.bytes_read / max(self.info.size_bytes, 1), clock.last_t or 0.0)
                    next_progress = stream.bytes_read + CHUNK
            if clock.last_t is not None:
                yield from ((clock.last_t, m) for m in pending)
            else:
                self.untimed += len(pending)
        self._conclude(stream, clock, others, crc_errors)

    def _timed(self, msg: Any, frame: Frame, clock: BootClock, pending: list[Any]) -> list[TimedMessage]:
        """``msg`` on the timeline: its own time_boot_ms, else the autopilot time heard last (held until one is)."""
        boot_ms = getattr(msg, "time_boot_ms", None)
        if isinstance(boot_ms, int) and (frame.sysid, frame.compid) == self.autopilot:
            t = clock.at(boot_ms, frame.stamp_us / 1e6)
            if not pending:
                return [(t, msg)]
            held = [(t, m) for m in pending]
            pending.clear()
            return [*held, (t, msg)]
        if clock.last_t is None:  # held until the autopilot's first time; beyond PENDING_MAX, left out (counted)
            if len(pending) < PENDING_MAX:
                pending.append(msg)
            else:
                self.untimed += 1
            return []
        return [(clock.last_t, msg)]

    def _conclude(self, stream: FrameStream, clock: BootClock, others: Counter[tuple[int, int]],
                  crc_errors: int) -> None:
        """What the reading met, in the notes; a log cut short in ``stopped``."""
        if stream.cut is not None:
            reached = f"t = {clock.last_t:.1f} s" if clock.last_t is not None else "no autopilot time (none was heard)"
            self.info.stopped = (f"the file ends inside a message at byte {stream.cut} of {self.info.size_bytes} "
                                 f"(cut short): read up to {reached}")
        if stream.skipped_bytes:
            self.info.note(f"{stream.skipped_bytes} bytes that are not MAVLink frames skipped (the first at byte "
                           f"{stream.first_skip})")
        if crc_errors:
            self.info.note(f"{crc_errors} frames with a bad checksum or unknown to the dialect dropped")
        if self.untimed:
            self.info.note(f"{self.untimed} messages without a time of their own (HEARTBEAT, PARAM_VALUE ...) before "
                           "the autopilot's first time_boot_ms left out: nothing places them on its clock")
        if clock.reboots:
            self.info.note(f"the autopilot rebooted {counted(clock.reboots, 'time')}; the timeline continues across "
                           "(later times are its clock plus the time before)")
        if others:
            senders = ", ".join(f"{s}/{c} ({n} frames)" for (s, c), n in others.most_common(4))
            self.info.note(f"not the autopilot's, left out: {senders}")


class Decoder:
    """Frames to messages with pymavlink's definitions. The flat messages a report reads by the hundred thousand
    (numbers only, no arrays or text: ATTITUDE, positions, IMU, HEARTBEAT, RC and servo PWM) are unpacked here
    with their class's own unpacker, field order and CRC extra (a quarter of the time of pymavlink's general
    decode, which checks signing and lengths every time); every other message goes through that decode."""

    def __init__(self) -> None:
        self.parser = mavlink.MAVLink(None)
        self.flat = {i: _Flat(mavlink.mavlink_map[i]) for i in FLAT if _is_flat(mavlink.mavlink_map[i])}

    def __call__(self, frame: Frame) -> Any:
        """The message, None when the frame does not decode (a bad CRC, a damaged or unknown message)."""
        flat = self.flat.get(frame.msgid)
        if flat is None:
            return _decode(self.parser, frame)
        raw = frame.raw
        head, sign = (10, 13 if raw[2] & 1 else 0) if raw[0] == V2 else (6, 0)
        end = len(raw) - 2 - sign
        if _crc(raw[1:end] + flat.extra) != raw[end] | raw[end + 1] << 8:
            return None
        payload = raw[head:end]
        if len(payload) != flat.size:  # MAVLink 2 trims trailing zeros (and extensions may be absent or more)
            payload = (payload + bytes(flat.size))[:flat.size]
        values = flat.unpack(payload)
        return flat.kind(*values) if flat.orders is None else flat.kind(*[values[i] for i in flat.orders])


class _Flat:
    """What decoding one flat message kind needs: its class, unpacker, CRC extra and wire order (None: as is)."""

    def __init__(self, kind: Any) -> None:
        self.kind, self.unpack, self.size = kind, kind.unpacker.unpack, kind.unpacker.size
        self.extra = bytes((kind.crc_extra,))
        self.orders = None if list(kind.orders) == list(range(len(kind.orders))) else list(kind.orders)


def _crc(data: bytes) -> int:
    """MAVLink's CRC-16/MCRF4XX (pymavlink's: its C implementation when installed)."""
    return mcrf4xx(data, 0xFFFF) if mcrf4xx is not None else x25crc(data).crc


def _is_flat(kind: Any) -> bool:
    return all(n == 1 for n in kind.lengths) and not any(t.startswith("char") for t in kind.fieldtypes)


def _decode(parser: Any, frame: Frame) -> Any:
    """The frame decoded by pymavlink (CRC checked), None when it does not decode."""
    try:
        msg = parser.decode(bytearray(frame.raw))
    except Exception:  # pymavlink raises its MAVError and struct errors for damaged frames
        return None
    return None if msg.get_type() == "UNKNOWN" or msg.get_type().startswith("UNKNOWN") else msg


def _utc(stamp_us: int) -> str:
    return datetime.fromtimestamp(stamp_us / 1e6, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
