"""Mission files that ground stations use: QGroundControl `.plan` (JSON) and `QGC WPL 110` `.waypoints`.

Reading validates as it goes and reports the first problem in one line naming the file and the item
(or line); writing produces files QGroundControl, Mission Planner, MAVProxy and pymavlink load.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from mission.plan import FRAME_GLOBAL, Mission, MissionError, MissionItem, validate

WPL_HEADER = "QGC WPL 110"
WPL_FIELDS = 12
MAV_TYPE_SURFACE_BOAT = 11
MAV_AUTOPILOT_ARDUPILOTMEGA = 3
# QGroundControl's AltMode: 0 mixed (global setting only), 1 relative to home, 2 AMSL
ALT_MODE_MIXED, ALT_MODE_RELATIVE, ALT_MODE_AMSL = 0, 1, 2
ALT_MODE_BY_FRAME = {0: ALT_MODE_AMSL, 3: ALT_MODE_RELATIVE, 5: ALT_MODE_AMSL, 6: ALT_MODE_RELATIVE}
# Files are read as "utf-8-sig": a UTF-8 byte-order mark (Windows editors add one) is dropped, not parsed.
READ_ENCODING = "utf-8-sig"
WAYPOINT_SUFFIXES = (".waypoints", ".txt", ".mission")


def _number(value: Any, where: str, allow_null: bool = False) -> float:
    """A finite number from JSON/text (null -> NaN where allowed)."""
    if value is None and allow_null:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise MissionError(f"{where}: expected a number, got {value!r}")
    return float(value)


def read_plan(path: str | Path) -> Mission:
    """Read a QGroundControl `.plan` file (SimpleItems only; surveys and other complex items refused)."""
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding=READ_ENCODING))
    except OSError as exc:
        raise MissionError(f"{path}: cannot read file ({exc.strerror or exc})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise MissionError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or data.get("fileType") != "Plan":
        raise MissionError(f"{path}: missing key 'fileType': \"Plan\" (not a QGroundControl plan)")
    mission = data.get("mission")
    if not isinstance(mission, dict):
        raise MissionError(f"{path}: missing key 'mission'")
    for key in ("items", "plannedHomePosition"):
        if key not in mission:
            raise MissionError(f"{path}: missing key 'mission.{key}'")
    home_pos = mission["plannedHomePosition"]
    if not isinstance(home_pos, list) or len(home_pos) != 3:
        raise MissionError(f"{path}: mission.plannedHomePosition: expected [lat, lon, alt]")
    home = MissionItem(*(_number(v, f"{path}: mission.plannedHomePosition") for v in home_pos),
                       frame=FRAME_GLOBAL)
    if not isinstance(mission["items"], list):
        raise MissionError(f"{path}: mission.items: expected a list")
    items = [_plan_item(raw, f"{path}: item {index}") for index, raw in enumerate(mission["items"], start=1)]
    return validate(Mission(home, tuple(items)), str(path))


def _plan_item(raw: Any, where: str) -> MissionItem:
    """One `.plan` SimpleItem."""
    if not isinstance(raw, dict):
        raise MissionError(f"{where}: expected an object")
    kind = raw.get("type")
    if kind == "ComplexItem":
        raise MissionError(f"{where}: complex item '{raw.get('complexItemType', '?')}' is not supported "
                           f"(only single NAV_WAYPOINT items)")
    if kind != "SimpleItem":
        raise MissionError(f"{where}: item type {kind!r} is not supported (expected 'SimpleItem')")
    for key in ("command", "frame", "params"):
        if key not in raw:
            raise MissionError(f"{where}: missing key '{key}'")
    params = raw["params"]
    if not isinstance(params, list) or len(params) != 7:
        raise MissionError(f"{where}: params: expected 7 values")
    command, frame = raw["command"], raw["frame"]
    if not isinstance(command, int) or not isinstance(frame, int):
        raise MissionError(f"{where}: command and frame must be integers")
    p = [_number(v, f"{where}: params[{i}]", allow_null=i < 4) for i, v in enumerate(params)]
    return MissionItem(lat_deg=p[4], lon_deg=p[5], alt_m=p[6], command=command, frame=frame,
                       params=(p[0], p[1], p[2], p[3]), autocontinue=bool(raw.get("autoContinue", True)))


def _json_param(value: float) -> float | None:
    """NaN is written as null, as QGroundControl does."""
    return None if math.isnan(value) else value


def _altitude_mode(frame: int) -> int:
    """QGroundControl's AltitudeMode for a MAV_FRAME: relative (3, 6) or AMSL (0, 5); relative otherwise."""
    return ALT_MODE_BY_FRAME.get(frame, ALT_MODE_RELATIVE)


