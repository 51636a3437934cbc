"""`mavbridge signing setup`: give an autopilot a signing key from a passphrase (the field procedure).

Sends SETUP_SIGNING (no reply exists for it; sent three times for a lossy link), then listens with the
key: a HEARTBEAT signed with it proves the autopilot took it. ArduPilot refuses SETUP_SIGNING while
armed. Connect through a port that accepts unsigned packets (USB/SERIAL0, SITL's TCP 5760) when the
autopilot already has another key.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from mavbridge.cli.args import BAUD_HELP, CONFIG_HELP, CONNECT_HELP
from vessel.config import ConfigError

SENDS = 3
VERIFY_S = 5.0


def add_signing_parser(sub: Any) -> None:
    """`mavbridge signing setup`."""
    signing = sub.add_parser("signing", help="MAVLink 2 signing: set an autopilot's key from a passphrase",
                             description="MAVLink 2 signing for the companion's link (key = SHA-256 of the "
                                         "passphrase, as MAVProxy's `signing setup`).")
    actions = signing.add_subparsers(dest="signing_command", required=True, parser_class=type(signing))
    setup = actions.add_parser("setup", help="send SETUP_SIGNING to the autopilot and check that it signs",
                               description="Send SETUP_SIGNING with the key from the passphrase file, then "
                                           "check that the autopilot's heartbeats arrive signed with it.")
    setup.add_argument("--config", help=f"companion YAML (connection, ids, signing_passphrase_file; {CONFIG_HELP})")
    setup.add_argument("--connect", help=f"{CONNECT_HELP}; tcp:HOST:5760 or USB reach an unsigned port")
    setup.add_argument("--baud", type=int, help=BAUD_HELP)
    setup.add_argument("--signing-passphrase-file", metavar="FILE",
                       help="the passphrase (first line of FILE; default: the --config file's signing_passphrase_file: "
                            "one of them is required)")
    setup.add_argument("--timeout", type=float, default=30.0, help="wait this long for the autopilot, (0, 600] s "
                                                                   "(default 30)")


def signing_command(args: argparse.Namespace) -> int:
    """Carry out `mavbridge signing setup`: 0 once the autopilot signs with the key, 1 if it does not."""
    from mavbridge.cli.args import config_from_flags
    from mavbridge.link.connection import Link, LinkError
    from mavbridge.link.retry import RetrySettings
    from mavbridge.link.signing import sign_link, ticks_now

    if not math.isfinite(args.timeout):
        raise ConfigError(f"--timeout: {args.timeout:g} is not finite; allowed (0, 600] s")
    if not 0 < args.timeout <= 600:
        raise ConfigError(f"--timeout: {args.timeout:g} is outside the allowed range (0, 600] s")
    config = config_from_flags(args.config, {
        "connect": ("--connect", args.connect), "baud": ("--baud", args.baud),
        "signing_passphrase_file": ("--signing-passphrase-file", args.signing_passphrase_file)})
    key = config.signing_key()
    if key is None:
        raise ConfigError("--signing-passphrase-file: needed (or signing_passphrase_file in the --config YAML)")
    try:
        link = Link(config.connect, config.system_id, config.component_id, None, config.baud,
                    RetrySettings(config.command_timeout_s, config.command_retries))  # unsigned until sent
    except LinkError as exc:
        print(f"mavbridge signing: error: {exc}")
        return 1
    try:
        sysid, compid = link.wait_autopilot(args.timeout)
        for _ in range(SENDS):
            link.send("setup_signing", sysid, compid, list(key), ticks_now())
            link.wait_for(lambda m: False, 0.3)
        sign_link(link.conn, key)
        signed = link.wait_for(lambda m: m.get_type() == "HEARTBEAT", VERIFY_S)
    except LinkError as exc:
        print(f"mavbridge signing: error: {exc}")
        return 1
    finally:
        link.close()
    if signed is None:
        print(f"mavbridge signing: the autopilot {sysid}/{compid} did not start signing with the key from "
              f"{config.signing_passphrase_file} (armed? SETUP_SIGNING is refused while armed)")
        return 1
    print(f"mavbridge signing: autopilot {sysid}/{compid} signs with the key from {config.signing_passphrase_file}; "
          "give the companion the same file (signing_passphrase_file)")
    return 0
