"""How long `mavbridge report` takes on an hour's log, and how much memory: the issue's ≤ 20 s and ≤ 300 MB.

Run: python bench/report_speed.py [--minutes 60] [--log FILE] [--keep DIR] [--repeats 1]

Unless ``--log`` names one, writes a tlog of ``--minutes`` of an ArduPilot Rover's streams as a ground
station logs them: ATTITUDE and SCALED_IMU at 20 Hz, GLOBAL_POSITION_INT and LOCAL_POSITION_NED at 10 Hz,
SERVO_OUTPUT_RAW, RC_CHANNELS and VFR_HUD at 5 Hz, RAW_IMU and SCALED_IMU2 at 2 Hz, SYS_STATUS, HEARTBEAT and
SYSTEM_TIME at 1 Hz, and the ground station's own HEARTBEAT at 1 Hz: the motion of the vessel model riding
the paper's sea (1.75 m, 6 s; heave, its ideal IMU) on legs of 10 minutes at changing shaft speeds and
headings. Then runs ``mavbridge report`` on it as a child process (its progress line shows) and prints the
wall time, the CPU time (the report and the child it reads with), and the memory: the peak of the summed
proportional set size (PSS, shared pages split between the processes that share them) of the report and its
children, sampled every 50 ms from /proc, and the largest single process's peak RSS; with the machine's load
before and after.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import struct
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mav

from vessel import SEA_PRESETS, Plant, otter_parameters
from vessel.geo import latlon_from_ned
from vessel.imu import ImuModel
from vessel.sensors import rotation_body_to_ned

HOME = (-35.363261, 149.165230)
EPOCH_US = 1_733_000_000_000_000
LEG_S = 600.0
LEGS = ((70.0, 70.0), (60.0, 80.0), (90.0, 90.0), (80.0, 60.0), (50.0, 50.0), (75.0, 65.0))
EVERY = {"SCALED_IMU": 1, "GLOBAL_POSITION_INT": 2, "LOCAL_POSITION_NED": 2, "SERVO_OUTPUT_RAW": 4,
         "RC_CHANNELS": 4, "VFR_HUD": 4, "RAW_IMU": 10, "SCALED_IMU2": 10, "SYS_STATUS": 20, "HEARTBEAT": 20,
         "SYSTEM_TIME": 20}  # in 20 Hz ticks


def _streams(ms: int, x: np.ndarray, force: np.ndarray, rates: np.ndarray, legs: int) -> dict[str, object]:
    """Every message an ArduPilot boat streams at one 20 Hz tick of state ``x``."""
    lat, lon = latlon_from_ned(*HOME, float(x[0]), float(x[1]))
    v = rotation_body_to_ned(x[3], x[4], x[5]) @ x[6:9]
    acc = [round(f / 9.80665 * 1000) for f in force]
    gyr = [round(r * 1000) for r in rates]
    return {
        "ATTITUDE": mav.MAVLink_attitude_message(ms, x[3], x[4], math.remainder(x[5], 2 * math.pi), *rates),
        "SCALED_IMU": mav.MAVLink_scaled_imu_message(ms, *acc, *gyr, 0, 0, 0),
        "GLOBAL_POSITION_INT": mav.MAVLink_global_position_int_message(
            ms, round(lat * 1e7), round(lon * 1e7), round(-x[2] * 1000), round(-x[2] * 1000),
            *(round(c * 100) for c in v), round(math.degrees(x[5]) % 360 * 100)),
        "LOCAL_POSITION_NED": mav.MAVLink_local_position_ned_message(ms, x[0], x[1], x[2], *v),
        "SERVO_OUTPUT_RAW": mav.MAVLink_servo_output_raw_message(ms * 1000 % 2**32, 0, 1700, 0, 1650, *[0] * 13),
        "RC_CHANNELS": mav.MAVLink_rc_channels_message(ms, 8, 1500, 1500, 1700, 1500, *[0] * 14, 255),
        "VFR_HUD": mav.MAVLink_vfr_hud_message(0, float(np.hypot(v[0], v[1])), 0, 70, 0, 0),
        "RAW_IMU": mav.MAVLink_raw_imu_message(ms * 1000, *acc, *gyr, 0, 0, 0, 0, 0),
        "SCALED_IMU2": mav.MAVLink_scaled_imu2_message(ms, *acc, *gyr, 0, 0, 0, 0),
        "SYS_STATUS": mav.MAVLink_sys_status_message(0, 0, 0, 500, 12000, 0, 90, 0, 0, 0, 0, 0, 0),
        "HEARTBEAT": mav.MAVLink_heartbeat_message(mav.MAV_TYPE_SURFACE_BOAT, mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                   mav.MAV_MODE_FLAG_SAFETY_ARMED | 1, legs % 2 * 10, 4, 3),
        "SYSTEM_TIME": mav.MAVLink_system_time_message(EPOCH_US + ms * 1000, ms),
    }


def write_log(path: Path, minutes: float) -> int:
    """The synthetic tlog (see the module docstring); returns its number of frames."""
    plant = Plant(otter_parameters(), SEA_PRESETS["paper"].waves(), dt=0.01, surface_heave=True)
    imu = ImuModel.for_plant(plant)
    boat, gcs = mav.MAVLink(None, srcSystem=1, srcComponent=1), mav.MAVLink(None, srcSystem=255, srcComponent=190)
    gcs_beat = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    frames, tick = 0, 0
    with path.open("wb") as handle:
        while plant.time < minutes * 60.0:
            leg = int(plant.time // LEG_S)
            ms = 30_000 + tick * 50
            stamp = struct.pack(">Q", EPOCH_US + ms * 1000)
            force, rates = imu.measure(plant.state, plant.time)
            for name, msg in _streams(ms, plant.state, force, rates, leg).items():
                if tick % EVERY.get(name, 1) == 0:
                    handle.write(stamp + msg.pack(boat))
                    frames += 1
            if tick % 20 == 0:
                handle.write(stamp + gcs_beat.pack(gcs))
                frames += 1
            plant.advance(LEGS[leg % len(LEGS)], 5)
            tick += 1
    return frames


def _pss_kb(pid: int) -> int:
    """PSS (kB) of ``pid`` and its children, 0 for what has gone."""
    total = 0
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            if line.startswith("Pss:"):
                total += int(line.split()[1])
        children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        return total
    return total + sum(_pss_kb(int(child)) for child in children)


def _watch_memory(process: subprocess.Popen, peak: list[int]) -> None:
    while process.poll() is None:
        peak[0] = max(peak[0], _pss_kb(process.pid))
        time.sleep(0.05)


def measure(log: Path, out: Path) -> tuple[float, float, float, float, int]:
    """(wall s, CPU s, peak summed PSS MB, peak single RSS MB, exit code) of one `mavbridge report` of ``log``."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    process = subprocess.Popen([sys.executable, "-m", "mavbridge.cli", "report", str(log), "--out", str(out)],
                               stdout=subprocess.PIPE, text=True)
    peak = [0]
    watcher = threading.Thread(target=_watch_memory, args=(process, peak), daemon=True)
    watcher.start()
    stdout, _ = process.communicate()
    wall = time.perf_counter() - start
    watcher.join()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    print(stdout.rstrip())
    return wall, cpu, peak[0] / 1024.0, after.ru_maxrss / 1024.0, process.returncode


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=60.0, help="length of the synthetic log")
    parser.add_argument("--log", type=Path, help="report this log instead of writing one")
    parser.add_argument("--keep", type=Path, help="write the synthetic log and the reports here (kept)")
    parser.add_argument("--repeats", type=int, default=1, help="reports of the same log")
    args = parser.parse_args()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="report-speed-"))
    folder.mkdir(parents=True, exist_ok=True)
    log = args.log
    if log is None:
        log = folder / f"rover-{args.minutes:g}min.tlog"
        start = time.perf_counter()
        frames = write_log(log, args.minutes)
        print(f"wrote {log}: {frames} frames, {log.stat().st_size / 1e6:.1f} MB, {args.minutes:g} min of 20 Hz "
              f"ATTITUDE, in {time.perf_counter() - start:.1f} s")
    for i in range(args.repeats):
        load = os.getloadavg()[0]
        wall, cpu, pss, rss, code = measure(log, folder / f"report-{i + 1}")
        print(f"report {i + 1}: exit {code}, wall {wall:.1f} s, CPU {cpu:.1f} s, memory {pss:.0f} MB (peak PSS of "
              f"the report and its reading child; largest single RSS {rss:.0f} MB) (targets 20 s, 300 MB; load "
              f"{load:.1f} before, {os.getloadavg()[0]:.1f} after, {os.cpu_count()} cores)")
    if args.keep is None:
        print(f"(log and reports in {folder}; --keep DIR to choose where)")


if __name__ == "__main__":
    main()
