"""What a log holds for identification, as arrays: attitude, speed over ground and the propulsion command.

Every format is read by ``mavbridge.field``'s readers (``open_log``), as `mavbridge report` reads it: ATTITUDE
(roll, pitch, yaw, yaw unwrapped; the body rates beside them), GLOBAL_POSITION_INT (speed over
ground from its velocity), SERVO_OUTPUT_RAW or DataFlash RCOU (the motors' PWM, turned into outputs in [−1, 1] by
the log's SERVOn_FUNCTION/MIN/TRIM/MAX/REVERSED through ``mavbridge.field.boat``), PARAM_VALUE. The Otter API CSV
says its commands in columns the reader does not turn into MAVLink — ``n1``, ``n2`` (shaft speeds, rpm), ``tau_X``
(N), ``tau_N`` (N·m) — so they are read beside it, row by row on the reader's own timeline and with its own number
parsing. SI inside: shaft speeds in rad/s.
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.field.boat import THROTTLE_LEFT, THROTTLE_RIGHT, motor_servos
from mavbridge.field.logs import LogError, open_log
from mavbridge.field.otter_csv import OtterCsvReader

RPM = 2 * math.pi / 60  # rad/s per rpm
OTTER_COMMANDS = ("n1", "n2", "tau_X", "tau_N")


@dataclass
class LogData:
    """One log's arrays (SI, rad): attitude rows (t, roll, pitch, yaw, p, q, r: the body rates, rad/s,
    NaN where the log has none), speed rows (t, m/s), and the commands it holds: 'shafts' rows (t, n1, n2 rad/s),
    'tau' rows (t, τ_X N, τ_N N·m), 'motors' rows (t, left, right)."""

    path: Path
    format: str
    start_text: str
    attitude: np.ndarray
    speed: np.ndarray
    commands: dict[str, np.ndarray] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def duration_s(self) -> float:
        """From the first to the last attitude sample."""
        return float(self.attitude[-1, 0] - self.attitude[0, 0]) if self.attitude.size else 0.0

    @property
    def day(self) -> str:
        """The log's day ('2024-03-22'), from when it says it starts, else 'unknown day'."""
        return self.start_text[:10] if self.start_text[:4].isdigit() else "unknown day"


def _rows(values: array, width: int) -> np.ndarray:
    flat = np.frombuffer(values, dtype=float)
    return flat.reshape(flat.size // width, width).copy()


class _Collector:
    """Takes a reader's messages; keeps compact arrays only."""

    def __init__(self) -> None:
        self.att, self.speed, self.servo = array("d"), array("d"), array("d")
        self.params: dict[str, float] = {}

    def take(self, t: float, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "ATTITUDE":
            angles = (msg.roll, msg.pitch, msg.yaw)
            if all(math.isfinite(a) for a in angles) and abs(msg.roll) < math.pi / 2 and abs(msg.pitch) < math.pi / 2:
                rates = (getattr(msg, name, math.nan) for name in ("rollspeed", "pitchspeed", "yawspeed"))
                self.att.extend((t, *angles, *(float(v) if v is not None else math.nan for v in rates)))
        elif kind == "GLOBAL_POSITION_INT":
            if msg.lat or msg.lon:
                self.speed.extend((t, math.hypot(msg.vx, msg.vy) / 100.0))
        elif kind == "SERVO_OUTPUT_RAW":
            self.servo.extend((t, *(float(getattr(msg, f"servo{n}_raw", 0) or 0) for n in range(1, 17))))
        elif kind == "PARAM_VALUE":
            name = msg.param_id.decode() if isinstance(msg.param_id, bytes) else str(msg.param_id)
            self.params[name.rstrip("\x00")] = float(msg.param_value)


def _motors(servo: np.ndarray, params: dict[str, float], notes: list[str]) -> np.ndarray | None:
    """Rows (t, left, right) of the motors' outputs in [−1, 1]; None when no servo output had a pulse."""
    if not servo.size:
        return None
    servos = motor_servos(params, notes.append)
    left, right = servos[THROTTLE_LEFT], servos[THROTTLE_RIGHT]
    rows = []
    for row in servo:
        a, b = left.output(int(row[left.number])), right.output(int(row[right.number]))
        if a is not None and b is not None:
            rows.append((row[0], a, b))
    return np.array(rows) if rows else None


def otter_commands(path: Path) -> dict[str, np.ndarray]:
    """The Otter API CSV's command columns, on the reader's timeline (seconds since the first timed row; NaN where
    a cell could not be read: the reader's own table, dates read back as it reads them)."""
    reader = OtterCsvReader(path)
    if not any(n in reader.columns for n in OTTER_COMMANDS):
        return {}
    table = reader.table()
    t = np.array(table.t, float)
    column = {n: np.array([table.value(n, row) for row in range(t.size)], float)
              for n in OTTER_COMMANDS if n in reader.columns}
    out = {}
    if "n1" in column and "n2" in column:
        out["shafts"] = np.column_stack([t, column["n1"] * RPM, column["n2"] * RPM])
    if "tau_X" in column and "tau_N" in column:
        out["tau"] = np.column_stack([t, column["tau_X"], column["tau_N"]])
    return out


def read_log(path: Path, fmt: str = "auto") -> LogData:
    """The arrays of one log; LogError (one line) for a file that is not a log or holds no attitude."""
    reader = open_log(Path(path), fmt, outputs=True)
    got = _Collector()
    for t, msg in reader.messages():
        got.take(t, msg)
    info = reader.info
    attitude = _rows(got.att, 7)
    if not attitude.size:
        raise LogError(f"LOG: {path}: no attitude in this {info.format} log: nothing to identify")
    attitude[:, 3] = np.unwrap(attitude[:, 3])
    notes = list(info.notes) + ([f"cut short: {info.stopped}"] if info.stopped else [])
    data = LogData(Path(path), info.format, info.start_text, attitude, _rows(got.speed, 2), notes=notes)
    motors = _motors(_rows(got.servo, 17), got.params, data.notes)
    if motors is not None:
        data.commands["motors"] = motors
    if info.format == "otter-csv":
        data.commands.update(otter_commands(Path(path)))
    return data
