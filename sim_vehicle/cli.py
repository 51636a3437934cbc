"""``sim-vehicle``: command line of the SITL boat; bad input gives one line on stderr and exit status 2."""

from __future__ import annotations

import argparse
import logging
import math
import secrets
import shutil
import signal
import sys
from pathlib import Path

from sim_vehicle import lockstep
from sim_vehicle.argtypes import SEED_MAX, parameter_names, positive_seconds, sea_state_number, seed_number
from sim_vehicle.cli_checks import check_outputs, check_params_store, check_serial, open_failure
from sim_vehicle.logs import fresh_log_dir
from sim_vehicle.mavlink.signing import store_signing_passphrase
from sim_vehicle.rover.params import ParamTable, is_param_name, read_parm
from sim_vehicle.scenario import CURRENT_HELP, SEA_HELP, SEA_STATE_HELP, sim_world
from sim_vehicle.sim import Options, Simulator
from vessel.argtypes import OneLineParser, add_renamed, add_version, naming
from vessel.config import ConfigError
from vessel.geo import Home, parse_home
from vessel.world import SEA_PRESETS, World

DEFAULT_STORE = Path("runs") / "sim_state" / "params.json"
DEFAULT_OUTPUTS = ["udp:127.0.0.1:14550", "udp:127.0.0.1:14551"]
NEGATIVE_VALUE_FLAGS = ("--home", "--sea", "--current", "--seed", "--sea-state")  # values may start with '-'


_Parser = OneLineParser  # one-line errors, exit 2 (vessel.argtypes: every console script's)


def _port(text: str) -> int:
    """A TCP/UDP port number in [1, 65535]."""
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port must be in [1, 65535], got {port}")
    return port


def _output(text: str) -> tuple[str, int]:
    """A ``udp:HOST:PORT`` output as (host, port)."""
    parts = text.split(":")
    if len(parts) != 3 or parts[0] != "udp" or not parts[1]:
        raise argparse.ArgumentTypeError(f"expected udp:HOST:PORT, got {text!r}")
    return parts[1], _port(parts[2])


def _serial(text: str) -> tuple[str, int | None]:
    """``DEVICE[,BAUD]`` as (device, baud or None)."""
    device, _, baud = text.partition(",")
    if not device:
        raise argparse.ArgumentTypeError(f"expected DEVICE[,BAUD], got {text!r}")
    if not baud:
        return device, None
    try:
        rate = int(baud)
    except ValueError:
        raise argparse.ArgumentTypeError(f"baud must be a whole number, got {baud!r}") from None
    if not 1200 <= rate <= 4_000_000:
        raise argparse.ArgumentTypeError(f"baud must be in [1200, 4000000], got {rate}")
    return device, rate


