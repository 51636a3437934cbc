"""MAVSDK 4.1 aborts the process when a plugin outlives its Mavsdk instance: ours never do.

Seen under load in CI: `mission upload` printed "upload accepted by the vehicle" and died of SIGABRT,
because the executor thread that ran the upload dropped the last reference to its MissionRaw plugin
while the main thread was already destroying Mavsdk. Each plugin's and Mavsdk's ``destroy`` is traced
here (the real library's methods, wrapped to record when they ran), and every plugin must be gone
before Mavsdk's teardown starts. The worker's window is widened on purpose (it lingers after each
call, as a descheduled thread does under load), so that a teardown that does not wait for it fails
every time rather than now and then.
"""

from __future__ import annotations

import asyncio
import threading
import time
from concurrent.futures import thread as executor_thread
from pathlib import Path

import pytest
from mavsdk.mavsdk import Mavsdk
from mavsdk.plugins.mission_raw import MissionRaw
from mavsdk.plugins.telemetry import Telemetry

from mission import transfer
from sim_vehicle.harness import SimProcess

UPLOADS = 3
WORKER_LINGER_S = 0.2  # how long a worker keeps the finished call (and its plugin) before dropping it


def _trace(monkeypatch: pytest.MonkeyPatch, cls: type, events: list[tuple[str, str]]) -> None:
    """Record ("<Class> released", thread) once a destroy() has released a handle, ("Mavsdk teardown", thread)
    as Mavsdk's destroy begins."""
    original = cls.destroy

    def destroy(self: object) -> None:
        if cls is Mavsdk and self._handle:
            events.append(("Mavsdk teardown", threading.current_thread().name))
        had_handle = self._handle is not None
        original(self)
        if had_handle and cls is not Mavsdk:
            events.append((f"{cls.__name__} released", threading.current_thread().name))

    monkeypatch.setattr(cls, "destroy", destroy)


def _linger_after_each_call(monkeypatch: pytest.MonkeyPatch) -> None:
    """Keep each executor work item, and so the call's plugin, alive a while after its result is set."""
    run = executor_thread._WorkItem.run

    def run_then_linger(self: object) -> None:
        run(self)
        time.sleep(WORKER_LINGER_S)

    monkeypatch.setattr(executor_thread._WorkItem, "run", run_then_linger)


async def _upload_then_use_the_executor(url: str, north_m: float) -> str:
    """Upload, then run a call on the loop's default executor: the connection must leave a usable one."""
    await transfer.upload_relative(north_m, 0.0, url, 20.0, progress=lambda _line: None)
    return await asyncio.to_thread(lambda: "still usable")


def test_every_plugin_is_released_before_mavsdk_is_destroyed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """HOME_POSITION barely awaited, so home mostly comes from a mission download: each upload makes a
    telemetry plugin and one or two MissionRaw plugins, whose transfers run on the executor."""
    events: list[tuple[str, str]] = []
    for cls in (Telemetry, MissionRaw, Mavsdk):
        _trace(monkeypatch, cls, events)
    _linger_after_each_call(monkeypatch)
    monkeypatch.setattr(transfer, "HOME_POSITION_WAIT_S", 1e-3)
    with SimProcess(tmp_path, speedup=5, waves="calm", extra=["--wipe"], udp_outs=1) as sim:
        url = f"udpin://127.0.0.1:{sim.udp_ports[0]}"
        for upload in range(UPLOADS):
            events.clear()
            assert asyncio.run(_upload_then_use_the_executor(url, 30.0 + upload)) == "still usable"
            names = [name for name, _thread in events]
            assert names.count("Mavsdk teardown") == 1 and names[-1] == "Mavsdk teardown", events
            assert names.count("Telemetry released") == 1 and names.count("MissionRaw released") in (1, 2), events
