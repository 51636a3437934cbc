"""ArduPilot's own DataFlash log (``.bin``, or the text ``.log``), read with pymavlink's DFReader, said in MAVLink.

Taken: ATT (roll, pitch, yaw in degrees), IMU (the first IMU: body rates rad/s, specific force m/s²), GPS
(the first receiver, a 3D fix or better: position, ground speed and course, climb) or POS (the EKF's position,
where logged, with GPS's velocity), MODE and ARM/EV (the mode and the arming, as a HEARTBEAT), RCOU (the
servo outputs), RCIN (the RC inputs), CMD (the mission) and PARM (the parameters). ATT becomes ATTITUDE with
the body rates of the IMU sample next to it (within 60 ms; else the angles' own rate of change), preceded by
that IMU sample as SCALED_IMU, so the companion's ``StateEstimate`` sees what it would have seen streamed.
The timeline is the log's TimeUS (the autopilot's time since boot). Modes are named by the vehicle the log's
firmware message names (MSG/VER); without one, as ArduPilot Rover's (said in the notes).
DFReader's own prints (bad headers, skipped bytes) are caught and counted in the notes.
"""

from __future__ import annotations

import contextlib
import io
import math
from collections.abc import Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from mavbridge.field import say
from mavbridge.field.logs import LogError, LogInfo, Progress, TimedMessage
from mavbridge.link.connection import mavlink, mavutil

TYPES = ["ATT", "IMU", "GPS", "POS", "MODE", "ARM", "EV", "CMD", "MSG"]
OUTPUT_TYPES = ["RCOU", "RCIN", "PARM"]  # what the boat did, and its parameters: for a replay
IMU_FRESH_US = 60_000  # an IMU sample this close to an ATT gives its body rates (as the companion's IMU_FRESH_MS)
EV_ARMED, EV_DISARMED = 10, 11  # DataFlash EV ids (LogEvent::ARMED / DISARMED)
GPS_3D_FIX = 3
HEAD = b"\xa3\x95\x80"  # a binary log starts with the FMT of FMT


def looks_like_dataflash(head: bytes) -> bool:
    """A binary DataFlash log (starts with FMT) or a text one (its first line is an FMT line)."""
    if head.startswith(HEAD):
        return True
    first = head.split(b"\n", 1)[0].strip()
    return first.startswith(b"FMT,") and first.count(b",") >= 4


