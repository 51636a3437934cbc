"""The Otter API's own log: a semicolon CSV at about 9 Hz, said in MAVLink (ATTITUDE, GLOBAL_POSITION_INT).

Columns (by name; 30, 34 and 41-column files exist): an unnamed first column of local time
``YYYY-MM-DD_HH:MM:SS:ffffff`` (``current_time``, Unix seconds, where the file has it, is preferred),
``current_orientation_1/2/3`` roll, pitch, yaw in degrees, ``current_rotational_velocities_1/2/3`` their rates
in °/s, ``lat``/``lon`` in degrees (0 = no fix), ``current_speed`` (m/s over ground) and
``current_course_over_ground`` (degrees). ``height`` is always 0 on the Otter: there is no heave.

What real files do, and what is done about it (each said in the notes): the first row is an all-zero
placeholder (no attitude, and a speed that is not one) — rows whose attitude and rates are all zero carry no
attitude; attitude repeats unchanged for up to 2 s when the API re-sends an old sample — a repeat is not a new
sample; rows without a fix carry no position (nor velocity); a file that went through a spreadsheet has
numbers turned into dates (``jan.68`` for 1.68, Norwegian or English month names) — read back as month.digits;
a time that does not move forward ends no file but drops its row. The timeline is seconds since the first row.
"""

from __future__ import annotations

import math
import re
from collections import Counter
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path
from typing import Any

from mavbridge.field import say
from mavbridge.field.logs import LogError, LogInfo, Progress, TimedMessage

ANGLES = ("current_orientation_1", "current_orientation_2", "current_orientation_3")
RATES = ("current_rotational_velocities_1", "current_rotational_velocities_2", "current_rotational_velocities_3")
MONTHS = {"jan": 1, "feb": 2, "mar": 3, "apr": 4, "mai": 5, "may": 5, "jun": 6, "jul": 7, "aug": 8, "sep": 9,
          "okt": 10, "oct": 10, "nov": 11, "des": 12, "dec": 12}
MANGLED = re.compile(r"^(-?)([A-Za-z]{3})\.(\d+)$")
TIME_FORMAT = "%Y-%m-%d_%H:%M:%S:%f"
MAX_SPEED_M_S = 20.0  # a speed over ground beyond this is the placeholder's, not the boat's
GAP_S = 1.0  # rows further apart than this are a gap (said in the notes)


def looks_like_otter_csv(head: bytes) -> bool:
    """The header of an Otter API log: semicolons, an unnamed first column, the orientation columns."""
    first = head.split(b"\n", 1)[0]
    return first.startswith(b";") and all(name.encode() in first for name in ANGLES)


def number(text: str, repaired: Counter[str]) -> float | None:
    """A cell as a float: empty is None; a spreadsheet's date ('jan.68') is read back as 1.68 (counted)."""
    text = text.strip()
    if not text:
        return None
    try:
        return float(text)
    except ValueError:
        pass
    found = MANGLED.match(text)
    if found and found.group(2).lower() in MONTHS:
        repaired[text] += 1
        value = MONTHS[found.group(2).lower()] + float(f"0.{found.group(3)}")
        return -value if found.group(1) else value
    return None