def write_plan(mission: Mission, path: str | Path, cruise_speed_mps: float = 2.0) -> None:
    """Write a QGroundControl `.plan` file for an ArduPilot boat.

    Each item's AltitudeMode follows its frame; the plan's global mode is the items' common one, or
    mixed when they differ (QGroundControl then keeps each item's own mode).
    """
    items = []
    modes = {_altitude_mode(item.frame) for item in mission.items}
    global_mode = modes.pop() if len(modes) == 1 else ALT_MODE_MIXED
    for jump_id, item in enumerate(mission.items, start=1):
        items.append({
            "AMSLAltAboveTerrain": None,
            "Altitude": item.alt_m,
            "AltitudeMode": _altitude_mode(item.frame),
            "autoContinue": item.autocontinue,
            "command": item.command,
            "doJumpId": jump_id,
            "frame": item.frame,
            "params": [*(_json_param(v) for v in item.params), item.lat_deg, item.lon_deg, item.alt_m],
            "type": "SimpleItem",
        })
    plan = {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": cruise_speed_mps,
            "firmwareType": MAV_AUTOPILOT_ARDUPILOTMEGA,
            "globalPlanAltitudeMode": global_mode,
            "hoverSpeed": 5,
            "items": items,
            "plannedHomePosition": [mission.home.lat_deg, mission.home.lon_deg, mission.home.alt_m],
            "vehicleType": MAV_TYPE_SURFACE_BOAT,
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "version": 1,
    }
    Path(path).write_text(json.dumps(plan, indent=4) + "\n", encoding="utf-8")


def read_waypoints(path: str | Path) -> Mission:
    """Read a `QGC WPL 110` file: line 0 is home, the rest are items (12 tab-separated fields each)."""
    path = Path(path)
    try:
        lines = path.read_text(encoding=READ_ENCODING).splitlines()
    except OSError as exc:
        raise MissionError(f"{path}: cannot read file ({exc.strerror or exc})") from None
    except UnicodeDecodeError:
        raise MissionError(f"{path}: not a text file") from None
    if not lines or lines[0].strip() != WPL_HEADER:
        raise MissionError(f"{path}: line 1: expected the header '{WPL_HEADER}'")
    rows: list[MissionItem] = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split("\t") if "\t" in line else line.split()
        if len(fields) != WPL_FIELDS:
            raise MissionError(f"{path}: line {number}: expected {WPL_FIELDS} fields, got {len(fields)}")
        try:
            index, _current, frame, command = (int(f) for f in fields[0:4])
            values = [float(f) for f in fields[4:11]]
            autocontinue = int(fields[11])
        except ValueError:
            raise MissionError(f"{path}: line {number}: fields must be numbers") from None
        if index != len(rows):
            raise MissionError(f"{path}: line {number}: index {index} out of order (expected {len(rows)})")
        rows.append(MissionItem(lat_deg=values[4], lon_deg=values[5], alt_m=values[6], command=command,
                                frame=frame, params=(values[0], values[1], values[2], values[3]),
                                autocontinue=bool(autocontinue)))
    if not rows:
        raise MissionError(f"{path}: no home line after the header")
    return validate(Mission(rows[0], tuple(rows[1:])), str(path))


def write_waypoints(mission: Mission, path: str | Path) -> None:
    """Write a `QGC WPL 110` file (home as line 0, current flag on home as Mission Planner does)."""
    lines = [WPL_HEADER]
    for index, item in enumerate(mission.all_items()):
        current = 1 if index == 0 else 0
        numbers = [*item.params, item.lat_deg, item.lon_deg, item.alt_m]
        text = "\t".join(f"{v:.8f}" if not math.isnan(v) else "0.00000000" for v in numbers)
        lines.append(f"{index}\t{current}\t{item.frame}\t{item.command}\t{text}\t{int(item.autocontinue)}")
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def read_mission_file(path: str | Path) -> Mission:
    """Read `.plan` or `.waypoints` by extension (`.txt` and `.mission` as waypoints too)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".plan":
        return read_plan(path)
    if suffix in WAYPOINT_SUFFIXES:
        return read_waypoints(path)
    raise MissionError(f"{path}: unknown mission file type '{suffix}' (allowed: .plan, .waypoints)")


def write_mission_file(mission: Mission, path: str | Path) -> None:
    """Write `.plan` or `.waypoints` by extension (`.txt` and `.mission` as waypoints too)."""
    suffix = Path(path).suffix.lower()
    if suffix == ".plan":
        write_plan(mission, path)
    elif suffix in WAYPOINT_SUFFIXES:
        write_waypoints(mission, path)
    else:
        raise MissionError(f"{path}: unknown mission file type '{suffix}' (allowed: .plan, .waypoints)")


def check_output_file(path: str | Path, flag: str = "--out") -> None:
    """Raise MissionError unless ``path`` can take a mission file: a known extension, an existing folder, not a
    folder itself. Checked before connecting, so that a download is never lost to a bad name afterwards."""
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix != ".plan" and suffix not in WAYPOINT_SUFFIXES:
        raise MissionError(f"{flag}: {path}: unknown mission file type '{suffix}' (allowed: .plan, .waypoints)")
    if target.is_dir():
        raise MissionError(f"{flag}: {path} is a folder; give a file name ending .plan or .waypoints")
    folder = target.parent
    if not folder.is_dir():
        why = "is a file, not a folder" if folder.exists() else "does not exist"
        raise MissionError(f"{flag}: {path}: the folder {folder} {why}")
    if not os.access(folder, os.W_OK):
        raise MissionError(f"{flag}: {path}: the folder {folder} is not writable")
