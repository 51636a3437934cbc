"""A null-modem cable in software: two pseudo-terminals whose masters a thread cross-connects.

pymavlink opens a serial link by device path, and only the slave side of a pseudo-terminal has one; so
two pty pairs are made, the simulator opens one slave, the companion the other, and a relay thread
copies bytes between the two masters. Both slaves are put in raw mode first, so no line discipline
(echo, CR/LF mapping) touches the binary MAVLink stream.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty


class NullModem:
    """Two pseudo-terminals whose masters are cross-connected by a thread; ``ends`` are the device paths."""

    def __init__(self) -> None:
        self._fds: list[int] = []
        masters, self.ends = [], []
        for _ in range(2):
            master, slave = os.openpty()
            tty.setraw(slave)
            self._fds += [master, slave]  # keep the slaves open: a master reads EIO while no slave is open
            masters.append(master)
            self.ends.append(os.ttyname(slave))
        self._a, self._b = masters
        self.bytes = [0, 0]
        self.running = True
        self._thread = threading.Thread(target=self._relay, daemon=True)
        self._thread.start()

    def _relay(self) -> None:
        while self.running:
            ready, _, _ = select.select([self._a, self._b], [], [], 0.1)
            for fd in ready:
                try:
                    data = os.read(fd, 65536)
                except OSError:
                    continue
                target = self._b if fd == self._a else self._a
                view = memoryview(data)
                while view and self.running:
                    try:
                        view = view[os.write(target, view):]
                    except BlockingIOError:
                        time.sleep(0.001)
                    except OSError:
                        break
                self.bytes[fd == self._b] += len(data)

    def close(self) -> None:
        """Stop the relay and close all four descriptors."""
        self.running = False
        self._thread.join(timeout=2)
        for fd in self._fds:
            os.close(fd)
