"""Mission upload, download and clear with MAVSDK's MissionRaw against an ArduPilot vehicle.

ArduPilot keeps home at seq 0, so uploads carry home first and put current=1 on seq 1 (MAVSDK
insists on exactly one current item). The high-level Mission plugin is not used: it sends no home.
"""

from __future__ import annotations

import asyncio
import gc
import math
import sys
from collections.abc import AsyncIterator, Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import aclosing, asynccontextmanager
from dataclasses import dataclass

import mavsdk
from mavsdk import LogLevel
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk, MavsdkConnectionError
from mavsdk.asyncio.plugins.mission_raw import MissionItem as RawItem
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync, MissionRawError
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

from mission.plan import FRAME_GLOBAL, MAV_CMD_NAV_WAYPOINT, Mission, MissionItem, validate
from vessel.geo import latlon_from_ned

DEFAULT_URL = "udpin://0.0.0.0:14550"
GCS_SYSTEM_ID = 245  # MAVSDK's ground-station default; not SYSID_MYGCS, so it never takes the RC link
GCS_COMPONENT_ID = 190
MISSION_TYPE_MISSION = 0
HOME_POSITION_WAIT_S = 3.0  # HOME_POSITION is requested at connection; after this, home comes from the mission


class TransferError(RuntimeError):
    """A mission transfer failed; the message is one line that says what and why."""


@dataclass(frozen=True)
class Home:
    """The vehicle's home position (deg, deg, m AMSL)."""

    lat_deg: float
    lon_deg: float
    alt_m: float


def _mavsdk_log_line(level: LogLevel, message: str, _file: str | None, _line: int) -> bool:
    """Print MAVSDK's ERROR lines on stderr, drop the rest; True: MAVSDK prints nothing itself.

    Transfer failures are reported by us in one line; MAVSDK's own errors are kept because they are
    the only explanation of a fatal one (MAVSDK 4.1 logs why, then aborts the process).
    """
    if level >= LogLevel.ERROR:
        print(f"MAVSDK error: {message}", file=sys.stderr, flush=True)
    return True


def _quiet_mavsdk() -> None:
    """Keep MAVSDK's debug, info and warning lines off the operator's terminal."""
    mavsdk.log_subscribe(_mavsdk_log_line)


@asynccontextmanager
async def plugins_released_before_teardown() -> AsyncIterator[None]:
    """Run MAVSDK's blocking calls on a thread pool of our own, and join it before the Mavsdk instance goes.

    MAVSDK's asyncio wrappers run each blocking call (an upload, a download, an arm) in the event loop's
    default executor, and the worker thread holds the call, and so its plugin, for a moment after the
    result is back. When that reference is the plugin's last, the worker releases the plugin while this
    thread is already destroying Mavsdk, and MAVSDK 4.1 aborts the process if a plugin is still alive at
    that point (seen under load: `mission upload` exiting with SIGABRT right after "upload accepted").
    Joining the pool, then collecting reference cycles on this thread, releases every plugin first.
    Enter it inside ``async with Mavsdk(...)``, so that it is left before the instance is destroyed. One
    at a time per event loop: two open at once would swap the loop's executor under each other.
    """
    loop = asyncio.get_running_loop()
    pool = ThreadPoolExecutor(thread_name_prefix="mavsdk-call")
    loop.set_default_executor(pool)
    try:
        yield
    finally:
        pool.shutdown(wait=True)  # waits, too, for a call whose await was cancelled but still runs in C
        gc.collect()
        loop.set_default_executor(ThreadPoolExecutor())  # for the loop's later to_thread calls; no threads yet


@asynccontextmanager
async def connected_system(url: str, timeout_s: float, progress: Callable[[str], None]) -> AsyncIterator[object]:
    """Connect to ``url`` and yield the first autopilot found, or raise TransferError on timeout.

    Every plugin made from the system inside the block is released before the Mavsdk instance
    (`plugins_released_before_teardown`).
    """

    _quiet_mavsdk()
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    config.system_id = GCS_SYSTEM_ID
    config.component_id = GCS_COMPONENT_ID
    async with Mavsdk(config) as drone, plugins_released_before_teardown():
        try:
            await drone.add_any_connection(url)
        except MavsdkConnectionError as exc:
            raise TransferError(f"connection {url!r} refused: {exc}") from None
        progress(f"waiting for a vehicle on {url} (up to {timeout_s:g} s)")
        system = await drone.first_autopilot(timeout_s=timeout_s)
        if system is None:
            raise TransferError(f"no vehicle answered on {url} within {timeout_s:g} s")
        progress(f"vehicle {await system.get_system_id()} connected")
        yield system


def to_mavsdk_items(mission: Mission) -> list[object]:
    """MAVSDK MissionItems, home at seq 0 (frame GLOBAL), current=1 on seq 1; lat/lon as degE7.

    A NAV_WAYPOINT's param1 is ArduPilot's hold time in seconds, so an unset one (NaN, a `.plan` null)
    goes out as 0 s; params 2-4 may stay NaN.
    """

    result = []
    for seq, item in enumerate(mission.all_items()):
        p1, p2, p3, p4 = item.params
        if item.command == MAV_CMD_NAV_WAYPOINT and math.isnan(p1):
            p1 = 0.0
        result.append(RawItem(seq=seq, frame=item.frame, command=item.command, current=1 if seq == 1 else 0,
                              autocontinue=int(item.autocontinue), param1=p1, param2=p2, param3=p3,
                              param4=p4, x=round(item.lat_deg * 1e7), y=round(item.lon_deg * 1e7),
                              z=float(item.alt_m), mission_type=MISSION_TYPE_MISSION))
    return result


