"""Benchmark: Balanced over a bad radio — loss × one-way delay → parameters, mission, reached, roll, retries.

Run: OMP_NUM_THREADS=1 python bench/link_faults.py [--full] [--speedup 5] [--seed 1] [--jitter 0.25]

Each cell is one real run: `sim-vehicle` in the paper's waves (seeded) with the Balanced waypoint uploaded as its
mission (on its TCP port, outside the relay), the chaos relay (the same loss and delay both ways, delay in
simulated time, jitter as a fraction of it), and `mavbridge run --arm --set-mode`, which must read every
parameter its commands depend on (or refuse, naming it), download the mission whole, and fly there. The
default grid is loss 0/20/40/50 % × delay 0/400 ms; ``--full`` runs loss 0/10/20/30/40/50 % × delay
0/100/200/400 ms (24 runs, about half an hour on 2 shared cores). Printed per cell: whether the parameters
were read (their count, or the refusal), the mission items downloaded, reached, average roll, arrival, and the
resends by kind (param read, mission, command, stream request). Paced runs: the figures move a little with
the machine's load (lockstep cannot wait for what the relay lost).
"""

from __future__ import annotations

import argparse
import json
import re
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from chaos_relay import ChaosRelay, Faults

from mavbridge.link.retry import RETRY_KINDS
from sim_vehicle.harness import SimProcess, free_port
from vessel.geo import latlon_from_ned

HOME_LAT, HOME_LON = -35.363261, 149.165230
HOME = f"--home={HOME_LAT},{HOME_LON},584,90"
DEFAULT_GRID = ((0.0, 0.2, 0.4, 0.5), (0.0, 0.4))
FULL_GRID = ((0.0, 0.1, 0.2, 0.3, 0.4, 0.5), (0.0, 0.1, 0.2, 0.4))


def upload_mission(conn: Any, north: float, east: float) -> None:
    """Home + one NAV_WAYPOINT north/east metres from home, with the mission protocol (MISSION_ACK checked)."""
    items = [(HOME_LAT, HOME_LON), latlon_from_ned(HOME_LAT, HOME_LON, north, east)]
    conn.mav.mission_count_send(1, 1, len(items), 0)
    for seq, (lat, lon) in enumerate(items):
        request = conn.recv_match(type=["MISSION_REQUEST", "MISSION_REQUEST_INT"], blocking=True, timeout=5)
        if request is None or request.seq != seq:
            raise RuntimeError(f"mission upload: expected a request for item {seq}, got {request}")
        conn.mav.mission_item_int_send(1, 1, seq, 3, 16, 0, 1, 0, 0, 0, 0, round(lat * 1e7), round(lon * 1e7), 0, 0)
    ack = conn.recv_match(type="MISSION_ACK", blocking=True, timeout=5)
    if ack is None or ack.type != 0:
        raise RuntimeError(f"mission upload refused: {ack}")


def start_lines(stdout: str) -> tuple[str, str]:
    """(parameters: 'N read' or the refusal, mission: 'N waypoint(s)' or '-') from the companion's output."""
    params = re.search(r"parameters: (\d+) parameters read", stdout)
    refusal = re.search(r"refusing to engage: (.*)", stdout)
    mission = re.search(r"(\d+) waypoint\(s\) from the mission", stdout)
    said = f"{params.group(1)} read" if params else ("REFUSED" if refusal else "-")
    return said, (mission.group(1) if mission else "-")


def run_cell(loss: float, delay_s: float, args: argparse.Namespace, work: Path) -> dict[str, Any]:
    """One run through the relay; the companion's metrics with the relay's counts."""
    faults = Faults(loss=loss, delay_s=delay_s, jitter_s=delay_s * args.jitter)
    port = free_port(socket.SOCK_DGRAM)
    sim = SimProcess(work / "sim", speedup=args.speedup, waves="paper",
                     extra=[HOME, "--wipe", "--seed", str(args.seed)], udp_outs=1)
    out = work / "companion"
    cmd = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{port}", "--solver",
           args.solver, "--arm", "--set-mode", "--out", str(out), "--command-timeout", str(args.command_timeout),
           "--command-retries", str(args.command_retries), "--max-time", str(args.max_time)]
    north, east = (float(v) for v in args.waypoint.split(","))
    start = time.monotonic()
    with ChaosRelay(port, faults, faults, args.seed, args.speedup, sim.udp_ports[0]) as relay, sim:
        upload_mission(sim.connect(), north, east)
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
    metrics = json.loads((out / "metrics.json").read_text()) if (out / "metrics.json").exists() else {}
    params, mission = start_lines(done.stdout)
    link = metrics.get("link", {})
    return {"loss": loss, "delay_s": delay_s, "code": done.returncode, "phase": metrics.get("phase"),
            "params": params, "mission_waypoints": mission,
            "avg_roll_deg": metrics.get("avg_roll_deg"), "time_s": metrics.get("time_to_waypoint_s"),
            "retries": {kind: link.get(f"retries_{kind}") for kind in RETRY_KINDS},
            "wall_s": round(time.monotonic() - start, 1),
            "relay": relay.summary(), "tail": done.stdout.splitlines()[-8:] + done.stderr.splitlines()[-5:]}


def fmt(value: Any, spec: str) -> str:
    """A figure, or '-' when the run has none."""
    return "-" if value is None else format(value, spec)


def main() -> None:
    """Run the grid and print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--full", action="store_true", help="loss 0/10/20/30/40/50 % x delay 0/100/200/400 ms")
    p.add_argument("--solver", default="nrti", help="the companion's solver (default nrti, the real-time default)")
    p.add_argument("--speedup", type=float, default=5.0, help="simulator speedup (default 5)")
    p.add_argument("--seed", type=int, default=1, help="sea and relay seed (default 1)")
    p.add_argument("--jitter", type=float, default=0.25, help="jitter as a fraction of the delay (default 0.25)")
    p.add_argument("--waypoint", default="85,75", help="N,E metres from home (default: Balanced's 85,75)")
    p.add_argument("--command-timeout", type=float, default=0.5)
    p.add_argument("--command-retries", type=int, default=30, help="default 30: 0.75^31 < 1e-3 per command at 50 %")
    p.add_argument("--max-time", type=float, default=300.0, help="engaged autopilot seconds before giving up")
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
    print(f"{'loss':>5} {'delay':>6} {'params':>8} {'mission':>8} {'reached':>8} {'avg roll':>9} {'arrival':>8} "
          f"{'resends: param':>15} {'mission':>8} {'command':>8} {'stream':>7} {'wall':>6}")
    rows = []
    for loss in losses:
        for delay in delays:
            with tempfile.TemporaryDirectory(prefix="link_faults_") as work:
                row = run_cell(loss, delay, args, Path(work))
            rows.append(row)
            retries = row["retries"]
            print(f"{loss:>5.0%} {delay * 1000:>4.0f}ms {row['params']:>8} {row['mission_waypoints']:>8} "
                  f"{'yes' if row['phase'] == 'ARRIVED' else 'NO':>8} "
                  f"{fmt(row['avg_roll_deg'], '.2f'):>8}° {fmt(row['time_s'], '.1f'):>7}s "
                  f"{fmt(retries['param'], 'd'):>15} {fmt(retries['mission'], 'd'):>8} "
                  f"{fmt(retries['command'], 'd'):>8} {fmt(retries['stream'], 'd'):>7} {row['wall_s']:>5.0f}s",
                  flush=True)
            if args.only:
                print("\n".join(row["tail"]))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
