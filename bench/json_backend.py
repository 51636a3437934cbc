"""What one ArduPilot JSON frame costs the backend, at 400 Hz in the paper's sea (target ≤ 50 µs).

Run: OMP_NUM_THREADS=1 python bench/json_backend.py [--frames 2000] [--batches 15] [--udp] [--sea jonswap]

"Step" is everything the backend does for a new frame except the socket calls: decode the servo
packet, lockstep bookkeeping, one RK4 plant step (dt 2.5 ms), the sensor function (IMU, NED velocity,
quaternion) and the reply text. Printed per frame: the median and best batch, and the parts alone.
``--udp`` adds the loopback round trip to a real ``sim-vehicle --json-backend`` process (what the
firmware waits for each frame, including both kernels' UDP paths and the Python receive loop).
``--sea jonswap`` times the step in the simulator's default irregular sea instead (JONSWAP Hs 1.75 m, Tp 6 s,
200 components, hull-averaged, compiled, with surface heave as the backend runs it there).
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sim_vehicle.json_backend.backend import JsonBackend
from sim_vehicle.json_backend.model import JsonPhysics
from sim_vehicle.json_backend.protocol import encode_reply, encode_servo_packet, motor_output_to_pwm
from vessel import OceanCurrent, otter_parameters
from vessel.sea.irregular_sea import IrregularSea
from vessel.world import sea_preset

RATE_HZ = 400
PWM = [motor_output_to_pwm(0.7), 0, motor_output_to_pwm(0.3)]


def per_call_us(work: Callable[[int], None], frames: int, batches: int) -> tuple[float, float]:
    """(median, best) CPU µs per call over ``batches`` batches of ``frames`` calls.

    CPU time of this process, not wall time: on a shared machine the wall clock also counts the time
    other processes held the core, which is not what a frame costs.
    """
    times = []
    for b in range(batches):
        start = time.process_time()
        work(b * frames)
        times.append((time.process_time() - start) / frames * 1e6)
    return statistics.median(times), min(times)


def make_physics(sea: str) -> JsonPhysics:
    """The backend's plant in the paper's sea, or in the default JONSWAP sea with surface heave."""
    params = otter_parameters()
    if sea == "paper":
        return JsonPhysics(params, sea_preset("paper").waves(), OceanCurrent(), np.zeros(14))
    waves = IrregularSea(hs_m=1.75, tp_s=6.0).wave_field(params)
    return JsonPhysics(params, waves, OceanCurrent(), np.zeros(14), surface_heave=True)


def in_process(frames: int, batches: int, sea: str = "paper") -> None:
    """The backend's own cost per frame, and its three parts."""
    physics = make_physics(sea)
    physics.prepare(1 / RATE_HZ)
    backend = JsonBackend(physics)
    packets = [encode_servo_packet(RATE_HZ, i, PWM) for i in range(frames * batches)]

    def frames_work(offset: int) -> None:
        for i in range(offset, offset + frames):
            backend.handle(packets[i])

    def plant_work(offset: int) -> None:
        for _ in range(frames):
            physics.step((0.7, 0.3), 1 / RATE_HZ)

    def sensor_work(offset: int) -> None:
        for _ in range(frames):
            physics.reply_values()

    values = physics.reply_values()

    def encode_work(offset: int) -> None:
        for _ in range(frames):
            encode_reply(values)

    median, best = per_call_us(frames_work, frames, batches)
    target = "target <= 50 us; " if sea == "paper" else ""
    print(f"json-backend step, {RATE_HZ} Hz, {sea} sea: median {median:.1f} us, best {best:.1f} us CPU per frame "
          f"({target}{frames} frames x {batches} batches)")
    for name, work in (("plant RK4 step", plant_work), ("sensors", sensor_work), ("reply text", encode_work)):
        m, b = per_call_us(work, frames, batches)
        print(f"  {name:<15} median {m:6.1f} us, best {b:6.1f} us")


def round_trip(frames: int) -> None:
    """Median and 99th-percentile loopback round trip to a real backend process."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    repo = Path(__file__).resolve().parents[1]
    proc = subprocess.Popen([sys.executable, "-m", "sim_vehicle.cli", "--json-backend", f"127.0.0.1:{port}",
                             "--sea", "paper", "--seed", "1"], cwd=repo, stderr=subprocess.DEVNULL,
                            env={**os.environ, "OMP_NUM_THREADS": "1"})
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.settimeout(1.0)
    try:
        count = 0
        for _ in range(60):  # the firmware, too, re-sends until the physics answers
            sock.sendto(encode_servo_packet(RATE_HZ, count, PWM), ("127.0.0.1", port))
            try:
                sock.recvfrom(4096)
                break
            except TimeoutError:
                continue
        else:
            raise SystemExit("bench: the backend never answered")
        time.sleep(0.5)
        while True:  # drop answers to the start-up re-sends
            sock.settimeout(0.2)
            try:
                sock.recvfrom(4096)
            except TimeoutError:
                break
        sock.settimeout(5.0)
        rtts = []
        for count in range(1, frames + 1):
            start = time.perf_counter()
            sock.sendto(encode_servo_packet(RATE_HZ, count, PWM), ("127.0.0.1", port))
            sock.recvfrom(4096)
            rtts.append((time.perf_counter() - start) * 1e6)
        rtts.sort()
        print(f"UDP loopback round trip to the backend process: median {statistics.median(rtts):.0f} us, "
              f"p99 {rtts[int(0.99 * len(rtts))]:.0f} us ({frames} frames; 400 Hz in real time allows 2500 us)")
    finally:
        sock.close()
        proc.terminate()
        proc.wait(timeout=20)


def main() -> None:
    """Print the figures."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--batches", type=int, default=15)
    parser.add_argument("--udp", action="store_true", help="also time the loopback round trip to a process")
    parser.add_argument("--sea", choices=("paper", "jonswap"), default="paper",
                        help="the paper's regular sea (default; the 50 us target) or the default JONSWAP sea")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    in_process(args.frames, args.batches, args.sea)
    if args.udp:
        round_trip(args.frames)


if __name__ == "__main__":
    main()