def from_mavsdk_items(items: list[object]) -> Mission:
    """Our Mission from downloaded MAVSDK items (seq 0 is home)."""
    if not items:
        raise TransferError("the vehicle has no mission (not even home)")
    converted = [MissionItem(lat_deg=i.x / 1e7, lon_deg=i.y / 1e7, alt_m=float(i.z), command=int(i.command),
                             frame=int(i.frame), params=(i.param1, i.param2, i.param3, i.param4),
                             autocontinue=bool(i.autocontinue)) for i in items]
    home = converted[0]
    return Mission(MissionItem(home.lat_deg, home.lon_deg, home.alt_m, frame=FRAME_GLOBAL), tuple(converted[1:]))


def _raise_for(exc: Exception, action: str) -> None:
    """Turn a MissionRawError into a one-line TransferError."""
    result = getattr(exc, "result", None)
    name = getattr(result, "name", None) or str(result or exc)
    hints = {"TIMEOUT": "the vehicle stopped answering", "DENIED": "the vehicle refused (busy?)",
             "INT_MESSAGES_NOT_SUPPORTED": "the autopilot lacks MISSION_INT",
             "TOO_MANY_MISSION_ITEMS": "more items than the vehicle stores"}
    raise TransferError(f"mission {action} failed: {name}"
                        + (f" ({hints[name]})" if name in hints else "")) from None


async def vehicle_home(system: object, timeout_s: float) -> Home:
    """The vehicle's home: from HOME_POSITION (MAVSDK requests it), else seq 0 of its mission (ArduPilot's home).

    A HOME_POSITION that arrived before our subscription is not repeated, so the mission is the fallback.
    """
    telemetry = TelemetryAsync(system)

    async def first_home() -> Home:
        async with aclosing(telemetry.subscribe_home()) as homes:  # unsubscribes here, not when collected
            async for position in homes:
                if math.isfinite(position.latitude_deg) and (position.latitude_deg or position.longitude_deg):
                    return Home(position.latitude_deg, position.longitude_deg, position.absolute_altitude_m)
        raise TransferError("the vehicle's home stream ended")

    try:
        return await asyncio.wait_for(first_home(), min(timeout_s, HOME_POSITION_WAIT_S))
    except TimeoutError:
        pass
    try:
        items = await asyncio.wait_for(MissionRawAsync(system).download_mission(), timeout_s)
    except (MissionRawError, TimeoutError):
        items = []
    if not items or not (items[0].x or items[0].y):
        raise TransferError(f"the vehicle sent no home position within {timeout_s:g} s")
    return Home(items[0].x / 1e7, items[0].y / 1e7, float(items[0].z))


async def upload(mission: Mission, url: str = DEFAULT_URL, timeout_s: float = 10.0,
                 progress: Callable[[str], None] = print) -> None:
    """Validate, then upload the mission (home + items); the stored mission is untouched on any error."""

    validate(mission)
    async with connected_system(url, timeout_s, progress) as system:
        progress(f"uploading {len(mission.items)} item(s) after home")
        try:
            await MissionRawAsync(system).upload_mission(to_mavsdk_items(mission))
        except MissionRawError as exc:
            _raise_for(exc, "upload")
        progress("upload accepted by the vehicle")


async def upload_relative(north_m: float, east_m: float, url: str = DEFAULT_URL, timeout_s: float = 10.0,
                          progress: Callable[[str], None] = print) -> Mission:
    """Upload one waypoint given in metres from the vehicle's home (NED); returns the mission sent."""


    async with connected_system(url, timeout_s, progress) as system:
        home = await vehicle_home(system, timeout_s)
        lat, lon = latlon_from_ned(home.lat_deg, home.lon_deg, north_m, east_m)
        mission = validate(Mission(MissionItem(home.lat_deg, home.lon_deg, home.alt_m, frame=FRAME_GLOBAL),
                                   (MissionItem(lat, lon, 0.0),)))
        progress(f"waypoint {north_m:g} m north, {east_m:g} m east of home = {lat:.7f}, {lon:.7f}")
        try:
            await MissionRawAsync(system).upload_mission(to_mavsdk_items(mission))
        except MissionRawError as exc:
            _raise_for(exc, "upload")
        progress("upload accepted by the vehicle")
        return mission


async def download(url: str = DEFAULT_URL, timeout_s: float = 10.0,
                   progress: Callable[[str], None] = print) -> Mission:
    """Download the stored mission, home included."""

    async with connected_system(url, timeout_s, progress) as system:
        try:
            items = await MissionRawAsync(system).download_mission()
        except MissionRawError as exc:
            _raise_for(exc, "download")
        progress(f"downloaded {len(items)} item(s), home included")
        return from_mavsdk_items(list(items))


async def clear(url: str = DEFAULT_URL, timeout_s: float = 10.0, progress: Callable[[str], None] = print) -> None:
    """Clear the stored mission (ArduPilot keeps only home)."""

    async with connected_system(url, timeout_s, progress) as system:
        try:
            await MissionRawAsync(system).clear_mission()
        except MissionRawError as exc:
            _raise_for(exc, "clear")
        progress("mission cleared")