@contextlib.contextmanager
def _quiet(info: LogInfo) -> Iterator[None]:
    """DFReader's prints caught; what it said counted in the notes."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        yield
    said = [line for line in (out.getvalue() + err.getvalue()).splitlines() if line.strip()]
    if said:
        info.note(f"pymavlink's DataFlash reader: {said[0][:120]}" + (f" (and {len(said) - 1} more such lines)"
                                                                      if len(said) > 1 else ""))


def _time_us(m: Any) -> int | None:
    us = getattr(m, "TimeUS", None)
    if us is None:
        ms = getattr(m, "TimeMS", None)
        us = None if ms is None else int(ms) * 1000
    return None if us is None else int(us)


class _Translation:
    """DataFlash messages to MAVLink ones (see the module docstring); holds what one message needs of others."""

    def __init__(self, reader: Any, info: LogInfo) -> None:
        self.reader, self.info = reader, info
        self.use_pos = "POS" in reader.name_to_id
        self.imu: tuple[int, list[float], list[float]] | None = None  # (TimeUS, acc m/s², gyro rad/s)
        self.imu_sent_us: int | None = None
        self.last_att: tuple[int, float, float, float] | None = None
        self.velocity: tuple[float, float, float] | None = None  # GPS's, for POS: none before the first GPS
        self.left_out: dict[str, int] = {}  # what could not be said, and how often (into the notes at the end)
        self.course: float | None = None
        self.mode: int | None = None
        self.armed = False
        self.named = False  # a firmware message named the vehicle

    def __call__(self, m: Any) -> Iterator[Any]:
        kind = m.get_type()
        handler = getattr(self, f"_{kind.lower()}", None)
        if handler is not None:
            yield from handler(m)

    def _att(self, m: Any) -> Iterator[Any]:
        us = _time_us(m)
        angles = [math.radians(float(m.Roll)), math.radians(float(m.Pitch)), math.radians(float(m.Yaw))]
        if us is None or not all(math.isfinite(a) for a in angles):
            return
        rates = self._rates(us, angles)
        if rates is None:  # no IMU beside it and no earlier ATT: its rates are not in the log
            self.last_att = (us, *angles)
            self._count("ATT without an IMU sample beside it nor an earlier ATT to take its body rates from")
            return
        if self.imu is not None and self.imu[0] != self.imu_sent_us and abs(us - self.imu[0]) <= IMU_FRESH_US:
            self.imu_sent_us = self.imu[0]
            yield say.imu(self.imu[0] // 1000, self.imu[1], self.imu[2])
        self.last_att = (us, *angles)
        yield say.attitude(us // 1000, *angles, rates)

    def _count(self, what: str) -> None:
        self.left_out[what] = self.left_out.get(what, 0) + 1

    def _rates(self, us: int, angles: list[float]) -> list[float] | None:
        """Body rates: the IMU's beside this ATT, else the angles' rate of change since the last ATT; None when
        neither is there (the first ATT of a log without IMU, or one at the same time as the last)."""
        if self.imu is not None and abs(us - self.imu[0]) <= IMU_FRESH_US:
            return list(self.imu[2])
        if self.last_att is None or us <= self.last_att[0]:
            return None
        dt = (us - self.last_att[0]) / 1e6
        return [math.remainder(a - b, 2 * math.pi) / dt for a, b in zip(angles, self.last_att[1:], strict=True)]

    def _imu(self, m: Any) -> Iterator[Any]:
        us = _time_us(m)
        if us is not None and int(getattr(m, "I", 0) or 0) == 0:
            self.imu = (us, [m.AccX, m.AccY, m.AccZ], [m.GyrX, m.GyrY, m.GyrZ])
        yield from ()

    def _gps(self, m: Any) -> Iterator[Any]:
        if int(getattr(m, "I", 0) or 0) != 0 or int(getattr(m, "Status", 0)) < GPS_3D_FIX:
            return
        speed, course = float(m.Spd), float(m.GCrs)
        climb = getattr(m, "VZ", None)  # up is positive in ArduPilot's GPS log: down is −VZ
        if climb is None:  # an old log's GPS has no VZ: GLOBAL_POSITION_INT must say one; said in the notes
            self.info.note("GPS messages without VZ (an old log): vertical velocity said as 0 m/s (not in this log)")
            climb = 0.0
        climb = float(climb)
        self.velocity = (speed * math.cos(math.radians(course)), speed * math.sin(math.radians(course)), -climb)
        self.course = course
        us = _time_us(m)
        if not self.use_pos and us is not None:
            yield say.position(us // 1000, float(m.Lat), float(m.Lng), float(m.Alt), self.velocity, course)

    def _pos(self, m: Any) -> Iterator[Any]:
        us = _time_us(m)
        if us is not None and (m.Lat or m.Lng) and self.velocity is None:
            self._count("POS before the first GPS with a 3D fix (no velocity to go with it)")
        elif us is not None and (m.Lat or m.Lng) and self.velocity is not None:
            yield say.position(us // 1000, float(m.Lat), float(m.Lng), float(m.Alt), self.velocity, self.course)

    def _vehicle(self) -> int:
        kind = getattr(self.reader, "mav_type", mavlink.MAV_TYPE_GROUND_ROVER)
        return kind if self.named else mavlink.MAV_TYPE_GROUND_ROVER

    def _mode(self, m: Any) -> Iterator[Any]:
        number = getattr(m, "ModeNum", None)
        if number is None and isinstance(m.Mode, str):
            number = int(m.Mode) if m.Mode.strip().isdigit() else \
                (mavutil.mode_mapping_byname(self._vehicle()) or {}).get(m.Mode.upper())
        elif number is None:
            number = m.Mode
        if number is not None:
            self.mode = int(number)
            if not self.named:
                self.info.note("no firmware message (MSG/VER) names the vehicle: modes named as ArduPilot Rover's")
            yield say.heartbeat(self._vehicle(), self.mode, self.armed)

    def _arming(self, armed: bool) -> Iterator[Any]:
        self.armed = armed
        if self.mode is not None:
            yield say.heartbeat(self._vehicle(), self.mode, armed)

    def _arm(self, m: Any) -> Iterator[Any]:
        yield from self._arming(bool(m.ArmState))

    def _ev(self, m: Any) -> Iterator[Any]:
        if m.Id in (EV_ARMED, EV_DISARMED):
            yield from self._arming(m.Id == EV_ARMED)

    def _rcou(self, m: Any) -> Iterator[Any]:
        us = _time_us(m)  # a channel the log's layout lacks is 0: MAVLink's "no output" on that channel
        if us is not None:
            yield say.servo_outputs(us, [getattr(m, f"C{n}", 0) or 0 for n in range(1, 17)])

    def _rcin(self, m: Any) -> Iterator[Any]:
        us = _time_us(m)  # a channel the log's layout lacks is 0: no input on that channel (not counted)
        if us is not None:
            yield say.rc_inputs(us // 1000, [getattr(m, f"C{n}", 0) or 0 for n in range(1, 19)])

    def _cmd(self, m: Any) -> Iterator[Any]:
        params = [getattr(m, f"Prm{n}", 0.0) for n in range(1, 5)]
        yield say.mission_item(int(m.CNum), int(m.CId), float(m.Lat), float(m.Lng), float(m.Alt),
                               int(getattr(m, "Frame", 0) or 0), params)

    def _parm(self, m: Any) -> Iterator[Any]:
        yield say.parameter(str(m.Name), float(m.Value))

    def _msg(self, m: Any) -> Iterator[Any]:
        text = str(getattr(m, "Message", ""))
        if any(name in text for name in ("Rover", "Copter", "Plane", "Sub", "Blimp", "Antenna")) and not self.named:
            self.named = True
            self.info.source = f"ArduPilot DataFlash log ({text.strip()})"
        yield from ()


class DataflashReader:
    """``LogReader`` for an ArduPilot DataFlash log (see the module docstring)."""

    def __init__(self, path: Path, outputs: bool = False) -> None:
        self.path, self.types = path, TYPES + (OUTPUT_TYPES if outputs else [])
        self.info = LogInfo(path, "dataflash", source="ArduPilot DataFlash log", size_bytes=path.stat().st_size)

    def _open(self) -> Any:
        from pymavlink import DFReader

        with _quiet(self.info):
            try:
                with self.path.open("rb") as handle:
                    text = not handle.read(3).startswith(HEAD)
                return DFReader.DFReader_text(str(self.path)) if text else DFReader.DFReader_binary(str(self.path))
            except Exception as exc:  # DFReader raises what struct, mmap or its parser raise on a damaged file
                raise LogError(f"LOG: {self.path}: not a readable DataFlash log ({exc})") from None

    def messages(self, progress: Progress | None = None) -> Iterator[TimedMessage]:
        """The log's ATT, IMU, GPS/POS, MODE, ARM, RCOU, RCIN, CMD and PARM as MAVLink, on TimeUS."""
        reader = self._open()
        translate, t, step = _Translation(reader, self.info), 0.0, 0
        while True:
            with _quiet(self.info):
                m = reader.recv_match(type=self.types)
            if m is None:
                break
            us = _time_us(m)
            if us is not None and m.get_type() not in ("PARM", "MSG", "CMD"):
                t = us / 1e6
                if not self.info.start_text and getattr(m, "_timestamp", 0) > 1e9:
                    self.info.start_text = datetime.fromtimestamp(m._timestamp, UTC).strftime("%Y-%m-%d %H:%M:%S UTC")
            for msg in translate(m):
                yield t, msg
            step += 1
            if progress is not None and step % 5000 == 0:
                progress(float(getattr(reader, "percent", 0.0)) / 100.0, t)
        self._check_end(reader, t)
        for what, n in translate.left_out.items():
            self.info.note(f"{n} {what} left out")

    def _check_end(self, reader: Any, t: float) -> None:
        """A binary log whose last message runs past the end of the file was cut short: say where."""
        formats, offsets, counts = (getattr(reader, name, None) for name in ("formats", "offsets", "counts"))
        if not isinstance(counts, list) or formats is None or offsets is None:
            return  # a text log: read line by line, nothing to cut
        ends = [(int(offsets[k][counts[k] - 1]), formats[k].len) for k in range(256)
                if counts[k] > 0 and k in formats]
        cut = [ofs for ofs, length in ends if ofs + length > reader.data_len]
        if cut:
            self.info.stopped = (f"the file ends inside a message at byte {min(cut)} of {reader.data_len} "
                                 f"(cut short): read up to t = {t:.1f} s")
