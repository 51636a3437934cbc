"""MAVLink transports: a TCP server (one channel per client), UDP outputs that answer their peer, and a
serial port (a real UART, a USB adapter or a pseudo-terminal).

Each channel has its own pymavlink codec (sequence numbers, parser state, MAVLink 2 framing); reading
never blocks and never raises on bad bytes.
"""

from __future__ import annotations

import os
import socket
import termios
import tty
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

MAX_BACKLOG_BYTES = 1 << 20  # a TCP client that stops reading is dropped past this much unsent data
RECV_BYTES = 65536

TlogHook = Callable[[bytes, bool], None]  # (frame, outgoing)


def make_codec(sysid: int, compid: int) -> mavlink.MAVLink:
    """A MAVLink 2 encoder/decoder that tolerates garbage instead of raising."""
    codec = mavlink.MAVLink(None, srcSystem=sysid, srcComponent=compid)
    codec.robust_parsing = True
    return codec


class Channel:
    """One MAVLink conversation: decode what arrives, encode what leaves, and count it."""

    def __init__(self, name: str, index: int, sysid: int, compid: int, tlog: TlogHook | None) -> None:
        self.name = name
        self.index = index  # stream-rate channel (SRn_*)
        self.codec = make_codec(sysid, compid)
        self.tlog = tlog
        self.closed = False
        self.rx_messages = 0

    def decode(self, data: bytes) -> list[mavlink.MAVLink_message]:
        """Valid messages in ``data``; garbage, bad CRCs and unknown ids are dropped."""
        out: list[mavlink.MAVLink_message] = []
        try:
            msgs = self.codec.parse_buffer(data) or []
        except Exception:
            old, self.codec = self.codec, make_codec(self.codec.srcSystem, self.codec.srcComponent)
            self.codec.signing = old.signing  # a parser reset must never drop the signing key
            if "check_signature" in vars(old):
                self.codec.check_signature = old.check_signature
            return out
        for msg in msgs:
            if msg is None or msg.get_type() in ("BAD_DATA", "UNKNOWN") or msg.get_msgId() < 0:
                continue
            out.append(msg)
            self.rx_messages += 1
            if self.tlog is not None:
                self.tlog(bytes(msg.get_msgbuf()), False)
        return out

    def encode(self, msg: mavlink.MAVLink_message) -> bytes | None:
        """Frame ``msg`` with this channel's sequence number; None if a field cannot be packed."""
        try:
            frame = bytes(msg.pack(self.codec))
        except Exception:
            return None
        self.codec.seq = (self.codec.seq + 1) % 256
        if self.tlog is not None:
            self.tlog(frame, True)
        return frame

    def send(self, msg: mavlink.MAVLink_message) -> None:
        """Encode and transmit one message."""
        frame = self.encode(msg)
        if frame is not None:
            self.write(frame)

    def write(self, frame: bytes) -> None:
        """Transmit raw bytes (transport-specific)."""
        raise NotImplementedError

    def receive(self) -> list[mavlink.MAVLink_message]:
        """Read whatever is waiting without blocking (transport-specific)."""
        raise NotImplementedError

    def fileno(self) -> int:
        """Socket descriptor for select()."""
        raise NotImplementedError

    def close(self) -> None:
        """Release the transport."""
        self.closed = True


