"""Test and bench harness: runs a real ``sim-vehicle`` process on free loopback ports and connects to it.

(The waits that tests use on such a link live in ``tests/waits.py``.)
"""

from __future__ import annotations

import os
import random
import socket
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil

TEST_PORTS = (20000, 32768)  # below the kernel's ephemeral ports (see free_port)
PORT_DRAWS = 200
START_TIMEOUT_S = 45.0  # an irregular sea compiles its plant (1–4 s, more on a busy machine) before the port opens


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    """A loopback port nobody holds right now, drawn below Linux's ephemeral range (32768–60999): the kernel hands
    those to every process's outgoing sockets, so one taken from there could be another test's source port by
    the time its owner binds it (a companion then refuses it as in use)."""
    draw = random.SystemRandom()
    for _ in range(PORT_DRAWS):
        port = draw.randrange(*TEST_PORTS)
        with socket.socket(socket.AF_INET, kind) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                continue
            return port
    with socket.socket(socket.AF_INET, kind) as s:  # all drawn were taken: any port the kernel gives
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def sim_vehicle_command() -> list[str]:
    """The installed ``sim-vehicle`` script next to this interpreter, else ``python -m sim_vehicle``."""
    script = Path(sys.executable).with_name("sim-vehicle")
    return [str(script)] if script.exists() else [sys.executable, "-m", "sim_vehicle"]


class SimProcess:
    """A sim-vehicle subprocess with its TCP port and log folder; stops it (by its handle) on exit."""

    def __init__(
        self,
        workdir: Path,
        speedup: float = 10.0,
        waves: str | None = "calm",
        extra: Sequence[str] = (),
        udp_outs: int = 0,
        wait_for_client: bool = False,
        sensors: str = "ideal",
        sea_phase: str = "boot",
    ) -> None:
        self.workdir = Path(workdir)
        self.tcp_port = free_port()
        self.udp_ports = [free_port(socket.SOCK_DGRAM) for _ in range(udp_outs)]
        self.log_dir = self.workdir / "simlog"
        # Explicit sensor mode and sea phase: ideal sensors and the phase origin at boot (seed 0) keep the
        # tests that compare telemetry with the true state or the in-process truth exact; pass
        # sensors="realistic" / sea_phase="hidden" to test what a companion would really get.
        mode = {"ideal": ["--ideal-sensors"], "realistic": []}[sensors]
        phase = {"boot": ["--sea-phase", "boot"], "hidden": []}[sea_phase]
        self.args = [
            *sim_vehicle_command(),
            "--tcp",
            str(self.tcp_port),
            "--speedup",
            str(speedup),
            *(["--sea", waves] if waves else []),
            "--params-store",
            str(self.workdir / "params.json"),
            "--log-dir",
            str(self.log_dir),
            *mode,
            *phase,
            *(["--seed", "0"] if "--seed" not in extra else []),
            *extra,
        ]
        self.args += [a for p in self.udp_ports for a in ("--out", f"udp:127.0.0.1:{p}")] or ["--no-out"]
        self.wait_for_client = wait_for_client  # --wait-for-client: simulated time starts when a client speaks
        if wait_for_client:
            self.args.append("--wait-for-client")
        self.stderr_path = self.workdir / "sim_vehicle.stderr"
        self.proc: subprocess.Popen[bytes] | None = None
        self.connections: list[Any] = []

    def __enter__(self) -> SimProcess:
        self.start()
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()

    def start(self) -> None:
        """Launch and wait until the TCP port accepts connections."""
        self.workdir.mkdir(parents=True, exist_ok=True)
        with self.stderr_path.open("ab") as err:  # a file, not a pipe: a chatty process can never block
            self.proc = subprocess.Popen(self.args, stdout=subprocess.DEVNULL, stderr=err)
        deadline = time.monotonic() + START_TIMEOUT_S
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise RuntimeError(f"sim-vehicle exited: {self._stderr()}")
            try:
                with socket.create_connection(("127.0.0.1", self.tcp_port), timeout=0.2):
                    return
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise TimeoutError("sim-vehicle did not open its TCP port")

    def _stderr(self) -> str:
        """What the process has written to stderr so far."""
        try:
            return self.stderr_path.read_text(errors="replace")
        except OSError:
            return ""

    def connect(self, source_system: int = 255, source_component: int = 190) -> Any:
        """A pymavlink TCP client; waits for the first heartbeat (sending its own first with --wait-for-client)."""
        conn = mavutil.mavlink_connection(
            f"tcp:127.0.0.1:{self.tcp_port}",
            source_system=source_system,
            source_component=source_component,
            autoreconnect=False,
        )
        self.connections.append(conn)
        if self.wait_for_client:  # speak first, as a ground station does, so that simulated time starts
            conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        if conn.wait_heartbeat(timeout=10) is None:
            raise TimeoutError("no heartbeat")
        return conn

    def stop(self) -> str:
        """Terminate (then kill if needed) the process; returns its stderr."""
        for conn in self.connections:
            conn.close()
        self.connections.clear()
        if self.proc is None:
            return ""
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=5)
        err = self._stderr()
        self.proc = None
        return err

