"""The serial code path: `sim-vehicle --serial` refusals. (The Balanced run over a serial link with the boat's
configuration is deploy/README.md's section 5, run as written by ``test_deploy_readme``.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from sim_vehicle.harness import sim_vehicle_command
from tests.system.nullmodem import NullModem

ROOT = Path(__file__).resolve().parents[2]
PARM = ROOT / "deploy" / "otter-rover.parm"
HOME = "--home=-35.363261,149.165230,584,90"  # heading East, as the Balanced scenario starts
pytestmark = pytest.mark.slow


def _mavbridge(*args: str, timeout: float) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mavbridge.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


def test_serial_port_refuses_a_non_mavlink_protocol(tmp_path: Path, modem: NullModem) -> None:
    """SERIAL2_PROTOCOL 5 (GPS): the simulator will not speak MAVLink there, and says why."""
    parm = tmp_path / "gps-on-serial2.parm"
    parm.write_text(PARM.read_text() + "\nSERIAL2_PROTOCOL,5\n")
    result = subprocess.run([*sim_vehicle_command(), "--params", str(parm), "--params-store", str(tmp_path / "p.json"),
                             "--no-tcp", "--no-out", "--serial", modem.ends[0], "--duration", "1"],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert "SERIAL2_PROTOCOL is 5" in result.stderr and result.stderr.count("\n") <= 2, result.stderr