class UdpChannel(Channel):
    """Sends to its configured peer, and to whoever last sent it a packet."""

    def __init__(
        self, host: str, port: int, index: int, sysid: int, compid: int, tlog: TlogHook | None
    ) -> None:
        super().__init__(f"udp:{host}:{port}", index, sysid, compid, tlog)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.sock.bind(("0.0.0.0", 0))
        self.peer = (host, port)

    def write(self, frame: bytes) -> None:
        """Send a datagram; an unreachable peer is not an error for a broadcaster."""
        try:
            self.sock.sendto(frame, self.peer)
        except OSError:
            pass

    def receive(self) -> list[mavlink.MAVLink_message]:
        """Drain waiting datagrams and remember the last sender as the peer."""
        msgs: list[mavlink.MAVLink_message] = []
        for _ in range(256):
            try:
                data, addr = self.sock.recvfrom(RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:  # ICMP port unreachable reported on a later call
                continue
            self.peer = addr
            msgs.extend(self.decode(data))
        return msgs

    def fileno(self) -> int:
        """Socket descriptor."""
        return self.sock.fileno()

    def close(self) -> None:
        """Close the socket."""
        super().close()
        self.sock.close()


class TcpChannel(Channel):
    """One accepted TCP client with a bounded output backlog."""

    def __init__(
        self,
        sock: socket.socket,
        addr: tuple[str, int],
        index: int,
        sysid: int,
        compid: int,
        tlog: TlogHook | None,
    ) -> None:
        super().__init__(f"tcp:{addr[0]}:{addr[1]}", index, sysid, compid, tlog)
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock = sock
        self._backlog = bytearray()

    def write(self, frame: bytes) -> None:
        """Queue and flush; a client that cannot keep up is disconnected."""
        if self.closed:
            return
        self._backlog += frame
        self.flush()
        if len(self._backlog) > MAX_BACKLOG_BYTES:
            self.close()

    def flush(self) -> None:
        """Send as much of the backlog as the socket takes."""
        while self._backlog and not self.closed:
            try:
                sent = self.sock.send(self._backlog)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                self.close()
                return
            del self._backlog[:sent]

    def receive(self) -> list[mavlink.MAVLink_message]:
        """Read available bytes; EOF or a socket error closes the channel."""
        msgs: list[mavlink.MAVLink_message] = []
        for _ in range(64):
            try:
                data = self.sock.recv(RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                self.close()
                break
            if not data:
                self.close()
                break
            msgs.extend(self.decode(data))
        self.flush()
        return msgs

    def fileno(self) -> int:
        """Socket descriptor."""
        return self.sock.fileno()

    def close(self) -> None:
        """Close the client socket."""
        if not self.closed:
            super().close()
            try:
                self.sock.close()
            except OSError:
                pass


class TcpServer:
    """Listening socket that turns each new client into a TcpChannel on stream channel ``index``."""

    def __init__(self, host: str, port: int, index: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind((host, port))
        self.sock.listen(8)
        self.sock.setblocking(False)
        self.index = index

    def accept(self, sysid: int, compid: int, tlog: TlogHook | None) -> list[TcpChannel]:
        """Accept every pending client."""
        clients: list[TcpChannel] = []
        for _ in range(16):
            try:
                sock, addr = self.sock.accept()
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                break
            clients.append(TcpChannel(sock, addr, self.index, sysid, compid, tlog))
        return clients

    def fileno(self) -> int:
        """Socket descriptor."""
        return self.sock.fileno()

    def close(self) -> None:
        """Stop listening."""
        self.sock.close()


class SerialChannel(Channel):
    """A serial device in raw mode at ``baud`` (like an autopilot's SERIALn port); never blocks.

    Bytes that the device does not take at once (a slow UART, a peer not reading) are kept up to
    MAX_BACKLOG_BYTES, then the oldest are dropped: a serial port cannot disconnect a slow reader.
    """

    def __init__(self, device: str, baud: int, index: int, sysid: int, compid: int, tlog: TlogHook | None) -> None:
        super().__init__(f"serial:{device}@{baud}", index, sysid, compid, tlog)
        self.fd = os.open(device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            tty.setraw(self.fd)
            attrs = termios.tcgetattr(self.fd)
            speed = getattr(termios, f"B{baud}", None)
            if speed is not None:
                attrs[4] = attrs[5] = speed
            attrs[2] |= termios.CLOCAL | termios.CREAD
            termios.tcsetattr(self.fd, termios.TCSANOW, attrs)
        except termios.error:
            pass  # not a terminal (e.g. a FIFO in a test): bytes still flow
        self._backlog = bytearray()

    def write(self, frame: bytes) -> None:
        """Queue and flush; the oldest bytes go when the backlog overflows."""
        if self.closed:
            return
        self._backlog += frame
        self.flush()
        if len(self._backlog) > MAX_BACKLOG_BYTES:
            del self._backlog[: len(self._backlog) - MAX_BACKLOG_BYTES]

    def flush(self) -> None:
        """Write as much of the backlog as the device takes now."""
        while self._backlog and not self.closed:
            try:
                sent = os.write(self.fd, self._backlog)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                return  # e.g. EIO while the other end of a pseudo-terminal is closed: try again later
            del self._backlog[:sent]

    def receive(self) -> list[mavlink.MAVLink_message]:
        """Read whatever bytes are waiting."""
        msgs: list[mavlink.MAVLink_message] = []
        for _ in range(64):
            try:
                data = os.read(self.fd, RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                break
            except OSError:
                break
            if not data:
                break
            msgs.extend(self.decode(data))
        self.flush()
        return msgs

    def fileno(self) -> int:
        """Device descriptor."""
        return self.fd

    def close(self) -> None:
        """Close the device."""
        if not self.closed:
            super().close()
            try:
                os.close(self.fd)
            except OSError:
                pass
