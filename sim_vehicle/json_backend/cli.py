"""Command line of ``sim-vehicle --json-backend [HOST:]PORT``: the world, the run folder, the UDP loop.

``sim-vehicle`` hands its whole argument list here when ``--json-backend`` is present, so the normal
simulator's parser stays as it is. Bad input gives one line on stderr and exit status 2.
"""

from __future__ import annotations

import argparse
import logging
import math
import secrets
import signal
import socket
import sys
from pathlib import Path
from typing import NoReturn

import numpy as np

from sim_vehicle.argtypes import finite_number, positive_seconds, sea_state_number, seed_number
from sim_vehicle.json_backend.backend import JsonBackend, open_socket, serve
from sim_vehicle.json_backend.log import JsonStateCsv, write_sea_record
from sim_vehicle.json_backend.model import JsonPhysics
from sim_vehicle.scenario import CURRENT_HELP, SEA_HELP, SEA_STATE_HELP, seeded_waves, sim_world
from vessel import OceanCurrent, WaveField
from vessel.argtypes import add_renamed
from vessel.config import ConfigError
from vessel.geo import Home
from vessel.sea.irregular import IrregularWaves
from vessel.sea.wind import Wind
from vessel.vessel_spec import VesselSpec
from vessel.world import SEA_PRESETS

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 9002
PREPARED_RATE_HZ = 400  # deploy/otter-json-sitl.parm's SIM_RATE_HZ: its plant is built before the first frame

log = logging.getLogger("sim_vehicle")


class _Parser(argparse.ArgumentParser):
    """argparse that reports errors in one line."""

    def error(self, message: str) -> NoReturn:
        """Print ``prog: error: message`` and exit 2."""
        self.exit(2, f"{self.prog}: error: {message}\n")


