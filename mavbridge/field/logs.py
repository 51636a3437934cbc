"""One vocabulary for every log a trial leaves: the autopilot's messages, as MAVLink says them, on one timeline.

A reader (``tlog``, ``dataflash``, ``otter_csv``) streams ``(t_s, message)`` pairs: ``message`` is a pymavlink
MAVLink message (ATTITUDE, GLOBAL_POSITION_INT, HEARTBEAT, SCALED_IMU, SERVO_OUTPUT_RAW, RC_CHANNELS,
MISSION_ITEM_INT, PARAM_VALUE, HOME_POSITION ...), read from a ``.tlog`` or said in MAVLink for what a DataFlash
or Otter log holds, so that the companion's own ``StateEstimate`` takes every format alike. ``t_s`` is the
log's timeline in seconds: the autopilot's clock (time_boot_ms) for MAVLink and DataFlash logs, continued
across a reboot; seconds since the first row for the Otter API's CSV. Messages come in the log's order.

``open_log`` finds the format from the file's first bytes (``--format`` may name it) and refuses, in one line
(``LogError``), a file that is none of them. A log cut short is read up to where it stops, and says so
(``LogInfo.stopped``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

FORMATS = ("auto", "tlog", "dataflash", "otter-csv")
FORMAT_HELP = ("the log's format: auto (from its first bytes), tlog (MAVLink from a ground station or the companion), "
               "dataflash (ArduPilot's .bin or text .log) or otter-csv (the Otter API's semicolon CSV)")
KINDS = "a MAVLink .tlog, an ArduPilot DataFlash .bin/.log or an Otter API .csv"

TimedMessage = tuple[float, Any]  # (t_s on the log's timeline, a MAVLink message)
Progress = Callable[[float, float], None]  # (fraction of the file read, t_s reached)


def plural(n: int, noun: str, many: str | None = None) -> str:
    """A count with its noun in the right number: '1 window', '3 windows', '2 stretches' (``many``)."""
    return f"{n} {noun if n == 1 else many or noun + 's'}"


class LogError(ValueError):
    """A file that is not a readable log (of the kind asked for), or holds nothing to report: one line."""


@dataclass
class LogInfo:
    """What a reader learnt about its log besides the messages (filled while reading)."""

    path: Path
    format: str
    source: str = ""  # who wrote the messages: "autopilot 1/1 (ArduPilot, surface boat)", "Otter API"
    start_text: str = ""  # when the log starts, as the log says it ("2024-03-07 15:34:58 UTC")
    stopped: str | None = None  # why the log ends early (cut short), None when read to its end
    notes: list[str] = field(default_factory=list)  # what the reading had to skip or repair, one line each
    size_bytes: int = 0

    def note(self, line: str) -> None:
        """Say one thing about the reading (once)."""
        if line not in self.notes:
            self.notes.append(line)


class LogReader(Protocol):
    """A log opened for reading: its info, and its messages (each call reads the file again from the start)."""

    info: LogInfo

    def messages(self, progress: Progress | None = None) -> Iterator[TimedMessage]:
        """The autopilot's messages on the log's timeline; ``progress`` is told how far the reading is."""
        ...


def _head(path: Path, size: int = 4096) -> bytes:
    with path.open("rb") as handle:
        return handle.read(size)


def sniff(path: Path) -> str | None:
    """The format of ``path`` from its first bytes (None when it is none of ours)."""
    from mavbridge.field.dataflash import looks_like_dataflash
    from mavbridge.field.otter_csv import looks_like_otter_csv
    from mavbridge.field.tlog import looks_like_tlog

    head = _head(path)
    for name, test in (("dataflash", looks_like_dataflash), ("otter-csv", looks_like_otter_csv),
                       ("tlog", looks_like_tlog)):
        if test(head):
            return name
    return None


def check_file(path: Path, flag: str = "LOG") -> None:
    """LogError (one line naming ``flag``) unless ``path`` is a readable, non-empty file."""
    if not path.exists():
        raise LogError(f"{flag}: {path}: no such file")
    if path.is_dir():
        raise LogError(f"{flag}: {path} is a folder, not a log file ({KINDS})")
    try:
        size = path.stat().st_size
        with path.open("rb"):
            pass
    except OSError as exc:
        raise LogError(f"{flag}: {path}: cannot be read ({exc.strerror or exc})") from None
    if size == 0:
        raise LogError(f"{flag}: {path} is empty (expected {KINDS})")


def check_out(out: str | None) -> None:
    """LogError (one line naming --out) when the output folder cannot be made: it, or a folder above it, is a file."""
    if out is None:
        return
    for folder in (Path(out), *Path(out).parents):
        if folder.exists() and not folder.is_dir():
            raise LogError(f"--out: {out}: {folder} is a file, not a folder")


def open_log(path: Path, fmt: str = "auto", sysid: int | None = None, outputs: bool = False) -> LogReader:
    """A reader for ``path`` in ``fmt`` (auto: found from its first bytes); ``sysid`` picks the autopilot of a
    MAVLink log that holds several; ``outputs``: the RC inputs, servo outputs and parameters too (a replay's).
    LogError (one line) for a file that is not such a log."""
    from mavbridge.field.dataflash import DataflashReader
    from mavbridge.field.otter_csv import OtterCsvReader
    from mavbridge.field.tlog import TlogReader

    check_file(path)
    found = sniff(path)
    if fmt == "auto":
        if found is None:
            raise LogError(f"LOG: {path} is not a log this reads (expected {KINDS}; --format names one)")
        fmt = found
    elif found != fmt:
        seen = f"it looks like {found}" if found else "it is none of the formats this reads"
        raise LogError(f"--format {fmt}: {path} is not a {fmt} log ({seen})")
    if fmt != "tlog" and sysid is not None:
        raise LogError(f"--sysid: applies to MAVLink .tlog logs only ({path} is {fmt})")
    readers: dict[str, Callable[[], LogReader]] = {
        "tlog": lambda: TlogReader(path, sysid, outputs), "dataflash": lambda: DataflashReader(path, outputs),
        "otter-csv": lambda: OtterCsvReader(path)}
    return readers[fmt]()
