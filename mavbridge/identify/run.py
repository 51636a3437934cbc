"""`mavbridge identify LOG... [--out DIR] [--base published|corrected|FILE]`: carried out.

Every log is opened and read first (a file that is not a log is refused in one line before anything is
written); a log without attitude among several is left out with a line, alone it is the error. The logs are
identified together (one boat), and, when there are several, each log and each day alone for the tables. A set
of logs that identifies nothing is one line per missing quantity and exit 2. The outputs go to a fresh folder:
an --out that already holds them is refused, never overwritten.
"""

from __future__ import annotations

import json
import math
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from mavbridge.field.logs import LogError, check_out
from mavbridge.identify.analyse import Identification
from mavbridge.identify.commands import identify
from mavbridge.identify.logdata import LogData, read_log
from mavbridge.identify.outputs import (
    model_check,
    resolve_base,
    unfit_lines,
    vessel_fields,
    vessel_mapping,
    write_yaml,
    yaw_identified,
)
from vessel import OtterParameters

OUTPUTS = ("identify.json", "vessel.yaml", "identify.html")
UNFIT = {"yaw_time_constant": "the model flown through the logs' commands comes closest to their yaw rate at no "
                              "yaw_time_constant inside 0.05-20 s (its yaw answers the commands otherwise than the "
                              "boat's)"}


def out_folder(out: str | None) -> Path:
    """The folder to write: --out (refused when it already holds an output), else a new runs/identify-<time>."""
    check_out(out)
    if out is not None:
        folder = Path(out)
        taken = [name for name in OUTPUTS if (folder / name).exists()]
        if taken:
            raise LogError(f"--out: {out} already holds {taken[0]}: pick a new folder (nothing is overwritten)")
        return folder
    stem = Path("runs") / f"identify-{time.strftime('%Y%m%d-%H%M%S')}"
    folder, n = stem, 1
    while folder.exists():
        n += 1
        folder = stem.with_name(f"{stem.name}-{n}")
    return folder


def read_all(paths: list[str], say: Any) -> list[LogData]:
    """Each log's arrays; a log without attitude among several is left out with a line."""
    logs = []
    for path in paths:
        try:
            logs.append(read_log(Path(path)))
        except LogError as exc:
            if len(paths) == 1 or "no attitude" not in str(exc):
                raise
            say(f"left out: {exc}")
    if not logs:
        raise LogError("LOG: none of the logs holds attitude: nothing to identify")
    return logs


def figures_row(result: Identification) -> dict[str, Any]:
    """{name: {value, low, high, unit, source, fit_r2}} of every estimate."""
    return {name: e.row() for name, e in result.estimates.items()}


def breakdown(logs: list[LogData], base: OtterParameters) -> dict[str, Any]:
    """Each log alone, and each day alone (when the logs span several)."""
    per_log = {str(log.path): figures_row(identify([log], base)) for log in logs} if len(logs) > 1 else {}
    days: dict[str, list[LogData]] = defaultdict(list)
    for log in logs:
        days[log.day].append(log)
    per_day = {day: figures_row(identify(group, base)) for day, group in sorted(days.items())} \
        if len(days) > 1 else {}
    return {"per_log": per_log, "per_day": per_day}


def identify_command(paths: list[str], out: str | None, base_name: str, command: str) -> int:
    """Carry out the command; 2 with one line per reason when nothing could be identified."""
    def say(line: str) -> None:
        print(line, flush=True)

    base, named, file_fields = resolve_base(base_name)
    folder = out_folder(out)
    logs = read_all(paths, say)
    result = identify(logs, base)
    for line in result.missing:
        say(f"not identified: {line}")
    if not result.estimates:
        sys.stderr.write(f"mavbridge: error: {', '.join(paths)}: nothing identifiable in "
                         f"{'these logs' if len(logs) > 1 else 'this log'}\n")
        return 2
    fields = vessel_fields(base, result)
    for line in unfit_lines(result):
        result.missing.append(line)
        say(f"not in vessel.yaml: {line}")
    for name, field in (("roll_period_s", "gyration_roll"), ("roll_damping_ratio", "zeta_roll"),
                        ("pitch_period_s", "gyration_pitch"), ("pitch_damping_ratio", "zeta_pitch"),
                        ("yaw_nomoto_time_constant_s", "yaw_time_constant")):
        if name in result.estimates and field not in fields and (field != "yaw_time_constant"
                                                                 or yaw_identified(result)):
            line = f"{name} {result.estimates[name].value:.3g}: {UNFIT.get(field, f'beyond what {field} can give')}; " \
                   "left as the base's"
            result.missing.append(line)
            say(f"not in vessel.yaml: {line}")
    identified = base.replace(**fields)
    data = {"command": command, "logs": [{"path": str(log.path), "format": log.format, "day": log.day,
                                          "duration_s": round(log.duration_s, 1), "notes": log.notes}
                                         for log in logs],
            "base": base_name, **figures_row(result), "not_identified": result.missing,
            "surge_command": _surge_summary(result), "vessel_fields": fields,
            "model_check": model_check(base, identified, result), **breakdown(logs, base)}
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "identify.json").write_text(json.dumps(data, indent=1, default=float) + "\n", encoding="utf-8")
    write_yaml(folder / "vessel.yaml", vessel_mapping(named, file_fields, fields), command)
    from mavbridge.identify.page import write_page

    write_page(folder / "identify.html", result, data, base, identified)
    for name, e in result.estimates.items():
        say(f"{name}: {e.text()} (R² {e.fit:.2f}; {e.source})")
    say(f"wrote {folder / 'identify.json'}, {folder / 'vessel.yaml'}, {folder / 'identify.html'}")
    return 0


def _surge_summary(result: Identification) -> dict[str, Any]:
    """The surge command's kind and full scale (the log's unit), and its steady windows."""
    s = result.surge
    if not s:
        return {}
    return {"command": s["label"], "unit": s["unit"], "full_forward": round(s["full_forward"], 3),
            "full_reverse": round(s["full_reverse"], 3),
            "steady_windows": [{"t_s": round(p.t_s, 1), "command": round(p.command, 3),
                                "thrust_fraction": round(p.fraction, 4), "speed_m_s": round(p.speed_m_s, 3),
                                "pitch_deg": round(math.degrees(p.pitch_rad), 3)
                                if math.isfinite(p.pitch_rad) else None}
                               for p in s["points"]]}