def _local_time(cell: str) -> str:
    """The first column's time as a reader writes it, '2024-03-22 12:42:29 (the log's local time)'."""
    try:
        return datetime.strptime(cell.strip(), TIME_FORMAT).strftime("%Y-%m-%d %H:%M:%S (the log's local time)")
    except ValueError:
        return ""


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

    def _cell(self, cells: list[str], name: str, repaired: Counter[str]) -> float | None:
        i = self.columns.get(name)
        return number(cells[i], repaired) if i is not None and i < len(cells) else None

    def _time(self, cells: list[str], repaired: Counter[str]) -> float | None:
        """The row's time in Unix-like seconds: current_time, else the first column's local time."""
        unix = self._cell(cells, "current_time", repaired)
        if unix is not None and unix > 1e8:
            return unix
        try:
            return datetime.strptime(cells[0].strip(), TIME_FORMAT).timestamp()
        except ValueError:
            return None

    def messages(self, progress: Progress | None = None) -> Iterator[TimedMessage]:
        """ATTITUDE and GLOBAL_POSITION_INT per row (what it holds of them), on seconds since the first row."""
        counts, repaired = Counter[str](), Counter[str]()
        first_t: float | None = None
        last: dict[str, Any] = {"t": -math.inf, "attitude": None, "gap": 0.0}
        done, t = 0, 0.0
        with self.path.open(encoding="utf-8", errors="replace") as handle:
            handle.readline()
            for line in handle:
                done += len(line)
                cells = line.rstrip("\r\n").split(";")
                if len(cells) < len(self.columns):
                    self._short_row(line, t, counts)
                    continue
                row_t = self._time(cells, repaired)
                if row_t is None:
                    counts["rows without a readable time"] += 1
                    continue
                if first_t is None:
                    first_t = row_t
                    self.info.start_text = _local_time(cells[0])
                t = row_t - first_t
                yield from self._row(t, cells, counts, repaired, last)
                if progress is not None and counts["rows"] % 2000 == 0:
                    progress(done / max(self.info.size_bytes, 1), t)
        self._conclude(counts, repaired, last)

    def _short_row(self, line: str, t: float, counts: Counter[str]) -> None:
        """A row with fewer cells than the header: the file's cut-off end, or a damaged row (skipped, counted)."""
        if line.endswith("\n"):
            counts["rows with fewer cells than the header"] += 1
        else:
            self.info.stopped = (f"the file ends inside a row (cut short): read up to t = {t:.1f} s, the last "
                                 "row left out")

    def _row(self, t: float, cells: list[str], counts: Counter[str], repaired: Counter[str],
             last: dict[str, Any]) -> Iterator[TimedMessage]:
        """One row's messages: its position (with a fix), then its attitude (when it is a new sample)."""
        if t <= last["t"]:
            counts["rows whose time does not move forward"] += 1
            return
        last["gap"] = max(last["gap"], t - last["t"]) if math.isfinite(last["t"]) else 0.0
        last["t"] = t
        counts["rows"] += 1
        ms = round(t * 1000)
        fix = self._position(ms, cells, repaired)
        if fix is None:
            counts["rows without a position fix (lat/lon 0)"] += 1
        else:
            yield t, fix
        values = [self._cell(cells, name, repaired) for name in (*ANGLES, *RATES)]
        values = [0.0 if v is None or not math.isfinite(v) else v for v in values]
        if not any(values):
            counts["rows without attitude (all zero: a placeholder)"] += 1
        elif values == last["attitude"]:
            counts["rows repeating the previous attitude (not a new sample)"] += 1
        else:
            last["attitude"] = values
            rad = [math.radians(v) for v in values]
            yield t, say.attitude(ms, rad[0], rad[1], rad[2], rad[3:6])

    def _position(self, ms: int, cells: list[str], repaired: Counter[str]) -> Any:
        """GLOBAL_POSITION_INT of the row's fix (velocity from speed and course over ground), None without one."""
        lat, lon = self._cell(cells, "lat", repaired), self._cell(cells, "lon", repaired)
        if lat is None or lon is None or (lat == 0 and lon == 0) or not (abs(lat) <= 90 and abs(lon) <= 180):
            return None
        speed = self._cell(cells, "current_speed", repaired)
        course = self._cell(cells, "current_course_over_ground", repaired)
        velocity = (0.0, 0.0, 0.0)
        if speed is not None and course is not None and 0.0 <= speed <= MAX_SPEED_M_S:
            velocity = (speed * math.cos(math.radians(course)), speed * math.sin(math.radians(course)), 0.0)
        return say.position(ms, lat, lon, 0.0, velocity, course)

    def _conclude(self, counts: Counter[str], repaired: Counter[str], last: dict[str, Any]) -> None:
        for what, n in counts.items():
            if what != "rows" and n:
                self.info.note(f"{n} {what}")
        if repaired:
            example = repaired.most_common(1)[0][0]
            self.info.note(f"{sum(repaired.values())} numbers a spreadsheet had turned into dates read back "
                           f"(e.g. {example!r} as {number(example, Counter()):g})")
        if last["gap"] > GAP_S:
            self.info.note(f"the longest gap between rows is {last['gap']:.1f} s")