def _speedup(text: str) -> float:
    """A speed-up factor in [0, 1000]; 0 runs unpaced."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"speedup must be a finite number in [0, 1000], got {text}")
    if not 0 <= value <= 1000:
        raise argparse.ArgumentTypeError(
            f"speedup must be in [0, 1000] (0 = as fast as possible), got {text}"
        )
    return value


def _home(text: str) -> object:
    """``LAT,LON,ALT,HEADING`` as a Home."""
    try:
        return parse_home(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also documents every option)."""
    p = _Parser(prog="sim-vehicle", description="SITL Otter boat that speaks MAVLink like ArduPilot Rover.")
    add_version(p)
    p.add_argument("--tcp", type=_port, default=5760, metavar="PORT", help="TCP server port (default 5760)")
    p.add_argument("--no-tcp", action="store_true", help="no TCP server")
    p.add_argument(
        "--out",
        type=_output,
        action="append",
        metavar="udp:HOST:PORT",
        help="UDP output, repeatable (default udp:127.0.0.1:14550 and udp:127.0.0.1:14551)",
    )
    p.add_argument("--no-out", action="store_true", help="no UDP outputs")
    p.add_argument(
        "--serial",
        type=_serial,
        metavar="DEVICE[,BAUD]",
        help="also serve MAVLink on a serial device (a UART, USB adapter or /dev/pts/N) as SERIAL2: "
        "needs SERIAL2_PROTOCOL 1 or 2, stream rates SR2_*; BAUD in [1200, 4000000], else SERIAL2_BAUD's "
        "(default: none, no serial port)",
    )
    p.add_argument("--speedup", type=_speedup, default=1.0,
                   help="simulated/wall time ratio, [0, 1000]: 1 = real time, 0 = as fast as possible (default 1)")
    p.add_argument(
        "--home",
        type=_home,
        default=None,
        metavar="LAT,LON,ALT,HEADING",
        help="home position and initial heading (default ArduPilot's CMAC)",
    )
    p.add_argument(
        "--scenario",
        type=Path,
        metavar="FILE",
        help="scenario YAML: the plant's vessel, sea state and start pose (heading, offset from home, "
        "velocity); --sea/--current given too override its sea, --vessel its vessel (default: none)",
    )
    p.add_argument(
        "--vessel",
        metavar="SET|FILE",
        help="the simulated boat's hull: a named set (published, corrected) or a vessel YAML file {base, "
             "<OtterParameters field>: value} (default: the scenario's vessel, else published); the companion is "
             "never told it",
    )
    p.add_argument("--sea", metavar="NAME|SPEC", help=SEA_HELP)
    add_renamed(p, "--waves", "--sea", choices=tuple(SEA_PRESETS))
    p.add_argument("--sea-state", type=sea_state_number, metavar="N",
                   help=SEA_STATE_HELP)
    p.add_argument("--seed", type=seed_number, metavar="N",
                   help="seed of the sea's hidden phase origin and the sensor noise, integer in "
                        f"[0, {SEED_MAX}] (default: a fresh one each start, printed and written to sea.json)")
    p.add_argument("--sea-phase", choices=("hidden", "boot"), default="hidden",
                   help="hidden (default): phase origin drawn from --seed; boot: the sea as written, phase 0 at "
                        "boot (only for tests that compare with the in-process simulation truth)")
    p.add_argument("--ideal-sensors", action="store_true",
                   help="report the true state exactly (no SIM_* sensor noise, lag or GPS rate)")
    p.add_argument("--heave", choices=("surface", "paper"), default=None,
                   help="surface: the hull heaves with the sea; paper: the paper's model (default: paper with "
                        "--ideal-sensors in a regular sea, else surface)")
    p.add_argument(
        "--current", metavar="SPEED,DIR", help=CURRENT_HELP
    )
    p.add_argument("--params", type=Path, metavar="FILE", help=".parm file of default values (NAME VALUE)")
    p.add_argument(
        "--params-store",
        type=Path,
        default=DEFAULT_STORE,
        metavar="PATH",
        help=f"where parameter changes persist (default {DEFAULT_STORE}); missions go next to it",
    )
    p.add_argument("--wipe", action="store_true", help="forget stored parameters and missions first")
    p.add_argument("--hide-params", type=parameter_names, metavar="NAME,...",
                   help="serve these parameters as an autopilot whose firmware lacks them: not listed, a read or set "
                        "answered as for an unknown name (the simulation still uses their values; for tests); each "
                        "a parameter of this simulator (default: none)")
    p.add_argument("--no-param-error", action="store_true",
                   help="answer a read or set of an unknown parameter with nothing, as firmware before PARAM_ERROR "
                        "(default: PARAM_ERROR DOES_NOT_EXIST, as recent ArduPilot)")
    p.add_argument("--signing-passphrase", metavar="TEXT", help="MAVLink 2 signing on, key SHA-256(TEXT) as MAVProxy's "
                   "`signing setup` makes it, stored with the parameters (unsigned accepted only on the TCP port); "
                   "default: the key stored in --params-store (an earlier --signing-passphrase or SETUP_SIGNING), "
                   "else unsigned")
    p.add_argument("--log-dir", type=Path, metavar="DIR",
                   help="write sim_vehicle.tlog and state.csv here (default: none, no logs)")
    p.add_argument(
        "--no-rc-receiver",
        action="store_true",
        help="no simulated RC receiver: only overrides give RC (RC failsafe applies)",
    )
    p.add_argument("--duration", type=positive_seconds, metavar="S",
                   help="stop after S simulated seconds, S > 0 (default: none, run until SIGINT or SIGTERM)")
    p.add_argument(
        "--wait-for-client",
        action="store_true",
        help="hold simulated time at 0 until a client sends its first MAVLink message (as SITL waits for SERIAL0)",
    )
    lockstep.add_arguments(p)  # --lockstep, --lockstep-timeout, --lockstep-start
    p.add_argument("-v", "--verbose", action="store_true", help="log STATUSTEXT and connections to stderr")
    p.add_argument("--json-backend", nargs="?", metavar="[HOST:]PORT",
                   help="instead: physics only, for the real ArduPilot firmware (--model JSON:HOST), default "
                        "port 9002; options: sim-vehicle --json-backend --help")
    return p


