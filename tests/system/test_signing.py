"""The companion's side of MAVLink 2 signing against the simulator, on its UDP channel (not channel 0): a signed
link arms; an unsigned autopilot is refused; `mavbridge signing setup` sets the key and `mavbridge check` reports
signed (PASS) or unsigned (WARN); passphrase-file mistakes are one line."""

from __future__ import annotations

import io
import os
from contextlib import redirect_stdout
from pathlib import Path

import pytest

from mavbridge.cli import main
from mavbridge.link.connection import Link, LinkError
from mavbridge.link.signing import LinkSettings, key_from_file
from sim_vehicle.harness import SimProcess
from tests.rover import ACCEPTED
from tests.system.test_mavproxy import MAVPROXY, Console

pytestmark = pytest.mark.integration
PASSPHRASE = "otter harbour test"


def passphrase_file(tmp_path: Path, text: str = PASSPHRASE, mode: int = 0o600) -> Path:
    path = tmp_path / "signing.key"
    path.write_text(text + "\n")
    path.chmod(mode)
    return path


def test_a_signed_link_arms_and_an_unsigned_autopilot_is_refused(tmp_path: Path) -> None:
    settings = LinkSettings(signing_passphrase_file=str(passphrase_file(tmp_path)))
    with SimProcess(tmp_path / "signed", speedup=5.0, udp_outs=1,
                    extra=["--wipe", "--signing-passphrase", PASSPHRASE]) as sim:
        link = Link(f"udpin:127.0.0.1:{sim.udp_ports[0]}", settings=settings)
        try:
            link.wait_autopilot(30)
            assert link.command_long(400, (1.0, 2989.0)) == ACCEPTED  # ARM, signed, on a non-zero channel
            assert link.mav.signing.goodsig_count > 10 and link.counts["unsigned"] == 0
        finally:
            link.close()
    with SimProcess(tmp_path / "unsigned", speedup=5.0, udp_outs=1, extra=["--wipe"]) as sim:
        link = Link(f"udpin:127.0.0.1:{sim.udp_ports[0]}", settings=settings)
        try:
            with pytest.raises(LinkError, match="no autopilot heartbeat"):
                link.wait_autopilot(3)
            assert link.counts["unsigned"] > 0 and link.counts["accepted"] == 0
        finally:
            link.close()


def check_rows(port: int, *args: str) -> dict[str, str]:
    """`mavbridge check` (no solve timing) on the simulator's UDP output: item -> status."""
    out = io.StringIO()
    with redirect_stdout(out):
        main(["check", "--connect", f"udpin:127.0.0.1:{port}", "--timeout", "10", "--solves", "0",
              "--waypoint", "50,50", *args])
    rows = {}
    for line in out.getvalue().splitlines():
        status, _, rest = line.partition("  ")
        if status in ("PASS", "WARN", "FAIL"):
            rows[rest.strip().split("  ")[0].strip()] = status
    return rows


def test_signing_setup_then_check_reports_signed(tmp_path: Path) -> None:
    key_file = passphrase_file(tmp_path)
    with SimProcess(tmp_path / "sim", speedup=5.0, udp_outs=1, extra=["--wipe"]) as sim:
        assert check_rows(sim.udp_ports[0])["MAVLink 2 signing"] == "WARN"
        out = io.StringIO()
        with redirect_stdout(out):
            code = main(["signing", "setup", "--connect", f"tcp:127.0.0.1:{sim.tcp_port}",
                         "--signing-passphrase-file", str(key_file)])
        assert code == 0, out.getvalue()
        assert "signs with the key" in out.getvalue()
        assert check_rows(sim.udp_ports[0], "--signing-passphrase-file", str(key_file))["MAVLink 2 signing"] == "PASS"
        rows = check_rows(sim.udp_ports[0], "--signing-passphrase-file", str(passphrase_file(tmp_path, "wrong")))
        assert rows["MAVLink 2 signing"] == "FAIL"


def test_passphrase_file_readable_by_others_is_warned_about(tmp_path: Path, capsys) -> None:
    path = passphrase_file(tmp_path, mode=0o644)
    assert len(key_from_file(str(path))) == 32
    assert f"{path} is readable by other users" in capsys.readouterr().err
    if os.geteuid() != 0:  # root reads anything: an unreadable file cannot be made for it
        path.chmod(0)
        with pytest.raises(Exception, match="cannot read the passphrase file"):
            key_from_file(str(path))


@pytest.mark.skipif(not Path(MAVPROXY).exists(), reason="MAVProxy is not installed (pip install '.[test]')")
def test_mavproxy_signing_setup_interoperates_with_the_companion(tmp_path: Path) -> None:
    """MAVProxy's `signing setup PASSPHRASE` on channel 0 (TCP); the companion, given a file with the same
    passphrase, then gets signed heartbeats on its UDP channel and its signed ARM is accepted. (MAVProxy takes
    the first word of what follows `signing setup` as the passphrase: a one-word passphrase here.)"""
    word = "otter-harbour-test"
    settings = LinkSettings(signing_passphrase_file=str(passphrase_file(tmp_path, word)))
    with SimProcess(tmp_path / "sim", speedup=2.0, udp_outs=1, extra=["--wipe"]) as sim:
        console = Console([MAVPROXY, "--master", f"tcp:127.0.0.1:{sim.tcp_port}", "--state-basedir",
                           str(tmp_path / "mavproxy"), "--default-modules", "signing"])
        try:
            console.expect("online system 1", timeout=60)
            console.type(f"signing setup {word}")
            console.expect("Sent secret_key")
        finally:
            console.close()
        link = Link(f"udpin:127.0.0.1:{sim.udp_ports[0]}", settings=settings)
        try:
            link.wait_autopilot(30)
            assert link.command_long(400, (1.0, 2989.0)) == ACCEPTED
            assert link.mav.signing.goodsig_count > 0
        finally:
            link.close()
