"""The command line of `mavbridge identify` (argument parsing and dispatch)."""

from __future__ import annotations

import argparse
import shlex
from typing import Any


def add_identify_parser(sub: Any) -> None:
    """`mavbridge identify`: a model of the boat from a trial's logs."""
    parser = sub.add_parser(
        "identify", help="identify the boat (roll/pitch period and damping, surge speed, Nomoto K and T) from logs",
        description="Read MAVLink .tlogs, ArduPilot DataFlash .bin/.log and Otter API .csv logs of one boat; "
                    "identify what they show, each with an interval and a fit figure, and say what they cannot; "
                    "write DIR/identify.json, DIR/vessel.yaml (a vessel mapping) and DIR/identify.html.")
    parser.add_argument("log", nargs="+", metavar="LOG", help="the logs of one boat (one or more files)")
    parser.add_argument("--out", metavar="DIR", help="folder for identify.json, vessel.yaml and identify.html "
                                                     "(default runs/identify-<time>; a folder that already holds "
                                                     "them is refused, never overwritten)")
    parser.add_argument("--base", default="published", metavar="published|corrected|FILE",
                        help="the model the identified fields change: published (default), corrected, or a vessel "
                             "YAML file (base plus fields)")


def identify_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge identify`."""
    from mavbridge.identify.run import identify_command as run

    words = ["mavbridge", "identify", *args.log]
    if args.out:
        words += ["--out", args.out]
    if args.base != "published":
        words += ["--base", args.base]
    return run(args.log, args.out, args.base, " ".join(shlex.quote(w) for w in words))