def parse_endpoint(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` -> (host, port); host defaults to 127.0.0.1, port must be in [1, 65535]."""
    host, _, port_text = text.rpartition(":")
    try:
        port = int(port_text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected [HOST:]PORT, got {text!r}") from None
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"port must be in [1, 65535], got {port}")
    if ":" in text and not host:
        raise argparse.ArgumentTypeError(f"empty host in {text!r}")
    return host or DEFAULT_HOST, port


def _heading(text: str) -> float:
    """An initial heading in [-360, 360] deg."""
    value = finite_number(text)
    if not -360.0 <= value <= 360.0:
        raise argparse.ArgumentTypeError(f"heading must be in [-360, 360] deg, got {text}")
    return value


def build_parser() -> argparse.ArgumentParser:
    """The parser of the JSON-backend mode (also documents every option)."""
    p = _Parser(prog="sim-vehicle --json-backend",
                description="Physics of the Otter for ArduPilot's JSON SITL (`--model JSON:HOST`): no MAVLink "
                            "of its own, the firmware speaks it.")
    p.add_argument("--json-backend", type=parse_endpoint, nargs="?", const=f"{DEFAULT_HOST}:{DEFAULT_PORT}",
                   default=f"{DEFAULT_HOST}:{DEFAULT_PORT}", metavar="[HOST:]PORT",
                   help=f"UDP address the firmware sends servo packets to (default {DEFAULT_HOST}:{DEFAULT_PORT}; "
                        "0.0.0.0:PORT for a firmware on another machine)")
    p.add_argument("--sea", metavar="NAME|SPEC", help=SEA_HELP)
    add_renamed(p, "--waves", "--sea", choices=tuple(SEA_PRESETS))
    p.add_argument("--sea-state", type=sea_state_number, metavar="N",
                   help=SEA_STATE_HELP)
    p.add_argument("--heave", choices=("surface", "paper"), default=None,
                   help="surface: the hull heaves with the sea; paper: the paper's model (default: surface in an "
                        "irregular sea, paper in a regular one, as the simulator with its ideal sensors)")
    p.add_argument("--current", metavar="SPEED,DIR", help=CURRENT_HELP)
    p.add_argument("--vessel", metavar="SET|FILE", help="the simulated boat's hull: a named set (published, "
                   "corrected) or a vessel YAML file (default: the scenario's vessel, else published)")
    p.add_argument("--scenario", type=Path, metavar="FILE",
                   help="scenario YAML: vessel parameter set, sea and start pose; --sea/--current override "
                        "(default: none)")
    p.add_argument("--heading", type=_heading, default=None, metavar="DEG",
                   help=f"initial heading, deg (default {Home().heading_deg:g}, the simulator's home heading)")
    p.add_argument("--seed", type=seed_number, default=None, metavar="N",
                   help="seed of the sea's phase origin (default: a fresh one, written to the run folder)")
    p.add_argument("--log-dir", type=Path, metavar="DIR",
                   help="write state.csv and sea.json here (default: none, no logs)")
    p.add_argument("--duration", type=positive_seconds, metavar="S",
                   help="stop after S s of physics time, S > 0 (default: none, run until SIGINT or SIGTERM)")
    p.add_argument("-v", "--verbose", action="store_true", help="log restarts and rate changes to stderr")
    return p


def build_world(args: argparse.Namespace) -> tuple[VesselSpec, WaveField, OceanCurrent, np.ndarray, Wind | None]:
    """(the plant's vessel, waves, current, x0) from the flags and the optional scenario, by ``sim-vehicle``'s route.

    An irregular sea is averaged over the waterplane of the world's vessel, as the simulator's
    (``sim_vehicle.physics.Physics.create``).
    """
    world = sim_world(args.scenario, args.sea, args.current, Home(), args.sea_state, args.vessel)
    x0 = world.plant_state()
    if args.heading is not None:
        x0[5] = math.radians(args.heading)
    return world.vessel, world.sea.waves(world.params()), world.sea.current(), x0, world.sea.wind()


def surface_heave(args: argparse.Namespace, waves: WaveField) -> bool:
    """--heave, else the simulator's default for ideal sensors: the hull heaves with an irregular sea only."""
    if args.heave is not None:
        return bool(args.heave == "surface")
    return isinstance(waves, IrregularWaves)


def _bind(host: str, port: int) -> socket.socket:
    """The backend's UDP socket, or a one-line ConfigError naming the address."""
    try:
        return open_socket(host, port)
    except OSError as exc:
        raise ConfigError(f"--json-backend: cannot bind UDP {host}:{port} ({exc.strerror or exc}); "
                          "is another physics backend or a stale SITL still running?") from None


def _run_folder(args: argparse.Namespace, seed: int, waves: WaveField, current: OceanCurrent, vessel: VesselSpec,
                x0: np.ndarray) -> JsonStateCsv | None:
    """sea.json and state.csv in --log-dir (a folder that already holds a run is refused, never overwritten)."""
    if args.log_dir is None:
        return None
    if args.log_dir.exists() and not args.log_dir.is_dir():
        raise ConfigError(f"--log-dir: {args.log_dir} is a file, not a folder")
    try:
        args.log_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"--log-dir: {args.log_dir}: cannot create the folder ({exc.strerror or exc})") from None
    earlier = [name for name in ("state.csv", "sea.json") if (args.log_dir / name).exists()]
    if earlier:
        raise ConfigError(f"--log-dir: {args.log_dir} already holds a run ({', '.join(earlier)}); "
                          "give an empty or new folder, runs are never overwritten")
    write_sea_record(args.log_dir / "sea.json", seed, waves, current, vessel, x0)
    return JsonStateCsv(args.log_dir / "state.csv", waves)


def _prepare(args: argparse.Namespace) -> tuple[JsonBackend, socket.socket]:
    """World, socket, then run folder (nothing is written when the port cannot be had); errors for the caller."""
    vessel, waves, current, x0, wind = build_world(args)
    seed = args.seed if args.seed is not None else secrets.randbits(32)
    waves = seeded_waves(waves, seed)
    host, port = args.json_backend
    sock = _bind(host, port)
    try:
        state_csv = _run_folder(args, seed, waves, current, vessel, x0)
    except (ConfigError, OSError):
        sock.close()
        raise
    heave = surface_heave(args, waves)
    if isinstance(waves, IrregularWaves):
        log.info("json-backend: compiling the irregular sea's plant for %d Hz frames (1-4 s)", PREPARED_RATE_HZ)
    physics = JsonPhysics(vessel.params(), waves, current, x0, heave, wind)
    physics.prepare(1.0 / PREPARED_RATE_HZ)
    log.info("json-backend: listening on UDP %s:%d, sea seed %d, heave %s", host, port, seed,
             "surface" if heave else "paper")
    return JsonBackend(physics, state_csv), sock


def main(argv: list[str]) -> int:
    """Run the backend until a signal or --duration; print a one-line summary at the end."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        format="sim-vehicle: %(message)s", stream=sys.stderr)
    try:
        backend, sock = _prepare(args)
    except ConfigError as exc:
        print(f"sim-vehicle: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"sim-vehicle: error: cannot write the run folder: {exc.strerror or exc}", file=sys.stderr)
        return 2
    flag = {"running": True}

    def stop(signum: int, frame: object) -> None:
        """SIGTERM/SIGINT: answer no more frames, then close the log."""
        flag["running"] = False

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    status = 0
    try:
        serve(backend, sock, lambda: flag["running"], args.duration)
    except FloatingPointError as exc:
        print(f"sim-vehicle: error: {exc}", file=sys.stderr)
        status = 1
    finally:
        sock.close()
        if backend.csv is not None:
            backend.csv.close()
        print(backend.stats.summary(backend.physics.time), file=sys.stderr)
    return status
