"""MAVProxy, a ground station people really use, against the simulator: parameters, a mission file, modes."""

from __future__ import annotations

import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from mission import Mission, MissionItem, write_mission_file
from mission.plan import FRAME_GLOBAL
from sim_vehicle.harness import SimProcess

pytestmark = pytest.mark.slow
MAVPROXY = shutil.which("mavproxy.py") or str(Path(sys.executable).with_name("mavproxy.py"))


class Console:
    """MAVProxy's console: we type lines and wait for what it prints."""

    def __init__(self, args: list[str]) -> None:
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                     text=True)
        self.lines: list[str] = []
        self.seen: list[str] = []  # every line of the session (``lines`` is cleared on each command)
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.lines.append(line.strip())
            self.seen.append(line.strip())

    def expect(self, text: str, timeout: float = 30.0) -> str:
        """The first line (from now on or already seen) containing ``text``, prompts stripped."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for line in self.lines:
                if text in line:
                    return line[line.index(text):] if text == "Received " else line
            time.sleep(0.05)
        raise AssertionError(f"MAVProxy never printed {text!r}:\n" + "\n".join(self.lines[-30:]))

    def type(self, command: str) -> None:
        """One console command."""
        assert self.proc.stdin is not None
        self.lines.clear()
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        """Quit MAVProxy (killed if it will not)."""
        if self.proc.poll() is None:
            try:
                self.type("exit")
                self.proc.wait(10)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is not installed (pip install '.[test]')")
def test_mavproxy_lists_parameters_loads_a_waypoints_file_and_switches_modes(tmp_path: Path) -> None:
    waypoints = tmp_path / "mission.waypoints"
    home = MissionItem(-35.363261, 149.165230, 584.0, frame=FRAME_GLOBAL)
    write_mission_file(Mission(home, (MissionItem(-35.3624974, 149.1660562, 0.0),)), waypoints)
    with SimProcess(tmp_path / "sim", speedup=1, waves="calm", extra=["--wipe"]) as sim:
        console = Console([MAVPROXY, "--master", f"tcp:127.0.0.1:{sim.tcp_port}", "--state-basedir",
                           str(tmp_path / "mavproxy"), "--default-modules", "param,wp,mode,cmdlong,fence"])
        try:
            received = console.expect("Received ", timeout=60)  # "Received N parameters"
            assert received.endswith("parameters") and int(received.split()[1]) > 50
            console.type("param show SYSID_MYGCS")
            assert console.expect("SYSID_MYGCS").split()[-1] in ("255", "255.0")
            console.type(f"wp load {waypoints}")
            console.expect("MISSION_ACK: TYPE_MISSION: ACCEPTED")
            console.type("wp list")
            console.expect("-35.3624974")
            console.type("mode GUIDED")
            console.expect("Mode GUIDED")
            console.type("mode HOLD")
            console.expect("Mode HOLD")
            # no fence is set: SYS_STATUS says so as ArduPilot does, and MAVProxy's fence module sees no breach
            assert not [line for line in console.seen if "fence breach" in line], console.seen[-30:]
        finally:
            console.close()
