"""Benchmark: the companion's whole control step on a quiet computer and beside two CPU spinners, side by side.

Run: OMP_NUM_THREADS=1 python bench/step_under_load.py [--duration 60] [--realtime] [--conditions NAME,...]
     [--watch 60] [--seed 1] [--spinners 2] [--estimator process|inline] [--parts] [--no-rest] [--cold]

The step is `mavbridge run`'s, made of its own parts as it builds them: the state from the autopilot's
messages (``StateEstimate``), every ATTITUDE to the wave estimator through the ``WaveGate`` (``make_wave_source``:
in a process of its own as the companion's default ``estimator_process`` has it, whose CPU time per step and
faults are printed apart; ``--estimator inline`` in the step's process), and at each 0.1 s tick the wave handed to
the NMPC, the state predicted over the link's delay, the NMPC solve (default solver nrti) and the RC command.
Its telemetry is real: `sim-vehicle` in the paper's waves (realistic sensors, hidden phase, ``--seed``) streams
what the companion asks for (``mavbridge.link.streams``) into a ``Link`` for ``--watch`` + ``--duration``
simulated seconds. That recording is replayed paced at speedup 1 on the wall clock as the companion's loop reads
it: rest until the next tick can come (``pause_s``), then every message that has come, or the next; a step due
when the newest ATTITUDE reaches the next tick (``flight.schedule``). The first ``--watch`` seconds are replayed
unpaced with no steps (the estimator watches the boat, as from connection until the pilot engages; its process is
waited for), then the cold solve, then ``--duration`` paced seconds (the estimator's process never waited for).

A step's time is its control step plus the message handling since the previous one (the companion's whole work
per period). "command" is the control step until the command is ready to send: as in the run, the next period's
preparation (nrti's background job) is started after it (``solve(defer_advance=True)``, then ``advance()``),
and the period's samples go to the estimator's process after it too (``WaveGate.command_sent``).
Missed ticks: ticks the loop reached a period or more late (skipped, as the companion skips them), the ticks the
recording has no ATTITUDE for apart ("gaps"). Conditions, each on fresh parts: quiet; two spinners (``while True:
pass``) beside it; with ``--realtime`` also the spinners with the bench under ``mavbridge.cli.realtime``
(``--conditions realtime --duration 600``: it alone, ten minutes). Printed too: the loop's reads of the link per
step, the load before and after, the garbage collector's runs. ``--parts`` also times each part of the step
(``PARTS``; every call since the previous step summed, a part not called 0) and prints their medians per
condition: hot each costs a few microseconds, paced several times that (its code and data have left the caches),
so this says where a step's time goes as it flies; each timer adds about a microsecond.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import tempfile
import time
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.cli.args import single_scenario
from mavbridge.companion.config import CompanionConfig
from mavbridge.companion.delay import make_compensator
from mavbridge.companion.flight import build_nmpc, ready_for_loop, schedule
from mavbridge.companion.output_paths import RcOverride
from mavbridge.companion.outputs import RcSetup
from mavbridge.companion.state import StateEstimate
from mavbridge.companion.wave_gate import WaveGate, make_wave_source
from mavbridge.lab.machine import cold_line, cold_table, collections_timed, load, spinners
from mavbridge.link.connection import Link
from mavbridge.link.streams import request_streams
from mavbridge.preflight.rules import Context
from sim_vehicle.harness import SimProcess

HOME_LAT, HOME_LON = -35.363261, 149.165230  # the simulator's default home
RECORD_SPEEDUP = 10.0
WAYPOINT_NE = (85.0, 75.0)  # Balanced's


@dataclass
class Recording:
    """The autopilot's messages in arrival order, each with its replay time (newest time_boot_ms so far, ms)."""

    messages: list[Any] = field(default_factory=list)
    stamps_ms: list[int] = field(default_factory=list)

    def add(self, msg: Any) -> None:
        stamp = getattr(msg, "time_boot_ms", None)
        newest = self.stamps_ms[-1] if self.stamps_ms else 0
        self.messages.append(msg)
        self.stamps_ms.append(max(newest, int(stamp)) if stamp is not None else newest)


