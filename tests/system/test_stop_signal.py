"""A stop signal before the autopilot answers (systemd stopping a service whose autopilot has not booted):
the companion stops at once with exit 0 (no restart), its logs written, also when the signal comes twice."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from sim_vehicle.harness import free_port

pytestmark = pytest.mark.integration


@pytest.mark.parametrize("signals", [1, 2])
def test_sigterm_while_waiting_for_the_autopilot_stops_cleanly(tmp_path: Path, signals: int) -> None:
    out = tmp_path / "run"
    port = free_port(socket.SOCK_DGRAM)
    proc = subprocess.Popen([sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}",
                             "--waypoint", "10,10", "--out", str(out)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout or ()), daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 60
        while not any(line.startswith("waves:") for line in list(lines)):  # printed once the link is open
            assert time.monotonic() < deadline and proc.poll() is None, f"no start line: {lines}"
            time.sleep(0.05)
        time.sleep(0.5)  # inside the wait for the heartbeat (connect_timeout_s is 30 s by default)
        for _ in range(signals):
            proc.send_signal(signal.SIGTERM)
        code = proc.wait(timeout=15)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    reader.join(timeout=5)
    text = "".join(lines)
    assert code == 0, text
    assert "stopped by signal SIGTERM before flying" in text and "no autopilot heartbeat" not in text, text
    assert json.loads((out / "metrics.json").read_text())["phase"] is not None
