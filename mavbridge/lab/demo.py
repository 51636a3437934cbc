"""`mavbridge demo`: the whole system in one command, as separate processes over UDP loopback.

Parses the scenario once and writes it, resolved, to ``<run folder>/scenario.yaml``; both children read
that one file with the one loader: `sim-vehicle --scenario` its world (vessel, sea, start), `mavbridge run
--scenario` all of it. Then it uploads the waypoint with `mission upload` (MAVSDK), runs `mavbridge run`
(which arms and sets the mode, and flies on the wave estimated from the boat's motion unless ``--wave-source
scenario``), waits for the arrival or t_max, stops every process it started by its own handles, prints
the figures and leaves a run folder with tlogs, CSVs, metrics and plots.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import yaml

from mavbridge.companion.summary import summary_lines
from mavbridge.lab.plots import plot_path, plot_timeseries
from mavbridge.lab.runlog import fresh_run_folder
from mavbridge.lab.scenario import Scenario
from vessel.geo import Home


def free_udp_port() -> int:
    """A UDP port on 127.0.0.1 that nothing is bound to right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _stop(process: subprocess.Popen, name: str, grace_s: float = 5.0) -> None:
    """Terminate a child we started (SIGTERM, then SIGKILL after a grace period) and reap it."""
    if process.poll() is None:
        process.terminate()
        try:
            process.wait(grace_s)
        except subprocess.TimeoutExpired:
            print(f"demo: {name} did not stop in {grace_s:g} s, killing it", file=sys.stderr)
            process.kill()
            process.wait()


def _plot(scenario: Scenario, out: Path, metrics: dict) -> None:
    """The paper's figures from the simulator's true state."""
    with (out / "sim" / "state.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    if not rows:
        return
    t = np.array([float(r["t_s"]) for r in rows])
    engaged_from = metrics.get("engaged_at_s") or 0.0
    keep = t >= engaged_from
    col = {k: np.array([float(r[k]) for r in rows])[keep] for k in ("north_m", "east_m", "roll_rad", "pitch_rad",
                                                                     "wave_slope_rad", "n1_rad_s", "n2_rad_s")}
    params = scenario.plant_params()  # the simulator's boat: τ from its shaft speeds
    from vessel import shaft_speeds_to_tau

    tau_x, tau_n = (np.asarray(v, float) for v in shaft_speeds_to_tau(params, col["n1_rad_s"], col["n2_rad_s"]))
    force = -0.5 * params.matrices().m_total * params.g * np.sin(2 * col["wave_slope_rad"])
    wp = (scenario.waypoint.north_m, scenario.waypoint.east_m)
    plot_path(out / "path.png", col["north_m"], col["east_m"], wp, scenario.waypoint.acceptance_radius_m,
              scenario.sea.waves(params), float(t[keep][-1]), "demo: simulator + companion over MAVLink")
    plot_timeseries(out / "timeseries.png", t[keep], force, np.degrees(col["roll_rad"]),
                    np.degrees(col["pitch_rad"]), tau_x, tau_n, "demo (true plant state; τ from shaft speeds)")


def write_resolved(scenario: Scenario, out: Path) -> Path:
    """The scenario as the children read it: every section resolved, one file in the run folder."""
    path = out / "scenario.yaml"
    path.write_text(yaml.safe_dump(scenario.to_mapping(), sort_keys=False), encoding="utf-8")
    return path


LOCKSTEP_STARTUP_WALL_S = 30.0  # --lockstep: wall seconds of startup (upload, connect, arm) before commanding


def lockstep_flags(speedup: float) -> tuple[list[str], list[str]]:
    """(simulator flags, companion flags) for a lockstep demo: both start the first control tick at the same
    autopilot time, late enough for the startup at this speedup, so that the same scenario gives the same run."""
    start = f"{round(LOCKSTEP_STARTUP_WALL_S * speedup):d}"
    return (["--lockstep", "--lockstep-timeout", "20", "--lockstep-start", start],
            ["--lockstep", "--start-at", start])


class DemoInterruptedError(Exception):
    """A signal (SIGINT, SIGTERM, SIGHUP) asked the demo to stop; it still stops its children and reports."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def _interrupt(signum: int, frame: object) -> None:
    raise DemoInterruptedError(signum)


def sim_realism(waves: str) -> list[str]:
    """The simulator's sea and sensors for the demo: realistic (its defaults: the hull heaving with the sea,
    a phase the companion is never told, sensor noise) when the companion estimates the waves; with
    ``--wave-source scenario`` (simulation-only truth) the phase from boot and exact sensors, so that the truth
    the companion reads is the simulator's."""
    return [] if waves == "estimated" else ["--sea-phase", "boot", "--ideal-sensors"]


