"""`mission` command line: upload, download and clear the waypoint mission with MAVSDK."""

from __future__ import annotations

import argparse
import asyncio
import math
import sys
from collections.abc import Sequence
from pathlib import Path

from mission import transfer
from mission.files import check_output_file, read_mission_file, write_mission_file
from mission.plan import FRAME_GLOBAL, Mission, MissionError, MissionItem, check_latlon, check_range, validate
from vessel.addresses import check_device, check_network
from vessel.argtypes import OneLineParser, add_version, positive_metres
from vessel.config import ConfigError
from vessel.geo import DEFAULT_MAX_RANGE_M

EXIT_USAGE = 2
EXIT_FAILED = 1


# OneLineParser: one-line errors, exit 2; a bare command lists its subcommands (vessel.argtypes)


def _pair(text: str) -> tuple[float, float]:
    """Two finite numbers 'A,B'."""
    parts = text.split(",")
    try:
        a, b = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected two numbers 'A,B', got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise argparse.ArgumentTypeError(f"{text!r} has a non-finite number")
    return a, b


NETWORK_SCHEMES = ("udpin", "udpout", "tcpin", "tcpout", "udp", "tcp")  # MAVSDK's SCHEME://HOST:PORT forms
URL_FORMS = "udpin://HOST:PORT, udpout://HOST:PORT, tcpin://HOST:PORT, tcpout://HOST:PORT or serial:///dev/DEVICE:BAUD"


def _connection(text: str) -> str:
    """A MAVSDK connection URL (argparse type). pymavlink's ``udpin:HOST:PORT`` (the companion's form) is taken
    as MAVSDK's ``udpin://HOST:PORT``, so one string works for both commands."""
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, colon, rest = text.partition(":")
        if not (colon and scheme in NETWORK_SCHEMES):
            raise argparse.ArgumentTypeError(f"{text} is not a MAVSDK connection URL; expected {URL_FORMS}")
    if scheme == "serial" and rest:
        return text
    host, _, port = rest.rpartition(":")
    if scheme not in NETWORK_SCHEMES:
        raise argparse.ArgumentTypeError(f"{text}: unknown scheme {scheme}://; expected {URL_FORMS}")
    if not (port.isdigit() and 1 <= int(port) <= 65535) or not (host or scheme in ("udpin", "udp")):
        raise argparse.ArgumentTypeError(f"{text}: expected {scheme}://HOST:PORT with PORT in [1, 65535]")
    return f"{scheme}://{rest}"


URL_KINDS = {"udpin": "listen_udp", "udp": "listen_udp", "udpout": "send_udp", "tcpout": "tcp_client",
             "tcp": "tcp_client", "tcpin": "tcp_server"}  # MAVSDK's network schemes, as vessel.addresses names them


def check_reachable(url: str, timeout_s: float) -> None:
    """Before MAVSDK is asked (its complaints are raw lines, repeated, then a late exit): the URL's host resolves,
    a listening address is this machine's, a TCP vehicle accepts within ``timeout_s``, a serial device is there.
    A one-line MissionError naming --connect otherwise."""
    scheme, _, rest = url.partition("://")
    try:
        if scheme == "serial":
            device, _, baud = rest.rpartition(":")
            check_device(device if baud.isdigit() else rest, f"--connect: {url}")
            return
        host, _, port = rest.rpartition(":")
        check_network(URL_KINDS[scheme], host, int(port), f"--connect: {url}", min(timeout_s, 3.0))
    except ConfigError as exc:
        raise MissionError(str(exc)) from None


