"""Benchmark: the companion's own port under a flood of hostile MAVLink while it flies.

Run: OMP_NUM_THREADS=1 python bench/hostile_flood.py [--count 100000] [--rate 2500] [--speedup 1] [--seed 1]

Every message type of the ardupilotmega dialect, each packed with a valid CRC and extreme field values
(NaN, ±inf, ±3.4e38 floats; the minimum and maximum of each integer; 0xff-filled strings and arrays), from
a rotation of sources that includes the autopilot's own system/component id (1/1) and the companion's
(255/191), sent from another UDP socket to the companion's udpin port once the companion is engaged. A
real `sim-vehicle` in the paper's waves and a real `mavbridge run --arm --set-mode` fly Balanced; the
figures: packets sent, message types covered, the run's phase, average roll, arrival, what the companion's
link counted, and whether a traceback appeared.
"""

from __future__ import annotations

import argparse
import math
import os
import random
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.harness import SimProcess

HOME = "--home=-35.363261,149.165230,584,90"
FLOATS = (math.nan, math.inf, -math.inf, 3.4e38, -3.4e38, 0.0, -0.0, 1e-45)
INTS = {"int8_t": (-128, 127), "uint8_t": (0, 255), "int16_t": (-32768, 32767), "uint16_t": (0, 65535),
        "int32_t": (-2**31, 2**31 - 1), "uint32_t": (0, 2**32 - 1), "int64_t": (-2**63, 2**63 - 1),
        "uint64_t": (0, 2**64 - 1), "uint8_t_mavlink_version": (0, 255)}
SOURCES = ((1, 1), (255, 191), (0, 0), (1, 0), (1, 191))  # the autopilot's ids, the companion's, broadcast...
MESSAGE_TYPES = tuple(sorted(mavlink.mavlink_map.values(), key=lambda cls: cls.id))


def _extreme(kind: str, rng: random.Random) -> Any:
    """One extreme value of a MAVLink field type."""
    if kind in ("float", "double"):
        return rng.choice(FLOATS)
    lo, hi = INTS[kind]
    return rng.choice((lo, hi, hi // 2 + 1, lo + 1 if lo < 0 else 1))


def extreme_message(cls: Any, rng: random.Random) -> Any:
    """An instance of message class ``cls`` with every field at an extreme (arrays filled, strings 0xff)."""
    values = []
    for name, kind in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        length = cls.array_lengths[cls.ordered_fieldnames.index(name)]
        if kind == "char":
            values.append(bytes([rng.choice((0xFF, 0x80, 0x00, 0x41))]) * max(length, 1))
        elif length:
            values.append([_extreme(kind, rng) for _ in range(length)])
        else:
            values.append(_extreme(kind, rng))
    return cls(*values)


def hostile_packets(count: int, seed: int) -> Iterator[tuple[int, bytes]]:
    """``count`` (message id, packed frame) pairs: every message type in turn (shuffled each round), valid CRC."""
    rng = random.Random(seed)
    packers = {src: mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1]) for src in SOURCES}
    sent = 0
    while sent < count:
        order = list(MESSAGE_TYPES)
        rng.shuffle(order)
        for cls in order[:count - sent]:
            packer = packers[SOURCES[sent % len(SOURCES)]]
            packer.seq = rng.randrange(256)
            yield cls.id, extreme_message(cls, rng).pack(packer)
            sent += 1


class HostileFlood(threading.Thread):
    """Sends ``count`` hostile packets to a UDP port at ``rate`` per second; ``done`` is set at the end."""

    def __init__(self, port: int, count: int, rate: float, seed: int = 1) -> None:
        super().__init__(daemon=True, name="hostile-flood")
        self.port, self.count, self.rate, self.seed = port, count, rate, seed
        self.sent = 0
        self.types: set[int] = set()
        self.done = threading.Event()
        self.running = True

    def run(self) -> None:
        start = time.monotonic()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
            for msg_id, frame in hostile_packets(self.count, self.seed):
                if not self.running:
                    break
                sock.sendto(frame, ("127.0.0.1", self.port))
                self.sent += 1
                self.types.add(msg_id)
                ahead = self.sent / self.rate - (time.monotonic() - start)
                if ahead > 0.005:
                    time.sleep(ahead)
        self.done.set()


def fly_under_flood(args: argparse.Namespace, work: Path) -> dict[str, Any]:
    """One run to the Balanced waypoint, the flood starting once the companion is engaged."""
    import json

    out = work / "companion"
    with SimProcess(work / "sim", speedup=args.speedup, waves="paper", extra=[HOME, "--wipe", "--seed",
                    str(args.seed)], udp_outs=1) as sim:
        port = sim.udp_ports[0]
        cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--solver",
               "asrti", "--arm", "--set-mode", "--waypoint", args.waypoint, "--out", str(out), "--max-time",
               str(args.max_time)]
        flood = HostileFlood(port, args.count, args.rate, args.seed)
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        assert proc.stdout is not None
        lines: list[str] = []
        for line in proc.stdout:
            lines.append(line.rstrip())
            if "phase: engaged" in line and not flood.is_alive() and not flood.done.is_set():
                flood.start()
        code, stderr = proc.wait(args.timeout), proc.stderr.read() if proc.stderr else ""
        flood.running = False
    metrics = json.loads((out / "metrics.json").read_text()) if (out / "metrics.json").exists() else {}
    return {"code": code, "sent": flood.sent, "types": len(flood.types), "metrics": metrics, "lines": lines,
            "traceback": "Traceback" in stderr or any("Traceback" in line for line in lines), "stderr": stderr}


def main() -> None:
    """Fly once under the flood and print the figures."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--count", type=int, default=100_000, help="hostile packets (default 100000)")
    p.add_argument("--rate", type=float, default=2500.0, help="packets per wall second (default 2500)")
    p.add_argument("--speedup", type=float, default=1.0, help="simulator speedup (default 1: the flight lasts "
                                                             "long enough for the whole flood)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--waypoint", default="85,75", help="N,E metres from home (default: Balanced's 85,75)")
    p.add_argument("--max-time", type=float, default=200.0, help="engaged autopilot seconds before giving up")
    p.add_argument("--timeout", type=float, default=600.0, help="wall seconds before the companion is killed")
    args = p.parse_args()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    print(f"{args.count} hostile packets at {args.rate:g}/s ({len(MESSAGE_TYPES)} ardupilotmega message types, "
          f"sources {', '.join(f'{s}/{c}' for s, c in SOURCES)}), Balanced at speedup {args.speedup:g}")
    with tempfile.TemporaryDirectory(prefix="hostile_flood_") as work:
        r = fly_under_flood(args, Path(work))
    m = r["metrics"]
    print(f"sent {r['sent']} packets, {r['types']} message types; exit {r['code']}, phase {m.get('phase')}, "
          f"avg roll {m.get('avg_roll_deg')} deg, arrival {m.get('time_to_waypoint_s')} s, "
          f"traceback: {'YES' if r['traceback'] else 'none'}")
    print(f"companion link counts: {m.get('link')}")
    if r["traceback"] or m.get("phase") != "ARRIVED":
        print("\n".join(r["lines"][-15:]) + "\n" + r["stderr"][-3000:])


if __name__ == "__main__":
    main()
