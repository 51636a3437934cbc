"""The `mavbridge run` and `mavbridge demo` subcommands (argument parsing and dispatch)."""

from __future__ import annotations

import argparse
import dataclasses
import gc
import math
import subprocess
from pathlib import Path
from typing import Any

from mavbridge.cli.args import (
    BAUD_HELP,
    CONFIG_HELP,
    CONNECT_HELP,
    DEFAULT_COMPID,
    DEFAULT_SYSID,
    REAL_TIME_SOLVER,
    SOLVER_HELP,
    config_from_flags,
    from_config,
    link_flags,
    model_line,
    parse_north_east,
    positive_metres,
    refuse_form_without_guided,
    single_scenario,
)
from mavbridge.companion.choices import OUTPUTS, WAVE_SOURCES
from mavbridge.companion.outputs import ATTITUDE_FORMS
from mavbridge.link.signing import add_link_arguments
from mavbridge.nmpc.config import SOLVERS
from vessel.argtypes import add_renamed, seed_number
from vessel.config import ConfigError
from vessel.geo import DEFAULT_MAX_RANGE_M

# The demo's simulation speed with a real-time solver: at 10 the simulator, the companion's loop and its background
# preparation saturate a 2-core machine (2–10 % of the ticks skipped, a fifth of the steps on the late fallback);
# at 5 none were skipped (2026-12-05, `mavbridge demo`, both paths)
DEMO_SPEEDUP = 5.0
LOCKSTEP_WAIT_S = 5.0  # lockstep: the simulator waits, and so may the step for the estimator's process (paced: never)
DEMO_ENGAGE_AFTER_S = 30.0  # the demo's pilot engages this long after the companion connects (issue 29)
ATTITUDE_FORM_HELP = ("attitude_target: tau (default: the rate and speed targets that give the plan's steering and "
                      "throttle through Rover's loops, their gains read at start, closed on SERVO_OUTPUT_RAW), the "
                      "plan's body yaw rate (rate: the rate loop only), or its heading (Rover's heading P loop, "
                      "then its rate loop)")


SOURCE_NAMES = (*WAVE_SOURCES, "truth")  # truth: `mavbridge experiment`'s name for the scenario's sea


def companion_source(name: str | None) -> str | None:
    """The companion's name for a --wave-source value (truth, as the experiment says it, is its scenario)."""
    return "scenario" if name == "truth" else name


