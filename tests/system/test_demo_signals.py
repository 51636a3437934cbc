"""`mavbridge demo` stopped by SIGTERM or SIGHUP (systemd, a closed terminal) cleans up as on Ctrl-C.

Only the demo is signalled, as `kill -TERM <pid>` does; its children must be stopped by the handles it
holds, not left to run on under PID 1. What is awaited is the companion's "phase: engaged" line.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.waits import WaitTimeoutError

pytestmark = pytest.mark.slow


def _children() -> dict[int, list[int]]:
    """Parent pid -> child pids, of every process now (from /proc)."""
    tree: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            ppid = int(stat.rpartition(")")[2].split()[1])
            tree.setdefault(ppid, []).append(int(entry))
    return tree


def _descendants(pid: int) -> list[int]:
    tree, found, todo = _children(), [], [pid]
    while todo:
        for child in tree.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def _alive(pid: int) -> bool:
    """Running (a zombie, already dead and only waiting to be reaped, is not)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP])
def test_signal_stops_every_child_and_writes_the_plots(tmp_path: Path, signum: int) -> None:
    out = tmp_path / "demo"
    demo = subprocess.Popen([sys.executable, "-m", "mavbridge.cli", "demo", "--speedup", "4", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    lines: list[str] = []
    engaged = threading.Event()

    def read() -> None:
        assert demo.stdout is not None
        for line in demo.stdout:
            lines.append(line.rstrip())
            if "phase: engaged" in line:
                engaged.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        deadline = time.monotonic() + 300.0
        while not engaged.wait(0.5) and demo.poll() is None and time.monotonic() < deadline:
            pass
        if not engaged.is_set():  # the demo ended before engaging, or 300 s passed: say which, with its output
            why = f"ended with {demo.returncode}" if demo.poll() is not None else "still running after 300 s"
            raise WaitTimeoutError(f"the demo's companion never printed 'phase: engaged' (the demo {why}):\n"
                                   + "\n".join(lines))
        tree = _descendants(demo.pid)
        assert len(tree) >= 2, tree  # the simulator and the companion (and whatever they started)
        os.kill(demo.pid, signum)
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and any(_alive(p) for p in tree):
            time.sleep(0.1)
        left = [p for p in tree if _alive(p)]
        assert not left, f"still running 5 s after {signal.Signals(signum).name}: {left}"
        code = demo.wait(60)
    finally:
        if demo.poll() is None:
            os.killpg(demo.pid, signal.SIGKILL)
            demo.wait()
    time.sleep(0.3)  # the reader's last lines
    name = signal.Signals(signum).name
    assert code == 128 + signum, "\n".join(lines[-30:])
    assert f"demo: stopped by {name}; every process it started is stopped" in lines
    assert f"demo: exit status {128 + signum}" in lines
    assert (out / "companion" / "metrics.json").stat().st_size > 0  # the companion wrote its logs on the way out
    assert (out / "sim" / "state.csv").stat().st_size > 1000
    for plot in ("path.png", "timeseries.png"):
        assert (out / plot).stat().st_size > 1000, plot
