"""`sim-vehicle` says on start where it can be reached and where it logs (issue 17, item 11)."""

from __future__ import annotations

import socket
import subprocess
from pathlib import Path

from sim_vehicle.harness import free_port, sim_vehicle_command


def test_start_lines_name_sea_seed_ports_and_log_folder(tmp_path: Path) -> None:
    tcp, udp = free_port(), free_port(socket.SOCK_DGRAM)
    done = subprocess.run([*sim_vehicle_command(), "--tcp", str(tcp), "--out", f"udp:127.0.0.1:{udp}", "--sea",
                           "paper", "--seed", "7", "--duration", "0.5", "--speedup", "10", "--log-dir",
                           str(tmp_path / "logs"), "--params-store", str(tmp_path / "p.json")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "seed 7" in done.stderr
    assert f"sim-vehicle: MAVLink on TCP {tcp}, UDP to 127.0.0.1:{udp}; logs in {tmp_path / 'logs'}" in done.stderr
