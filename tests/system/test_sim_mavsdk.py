"""MAVSDK (PyPI mavsdk 4.x) against sim-vehicle over UDP: discovery, MissionRaw upload/download, AUTO run."""

from __future__ import annotations

import asyncio
import math
from contextlib import aclosing
from pathlib import Path

from mavsdk.asyncio.plugins import action, mission_raw

from mission.transfer import connected_system
from sim_vehicle.harness import SimProcess

HOME_LAT, HOME_LON = -35.363261, 149.165230


def _degE7(north: float, east: float) -> tuple[int, int]:
    lat = HOME_LAT + math.degrees(north / 6378137.0)
    lon = HOME_LON + math.degrees(east / (6378137.0 * math.cos(math.radians(HOME_LAT))))
    return round(lat * 1e7), round(lon * 1e7)


async def _scenario(port: int) -> tuple[list, list]:
    """Connect, upload home + one waypoint 30 m North, download, arm, start, wait for completion."""
    MissionItem = mission_raw.MissionItem
    # connected_system releases the plugins before the Mavsdk instance, as MAVSDK 4.1 requires
    async with connected_system(f"udpin://127.0.0.1:{port}", 10.0, lambda _line: None) as system:
        missions = mission_raw.MissionRawAsync(system)
        home = _degE7(0, 0)
        wp = _degE7(30, 0)
        items = [
            MissionItem(0, 0, 16, 1, 1, 0, 0, 0, 0, home[0], home[1], 584.0, 0),
            MissionItem(1, 3, 16, 0, 1, 0, 0, 0, 0, wp[0], wp[1], 0.0, 0),
        ]
        await missions.upload_mission(items)
        downloaded = await missions.download_mission()
        await action.ActionAsync(system).arm()
        await missions.start_mission()
        progress = []

        async def watch() -> None:
            async with aclosing(missions.subscribe_mission_progress()) as updates:
                async for p in updates:
                    progress.append((p.current, p.total))
                    if p.current == p.total == 2:
                        return

        await asyncio.wait_for(watch(), timeout=20.0)
        return downloaded, progress


def test_mavsdk_mission_raw_round_trip_and_run(tmp_path: Path) -> None:
    """MAVSDK discovers the boat, uploads and downloads with MissionRaw, arms, and sees the mission finish."""
    with SimProcess(tmp_path, speedup=10, udp_outs=1) as sim:
        downloaded, progress = asyncio.run(asyncio.wait_for(_scenario(sim.udp_ports[0]), timeout=60.0))
    assert len(downloaded) == 2 and downloaded[1].x == _degE7(30, 0)[0]
    assert progress[-1] == (2, 2)
