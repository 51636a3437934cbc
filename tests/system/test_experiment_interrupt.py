"""An interrupted `mavbridge experiment` writes the table of the runs that finished and lists the rest;
no queued run goes on running unreported. A real process with its pool of workers, stopped by SIGTERM."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.system.test_demo_signals import _alive, _descendants
from tests.waits import WaitTimeoutError

pytestmark = pytest.mark.slow
TABLE3 = Path(__file__).resolve().parents[2] / "scenarios" / "table3.yaml"


def test_sigterm_writes_what_finished_and_lists_what_did_not(tmp_path: Path) -> None:
    out = tmp_path / "exp"
    proc = subprocess.Popen([sys.executable, "-m", "mavbridge.cli", "experiment", str(TABLE3), "--solver", "asrti",
                             "--jobs", "2", "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)
    lines: list[str] = []
    first_done = threading.Event()

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line.rstrip())
            if "] done:" in line:
                first_done.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        if not first_done.wait(300):
            raise WaitTimeoutError("no run of the experiment finished in 300 s:\n" + "\n".join(lines[-20:]))
        workers = _descendants(proc.pid)
        os.kill(proc.pid, signal.SIGTERM)
        code = proc.wait(60)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and any(_alive(p) for p in workers):
            time.sleep(0.1)
        assert not [p for p in workers if _alive(p)], "workers still running after the experiment ended"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    time.sleep(0.3)
    assert code == 130, "\n".join(lines[-30:])
    summary = [line for line in lines if line.startswith("experiment: interrupted; finished: ")]
    assert len(summary) == 1, "\n".join(lines[-30:])
    finished_part, _, missing_part = summary[0].partition("; not finished: ")
    finished = [n.strip() for n in finished_part.removeprefix("experiment: interrupted; finished: ")
                .split(" (table")[0].split(",")]
    missing = [n.strip() for n in missing_part.split(",") if n.strip()]
    done = {line.split("]")[0].lstrip("[") for line in lines if "] done:" in line}
    assert set(finished) == done and missing, summary[0]  # every run reported done is listed, some are not
    table = (out / "table3.md").read_text()
    assert all(f"| {name} |" in table for name in finished)
    assert not any(f"| {name} |" in table for name in missing)
    assert len(finished) + len(missing) == 6
