"""Shared fixtures: simulator processes and ground-station links; the ``integration`` mark; the suite's order.

Every test that starts a process is marked ``integration`` here, so ``pytest -m "not integration"`` runs
the fast unit tests alone: everything under tests/system, every test using a process fixture below, and
every test in a module that starts processes itself (it imports ``subprocess`` or ``SimProcess``).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from sim_vehicle.harness import SimProcess
from tests.expected_durations import balanced_order, read_expected
from tests.rover import ARM, HOLD
from tests.waits import command, set_mode

PROCESS_FIXTURES = frozenset({"sim", "gcs", "start_sim"})
SYSTEM_DIR = Path(__file__).parent / "system"


def _starts_processes(item: pytest.Item) -> bool:
    """True if the test runs a process: under tests/system, through a process fixture, or by its module."""
    if SYSTEM_DIR in Path(str(item.path)).parents:
        return True
    if PROCESS_FIXTURES & set(getattr(item, "fixturenames", ())):
        return True
    module = getattr(item, "module", None)
    return module is not None and any(hasattr(module, name) for name in ("subprocess", "SimProcess"))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark every test that starts a process ``integration``; order the tests so that each xdist worker starts
    with its share of the slowest (``tests.expected_durations``)."""
    for item in items:
        if _starts_processes(item):
            item.add_marker(pytest.mark.integration)
    by_id = {item.nodeid: item for item in items}
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    items[:] = [by_id[test] for test in balanced_order(list(by_id), read_expected(), workers)]


@pytest.fixture(scope="module")
def sim(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Iterator[SimProcess]:
    """One calm-water simulator process for a whole test module, stopped (by its handle) afterwards.

    A module changes how it starts with ``SIM_OPTIONS = {...}`` (SimProcess keyword arguments, e.g.
    ``speedup``); the default runs at 10x.
    """
    options: dict[str, Any] = {"speedup": 10.0, **getattr(request.module, "SIM_OPTIONS", {})}
    workdir = tmp_path_factory.mktemp(request.module.__name__.rsplit(".", 1)[-1])
    with SimProcess(workdir, **options) as proc:
        yield proc


@pytest.fixture
def gcs(sim: SimProcess) -> Iterator[Any]:
    """A ground-station link (sysid 255) to the module's simulator; leaves the boat in HOLD, disarmed."""
    link = sim.connect()
    yield link
    assert set_mode(link, HOLD) == 0, "could not leave the boat in HOLD after the test"
    assert command(link, ARM, 0) == 0, "could not disarm after the test"


@pytest.fixture
def start_sim(tmp_path: Path) -> Iterator[Callable[..., SimProcess]]:
    """Start simulators with this test's own options (``start_sim(speedup=10, extra=[...])``); all are
    stopped when the test ends, however it ends."""
    started: list[SimProcess] = []

    def start(**options: Any) -> SimProcess:
        proc = SimProcess(tmp_path / f"sim{len(started)}", **options)
        started.append(proc)
        proc.start()
        return proc

    yield start
    for proc in reversed(started):
        proc.stop()
