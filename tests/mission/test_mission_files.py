"""Mission files: round trips, pymavlink's reader, and one-line errors for bad files and input."""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from mission import Mission, MissionError, MissionItem, read_mission_file, write_mission_file
from mission.plan import FRAME_GLOBAL
from vessel.geo import latlon_from_ned, ned_from_latlon

HOME = MissionItem(-35.363261, 149.165230, 584.0, frame=FRAME_GLOBAL)
MISSION = Mission(HOME, (MissionItem(-35.3625, 149.16606, 0.0),
                         MissionItem(-35.3621, 149.1670, 0.0, params=(5.0, 0.0, 0.0, 0.0))))


@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
def test_round_trip(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"m{suffix}"
    write_mission_file(MISSION, path)
    back = read_mission_file(path)
    assert back.home.lat_deg == pytest.approx(HOME.lat_deg, abs=1e-8)
    assert len(back.items) == 2
    for a, b in zip(back.items, MISSION.items, strict=True):
        assert (a.lat_deg, a.lon_deg, a.command, a.frame) == (pytest.approx(b.lat_deg, abs=1e-8),
                                                               pytest.approx(b.lon_deg, abs=1e-8), b.command, b.frame)
        assert a.params[0] == b.params[0]


def test_pymavlink_reads_what_we_write(tmp_path: Path) -> None:
    """In a fresh interpreter: pymavlink's MAVWPLoader fails under MAVLINK20=1 (which our links set)."""
    path = tmp_path / "m.waypoints"
    write_mission_file(MISSION, path)
    script = ("import sys; from pymavlink import mavwp; w = mavwp.MAVWPLoader(); n = w.load(sys.argv[1]); "
              "print(n, w.wp(1).x, w.wp(2).param1)")
    env = {k: v for k, v in os.environ.items() if k != "MAVLINK20"}
    out = subprocess.run([sys.executable, "-c", script, str(path)], capture_output=True, text=True, env=env,
                         timeout=60)
    assert out.returncode == 0, out.stderr
    count, lat, hold = out.stdout.split()
    assert int(count) == 3
    assert float(lat) == pytest.approx(MISSION.items[0].lat_deg, abs=1e-7)
    assert float(hold) == 5.0


def test_plan_nulls_become_nan(tmp_path: Path) -> None:
    path = tmp_path / "m.plan"
    write_mission_file(MISSION, path)
    data = json.loads(path.read_text())
    data["mission"]["items"][0]["params"][3] = None
    path.write_text(json.dumps(data))
    assert math.isnan(read_mission_file(path).items[0].params[3])


def _plan(tmp_path: Path, mutate: object) -> Path:
    path = tmp_path / "m.plan"
    write_mission_file(MISSION, path)
    data = json.loads(path.read_text())
    mutate(data)  # type: ignore[operator]
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(("mutate", "expected"), [
    (lambda d: d["mission"].pop("items"), "missing key 'mission.items'"),
    (lambda d: d["mission"]["items"][0].pop("command"), "item 1: missing key 'command'"),
    (lambda d: d["mission"]["items"].append({"type": "ComplexItem", "complexItemType": "survey"}),
     "item 3: complex item 'survey' is not supported"),
    (lambda d: d["mission"]["items"][1].update(command=3005), "item 2: command 3005 is not supported"),
    (lambda d: d["mission"]["items"][0]["params"].__setitem__(4, 95.0), "item 1: latitude 95.0 is outside"),
    (lambda d: d.pop("fileType"), "fileType"),
])
def test_bad_plan_files_name_the_item(tmp_path: Path, mutate: object, expected: str) -> None:
    with pytest.raises(MissionError, match=expected.replace("(", r"\(").replace(")", r"\)")) as info:
        read_mission_file(_plan(tmp_path, mutate))
    assert "\n" not in str(info.value)


def test_waypoints_line_with_11_fields_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "m.waypoints"
    write_mission_file(MISSION, path)
    lines = path.read_text().splitlines()
    lines[2] = "\t".join(lines[2].split("\t")[:11])
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(MissionError, match="line 3: expected 12 fields, got 11"):
        read_mission_file(path)


def test_unknown_extension_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(MissionError, match="unknown mission file type"):
        read_mission_file(tmp_path / "m.kml")
    with pytest.raises(MissionError, match="cannot read"):
        read_mission_file(tmp_path / "none.plan")


def test_flat_earth_round_trip_and_scale() -> None:
    lat, lon = latlon_from_ned(-35.363261, 149.165230, 85.0, 75.0)
    north, east = ned_from_latlon(-35.363261, 149.165230, lat, lon)
    assert (north, east) == (pytest.approx(85.0, abs=1e-6), pytest.approx(75.0, abs=1e-6))
    assert (lat + 35.363261) * 111_318.845 == pytest.approx(85.0, rel=1e-6)  # ArduPilot's metres per degree


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _mission_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mission.cli", *args], capture_output=True, text=True, timeout=60)


def test_cli_no_vehicle_answering_is_a_one_line_error() -> None:
    out = _mission_cli("upload", "--waypoint", "85,75", "--connect", f"udpin://127.0.0.1:{_free_udp_port()}",
                       "--timeout", "1")
    assert out.returncode == 1
    assert out.stderr.strip().splitlines() == [out.stderr.strip()]
    assert "no vehicle answered" in out.stderr


@pytest.mark.parametrize(("args", "expected"), [
    (["upload", "--latlon", "95,10"], "latitude 95.0 is outside the allowed range [-90, 90] deg"),
    (["upload", "--waypoint", "1e6,0"], "--waypoint"),
    (["upload", "--waypoint", "nan,0"], "non-finite"),
    (["upload", "--timeout", "-1", "--waypoint", "1,1"], "--timeout"),
])
def test_cli_bad_input_exits_2_before_connecting(args: list[str], expected: str) -> None:
    out = _mission_cli(*args)
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and expected in out.stderr


def test_cli_bad_file_exits_2(tmp_path: Path) -> None:
    path = _plan(tmp_path, lambda d: d["mission"]["items"].append({"type": "ComplexItem", "complexItemType": "survey"}))
    out = _mission_cli("upload", str(path), "--timeout", "1")
    assert out.returncode == 2 and "complex item 'survey'" in out.stderr
