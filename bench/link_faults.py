"""Benchmark: Balanced over a bad radio — loss × one-way delay → reached, average roll, arrival, retries.

Run: OMP_NUM_THREADS=1 python bench/link_faults.py [--full] [--speedup 5] [--seed 1] [--jitter 0.25]

Each cell is one real run: `sim-vehicle` in the paper's waves (seeded), the chaos relay (the same loss
and delay both ways, delay in simulated time, jitter as a fraction of it), and `mavbridge run --arm
--set-mode` to the Balanced waypoint. The default grid is loss 0/20/40 % × delay 0/400 ms; ``--full``
runs loss 0/10/20/30/40 % × delay 0/100/200/400 ms (20 runs, about 11 minutes on 2 shared cores). Paced runs: the
figures move a little with the machine's load (lockstep cannot wait for what the relay lost).
"""

from __future__ import annotations

import argparse
import json
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from chaos_relay import ChaosRelay, Faults

from sim_vehicle.harness import SimProcess, free_port

HOME = "--home=-35.363261,149.165230,584,90"
DEFAULT_GRID = ((0.0, 0.2, 0.4), (0.0, 0.4))
FULL_GRID = ((0.0, 0.1, 0.2, 0.3, 0.4), (0.0, 0.1, 0.2, 0.4))


def run_cell(loss: float, delay_s: float, args: argparse.Namespace, work: Path) -> dict[str, Any]:
    """One run through the relay; the companion's metrics with the relay's counts."""
    faults = Faults(loss=loss, delay_s=delay_s, jitter_s=delay_s * args.jitter)
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(work / "sim", speedup=args.speedup, waves="paper",
                     extra=[HOME, "--wipe", "--seed", str(args.seed)], udp_outs=1)
    out = work / "companion"
    cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--solver", "asrti",
           "--arm", "--set-mode", "--waypoint", args.waypoint, "--out", str(out), "--command-timeout",
           str(args.command_timeout), "--command-retries", str(args.command_retries), "--max-time", str(args.max_time)]
    start = time.monotonic()
    with ChaosRelay(port, faults, faults, args.seed, args.speedup, sim.udp_ports[0]) as relay, sim:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
    metrics = json.loads((out / "metrics.json").read_text()) if (out / "metrics.json").exists() else {}
    return {"loss": loss, "delay_s": delay_s, "code": done.returncode, "phase": metrics.get("phase"),
            "avg_roll_deg": metrics.get("avg_roll_deg"), "time_s": metrics.get("time_to_waypoint_s"),
            "retries": metrics.get("link", {}).get("retries"), "wall_s": round(time.monotonic() - start, 1),
            "relay": relay.summary(), "tail": done.stdout.splitlines()[-8:] + done.stderr.splitlines()[-5:]}


def fmt(value: Any, spec: str) -> str:
    """A figure, or '-' when the run has none."""
    return "-" if value is None else format(value, spec)


def main() -> None:
    """Run the grid and print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--full", action="store_true", help="loss 0/10/20/30/40 % x delay 0/100/200/400 ms")
    p.add_argument("--speedup", type=float, default=5.0, help="simulator speedup (default 5)")
    p.add_argument("--seed", type=int, default=1, help="sea and relay seed (default 1)")
    p.add_argument("--jitter", type=float, default=0.25, help="jitter as a fraction of the delay (default 0.25)")
    p.add_argument("--waypoint", default="85,75", help="N,E metres from home (default: Balanced's 85,75)")
    p.add_argument("--command-timeout", type=float, default=0.5)
    p.add_argument("--command-retries", type=int, default=20)
    p.add_argument("--max-time", type=float, default=150.0, help="engaged autopilot seconds before giving up")
    p.add_argument("--timeout", type=float, default=400.0, help="wall seconds per run before it is killed")
    p.add_argument("--json", type=Path, help="also write the rows here")
    p.add_argument("--only", metavar="LOSS,DELAY", help="one cell (e.g. 0.4,0.4), its companion output printed")
    args = p.parse_args()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # unwind: the simulator and companion are stopped
    losses, delays = FULL_GRID if args.full else DEFAULT_GRID
    if args.only:
        loss, delay = (float(v) for v in args.only.split(","))
        losses, delays = (loss,), (delay,)
    print(f"Balanced through the chaos relay: speedup {args.speedup:g}, seed {args.seed}, jitter "
          f"±{args.jitter:g} × delay, command timeout {args.command_timeout:g} s × {args.command_retries} retries")
    print(f"{'loss':>5} {'delay':>6} {'reached':>8} {'avg roll':>9} {'arrival':>8} {'retried':>8} {'wall':>6}")
    rows = []
    for loss in losses:
        for delay in delays:
            with tempfile.TemporaryDirectory(prefix="link_faults_") as work:
                row = run_cell(loss, delay, args, Path(work))
            rows.append(row)
            print(f"{loss:>5.0%} {delay * 1000:>4.0f}ms {'yes' if row['phase'] == 'ARRIVED' else 'NO':>8} "
                  f"{fmt(row['avg_roll_deg'], '.2f'):>7}° {fmt(row['time_s'], '.1f'):>7}s "
                  f"{fmt(row['retries'], 'd'):>8} {row['wall_s']:>5.0f}s", flush=True)
            if args.only:
                print("\n".join(row["tail"]))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