def demo_commands(scenario: Scenario, out: Path, resolved: str, ports: tuple[int, int, int], speedup: float,
                  output: str, waves: str, lockstep: bool, seed: int | None = None,
                  attitude_form: str | None = None, sim_params: str | None = None,
                  engage_after_s: float | None = None) -> tuple[list[str], list[str]]:
    """(simulator command, companion command) on the ports (ground station, companion, TCP); ``seed`` the
    simulator's (None: it draws a fresh one); ``attitude_form`` the GUIDED path's (None: the companion's);
    ``sim_params`` a .parm file of the simulator's defaults (None: its own); ``engage_after_s`` the companion's
    wait from connecting to switching and arming (None: its own default)."""
    gcs_port, companion_port, tcp_port = ports
    python = sys.executable
    home = Home(heading_deg=scenario.start.heading_deg)  # CMAC; the boat's pose itself comes from the file
    sim_cmd = [python, "-m", "sim_vehicle.cli", "--tcp", str(tcp_port), "--out", f"udp:127.0.0.1:{gcs_port}",
               "--out", f"udp:127.0.0.1:{companion_port}", "--scenario", resolved, f"--home={home.text()}",
               "--params-store", str(out / "sim_state" / "params.json"), "--wipe", "--log-dir", str(out / "sim"),
               "--speedup", f"{speedup:g}", *sim_realism(waves), *(["--seed", str(seed)] if seed is not None else []),
               *(["--params", sim_params] if sim_params else [])]
    companion_cmd = [python, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{companion_port}",
                     "--output", output, "--out", str(out / "companion"), "--arm", "--set-mode",
                     "--scenario", resolved, "--wave-source", waves, "--solver", scenario.controller.solver,
                     *(["--attitude-form", attitude_form] if attitude_form else []),
                     *(["--engage-after", f"{engage_after_s:g}"] if engage_after_s is not None else [])]
    if lockstep:
        sim_flags, companion_flags = lockstep_flags(speedup)
        sim_cmd += sim_flags
        companion_cmd += companion_flags
    return sim_cmd, companion_cmd


UPLOAD_TRIES = 2  # `mission upload` is idempotent; MAVSDK's process has been seen to die after "accepted"


def _upload_waypoint(scenario: Scenario, gcs_port: int) -> bool:
    """Upload the scenario's waypoint with `mission upload` (MAVSDK); a failed try is said and tried again
    (a whole upload replaces the mission, so a repeat is harmless). False when every try failed."""
    north, east = scenario.waypoint.north_m, scenario.waypoint.east_m
    for attempt in range(1, UPLOAD_TRIES + 1):
        try:
            upload = subprocess.run([sys.executable, "-m", "mission.cli", "upload", "--waypoint",
                                     f"{north:g},{east:g}", "--connect", f"udpin://127.0.0.1:{gcs_port}",
                                     "--timeout", "20"], capture_output=True, text=True, timeout=120)
        except subprocess.TimeoutExpired:
            print(f"demo: mission upload did not finish within 120 s (try {attempt} of {UPLOAD_TRIES})",
                  file=sys.stderr)
            continue
        print(upload.stdout.rstrip())
        if upload.returncode == 0:
            return True
        print(f"demo: mission upload failed with exit status {upload.returncode} (try {attempt} of "
              f"{UPLOAD_TRIES}): {upload.stderr.strip() or 'no message'}", file=sys.stderr)
    return False