def record(seconds: float, seed: int, work: Path) -> Recording:
    """``seconds`` of simulated telemetry, as the companion requests it, from `sim-vehicle` in the paper's waves."""
    rec = Recording()
    with SimProcess(work / "sim", speedup=RECORD_SPEEDUP, waves="paper", udp_outs=1, sensors="realistic",
                    sea_phase="hidden", extra=["--seed", str(seed), "--wipe"]) as sim:
        link = Link(f"udpin:127.0.0.1:{sim.udp_ports[0]}", log=lambda _line: None)
        try:
            link.wait_autopilot(30)
            request_streams(link, 0.1, lambda _line: None)
            link.handlers.append(rec.add)
            start_ms = rec.stamps_ms[-1] if rec.stamps_ms else 0
            deadline = time.monotonic() + seconds / RECORD_SPEEDUP * 4 + 60
            while (rec.stamps_ms[-1] if rec.stamps_ms else 0) - start_ms < seconds * 1000:
                if time.monotonic() > deadline:
                    raise TimeoutError(f"the simulator gave less than {seconds:g} s of telemetry in time")
                link.recv(0.1)
        finally:
            link.close()
    return rec


class CompanionStep:
    """The companion's parts for one condition, as `mavbridge run` builds them, and its per-period work."""

    def __init__(self, nmpc: Any, waves: Any, scenario: Any) -> None:
        config = CompanionConfig()
        self.nmpc, self.period_s = nmpc, scenario.controller.period_s
        self.state = StateEstimate(max_distance_m=config.max_distance_m)
        self.state.set_home(HOME_LAT, HOME_LON)  # (the mission's item 0 in a run)
        self.state.use_imu("SCALED_IMU")  # the fastest IMU stream, as the run measures it
        self.gate = WaveGate(waves, lambda _line: None, hold_s=scenario.estimation.hold_s)
        self.delay = make_compensator(config, nmpc)
        ctx = Context(config.system_id, "rc_override", self.period_s, scenario.waypoint.acceptance_radius_m)
        self.output = RcOverride(scenario.model_params(), ctx, lambda _line: None)
        self.output.setup = RcSetup()  # what prepare() reads from this simulator (Rover's RC defaults)
        self.solve_ms: list[float] = []
        self.child_cpu_s = 0.0  # the estimator's process's CPU time when the paced steps began (s)
        self.roll_term = 0
        self.parts: dict[str, list[float]] = {}  # --parts: each part's ms per step (``time_parts``)
        self.running: dict[str, int] = {}  # ... and its ns since the previous step

    def handle(self, msg: Any) -> None:
        """One message, as the run's link handlers take it (state, delay clock, the estimator's sample); the
        link's clock model only times what the replay does not mark ``backlog`` (the unpaced watch is)."""
        self.state.on_message(msg)
        self.delay.on_message(msg)
        if msg.get_type() == "ATTITUDE" and self.state.ready():
            self.gate.observe(self.state.motion_sample())

    def prepare(self) -> None:
        """The cold full solve before the loop (start_flight's), from the state now; from here the estimator's
        process (if it has one) is never waited for, as in a paced run (the unpaced watch, and this first step after
        it, wait for it to catch up)."""
        t_s = (self.state.attitude_ms or 0) / 1000.0
        self.gate.step(self.nmpc, t_s)
        self.nmpc.prepare(self.state.vector(), t_s, WAYPOINT_NE)
        if hasattr(self.gate.source, "wait_s"):
            self.gate.source.wait_s = 0.0
            self.child_cpu_s = self.gate.source.cpu_s  # its time per step counts from here, not the watch's

    def control(self, now_ms: int) -> float:
        """The control step of `mavbridge run` (its _control_step without the link): wave, prediction, solve,
        command, then the next period's preparation started; returns the wall clock when the command was ready."""
        x = self.state.vector()
        _age_s, plan_s = self.delay.compensate(now_ms / 1000.0)
        self.gate.step(self.nmpc, plan_s)
        result = self.nmpc.solve(self.delay.predict(x, now_ms / 1000.0, plan_s, self.nmpc.waves), plan_s,
                                 WAYPOINT_NE, deadline_s=self.period_s, defer_advance=True)
        self.delay.sent(plan_s, result.tau)
        self.output.compute(result, now_ms)
        command_ready = time.perf_counter()
        self.gate.command_sent()
        self.nmpc.advance()
        self.solve_ms.append(result.wall_time_s * 1e3)
        self.roll_term += bool(getattr(result, "roll_term_active", False))
        for label, series in self.parts.items():
            series.append(self.running.pop(label, 0) / 1e6)
        return command_ready


