"""Checks of `sim-vehicle`'s ports, device and files before the simulator opens them, and one line naming the
flag when opening fails anyway (a port taken, a device that refuses): never one generic line for all three."""

from __future__ import annotations

import errno
import socket
from pathlib import Path

from vessel.config import ConfigError


def check_outputs(outputs: list[tuple[str, int]]) -> None:
    """Every ``--out udp:HOST:PORT`` host resolves (the simulator would otherwise drop every datagram silently)."""
    for host, port in outputs:
        try:
            socket.getaddrinfo(host, port, socket.AF_INET, socket.SOCK_DGRAM)
        except OSError as exc:
            raise ConfigError(f"--out: udp:{host}:{port}: cannot resolve the host {host} "
                              f"({exc.strerror or exc})") from None


def check_serial(device: str) -> None:
    """A ``--serial`` device path exists (pyserial URLs such as ``socket://…`` are left to the port)."""
    if "://" not in device and not Path(device).exists():
        raise ConfigError(f"--serial: {device}: no such device")


def check_params_store(path: Path) -> None:
    """``--params-store`` names a file that can be made: not a folder, and not under a file."""
    if path.is_dir():
        raise ConfigError(f"--params-store: {path} is a folder; give a file name (e.g. {path / 'params.json'})")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ConfigError(f"--params-store: {path}: {parent} is a file, not a folder")
            return


def open_failure(exc: OSError, tcp: tuple[str, int] | None, serial: tuple[str, int | None] | None) -> str:
    """One line naming what could not be opened: the --serial device, the --tcp port, or the file."""
    reason = exc.strerror or str(exc)
    if serial is not None and exc.filename == serial[0]:
        return f"--serial: cannot open {serial[0]} ({reason})"
    if tcp is not None and exc.errno in (errno.EADDRINUSE, errno.EACCES, errno.EADDRNOTAVAIL):
        return f"--tcp: cannot listen on {tcp[0]}:{tcp[1]} ({reason})"
    if exc.filename:
        return f"cannot open {exc.filename} ({reason})"
    return f"cannot open a port ({reason})"
