"""Benchmark: Balanced over a slow radio — no delay, delay without compensation, delay with compensation.

Run: OMP_NUM_THREADS=1 python bench/delay_compensation.py [--delay 0.4] [--jitter 0.1] [--seed 1] [--speedup 5]

Each row is one real run: `sim-vehicle` in the paper's waves (seeded), the chaos relay (the same delay and
jitter both ways, in simulated seconds) and `mavbridge run --arm --set-mode` to the Balanced waypoint,
with ``--no-delay-compensation`` in the middle row. It prints, per row: reached, average roll, arrival time
(since engaging), the median and 95th percentile of the logged state age, and the average roll against
the no-delay run (the issue's acceptance: within 10 % with compensation). Paced runs (lockstep cannot
wait through a relay): the figures move a little with the machine's load.
"""

from __future__ import annotations

import argparse
import json
import signal
import socket
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

from chaos_relay import ChaosRelay, Faults
from link_faults import HOME, fmt

from sim_vehicle.harness import SimProcess, free_port

ROWS = (("no delay", False, True), ("delay, no compensation", True, False), ("delay, compensated", True, True))


def run_row(delayed: bool, compensate: bool, args: argparse.Namespace, work: Path) -> dict[str, Any]:
    """One run: the companion's metrics (and its last lines, for a failed run)."""
    faults = Faults(delay_s=args.delay, jitter_s=args.jitter) if delayed else Faults()
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(work / "sim", speedup=args.speedup, waves="paper",
                     extra=[HOME, "--wipe", "--seed", str(args.seed)], udp_outs=1)
    out = work / "companion"
    cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--solver", "asrti",
           "--arm", "--set-mode", "--waypoint", args.waypoint, "--out", str(out), "--max-time", str(args.max_time),
           "--delay-compensation" if compensate else "--no-delay-compensation"]
    with ChaosRelay(port, faults, faults, args.seed, args.speedup, sim.udp_ports[0]), sim:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
    metrics = json.loads((out / "metrics.json").read_text()) if (out / "metrics.json").exists() else {}
    return {"delayed": delayed, "compensate": compensate, "code": done.returncode, "phase": metrics.get("phase"),
            "avg_roll_deg": metrics.get("avg_roll_deg"), "time_s": metrics.get("time_to_waypoint_s"),
            "delay": metrics.get("delay", {}), "tail": done.stdout.splitlines()[-6:] + done.stderr.splitlines()[-5:]}


def main() -> None:
    """Run the three rows and print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--delay", type=float, default=0.4, help="one-way delay each way, simulated s (default 0.4)")
    p.add_argument("--jitter", type=float, default=0.1, help="± jitter on it, simulated s (default 0.1)")
    p.add_argument("--speedup", type=float, default=5.0, help="simulator speedup (default 5)")
    p.add_argument("--seed", type=int, default=1, help="sea and relay seed (default 1)")
    p.add_argument("--waypoint", default="85,75", help="N,E metres from home (default: Balanced's 85,75)")
    p.add_argument("--max-time", type=float, default=150.0, help="engaged autopilot seconds before giving up")
    p.add_argument("--timeout", type=float, default=400.0, help="wall seconds per run before it is killed")
    p.add_argument("--json", type=Path, help="also write the rows here")
    args = p.parse_args()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # unwind: the simulator and companion are stopped
    print(f"Balanced through the chaos relay: {args.delay * 1000:.0f} ms ± {args.jitter * 1000:.0f} ms each way, "
          f"speedup {args.speedup:g}, seed {args.seed}")
    print(f"{'run':<24} {'reached':>7} {'avg roll':>9} {'vs none':>8} {'arrival':>8} {'age med':>8} {'age p95':>8}")
    rows, reference = [], None
    for name, delayed, compensate in ROWS:
        with tempfile.TemporaryDirectory(prefix="delay_comp_") as work:
            row = run_row(delayed, compensate, args, Path(work))
        rows.append({"run": name, **row})
        roll = row["avg_roll_deg"]
        reference = roll if reference is None else reference
        versus = None if roll is None or not reference else 100.0 * (roll / reference - 1.0)
        age = row["delay"]
        print(f"{name:<24} {'yes' if row['phase'] == 'ARRIVED' else 'NO':>7} {fmt(roll, '.2f'):>8}° "
              f"{fmt(versus, '+.1f'):>7}% {fmt(row['time_s'], '.1f'):>7}s "
              f"{fmt(age.get('state_age_s_median'), '.3f'):>7}s {fmt(age.get('state_age_s_p95'), '.3f'):>7}s",
              flush=True)
        if row["phase"] != "ARRIVED":
            print("\n".join(row["tail"]))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