@dataclass
class Timings:
    """What one condition measured (ms, wall clock)."""

    steps_ms: list[float] = field(default_factory=list)
    handling_ms: list[float] = field(default_factory=list)  # of each step: the messages since the previous one
    command_ms: list[float] = field(default_factory=list)  # of each step: from its start to the command ready
    late_ms: list[float] = field(default_factory=list)  # the tick's ATTITUDE due to the start of its step
    missed: int = 0  # ticks skipped, in all
    gaps: int = 0  # of them, ticks the recording itself has no ATTITUDE for (a datagram lost while recording)
    reads: int = 0  # the loop's reads of the link (a wake-up each)


PARTS = (("state", "on_message", "handling: the state"), ("delay", "on_message", "handling: the delay clock"),
         ("gate", "observe", "handling: the estimator's samples"), ("delay", "compensate", "the clock (state's age)"),
         ("gate", "step", "the wave hand-over"), ("delay", "predict", "the prediction over the delay"),
         ("nmpc", "solve", "the NMPC's solve"), ("nmpc._backend", "solve", "  its backend (a full step)"),
         ("nmpc", "_prepared_feedback", "  its prepared feedback (nrti)"),
         ("nmpc._backend.advanced", "take", "    the background plan taken"),
         ("nmpc._backend", "feedback", "    the native feedback"), ("output", "compute", "the RC command"),
         ("gate", "command_sent", "the samples sent after the command"),
         ("nmpc", "advance", "the next preparation started"))  # (owner on CompanionStep, method, label)


def time_parts(step: CompanionStep) -> None:
    """``--parts``: each of PARTS the step has wrapped in a timer adding its wall ns to ``step.running``."""
    for path, method, label in PARTS:
        owner: Any = step
        for name in path.split("."):
            owner = getattr(owner, name, None)
        if owner is None or not hasattr(owner, method):
            continue
        inner, step.parts[label] = getattr(owner, method), []

        def timed(*args: Any, _inner: Callable[..., Any] = inner, _label: str = label, **kwargs: Any) -> Any:
            start = time.perf_counter_ns()
            try:
                return _inner(*args, **kwargs)
            finally:
                step.running[_label] = step.running.get(_label, 0) + time.perf_counter_ns() - start

        setattr(owner, method, timed)


def replay(rec: Recording, step: CompanionStep, watch_s: float, duration_s: float) -> Timings:
    """The watch unpaced, the cold solve, then ``duration_s`` paced at speedup 1 (see the module docstring)."""
    period_ms = round(step.period_s * 1000)
    t0_ms = rec.stamps_ms[0] + round(watch_s * 1000)
    i, step.delay.backlog = 0, True  # the watch is unpaced: not timed (it would look like a huge delay)
    while rec.stamps_ms[i] < t0_ms:
        step.handle(rec.messages[i])
        i += 1
    step.prepare()
    out, handled_s, next_tick, attitude_due, ideal_tick = Timings(), 0.0, None, 0.0, None
    wall0 = time.perf_counter()
    end_ms = t0_ms + duration_s * 1000

    def due_at(index: int) -> float:
        return wall0 + (rec.stamps_ms[index] - t0_ms) / 1000.0

    while i < len(rec.messages) and rec.stamps_ms[i] <= end_ms:
        rest = step.delay.pause_s(next_tick and next_tick / 1e3, step.period_s)
        wake = max(due_at(i), time.perf_counter() + rest)
        step.delay.backlog = wake > due_at(i)  # woken by the rest, not by a message: what came waited (not timed)
        if (wait := wake - time.perf_counter()) > 0:
            time.sleep(wait)
        start, out.reads = time.perf_counter(), out.reads + 1
        while i < len(rec.messages) and due_at(i) <= time.perf_counter():  # all that is due: the run drains too
            step.handle(rec.messages[i])
            if rec.messages[i].get_type() == "ATTITUDE":  # a loop always on time would step on this one
                attitude_due = due_at(i)
                ideal_due, ideal_tick, gap = schedule(rec.stamps_ms[i], ideal_tick, period_ms)
                out.gaps += gap if ideal_due else 0
            i += 1
        handled_s += time.perf_counter() - start
        if rest > 0.0 and step.delay.backlog:  # (as the run's read: how late the rest and what waited ended)
            step.delay.overslept(time.perf_counter() - wake)
        now_ms = step.state.attitude_ms
        due, next_tick, missed = schedule(now_ms, next_tick, period_ms) if now_ms is not None else (False, None, 0)
        if not due:
            continue
        step.delay.ticked((now_ms - next_tick + period_ms) / 1000.0)  # as the run's loop tells it
        begin = time.perf_counter()
        command_ready = step.control(now_ms)
        out.steps_ms.append((time.perf_counter() - begin + handled_s) * 1e3)
        out.command_ms.append((command_ready - begin) * 1e3)
        out.handling_ms.append(handled_s * 1e3)
        out.late_ms += [(begin - attitude_due) * 1e3] if attitude_due else []  # its ATTITUDE's arrival to its start
        handled_s = 0.0
        out.missed += missed
    return out