def mission_store(params_store: Path) -> Path:
    """The mission file that lives next to the parameter store."""
    return params_store.with_name(params_store.stem + ".missions.json")


def _load_params(args: argparse.Namespace) -> ParamTable:
    """Defaults from the table, then the .parm file, then the store (unless wiped)."""
    if args.wipe:
        for path in (args.params_store, mission_store(args.params_store)):
            try:
                path.unlink(missing_ok=True)
            except OSError as exc:
                raise ConfigError(f"{path}: cannot wipe ({exc.strerror})") from None
    defaults: dict[str, float] = {}
    extra: dict[str, float] = {}
    if args.params is not None:
        probe = ParamTable()
        with naming("--params"):
            values = read_parm(args.params)
        for name, value in values.items():
            if name in probe:
                defaults[name] = value
            elif is_param_name(name):
                extra[name] = value
            else:
                print(
                    f"sim-vehicle: ignoring unknown parameter {name} in {args.params} "
                    "(not a name in any ArduPilot Rover parameter group)",
                    file=sys.stderr,
                )
        if extra:
            print(
                f"sim-vehicle: warning: {len(extra)} parameter(s) in {args.params} are stored and reported but "
                f"not simulated: {', '.join(sorted(extra))}",
                file=sys.stderr,
            )
    check_params_store(args.params_store)
    with naming("--params-store"):
        table = ParamTable(store=args.params_store, defaults=defaults, extra=extra)
    if (table["RCMAP_ROLL"], table["RCMAP_THROTTLE"]) != (1, 3):
        print("sim-vehicle: warning: RCMAP_ROLL/RCMAP_THROTTLE are reported but not simulated: the sticks are "
              "channels 1 and 3", file=sys.stderr)
    return table


def _join_negative_values(argv: list[str]) -> list[str]:
    """``--home -35.3,149.1,...`` as ``--home=-35.3,...``: argparse would take the value for an option."""
    joined: list[str] = []
    i = 0
    while i < len(argv):
        flag = argv[i]
        if flag in NEGATIVE_VALUE_FLAGS and i + 1 < len(argv) and argv[i + 1][:2].replace(".", "0") \
                in {f"-{d}" for d in "0123456789"}:
            joined.append(f"{flag}={argv[i + 1]}")
            i += 2
            continue
        joined.append(flag)
        i += 1
    return joined


def sea_and_sensor_options(args: argparse.Namespace, world: World) -> dict[str, object]:
    """Seed (fresh unless given), sensor mode and heave model from the flags (see ``--heave``'s default)."""
    seed = args.seed if args.seed is not None else secrets.randbits(32)
    irregular = world.sea.spectrum is not None
    heave = args.heave or ("paper" if args.ideal_sensors and not irregular else "surface")
    return {"seed": seed if args.sea_phase == "hidden" else None, "noise_seed": seed,
            "ideal_sensors": args.ideal_sensors, "surface_heave": heave == "surface"}


def announce_compiling(opts: Options) -> None:
    """Before an irregular sea's plant compiles (1–4 s, ``vessel.jit``): say so; simulated time starts after."""
    if opts.world.sea.spectrum is not None:
        print("sim-vehicle: compiling the irregular sea's plant (1-4 s); simulated time starts after",
              file=sys.stderr, flush=True)


