"""A seeded UDP relay that makes a loopback link behave like a bad telemetry radio (tests and benches).

It sits between an autopilot's UDP output and a companion's ``udpin`` port::

    sim-vehicle --out udp:127.0.0.1:<relay.port>  ->  relay  ->  mavbridge run --connect udpin:127.0.0.1:<C>

and applies, independently each way (``down``: autopilot -> companion, ``up``: companion -> autopilot),
random loss, burst loss (a Gilbert-style "bad" state that loses every datagram while it lasts), a fixed
delay with uniform jitter, duplication and reordering (a datagram held back by an extra delay). Every
random draw comes from one ``random.Random`` per direction seeded from ``seed``, so a run's fault
pattern depends only on the seed and the order of datagrams.

Delays are given in *simulated* seconds and divided by ``time_scale`` (the simulator's --speedup), so a
400 ms delay means 400 ms of the boat's time at any speedup.

Run standalone: ``python bench/chaos_relay.py --listen 14560 --to 14551 --loss 0.3 --delay 0.2``.
"""

from __future__ import annotations

import argparse
import heapq
import random
import select
import socket
import threading
import time
from dataclasses import dataclass, field
from types import TracebackType


@dataclass(frozen=True)
class Faults:
    """What one direction of the link does to datagrams (probabilities per datagram; seconds of sim time)."""

    loss: float = 0.0  # independent loss
    burst_start: float = 0.0  # chance that a burst of losses starts at this datagram
    burst_length: float = 0.0  # mean datagrams lost in a burst (geometric)
    delay_s: float = 0.0  # one-way delay
    jitter_s: float = 0.0  # uniform in [-jitter, +jitter], added to the delay (never below zero)
    duplicate: float = 0.0  # chance a datagram is delivered twice
    reorder: float = 0.0  # chance a datagram is held back reorder_s longer (overtaken by later ones)
    reorder_s: float = 0.05

    def __post_init__(self) -> None:
        for name in ("loss", "burst_start", "duplicate", "reorder"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name}: {getattr(self, name)!r} is outside the allowed range [0, 1]")
        for name in ("burst_length", "delay_s", "jitter_s", "reorder_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name}: {getattr(self, name)!r} is outside the allowed range >= 0")


@dataclass
class Direction:
    """One way through the relay: its faults, its random stream and what it did."""

    faults: Faults
    rng: random.Random
    received: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0
    in_burst: int = 0  # datagrams still to lose in the current burst

    def delays(self) -> list[float]:
        """Simulated-time delays of the copies to deliver (empty: dropped)."""
        f, rng = self.faults, self.rng
        self.received += 1
        if self.in_burst == 0 and f.burst_start and rng.random() < f.burst_start:
            self.in_burst = 1 + int(rng.expovariate(1.0 / f.burst_length)) if f.burst_length > 0 else 1
        if self.in_burst > 0:
            self.in_burst -= 1
            self.dropped += 1
            return []
        if f.loss and rng.random() < f.loss:
            self.dropped += 1
            return []
        copies = 2 if f.duplicate and rng.random() < f.duplicate else 1
        self.duplicated += copies - 1
        out = []
        for _ in range(copies):
            delay = max(0.0, f.delay_s + (rng.uniform(-f.jitter_s, f.jitter_s) if f.jitter_s else 0.0))
            if f.reorder and rng.random() < f.reorder:
                delay += f.reorder_s
                self.reordered += 1
            out.append(delay)
        return out


@dataclass(order=True)
class _Pending:
    due: float
    seq: int
    data: bytes = field(compare=False)
    upward: bool = field(compare=False)


class ChaosRelay:
    """The relay: ``port`` is where the autopilot sends; datagrams go on to ``companion_port`` and back."""

    def __init__(self, companion_port: int, down: Faults = Faults(), up: Faults = Faults(), seed: int = 0,
                 time_scale: float = 1.0, port: int = 0, host: str = "127.0.0.1") -> None:
        self._sim_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sim_side.bind((host, port))
        self._companion_side = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._companion_side.bind((host, 0))
        self.port = int(self._sim_side.getsockname()[1])
        self._companion = (host, companion_port)
        self._sim_address: tuple[str, int] | None = None
        self.down = Direction(down, random.Random(seed * 2))
        self.up = Direction(up, random.Random(seed * 2 + 1))
        self.time_scale = time_scale
        self._queue: list[_Pending] = []
        self._seq = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="chaos-relay", daemon=True)

    def __enter__(self) -> ChaosRelay:
        self._thread.start()
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()

    def close(self) -> None:
        """Stop the thread and close both sockets."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        self._sim_side.close()
        self._companion_side.close()

    def _take(self, sock: socket.socket, upward: bool, now: float) -> None:
        """Read one datagram and queue its copies (if any survive)."""
        try:
            data, address = sock.recvfrom(65535)
        except OSError:
            return
        if not upward:
            self._sim_address = address
        for delay in (self.up if upward else self.down).delays():
            self._seq += 1
            heapq.heappush(self._queue, _Pending(now + delay / self.time_scale, self._seq, data, upward))

    def _deliver(self, now: float) -> None:
        """Send everything that is due."""
        while self._queue and self._queue[0].due <= now:
            item = heapq.heappop(self._queue)
            try:
                if item.upward:
                    if self._sim_address is not None:
                        self._sim_side.sendto(item.data, self._sim_address)
                else:
                    self._companion_side.sendto(item.data, self._companion)
            except OSError:  # the companion's port is not open yet: a radio would lose it too
                pass

    def _run(self) -> None:
        while not self._stop.is_set():
            now = time.monotonic()
            wait = min(0.05, max(0.0, self._queue[0].due - now)) if self._queue else 0.05
            ready, _, _ = select.select([self._sim_side, self._companion_side], [], [], wait)
            now = time.monotonic()
            for sock in ready:
                self._take(sock, sock is self._companion_side, now)
            self._deliver(time.monotonic())

    def summary(self) -> dict[str, dict[str, int]]:
        """Datagrams received, dropped, duplicated and reordered each way."""
        return {name: {"received": d.received, "dropped": d.dropped, "duplicated": d.duplicated,
                       "reordered": d.reordered} for name, d in (("down", self.down), ("up", self.up))}


def main() -> None:
    """Run a relay until interrupted, the same faults both ways."""
    p = argparse.ArgumentParser(description="UDP relay with seeded loss, delay, jitter, duplication, reordering")
    p.add_argument("--listen", type=int, required=True, help="port the autopilot sends to")
    p.add_argument("--to", type=int, required=True, help="the companion's udpin port")
    p.add_argument("--loss", type=float, default=0.0)
    p.add_argument("--burst-start", type=float, default=0.0)
    p.add_argument("--burst-length", type=float, default=0.0)
    p.add_argument("--delay", type=float, default=0.0, help="one-way delay, s (simulated)")
    p.add_argument("--jitter", type=float, default=0.0)
    p.add_argument("--duplicate", type=float, default=0.0)
    p.add_argument("--reorder", type=float, default=0.0)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--speedup", type=float, default=1.0, help="the simulator's --speedup")
    a = p.parse_args()
    try:
        faults = Faults(a.loss, a.burst_start, a.burst_length, a.delay, a.jitter, a.duplicate, a.reorder)
    except ValueError as exc:
        p.error(str(exc))
    with ChaosRelay(a.to, faults, faults, a.seed, a.speedup, a.listen) as relay:
        try:
            while True:
                time.sleep(5)
                print(relay.summary(), flush=True)
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