def _speedup(text: str) -> float:
    """A speedup in (0, 100]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number in (0, 100], got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text} is not finite; allowed (0, 100]")
    if not 0 < value <= 100:
        raise argparse.ArgumentTypeError(f"{text!r} is outside the allowed range (0, 100]")
    return value


def add_run_parser(sub: Any) -> None:
    """`mavbridge run`: the companion process."""
    run = sub.add_parser("run", help="fly the roll-aware NMPC over MAVLink (the companion process)",
                         description="Connect to an ArduPilot Rover, take the waypoint from its mission, and "
                                     "command it with the NMPC while it is armed in the configured mode.")
    run.add_argument("--config", help=f"companion YAML (connection, ids, output, timeouts); flags override it "
                                      f"({CONFIG_HELP})")
    run.add_argument("--connect", help=CONNECT_HELP)
    run.add_argument("--baud", type=int, help=BAUD_HELP)
    run.add_argument("--sysid", type=int,
                     help=f"our system id, [1, 255] ({from_config('system_id', str(DEFAULT_SYSID))} = ArduPilot's "
                          "SYSID_MYGCS)")
    run.add_argument("--compid", type=int,
                     help=f"our component id, [1, 255] ({from_config('component_id', str(DEFAULT_COMPID))}, onboard "
                          "computer)")
    run.add_argument("--output", choices=OUTPUTS, help=f"rc_override (MANUAL) or attitude_target (GUIDED) "
                                                       f"({from_config('output', 'rc_override')})")
    run.add_argument("--attitude-form", choices=ATTITUDE_FORMS, help=ATTITUDE_FORM_HELP)
    run.add_argument("--scenario", help="scenario YAML for controller, vessel and sea (default: the paper's "
                                        "Balanced run)")
    run.add_argument("--solver", choices=SOLVERS, default=REAL_TIME_SOLVER, help=SOLVER_HELP)
    run.add_argument("--wave-source", choices=SOURCE_NAMES,
                     help="where the NMPC's waves come from: estimated (default, or the YAML's waves: from the boat's "
                          "own motion) or scenario (the scenario's sea: simulation truth only; truth, as `mavbridge "
                          "experiment` says it, is the same). --waves is its old name")
    add_renamed(run, "--waves", "--wave-source", choices=SOURCE_NAMES)
    run.add_argument("--waypoint", type=parse_north_east, metavar="N,E",
                     help="waypoint in metres north,east of home, within --max-range (testing; default: the "
                          "autopilot's mission)")
    run.add_argument("--max-range", type=positive_metres, metavar="M",
                     help=f"never engage on a waypoint farther than this from home or the boat (m, default "
                          f"{DEFAULT_MAX_RANGE_M:g}, the limit of `mavbridge check` and `mission upload`)")
    run.add_argument("--arm", action="store_true", help="arm the vehicle at start")
    run.add_argument("--engage-after", type=float, metavar="S",
                     help="with --set-mode/--arm: switch and arm S seconds (autopilot time, 0..3600) after connecting, "
                          "as a pilot would once the boat is ready; the wave estimator watches the sea meanwhile "
                          "(default 0: as soon as the start is done)")
    run.add_argument("--set-mode", action="store_true", help="switch to the output's mode at start")
    run.add_argument("--dry-run", action="store_true", help="compute and log commands, send none")
    run.add_argument("--max-time", type=float, help=f"stop after this many seconds engaged (autopilot time), "
                                                    f"[0.1, 1e6] s ({from_config('max_time_s', 'no limit')})")
    run.add_argument("--out", help="run folder for tlog, CSV and metrics (default runs/companion-<time>)")
    run.add_argument("--lockstep", action="store_true", default=None,
                     help="simulation only, against sim-vehicle --lockstep: wait for each solve fully, no "
                          "wall-clock deadline (reproducible runs; never on a real boat)")
    run.add_argument("--start-at", type=float, metavar="S",
                     help=f"command from this autopilot time on, not before: comparable runs start in the same "
                          f"world; [0, 1e6] s ({from_config('start_at_s', 'none: from the first step')})")
    run.add_argument("--delay-compensation", action=argparse.BooleanOptionalAction, default=None,
                     help="predict the state over the link's measured delay before planning (default on; "
                          "--no-delay-compensation acts on the state as received, for comparison)")
    run.add_argument("--realtime", action=argparse.BooleanOptionalAction, default=None,
                     help="SCHED_FIFO scheduling (the YAML's realtime_priority, default 10), locked memory and an "
                          "isolated CPU where the system allows; one line says what it got and what it fell back "
                          "to, never fatal (default off, or the YAML's realtime)")
    run.add_argument("--identify", action="store_true",
                     help="fly the identification sequence (throttle steps, a 20/20 zig-zag, hard turns released) "
                          "around where the boat is, no waypoint, for `mavbridge identify`; RC override only, within "
                          "--max-range of where it starts (docs/how-to/identify.md)")
    add_link_arguments(run)


def add_demo_parser(sub: Any) -> None:
    """`mavbridge demo`: simulator + mission upload + companion, one command."""
    demo = sub.add_parser("demo", help="the whole system: sim-vehicle + mission upload + mavbridge run",
                          description="Start the simulator in the paper's waves and the companion side by side "
                                      "over UDP, upload the waypoint with MAVSDK, fly there, print the figures.")
    demo.add_argument("--speedup", type=_speedup, default=None,
                      help=f"simulation speed (default: {DEMO_SPEEDUP:g}, or 1 with the ipopt solver)")
    demo.add_argument("--solver", choices=SOLVERS, default=REAL_TIME_SOLVER, help=SOLVER_HELP)
    demo.add_argument("--output", choices=OUTPUTS, default="rc_override",
                      help="the companion's output: rc_override (MANUAL, the default) or attitude_target (GUIDED)")
    demo.add_argument("--attitude-form", choices=ATTITUDE_FORMS, help=ATTITUDE_FORM_HELP)
    demo.add_argument("--sim-params", metavar="FILE", help="a .parm file of the simulator's defaults (e.g. "
                      "deploy/otter-guided-tau.parm for --attitude-form tau)")
    demo.add_argument("--scenario", help="scenario YAML (default: the paper's Balanced run)")
    demo.add_argument("--wave-source", choices=SOURCE_NAMES, default="estimated",
                      help="where the companion's waves come from: estimated (default) or scenario (fly on the "
                           "simulator's truth; truth is the same). --waves is its old name")
    add_renamed(demo, "--waves", "--wave-source", choices=SOURCE_NAMES)
    demo.add_argument("--out", help="run folder (default runs/demo-<time>)")
    demo.add_argument("--lockstep", action="store_true", help="simulator and companion in lockstep, commanding "
                                                              "from a fixed autopilot time: a reproducible run")
    demo.add_argument("--seed", type=seed_number, default=None, metavar="N",
                      help="the simulator's seed (hidden wave phase, sensor noise), whole number in [0, 2^32-1]; "
                           "default a fresh one, printed in sim.log. With --lockstep the same seed gives the same run")
    demo.add_argument("--engage-after", type=float, default=DEMO_ENGAGE_AFTER_S, metavar="S",
                      help=f"the companion switches the mode and arms S seconds (autopilot time, 0..3600) after "
                           f"connecting, as a pilot would; the estimator watches the drifting boat meanwhile "
                           f"(default {DEMO_ENGAGE_AFTER_S:g}; with --lockstep the fixed start decides)")
    demo.add_argument("--direct", action="store_true",
                      help="fly the scenario with R = 0 (the paper's Direct: no roll term), for a comparison pair")


def run_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge run`."""
    import time

    from mavbridge.companion.flight import Companion, build_nmpc, ready_for_loop
    from mavbridge.companion.wave_gate import make_wave_source
    from mavbridge.lab.runlog import fresh_run_folder
    from mavbridge.link.port_guard import refuse_if_taken

    if args.dry_run and (args.arm or args.set_mode):
        raise ConfigError("--dry-run sends nothing: it cannot be combined with --arm or --set-mode")
    config = config_from_flags(args.config, {
        **link_flags(args), "output": ("--output", args.output), "max_time_s": ("--max-time", args.max_time),
        "waves": ("--wave-source", companion_source(args.wave_source)), "lockstep": ("--lockstep", args.lockstep),
        "start_at_s": ("--start-at", args.start_at), "max_range_m": ("--max-range", args.max_range),
        "engage_after_s": ("--engage-after", args.engage_after),
        "delay_compensation": ("--delay-compensation", args.delay_compensation),
        "attitude_form": ("--attitude-form", args.attitude_form), "realtime": ("--realtime", args.realtime)})
    refuse_form_without_guided(args.attitude_form, config.output)
    if args.identify:
        refuse_for_identify(args, config.output)
    config.signing_key()  # a missing or empty passphrase file: one line, exit 2, before the NMPC is built
    if args.waypoint is not None and not math.hypot(*args.waypoint) <= config.max_range_m:
        raise ConfigError(f"--waypoint: {args.waypoint[0]:g},{args.waypoint[1]:g} is {math.hypot(*args.waypoint):g} m "
                          f"from home, farther than --max-range {config.max_range_m:g} m")
    refuse_if_taken(config.connect)  # before seconds of building: a second companion on a port stops at once
    scenario = single_scenario(args.scenario, args.solver, config.model)
    out = fresh_run_folder(Path(args.out) if args.out else Path("runs") / time.strftime("companion-%Y%m%d-%H%M%S"))
    print(model_line(scenario), flush=True)
    waves = make_wave_source(config.waves, scenario.sea.waves, config.wave_roll_sign, config.wave_position_lag_s,
                             scenario.model_params(), process=config.estimator_process,
                             wait_s=LOCKSTEP_WAIT_S if config.lockstep else 0.0)
    try:
        with build_nmpc(scenario, waves, config.lockstep) as nmpc:  # seconds of building, before any link is open
            if config.realtime:  # after the building (its compiler runs are not real-time), before the link
                realtime_for(config, waves)
            ready_for_loop()  # the loop first to the interpreter; what is built left out of the collector's passes
            flight = identify_companion() if args.identify else Companion
            return flight(config, scenario, out, nmpc, waves, args.waypoint, args.arm, args.set_mode,
                          args.dry_run).run()
    finally:
        gc.unfreeze()  # the loop is over (see ready_for_loop): the interpreter ends as before, collecting all
        close_source(waves)


