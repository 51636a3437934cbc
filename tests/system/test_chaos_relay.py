"""The chaos relay itself: seeded fault patterns, and real datagrams through it on loopback, both ways."""

from __future__ import annotations

import random
import socket
import time

import pytest

from bench.chaos_relay import ChaosRelay, Direction, Faults


def pattern(faults: Faults, seed: int, n: int = 5000) -> list[int]:
    """Copies delivered per datagram (0 = lost) for ``n`` datagrams."""
    d = Direction(faults, random.Random(seed))
    return [len(d.delays()) for _ in range(n)]


def test_same_seed_same_pattern_and_loss_near_the_rate() -> None:
    faults = Faults(loss=0.4, duplicate=0.1)
    a, b, c = pattern(faults, 3), pattern(faults, 3), pattern(faults, 4)
    assert a == b and a != c
    lost = a.count(0) / len(a)
    assert 0.37 < lost < 0.43, lost
    assert 0.04 < a.count(2) / len(a) < 0.08  # 10 % of the 60 % that survive


def test_bursts_lose_runs_of_datagrams() -> None:
    lost = [k == 0 for k in pattern(Faults(burst_start=0.02, burst_length=8.0), 1, 20000)]
    runs, current = [], 0
    for gone in lost:
        if gone:
            current += 1
        elif current:
            runs.append(current)
            current = 0
    assert runs and sum(runs) / len(runs) > 4.0, f"mean burst {sum(runs) / max(len(runs), 1):.1f} datagrams"


def test_bad_probability_names_the_field() -> None:
    with pytest.raises(ValueError, match=r"loss: 1.5 is outside the allowed range \[0, 1\]"):
        Faults(loss=1.5)


def recv_all(sock: socket.socket, wait_s: float) -> list[tuple[bytes, float, tuple[str, int]]]:
    """Every datagram arriving within ``wait_s``, with its arrival time and sender."""
    out, deadline = [], time.monotonic() + wait_s
    while (left := deadline - time.monotonic()) > 0:
        sock.settimeout(left)
        try:
            data, sender = sock.recvfrom(2048)
            out.append((data, time.monotonic(), sender))
        except TimeoutError:
            break
    return out


def test_datagrams_are_delayed_in_simulated_time_duplicated_and_answered() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as companion, \
            socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sim:
        companion.bind(("127.0.0.1", 0))
        sim.bind(("127.0.0.1", 0))
        down = Faults(delay_s=0.4, duplicate=1.0)
        with ChaosRelay(companion.getsockname()[1], down, Faults(), seed=0, time_scale=2.0) as relay:
            sent = time.monotonic()
            sim.sendto(b"attitude", ("127.0.0.1", relay.port))
            got = recv_all(companion, 1.0)
            # (an ephemeral port may be one another test's simulator still sends to: only the relay's datagrams count)
            relay_out = next((sender for data, _, sender in got if data == b"attitude"), None)
            got = [g for g in got if g[2] == relay_out]
            assert [data for data, _, _ in got] == [b"attitude", b"attitude"]
            assert all(0.19 <= t - sent < 0.6 for _, t, _ in got), [t - sent for _, t, _ in got]  # 0.4 s / speedup 2
            companion.sendto(b"command", got[0][2])  # a udpin companion answers whoever sent
            back = [data for data, _, sender in recv_all(sim, 0.5) if sender == ("127.0.0.1", relay.port)]
            assert back == [b"command"]
        assert relay.summary()["down"] == {"received": 1, "dropped": 0, "duplicated": 1, "reordered": 0}