def _fly(scenario: Scenario, out: Path, cmds: tuple[list[str], list[str]], gcs_port: int, wall_limit_s: float,
         children: list[tuple[subprocess.Popen, str]]) -> int | None:
    """Start the simulator, upload the waypoint, run the companion to its end; 1 on a failure before flying,
    None once the companion has ended (or was stopped at ``wall_limit_s``). Children go into ``children``."""
    with (out / "sim.log").open("w") as sim_log:
        children.append((subprocess.Popen(cmds[0], stdout=sim_log, stderr=subprocess.STDOUT), "sim-vehicle"))
    if not _upload_waypoint(scenario, gcs_port):
        return 1
    companion = subprocess.Popen(cmds[1])
    children.append((companion, "mavbridge run"))
    try:
        companion.wait(wall_limit_s)
    except subprocess.TimeoutExpired:
        print(f"demo: companion still running after {wall_limit_s:.0f} s, stopping it", file=sys.stderr)
    return None


def _report(scenario: Scenario, out: Path, interrupted: DemoInterruptedError | None) -> int:
    """Plots and the summary from what the children left; the exit code (128 + signal when interrupted)."""
    stopped = f"demo: stopped by {interrupted}; every process it started is stopped" if interrupted else None
    metrics_path = out / "companion" / "metrics.json"
    if not metrics_path.exists():
        print(stopped or "demo: the companion wrote no metrics", file=sys.stderr)
        print(f"demo: exit status {128 + interrupted.signum if interrupted else 1}; run folder {out}")
        return 128 + interrupted.signum if interrupted else 1
    metrics = json.loads(metrics_path.read_text())
    with contextlib.suppress(Exception):  # the figures are a bonus; the metrics are the result
        _plot(scenario, out, metrics)
    arrived = metrics.get("time_to_waypoint_s")
    first, *rest = summary_lines(metrics)
    print(f"demo: {first}; run folder {out}")
    for line in rest:
        print(f"demo: {line}")
    if interrupted:
        print(stopped, file=sys.stderr)
        code = 128 + interrupted.signum
    else:
        code = 0 if arrived is not None and math.isfinite(arrived) else 1
    print(f"demo: exit status {code}")
    return code


def run_demo(scenario: Scenario, out: Path, speedup: float, output: str, waves: str = "estimated",
             lockstep: bool = False, seed: int | None = None, attitude_form: str | None = None,
             sim_params: str | None = None, engage_after_s: float | None = None) -> int:
    """Run the demo; returns 0 when the boat reached the waypoint. ``waves``: the companion's wave source,
    ``estimated`` (from the boat's motion) or ``scenario`` (the simulator's truth); ``lockstep``: a
    reproducible run; ``seed``: the simulator's (hidden phase, noise), None for a fresh one. SIGINT, SIGTERM
    and SIGHUP stop it the same way: every child stopped by its handle, logs and plots written, the exit
    status (128 + the signal) stated."""
    out = fresh_run_folder(out)
    resolved = str(write_resolved(scenario, out))
    ports = (free_udp_port(), free_udp_port(), free_tcp_port())
    print(f"demo: simulator TCP {ports[2]}, ground station UDP {ports[0]}, companion UDP {ports[1]}, "
          f"speedup {speedup:g}, output {output}, waves {waves}")
    cmds = demo_commands(scenario, out, resolved, ports, speedup, output, waves, lockstep, seed, attitude_form,
                         sim_params, engage_after_s)
    # lockstep: simulated time waits for every plan, so on a loaded machine it runs slower than the speedup
    wall_limit = scenario.t_max_s / speedup * (4.0 if lockstep else 1.0) + 120.0 + (
        LOCKSTEP_STARTUP_WALL_S if lockstep else 0.0)
    children: list[tuple[subprocess.Popen, str]] = []
    interrupted: DemoInterruptedError | None = None
    previous = {s: signal.signal(s, _interrupt) for s in STOP_SIGNALS}
    try:
        if _fly(scenario, out, cmds, ports[0], wall_limit, children) is not None:
            return 1
    except DemoInterruptedError as exc:
        interrupted = exc
    finally:
        for s in STOP_SIGNALS:  # a second signal must not cut the clean-up short
            signal.signal(s, signal.SIG_IGN)
        for process, name in reversed(children):
            _stop(process, name)
        for s, handler in previous.items():
            signal.signal(s, handler)
    return _report(scenario, out, interrupted)


def timestamped_folder(root: Path = Path("runs")) -> Path:
    """runs/demo-YYYYmmdd-HHMMSS."""
    return root / time.strftime("demo-%Y%m%d-%H%M%S")