def refuse_for_identify(args: argparse.Namespace, output: str) -> None:
    """--identify flies the RC override path around where the boat is: one line (exit 2) otherwise."""
    if output != "rc_override":
        raise ConfigError(f"--identify: flies the RC override path only (MANUAL), not --output {output}")
    if args.waypoint is not None:
        raise ConfigError("--identify: flies around where the boat is; it takes no --waypoint")


def identify_companion() -> Any:
    """The companion that flies the identification sequence (``mavbridge.companion.identify_run``)."""
    from mavbridge.companion.identify_run.flight import IdentifyCompanion

    return IdentifyCompanion


def close_source(waves: Any) -> None:
    """End the estimator's process, if the wave source has one; a failure there is said, never the run's result."""
    try:
        getattr(waves, "close", lambda: None)()
    except (OSError, subprocess.SubprocessError) as exc:
        print(f"mavbridge run: the wave estimator's process did not end cleanly: {exc}", flush=True)


def realtime_for(config: Any, waves: Any) -> None:
    """The real-time settings for the companion and, one priority below it, the estimator's process (above every
    normal process, never ahead of the control step: at priority 1 there is none below, and it stays as it is);
    one line each."""
    from mavbridge.cli.realtime import apply_realtime

    print(apply_realtime(config.realtime_priority).line(), flush=True)
    line = realtime_for_estimator(waves, config.realtime_priority)
    if line is not None:
        print(line, flush=True)


