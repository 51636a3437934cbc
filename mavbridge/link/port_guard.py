"""One companion per UDP port: a second `mavbridge run` on a port already listened on refuses to start.

pymavlink opens ``udpin:`` ports with SO_REUSEADDR, so on Linux two companions may bind the same port and
both receive the autopilot's stream and both command the boat. Before the link is opened the port is bound
once without SO_REUSEADDR (that fails while any socket holds it); once it is open, our own socket has
SO_REUSEADDR cleared, so that no later process can bind the port beside it, with the option or without.
"""

from __future__ import annotations

import errno
import socket
from typing import Any

from mavbridge.link.connection import LinkError

UDP_SERVER_PREFIXES = ("udpin:", "udp:")  # pymavlink's listening UDP forms ("udp:" is udpin)


def udp_server_address(url: str) -> tuple[str, int] | None:
    """(host, port) of a pymavlink listening UDP connection string; None for anything else (or no port)."""
    for prefix in UDP_SERVER_PREFIXES:
        if url.startswith(prefix):
            host, _, port = url[len(prefix):].rpartition(":")
            try:
                return host or "0.0.0.0", int(port)
            except ValueError:
                return None
    return None


def refuse_if_taken(url: str) -> None:
    """Raise LinkError naming the port when another process already listens on this UDP port."""
    address = udp_server_address(url)
    if address is None:
        return
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(address)
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise LinkError(f"UDP port {address[1]} ({url}) is already in use by another process (a second "
                                "companion?): refusing to share the autopilot's link") from None
            # any other error (no such address) is the link's to report, with its own message


def hold_exclusively(conn: Any) -> None:
    """Clear SO_REUSEADDR on an open pymavlink UDP server socket so that no one can bind its port beside us."""
    sock = getattr(conn, "port", None)
    if getattr(conn, "udp_server", False) and sock is not None:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 0)
