"""The Otter API's own log: a semicolon CSV at about 9 Hz, said in MAVLink (ATTITUDE, GLOBAL_POSITION_INT, and
NAMED_VALUE_FLOAT / POSITION_TARGET_GLOBAL_INT for its controller's figures).

Columns (by name; 30, 34 and 41-column files exist): an unnamed first column of local time
``YYYY-MM-DD_HH:MM:SS:ffffff`` (``current_time``, Unix seconds, where the file has it, is preferred),
``current_orientation_1/2/3`` roll, pitch, yaw in degrees, ``current_rotational_velocities_1/2/3`` their rates
in °/s, ``lat``/``lon`` in degrees (0 = no fix), ``current_speed`` (m/s over ground) and
``current_course_over_ground`` (degrees). ``height`` is always 0 on the Otter: there is no heave. Where the file
has them: the shaft speeds ``n1``/``n2`` (rpm), the controller's ``tau_X`` (N) and ``tau_N`` (N·m), its
``yaw_setpoint`` (rad), ``distance_to_target`` (m) and the target (``target_north/east_from_observer``, metres
from ``observer_lat/lon``), said as NAMED_VALUE_FLOAT (``NAMED``) and POSITION_TARGET_GLOBAL_INT.

What real files do, and what is done about it (each said in the notes): the first row is an all-zero
placeholder (no attitude, and a speed that is not one) — a row whose attitude and rates are all zero carries
nothing; attitude repeats unchanged for up to 2 s when the API re-sends an old sample — a repeat is not a new
sample; the position repeats when the GPS has not updated, with a speed of 0.0 — a repeat is not a new fix;
rows without a fix carry no position and no distance to the target (it is measured from 0°, 0°); a speed over
MAX_SPEED_M_S (after a row without a fix) is not the boat's: its row's position, which carries the velocity, is
left out; a file that went through a spreadsheet has numbers turned into dates, read back (``otter_cells``);
a cell that cannot be read is left out, with everything that travels with it (the row's attitude when one of
its six angles and rates is unreadable: ATTITUDE carries them together), counted per column; a time that does
not move forward ends no file but drops its row. The timeline is seconds since the first row.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.field import say
from mavbridge.field.logs import LogError, LogInfo, Progress, TimedMessage, plural
from mavbridge.field.otter_cells import Column, column_notes

ANGLES = ("current_orientation_1", "current_orientation_2", "current_orientation_3")
RATES = ("current_rotational_velocities_1", "current_rotational_velocities_2", "current_rotational_velocities_3")
FIX = ("lat", "lon", "current_speed", "current_course_over_ground")
NAMED = {"n1": "n1", "n2": "n2", "tau_X": "tau_X", "tau_N": "tau_N", "yaw_setpoint": "yaw_sp",
         "distance_to_target": "tgt_dist"}  # column: NAMED_VALUE_FLOAT name (≤ 10 characters)
TARGET = ("observer_lat", "observer_lon", "target_north_from_observer", "target_east_from_observer")
LABELS = dict(zip((*ANGLES, *RATES), ("roll", "pitch", "yaw", "roll rate", "pitch rate", "yaw rate"), strict=True))
TIME_FORMAT = "%Y-%m-%d_%H:%M:%S:%f"
MAX_SPEED_M_S = 20.0  # a speed over ground beyond this is the placeholder's, or a jump from 0°, 0°: not the boat's
MAX_TARGET_M = 10_000.0  # a distance to the target beyond this is measured from 0°, 0° (no fix), not the boat
GAP_S = 1.0  # rows further apart than this are a gap (said in the notes)


def looks_like_otter_csv(head: bytes) -> bool:
    """The header of an Otter API log: semicolons, an unnamed first column, the orientation columns."""
    first = head.split(b"\n", 1)[0]
    return first.startswith(b";") and all(name.encode() in first for name in ANGLES)


def _local_time(cell: str) -> str:
    """The first column's time as a reader writes it, '2024-03-22 12:42:29 (the log's local time)'."""
    try:
        return datetime.strptime(cell.strip(), TIME_FORMAT).strftime("%Y-%m-%d %H:%M:%S (the log's local time)")
    except ValueError:
        return ""


@dataclass
class Table:
    """The file's rows that have a time moving forward, column by column (NaN where a cell is not read)."""

    t: list[float] = field(default_factory=list)
    columns: dict[str, Column] = field(default_factory=dict)
    counts: Counter[str] = field(default_factory=Counter)
    start_text: str = ""
    stopped: str | None = None

    def value(self, name: str, row: int) -> float:
        """The cell of ``name`` in ``row``; NaN when the file has no such column or the cell was not read."""
        column = self.columns.get(name)
        return column.values[row] if column is not None else math.nan


class OtterCsvReader:
    """``LogReader`` for an Otter API CSV (see the module docstring)."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.info = LogInfo(path, "otter-csv", source="Otter API log (Maritime Robotics)",
                            size_bytes=path.stat().st_size)
        with path.open(encoding="utf-8", errors="replace") as handle:
            self.columns = {name.strip(): i for i, name in enumerate(handle.readline().rstrip("\r\n").split(";"))}
        missing = [name for name in ANGLES if name not in self.columns]
        if missing:
            raise LogError(f"--format otter-csv: {path}: no column {missing[0]} (roll, pitch and yaw in degrees)")
        self.wanted = [n for n in (*ANGLES, *RATES, *FIX, *NAMED, *TARGET) if n in self.columns]

    def _time(self, cells: list[str]) -> float | None:
        """The row's time in Unix-like seconds: current_time, else the first column's local time."""
        i = self.columns.get("current_time")
        try:
            unix = float(cells[i]) if i is not None else math.nan
        except ValueError:
            unix = math.nan
        if unix > 1e8:
            return unix
        try:
            return datetime.strptime(cells[0].strip(), TIME_FORMAT).timestamp()
        except ValueError:
            return None

    def table(self, progress: Progress | None = None) -> Table:
        """Every row with a time moving forward, its cells read (dates read back by their neighbours)."""
        table = Table(columns={name: Column(name) for name in self.wanted})
        first_t: float | None = None
        done, lines = 0, 0
        with self.path.open(encoding="utf-8", errors="replace") as handle:
            handle.readline()
            for line in handle:
                done, lines = done + len(line), lines + 1
                cells = line.rstrip("\r\n").split(";")
                row_t = self._time(cells) if len(cells) >= len(self.columns) else None
                if len(cells) < len(self.columns):
                    self._short_row(line, table)
                elif row_t is None:
                    table.counts["without a readable time"] += 1
                elif first_t is not None and row_t - first_t <= table.t[-1]:
                    table.counts["whose time does not move forward"] += 1
                else:
                    if first_t is None:
                        first_t, table.start_text = row_t, _local_time(cells[0])
                    table.t.append(row_t - first_t)
                    for name, column in table.columns.items():
                        column.add(cells[self.columns[name]])
                if progress is not None and lines % 2000 == 0:
                    progress(done / max(self.info.size_bytes, 1), table.t[-1] if table.t else 0.0)
        times = np.array(table.t, float)
        for column in table.columns.values():
            column.decide(times)
        return table

    def _short_row(self, line: str, table: Table) -> None:
        """A row with fewer cells than the header: the file's cut-off end, or a damaged row (skipped, counted)."""
        if line.endswith("\n"):
            table.counts["with fewer cells than the header"] += 1
        else:
            last = table.t[-1] if table.t else 0.0
            table.stopped = f"the file ends inside a row (cut short): read up to t = {last:.1f} s, the last row left " \
                "out"

    def messages(self, progress: Progress | None = None) -> Iterator[TimedMessage]:
        """Per row (what it holds of them): its position, the controller's figures, then its attitude."""
        table = self.table(progress)
        self.info.start_text, self.info.stopped = table.start_text, table.stopped
        counts, last = table.counts, {"attitude": None, "fix": None}
        for row, t in enumerate(table.t):
            values = [table.value(name, row) for name in (*ANGLES, *RATES)]
            if values == [0.0] * 6:
                counts["without attitude (all zero: a placeholder; nothing taken from them)"] += 1
                continue
            ms = round(t * 1000)
            fix = self._position(ms, table, row, counts, last)
            if fix is not None:
                yield t, fix
            yield from ((t, msg) for msg in self._controller(ms, table, row, last["fix"] is not None, counts))
            yield from ((t, msg) for msg in self._attitude(ms, values, counts, last))
        self._conclude(table)

    @staticmethod
    def _attitude(ms: int, values: list[float], counts: Counter[str], last: dict[str, Any]) -> list[Any]:
        if not all(math.isfinite(v) for v in values):
            counts["whose attitude or rates could not all be read: no attitude sample (ATTITUDE carries the "
                   "six together)"] += 1
            return []
        if values == last["attitude"]:
            counts["repeating the previous attitude (not a new sample)"] += 1
            return []
        last["attitude"] = values
        rad = [math.radians(v) for v in values]
        return [say.attitude(ms, rad[0], rad[1], rad[2], rad[3:6])]

    def _position(self, ms: int, table: Table, row: int, counts: Counter[str], last: dict[str, Any]) -> Any:
        """GLOBAL_POSITION_INT of the row's new fix (velocity from speed and course over ground), None without one."""
        lat, lon, speed, course = (table.value(name, row) for name in FIX)
        if not (abs(lat) <= 90 and abs(lon) <= 180) or (lat == 0 and lon == 0):
            counts["without a position fix (lat/lon 0 or unreadable)"] += 1
            last["fix"] = None
            return None
        if last["fix"] == (lat, lon):
            counts["repeating the previous position (not a new fix; their speed 0.0 is not measured)"] += 1
            return None
        last["fix"] = (lat, lon)
        if not (0.0 <= speed <= MAX_SPEED_M_S and math.isfinite(course)):
            counts[f"whose speed over ground is unreadable or over {MAX_SPEED_M_S:g} m/s (not the boat's): "
                   "the position left out too (it carries the velocity)"] += 1
            return None
        velocity = (speed * math.cos(math.radians(course)), speed * math.sin(math.radians(course)), 0.0)
        return say.position(ms, lat, lon, 0.0, velocity, course)

    @staticmethod
    def _controller(ms: int, table: Table, row: int, fixed: bool, counts: Counter[str]) -> list[Any]:
        """NAMED_VALUE_FLOAT of the controller's figures the row holds (the distance to the target only with a fix
        and under MAX_TARGET_M: without one, or just after, it is measured from 0°, 0°) and the target's position
        (from the observer's)."""
        distance = table.value("distance_to_target", row)
        if math.isfinite(distance) and not (fixed and distance <= MAX_TARGET_M):
            counts[f"whose distance to the target is from no fix or over {MAX_TARGET_M / 1000:g} km (measured from "
                   "0°, 0°): left out"] += 1
        out = [say.named_value(ms, name, value) for column, name in NAMED.items()
               if math.isfinite(value := table.value(column, row))
               and (column != "distance_to_target" or (fixed and value <= MAX_TARGET_M))]
        lat, lon, north, east = (table.value(name, row) for name in TARGET)
        if all(math.isfinite(v) for v in (lat, lon, north, east)) and (lat or lon) and abs(lat) <= 90:
            out.append(say.position_target(ms, lat, lon, north, east))
        return out

    def _conclude(self, table: Table) -> None:
        for what, n in table.counts.items():
            if n:
                self.info.note(f"{plural(n, 'row')} {what}")
        for line in column_notes(list(table.columns.values()), LABELS):
            self.info.note(line)
        gaps = np.diff(table.t) if len(table.t) > 1 else np.zeros(0)
        if gaps.size and gaps.max() > GAP_S:
            self.info.note(f"the longest gap between rows is {gaps.max():.1f} s "
                           f"({plural(int((gaps > GAP_S).sum()), 'gap')} over {GAP_S:g} s)")