def realtime_for_estimator(waves: Any, priority: int) -> str | None:
    """The real-time settings one priority below ``priority`` for the estimator's process, applied by that process
    itself (locked memory is a process's own), and the line saying what it got; None without such a process."""
    from mavbridge.cli.realtime import apply_realtime

    if not hasattr(waves, "call"):
        return None
    if priority < 2:
        return ("wave estimator's process: realtime: fell back: SCHED_OTHER (realtime_priority 1 leaves no priority "
                "below the control step's)")
    got = waves.call(apply_realtime, priority - 1)
    return f"wave estimator's process: {got.line() if hasattr(got, 'line') else f'realtime: no answer ({got})'}"


def demo_scenario(path: str | None, solver: str | None, direct: bool) -> Any:
    """The demo's one scenario (default the paper's Balanced run); ``direct``: the same with R = 0."""
    scenario = single_scenario(path, solver)
    if direct:
        scenario = dataclasses.replace(scenario, name=f"{scenario.name}-direct",
                                       controller=scenario.controller.replace(r=0.0))
    return scenario


def demo_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge demo`."""
    from mavbridge.lab.demo import run_demo, timestamped_folder

    refuse_form_without_guided(args.attitude_form, args.output)
    scenario = demo_scenario(args.scenario, args.solver, args.direct)
    speedup = args.speedup or (1.0 if scenario.controller.solver == "ipopt" else DEMO_SPEEDUP)
    out = Path(args.out) if args.out else timestamped_folder()
    if args.sim_params and not Path(args.sim_params).is_file():
        raise ConfigError(f"--sim-params: {args.sim_params} is not a readable file")
    if not math.isfinite(args.engage_after):
        raise ConfigError(f"--engage-after: {args.engage_after:g} is not finite; allowed [0, 3600] s")
    if not 0.0 <= args.engage_after <= 3600.0:
        raise ConfigError(f"--engage-after: {args.engage_after:g} is outside the allowed range [0, 3600] s")
    return run_demo(scenario, out, speedup, args.output, companion_source(args.wave_source), args.lockstep, args.seed,
                    args.attitude_form, args.sim_params, None if args.lockstep else args.engage_after)