def build_parser() -> OneLineParser:
    """`mission upload|download|clear`."""
    parser = OneLineParser(prog="mission", description=__doc__)
    add_version(parser)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=OneLineParser)
    common = OneLineParser(add_help=False)
    common.add_argument("--connect", type=_connection, default=transfer.DEFAULT_URL,
                        help=f"MAVSDK connection URL (default {transfer.DEFAULT_URL}; udpin:HOST:PORT, pymavlink's "
                             "form, is taken as udpin://HOST:PORT)")
    common.add_argument("--timeout", type=float, default=10.0,
                        help="seconds to wait for the vehicle, (0, 600] (default 10)")
    up = sub.add_parser("upload", parents=[common], help="upload a waypoint mission")
    source = up.add_mutually_exclusive_group(required=True)
    source.add_argument("--waypoint", type=_pair, metavar="N,E",
                        help="one waypoint, metres north,east of home, within --max-range (one of --waypoint, "
                             "--latlon or FILE is required)")
    source.add_argument("--latlon", type=_pair, metavar="LAT,LON",
                        help="one waypoint in degrees, LAT in [-90, 90], LON in [-180, 180], within --max-range of "
                             "the vehicle's home (one of --waypoint, --latlon or FILE is required)")
    source.add_argument("file", nargs="?", help="a QGroundControl .plan or QGC WPL 110 .waypoints file")
    up.add_argument("--max-range", type=positive_metres, default=DEFAULT_MAX_RANGE_M, metavar="M",
                    help=f"refuse a waypoint farther than this from home (m, default {DEFAULT_MAX_RANGE_M:g}: the "
                         "companion's engage limit)")
    down = sub.add_parser("download", parents=[common], help="download the stored mission")
    down.add_argument("--out", metavar="FILE", help="write it as .plan or as QGC WPL 110 .waypoints, .txt or "
                                                    ".mission (by extension; default: none, printed only)")
    sub.add_parser("clear", parents=[common], help="clear the stored mission")
    return parser


def _print_mission(mission: Mission) -> None:
    """One line per item, home first."""
    print(f"  0 home      {mission.home.lat_deg:.7f} {mission.home.lon_deg:.7f} {mission.home.alt_m:.1f} m")
    for seq, item in enumerate(mission.items, start=1):
        print(f"  {seq} cmd {item.command:<4} {item.lat_deg:.7f} {item.lon_deg:.7f} {item.alt_m:.1f} m")


async def _run(args: argparse.Namespace) -> int:
    """Carry out the subcommand."""
    if args.command == "upload":
        if args.waypoint is not None:
            north, east = args.waypoint
            if not math.hypot(north, east) <= args.max_range:
                raise MissionError(f"--waypoint: {north:g},{east:g} is {math.hypot(north, east):g} m from home, "
                                   f"farther than --max-range {args.max_range:g} m")
            await transfer.upload_relative(north, east, args.connect, args.timeout)
            return 0
        if args.latlon is not None:
            lat, lon = args.latlon
            check_latlon(lat, lon, "--latlon")
            mission = check_range(await _with_vehicle_home(args, MissionItem(lat, lon, 0.0)), args.max_range,
                                  "--latlon")
        else:
            if Path(args.file).is_dir():
                raise MissionError(f"{args.file} is a folder; give a .plan or .waypoints file")
            mission = check_range(read_mission_file(args.file), args.max_range, args.file)
        await transfer.upload(mission, args.connect, args.timeout)
        return 0
    if args.command == "download":
        if args.out:
            check_output_file(args.out)  # before connecting: never download, then fail on the name
        mission = await transfer.download(args.connect, args.timeout)
        _print_mission(mission)
        if args.out:
            write_mission_file(mission, args.out)
            print(f"written to {args.out}")
        return 0
    await transfer.clear(args.connect, args.timeout)
    return 0


async def _with_vehicle_home(args: argparse.Namespace, item: MissionItem) -> Mission:
    """A one-waypoint mission whose seq 0 is the vehicle's current home."""
    async with transfer.connected_system(args.connect, args.timeout, print) as system:
        home = await transfer.vehicle_home(system, args.timeout)
    return validate(Mission(MissionItem(home.lat_deg, home.lon_deg, home.alt_m, frame=FRAME_GLOBAL), (item,)))


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the `mission` console script."""
    args = build_parser().parse_args(argv)
    if not (math.isfinite(args.timeout) and 0 < args.timeout <= 600):
        why = "is outside the allowed range" if math.isfinite(args.timeout) else "is not finite; allowed"
        print(f"mission {args.command}: error: --timeout: {args.timeout!r} {why} (0, 600] s", file=sys.stderr)
        return EXIT_USAGE
    try:
        check_reachable(args.connect, args.timeout)
        return asyncio.run(_run(args))
    except MissionError as exc:
        print(f"mission {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except transfer.TransferError as exc:
        print(f"mission {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except KeyboardInterrupt:
        print(f"mission {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