def run_condition(name: str, around: Callable[[], Any], rec: Recording, args: argparse.Namespace,
                  scenario: Any, realtime: bool = False) -> dict[str, Any]:
    """One condition on fresh parts (its own estimator and NMPC), inside ``around()`` (the spinners or not); with
    ``realtime`` the estimator's process (if it has one) gets the companion's settings a priority lower, as
    `mavbridge run --realtime` gives them."""
    waves = make_wave_source("estimated", scenario.sea.waves(), 1.0, 0.0, scenario.model_params(),
                             process=args.estimator == "process")
    try:
        if realtime:
            from mavbridge.cli.realtime import DEFAULT_PRIORITY
            from mavbridge.cli.run import realtime_for_estimator

            line = realtime_for_estimator(waves, DEFAULT_PRIORITY)
            if line is not None:
                print(line, flush=True)
        with build_nmpc(scenario, waves) as nmpc, around():
            before = load()
            step = CompanionStep(nmpc, waves, scenario)
            if args.no_rest:  # the loop as it was before it rested: a read for every message as it comes
                step.delay.pause_s = lambda *_args: 0.0
            if args.parts:
                time_parts(step)
            ready_for_loop()  # as `mavbridge run` sets the interpreter before its loop
            with collections_timed() as gc_ms:
                timings = replay(rec, step, args.watch, args.duration)
            child_ms = (getattr(waves, "cpu_s", 0.0) - step.child_cpu_s) * 1e3 / max(1, len(step.solve_ms))
            after = load()
    finally:
        gc.unfreeze()  # (ready_for_loop froze this condition's parts: the next condition builds its own)
        getattr(waves, "close", lambda: None)()
    return {"name": name, "timings": timings, "solve_ms": step.solve_ms, "load": f"{before} -> {after}",
            "roll_term": step.roll_term / max(1, len(step.solve_ms)), "gc_ms": gc_ms, "child_ms": child_ms,
            "faults": dict(getattr(waves, "faults", {})), "parts": step.parts}


def figures(row: dict[str, Any]) -> str:
    """One line of the table."""
    t: Timings = row["timings"]
    steps, late, solve, command = (np.asarray(v, float) for v in (t.steps_ms, t.late_ms or [math.nan],
                                                                   row["solve_ms"], t.command_ms))
    return (f"{row['name']:<26} {len(steps):>6} {np.median(steps):>8.3f} {np.percentile(steps, 99):>8.3f} "
            f"{np.median(command):>8.3f} {np.percentile(command, 99):>8.3f} "
            f"{steps.max():>8.3f} {t.missed - t.gaps:>7} {np.median(solve):>8.3f} {np.percentile(solve, 99):>8.3f} "
            f"{np.median(t.handling_ms):>8.3f} {np.percentile(late, 99):>8.2f} {np.nanmax(late):>8.2f} "
            f"{row['roll_term']:>6.0%} {row['load']:>12} {t.gaps:>5} {len(row['gc_ms']):>5} "
            f"{max(row['gc_ms'], default=0.0):>7.2f} {row['child_ms']:>7.3f} {t.reads / max(1, len(steps)):>6.2f}"
            + (f"  estimator process: {row['faults']}" if any(row["faults"].values()) else ""))


def print_parts(row: dict[str, Any]) -> None:
    """``--parts``: each part's median and p90 ms per step, and its share of the median step."""
    median = float(np.median(row["timings"].steps_ms))
    print(f"\n{row['name']}: parts (ms per step, wall clock; indented ones are inside the one above)")
    for label, series in row["parts"].items():
        v = np.asarray(series[1:], float)  # (the first step's handling began before the timers)
        print(f"  {label:<36} {np.median(v):>8.4f} {np.percentile(v, 90):>8.4f} {np.median(v) / median:>6.0%}")


