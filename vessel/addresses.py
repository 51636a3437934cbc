"""Checks of a connection's address before a command opens it, shared by the command lines that talk MAVLink
(``mavbridge run/check/signing``, ``mission``) but free of MAVLink itself: a host that does not resolve, a local
address this machine does not have, a TCP peer where nothing listens, a serial device that is not there. Each is
one ConfigError naming the flag, raised before any folder is made or any library is asked to connect (whose own
complaints would be several raw lines and a later exit)."""

from __future__ import annotations

import errno
import socket
from pathlib import Path

from vessel.config import ConfigError

TCP_PROBE_S = 3.0  # how long a TCP peer has to accept the probe's connection
KINDS = ("listen_udp", "send_udp", "tcp_client", "tcp_server")


def _reason(exc: OSError) -> str:
    """The OS's words for ``exc`` (getaddrinfo's, for a name that does not resolve)."""
    return exc.strerror or str(exc) or type(exc).__name__


def _resolve(host: str, port: int, kind: int, what: str) -> None:
    """``host`` resolves to an IPv4 address, else a ConfigError starting with ``what``."""
    try:
        socket.getaddrinfo(host, port, socket.AF_INET, kind)
    except (OSError, UnicodeError) as exc:
        raise ConfigError(f"{what}: cannot resolve the host {host} ({_reason(exc)})") from None


def _bind(host: str, port: int, kind: int, what: str) -> None:
    """``host:port`` can be bound here; a port in use is left to the caller (the link names it better)."""
    with socket.socket(socket.AF_INET, kind) as probe:
        try:
            probe.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                return
            if exc.errno == errno.EADDRNOTAVAIL:
                raise ConfigError(f"{what}: {host} is not an address of this machine (listen on 0.0.0.0 or "
                                  "one of its own)") from None
            raise ConfigError(f"{what}: cannot listen on {host}:{port} ({_reason(exc)})") from None


def _connect(host: str, port: int, timeout_s: float, what: str) -> None:
    """Something accepts a TCP connection on ``host:port`` within ``timeout_s``; the probe's is closed at once."""
    try:
        socket.create_connection((host, port), timeout=timeout_s).close()
    except TimeoutError:
        raise ConfigError(f"{what}: no answer from {host}:{port} within {timeout_s:g} s (host unreachable?)") from None
    except OSError as exc:
        raise ConfigError(f"{what}: nothing accepts a connection on {host}:{port} ({_reason(exc)}); is the "
                          "autopilot or sim-vehicle listening there?") from None


def check_network(kind: str, host: str, port: int, what: str, timeout_s: float = TCP_PROBE_S) -> None:
    """Check an address of one of :data:`KINDS` before it is opened: the host resolves; a UDP or TCP server's
    address is one of this machine's; a TCP client's peer accepts. ``what`` starts the one-line ConfigError
    (e.g. ``--connect: tcp:HOST:5760``); an empty host (listen on every address) is 0.0.0.0."""
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}, got {kind!r}")
    host = host or "0.0.0.0"
    sock_kind = socket.SOCK_DGRAM if kind.endswith("udp") else socket.SOCK_STREAM
    _resolve(host, port, sock_kind, what)
    if kind in ("listen_udp", "tcp_server"):
        _bind(host, port, sock_kind, what)
    elif kind == "tcp_client":
        _connect(host, port, timeout_s, what)


def check_device(device: str, what: str) -> None:
    """A serial device's path exists (and is not a folder), else a one-line ConfigError starting with ``what``."""
    path = Path(device)
    if not path.exists():
        raise ConfigError(f"{what}: no such serial device {device}")
    if path.is_dir():
        raise ConfigError(f"{what}: {device} is a folder, not a serial device")
