"""`mission upload` refuses what the companion would refuse to fly, and `download --out` checks its file first.

Both checks happen before connecting: the commands below name a port nobody listens on, so a check that
came after connecting would show as "no vehicle answered" (exit 1) instead of the one-line refusal (exit 2).
"""

from __future__ import annotations

import math
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from mission import Mission, MissionItem, write_mission_file
from mission.plan import FRAME_GLOBAL
from vessel.geo import DEFAULT_MAX_RANGE_M, latlon_from_ned

HOME = (-35.363261, 149.165230)


def _free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _mission_cli(*args: str) -> subprocess.CompletedProcess[str]:
    url = f"udpin://127.0.0.1:{_free_udp_port()}"
    return subprocess.run([sys.executable, "-m", "mission.cli", *args, "--connect", url, "--timeout", "1"],
                          capture_output=True, text=True, timeout=60)


def _file(tmp_path: Path, suffix: str, north_m: float) -> Path:
    """A one-waypoint mission file ``north_m`` metres north of its home."""
    lat, lon = latlon_from_ned(*HOME, north_m, 0.0)
    path = tmp_path / f"m{suffix}"
    write_mission_file(Mission(MissionItem(*HOME, 0.0, frame=FRAME_GLOBAL), (MissionItem(lat, lon, 0.0),)), path)
    return path


@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
def test_a_file_with_a_far_waypoint_is_refused(tmp_path: Path, suffix: str) -> None:
    path = _file(tmp_path, suffix, DEFAULT_MAX_RANGE_M + 100.0)
    out = _mission_cli("upload", str(path))
    assert out.returncode == 2, out.stderr
    assert out.stderr.count("\n") == 1
    assert f"{path}: item 1 is 5.1 km from home, farther than --max-range 5000 m" in out.stderr


def test_a_file_within_range_gets_as_far_as_connecting(tmp_path: Path) -> None:
    out = _mission_cli("upload", str(_file(tmp_path, ".plan", DEFAULT_MAX_RANGE_M - 100.0)))
    assert out.returncode == 1 and "no vehicle answered" in out.stderr, out.stderr


@pytest.mark.parametrize(("args", "expected"), [
    (["upload", "--waypoint", "4000,3001"],
     f"--waypoint: 4000,3001 is {math.hypot(4000, 3001):g} m from home, farther than --max-range 5000 m"),
    (["upload", "--waypoint", "600,0", "--max-range", "500"], "farther than --max-range 500 m"),
    (["upload", "--waypoint", "6,0", "--max-range", "nan"], "--max-range"),
    (["upload", "--waypoint", "6,0", "--max-range", "0"], "--max-range"),
    (["download", "--out", "no/such/folder/x.plan"], "the folder no/such/folder does not exist"),
    (["download", "--out", "x.kml"], "unknown mission file type '.kml'"),
])
def test_refused_before_connecting(args: list[str], expected: str) -> None:
    out = _mission_cli(*args)
    assert out.returncode == 2, out.stderr
    assert out.stderr.count("\n") == 1 and expected in out.stderr, out.stderr


def test_download_into_a_folder_is_refused(tmp_path: Path) -> None:
    out = _mission_cli("download", "--out", str(tmp_path))
    assert out.returncode == 2 and "--out" in out.stderr, out.stderr
    assert list(tmp_path.iterdir()) == []