def announce(opts: Options, startup_s: float) -> None:
    """The start line: sea, seed (or phase at boot), sensor mode, heave model, start-up time."""
    sea = opts.world.sea
    phase = f"seed {opts.seed}" if opts.seed is not None else f"phase origin at boot, noise seed {opts.noise_seed}"
    print(f"sim-vehicle: {sea.describe()}; {phase}; sensors {'ideal' if opts.ideal_sensors else 'realistic'}; "
          f"heave {'surface' if opts.surface_heave else 'paper'}; ready in {startup_s:.1f} s",
          file=sys.stderr, flush=True)
    links = [f"TCP {opts.tcp_port}" if opts.tcp_port is not None else "no TCP"]
    links += [f"UDP to {host}:{port}" for host, port in opts.outputs]
    links += [f"serial {opts.serial[0]}"] if opts.serial else []
    logs = f"logs in {opts.log_dir}" if opts.log_dir is not None else "no logs (--log-dir)"
    print(f"sim-vehicle: MAVLink on {', '.join(links)}; {logs}", file=sys.stderr, flush=True)


def _log_dir(path: Path) -> Path:
    """A fresh log folder (never an earlier run's); ConfigError naming --log-dir when it cannot be made."""
    try:
        return fresh_log_dir(path, lambda line: print(f"sim-vehicle: {line}", file=sys.stderr))
    except FileExistsError:
        raise ConfigError(f"--log-dir: {path} is a file, not a folder") from None
    except OSError as exc:
        raise ConfigError(f"--log-dir: {path}: cannot create the folder ({exc.strerror or exc})") from None


def main(argv: list[str] | None = None) -> int:
    """Parse the command line, build the simulator and run it until a signal or --duration."""
    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv))
    if any(a == "--json-backend" or a.startswith("--json-backend=") for a in argv):
        from sim_vehicle.json_backend.cli import main as json_backend_main  # its own mode with its own options

        return json_backend_main(argv)
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING,
        format="sim-vehicle: %(message)s",
        stream=sys.stderr,
    )
    try:
        home = args.home or Home()
        world = sim_world(args.scenario, args.sea, args.current, home, args.sea_state, args.vessel)  # before writing
        outputs = [] if args.no_out else (args.out or [_output(o) for o in DEFAULT_OUTPUTS])
        check_outputs(outputs)
        if args.serial is not None:
            check_serial(args.serial[0])
        params = _load_params(args)
        hidden = args.hide_params or frozenset()
        unknown = sorted(name for name in hidden if name not in params)
        if unknown:
            raise ConfigError(f"--hide-params: {', '.join(unknown)} is not a parameter of this simulator")
        if args.signing_passphrase is not None:
            store_signing_passphrase(params, args.signing_passphrase)
        if args.log_dir is not None:
            args.log_dir = _log_dir(args.log_dir)
            if shutil.disk_usage(args.log_dir).free < 1 << 20:
                raise ConfigError(f"{args.log_dir}: less than 1 MB free for logs")
        opts = Options(
            home=home,
            world=world,
            speedup=args.speedup,
            params=params,
            log_dir=args.log_dir,
            tcp_port=None if args.no_tcp else args.tcp,
            rc_receiver=not args.no_rc_receiver,
            outputs=outputs,
            duration_s=args.duration,
            mission_store=mission_store(args.params_store),
            serial=args.serial,
            wait_for_client=args.wait_for_client,
            **sea_and_sensor_options(args, world),
            lockstep_period_s=args.lockstep,
            lockstep_timeout_s=args.lockstep_timeout,
            lockstep_start_s=args.lockstep_start,
            hidden_params=hidden,
            param_errors=not args.no_param_error,
        )
        announce_compiling(opts)
        sim = Simulator(opts)
    except ConfigError as exc:
        print(f"sim-vehicle: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        tcp = None if args.no_tcp else ("0.0.0.0", args.tcp)
        print(f"sim-vehicle: error: {open_failure(exc, tcp, args.serial)}", file=sys.stderr)
        return 2

    def stop(signum: int, frame: object) -> None:
        """SIGTERM/SIGINT: finish the current step, then close logs and sockets."""
        sim.running = False

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    announce(opts, sim.startup_s)
    try:
        sim.run()
    except FloatingPointError as exc:
        print(f"sim-vehicle: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