def main() -> None:
    """Record once, run each condition, print the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--duration", type=float, default=60.0, help="paced seconds per condition (default 60)")
    p.add_argument("--watch", type=float, default=60.0, help="seconds the estimator watches first (default 60)")
    p.add_argument("--seed", type=int, default=1, help="the simulator's seed (sea phase, sensor noise)")
    p.add_argument("--estimator", choices=("process", "inline"), default="process",
                   help="the wave estimator in a process of its own (default, the companion's) or inline")
    p.add_argument("--parts", action="store_true", help="also time each part of the step (see PARTS)")
    p.add_argument("--no-rest", action="store_true", help="no rest before a read (the loop before 2026-12-06)")
    p.add_argument("--solver", default="nrti", help="NMPC solver (default nrti, the companion's default)")
    p.add_argument("--spinners", type=int, default=2, help="CPU spinner processes beside it (default 2)")
    p.add_argument("--realtime", action="store_true", help="also: spinners with the step under --realtime")
    p.add_argument("--conditions", default=None, metavar="NAME,...",
                   help="which of quiet,spinners,realtime to run (default quiet,spinners, and realtime with "
                        "--realtime); e.g. --conditions realtime --duration 600 for the 10 minutes alone")
    p.add_argument("--cold", action="store_true", help="only print this computer's cold factor after gaps of "
                   "0.2 to 100 ms, asleep and spinning (mavbridge.lab.machine.cold_table), and stop")
    args = p.parse_args()
    if args.cold:
        print("\n".join(cold_table()))
        return
    chosen = (args.conditions or "quiet,spinners" + (",realtime" if args.realtime else "")).split(",")
    if not set(chosen) <= {"quiet", "spinners", "realtime"}:
        p.error(f"--conditions: {args.conditions!r}: names are quiet, spinners, realtime")
    scenario = single_scenario(None, args.solver)
    print(f"recording {args.watch + args.duration:g} s of telemetry (sim-vehicle, paper waves, seed {args.seed}, "
          f"speedup {RECORD_SPEEDUP:g}) ...", flush=True)
    with tempfile.TemporaryDirectory(prefix="step_under_load_") as work:
        rec = record(args.watch + args.duration + 1, args.seed, Path(work))
    print(f"{len(rec.messages)} messages; {os.cpu_count()} CPUs; load {load()}; solver {args.solver}; "
          f"replayed at speedup 1, {args.duration:g} s per condition", flush=True)
    print(cold_line(), flush=True)  # (how this computer's figures compare with another's: see mavbridge.lab.machine)
    conditions = {"quiet": ("quiet", nullcontext),
                  "spinners": (f"{args.spinners} spinners", lambda: spinners(args.spinners))}
    rows = [run_condition(*conditions[name], rec, args, scenario) for name in chosen if name in conditions]
    if "realtime" in chosen:  # last: the process stays real-time
        from mavbridge.cli.realtime import apply_realtime

        print(apply_realtime().line(), flush=True)
        rows.append(run_condition(f"{args.spinners} spinners + realtime", lambda: spinners(args.spinners), rec,
                                  args, scenario, realtime=True))
    print(f"\n{'condition':<26} {'steps':>6} {'median':>8} {'p99':>8} {'command':>8} {'command':>8} {'max':>8} "
          f"{'missed':>7} {'solve':>8} {'solve':>8} {'handling':>8} {'late p99':>8} {'late':>8} {'roll':>6} "
          f"{'load 1 min':>12} {'gaps':>5} {'gc':>5} {'gc max':>7} {'child':>7} {'reads':>6}")
    print(f"{'(step: ms, wall clock)':<26} {'':>6} {'':>8} {'':>8} {'median':>8} {'p99':>8} {'':>8} {'ticks':>7} "
          f"{'median':>8} {'p99':>8} {'median':>8} {'':>8} {'max':>8} {'term':>6} {'':>12} {'(rec)':>5} "
          f"{'runs':>5} {'ms':>7} {'ms/step':>7} {'/step':>6}")
    for row in rows:
        print(figures(row))
    if args.parts:
        for row in rows:
            print_parts(row)


if __name__ == "__main__":
    main()
