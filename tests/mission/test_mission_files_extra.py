"""Mission files: UTF-8 BOMs, NaN hold times going to MAVSDK, AltitudeMode by frame and `.mission` files."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from mission import Mission, MissionItem, read_mission_file, write_mission_file
from mission.plan import FRAME_GLOBAL
from mission.transfer import to_mavsdk_items

BOM = b"\xef\xbb\xbf"
HOME = MissionItem(-35.363261, 149.165230, 584.0, frame=FRAME_GLOBAL)


def _mission(*frames: int) -> Mission:
    return Mission(HOME, tuple(MissionItem(-35.3625 + 1e-4 * i, 149.16606, 0.0, frame=frame, params=(2.0, 0, 0, 0))
                               for i, frame in enumerate(frames)))


@pytest.mark.parametrize("suffix", [".plan", ".waypoints"])
def test_bom_at_start_of_file_is_ignored(tmp_path: Path, suffix: str) -> None:
    """A file saved by an editor that puts a UTF-8 byte-order mark first still reads (JSON and WPL header)."""
    path = tmp_path / f"m{suffix}"
    mission = _mission(3, 3)
    write_mission_file(mission, path)
    path.write_bytes(BOM + path.read_bytes())
    back = read_mission_file(path)
    assert back.home.lat_deg == pytest.approx(HOME.lat_deg, abs=1e-8)
    assert [(i.lat_deg, i.params[0]) for i in back.items] == [
        (pytest.approx(i.lat_deg, abs=1e-8), 2.0) for i in mission.items
    ]


def test_nan_hold_time_goes_out_as_zero(tmp_path: Path) -> None:
    """A `.plan` null in param1 (hold time) is sent as 0 s; a null param4 (yaw) stays NaN."""
    path = tmp_path / "m.plan"
    write_mission_file(_mission(3, 3), path)
    data = json.loads(path.read_text())
    data["mission"]["items"][0]["params"][0] = None
    data["mission"]["items"][0]["params"][3] = None
    path.write_text(json.dumps(data))
    mission = read_mission_file(path)
    assert math.isnan(mission.items[0].params[0])
    items = to_mavsdk_items(mission)
    assert items[1].param1 == 0.0
    assert math.isnan(items[1].param4)
    assert items[2].param1 == 2.0


@pytest.mark.parametrize(
    ("frames", "modes", "global_mode"),
    [((3, 6), [1, 1], 1), ((0, 5), [2, 2], 2), ((3, 0), [1, 2], 0)],
)
def test_plan_altitude_mode_follows_frame(
    tmp_path: Path, frames: tuple[int, ...], modes: list[int], global_mode: int
) -> None:
    """Relative frames (3, 6) are AltitudeMode 1, absolute ones (0, 5) AMSL 2; mixed plans say 0 globally."""
    path = tmp_path / "m.plan"
    write_mission_file(_mission(*frames), path)
    data = json.loads(path.read_text())
    assert [item["AltitudeMode"] for item in data["mission"]["items"]] == modes
    assert [item["frame"] for item in data["mission"]["items"]] == list(frames)
    assert data["mission"]["globalPlanAltitudeMode"] == global_mode
    assert [i.frame for i in read_mission_file(path).items] == list(frames)


def test_mission_extension_round_trip(tmp_path: Path) -> None:
    """`.mission` is written as `QGC WPL 110`, like `.waypoints`, and reads back the same."""
    path = tmp_path / "m.mission"
    mission = _mission(3, 0)
    write_mission_file(mission, path)
    assert path.read_text().splitlines()[0] == "QGC WPL 110"
    back = read_mission_file(path)
    assert back.home.lat_deg == pytest.approx(HOME.lat_deg, abs=1e-8)
    for a, b in zip(back.items, mission.items, strict=True):
        assert (a.lat_deg, a.lon_deg, a.frame, a.params) == (
            pytest.approx(b.lat_deg, abs=1e-8), pytest.approx(b.lon_deg, abs=1e-8), b.frame, b.params
        )
