"""Argument types and loaders shared by the `mavbridge` subcommands (run, demo, check)."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from vessel.addresses import check_device, check_network
from vessel.argtypes import naming
from vessel.argtypes import positive_metres as positive_metres  # re-exported for the CLIs
from vessel.config import ConfigError, describe_range

DEFAULT_CONNECT = "udpin:0.0.0.0:14551"  # mirrors CompanionConfig's defaults (kept import-light: no pymavlink for
DEFAULT_BAUD, DEFAULT_SYSID, DEFAULT_COMPID = 921600, 255, 191  # --help); tests/system/test_help_text.py holds them


def from_config(name: str, fallback: str) -> str:
    """The default of a flag that overrides a companion YAML field: the --config file's, else the built-in one."""
    return f"default: the --config file's {name}, else {fallback}"


CONFIG_HELP = "default: none: the built-in settings, which suit the simulator"
CONNECT_HELP = ("pymavlink connection: udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT (PORT in [1, 65535]) or a "
                f"serial device such as /dev/ttyAMA0 ({from_config('connect', DEFAULT_CONNECT)})")
BAUD_HELP = f"serial baud rate, [1200, 4000000] ({from_config('baud', str(DEFAULT_BAUD))})"
REAL_TIME_SOLVER = "nrti"  # the default of run, check, demo and the service; ipopt (the paper's) only by name
SOLVER_HELP = (f"NMPC solver (default {REAL_TIME_SOLVER}, the real-time one, whatever the scenario file says; "
               "ipopt is the paper's reference: too slow for real time here)")


def refuse_form_without_guided(attitude_form: str | None, output: str) -> None:
    """--attitude-form given for an output that sends no attitude target: one line (ConfigError), not ignored."""
    if attitude_form is not None and output != "attitude_target":
        raise ConfigError(f"--attitude-form: applies to --output attitude_target only (the output here is {output})")


def parse_north_east(text: str) -> tuple[float, float]:
    """'N,E' metres as two finite numbers (argparse type)."""
    try:
        north, east = (float(p) for p in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'N,E' in metres, got {text!r}") from None
    if not (math.isfinite(north) and math.isfinite(east)):
        raise argparse.ArgumentTypeError(f"{text!r} has a non-finite number")
    return north, east


def whole_number(minimum: int) -> Callable[[str], int]:
    """An argparse type: a whole number >= ``minimum``, with a one-line error otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {value}")
        return value

    return parse


count = whole_number(0)
positive = whole_number(1)


def single_scenario(path: str | None, solver: str | None, model: Any = None, given: Any = None) -> Any:
    """The one run a --scenario file defines (default: the paper's Balanced run, or ``given``), with --solver
    applied, and the companion's ``model`` (its config's, a ``VesselSpec``) over the scenario's ``controller.model``
    when given."""
    from mavbridge.lab.scenario import Scenario, load_scenarios

    if given is not None:
        scenario = given
    elif path:
        with naming("--scenario"):
            scenarios = load_scenarios(path)
        if len(scenarios) != 1:
            raise ConfigError(f"--scenario: {path} defines {len(scenarios)} runs; give a single-run scenario")
        scenario = scenarios[0]
    else:
        scenario = Scenario(name="balanced")
    if solver:
        scenario = dataclasses.replace(scenario, controller=scenario.controller.replace(solver=solver))
    if model is not None:
        scenario = dataclasses.replace(scenario, controller=scenario.controller.replace(model=model))
    return scenario


NETWORK_FORMS = ("udpin", "udpout", "udp", "udpbcast", "tcp", "tcpin")  # pymavlink's PREFIX:HOST:PORT forms
OTHER_FORMS = ("mcast", "uds", "unix", "ws", "wss", "wsserver", "csv")  # pymavlink's other PREFIX: forms: its own
CONNECT_FORMS = "udpin:HOST:PORT, udpout:HOST:PORT, tcp:HOST:PORT or a serial device such as /dev/ttyAMA0"


def check_connection(url: str, flag: str) -> None:
    """A pymavlink connection string the companion can open: [PREFIX:]HOST:PORT with a port in [1, 65535] (a bare
    HOST:PORT listens on UDP, as pymavlink takes it), pymavlink's other PREFIX: forms (left to it), or a serial
    device that exists (``DEVICE[,BAUD]``); a one-line ConfigError naming ``flag`` otherwise."""
    if "://" in url:
        raise ConfigError(f"{flag}: {url} is MAVSDK's form (the `mission` command's); the companion speaks "
                          f"pymavlink's: {CONNECT_FORMS}")
    prefix, colon, rest = url.partition(":")
    if colon and prefix in OTHER_FORMS:  # multicast, Unix sockets, websockets: pymavlink checks them itself
        return
    if colon and prefix in NETWORK_FORMS:
        host, _, port = rest.rpartition(":")
        if not (port.isdigit() and 1 <= int(port) <= 65535) or not (host or prefix in ("udpin", "udp")):
            raise ConfigError(f"{flag}: {url}: expected {prefix}:HOST:PORT with PORT in [1, 65535]")
        return
    if colon and "/" not in prefix and not Path(url).exists():  # pymavlink opens a bare HOST:PORT as udpin
        host, _, port = url.rpartition(":")
        if not (port.isdigit() and 1 <= int(port) <= 65535) or not host:
            raise ConfigError(f"{flag}: {url}: expected HOST:PORT (listening UDP, as udpin:HOST:PORT) with PORT "
                              f"in [1, 65535], or {CONNECT_FORMS}")
        return
    device = url if Path(url).exists() or "," not in url else url.rpartition(",")[0]
    if not Path(device).exists():
        raise ConfigError(f"{flag}: {url}: no such serial device; expected {CONNECT_FORMS}")


LINK_KINDS = {"udpin": "listen_udp", "udp": "listen_udp", "udpout": "send_udp", "udpbcast": "send_udp",
              "tcp": "tcp_client", "tcpin": "tcp_server"}  # pymavlink's network forms, in vessel.addresses' words


def check_reachable(url: str, flag: str) -> None:
    """Before anything is built or a run folder made: a connection string that passed :func:`check_connection`
    can be opened here, one line naming ``flag`` otherwise (vessel.addresses): its host resolves, a listening
    address is this machine's, a TCP autopilot accepts, a serial device is there. pymavlink's other forms are
    left to it."""
    prefix, colon, rest = url.partition(":")
    if colon and prefix in OTHER_FORMS:
        return
    if not (colon and prefix in LINK_KINDS):
        if not colon or "/" in prefix or Path(url).exists():  # a serial device, with or without its baud
            check_device(url if Path(url).exists() or "," not in url else url.rpartition(",")[0], f"{flag}: {url}")
            return
        prefix, rest = "udpin", url  # a bare HOST:PORT: pymavlink listens on UDP
    host, _, port = rest.rpartition(":")
    check_network(LINK_KINDS[prefix], host, int(port), f"{flag}: {url}")


def config_from_flags(path: str | None, flags: Mapping[str, tuple[str, Any]]) -> Any:
    """The companion YAML (or the defaults) with the flags given on top: ``flags`` maps a CompanionConfig field
    to (flag, value or None). A bad flag is reported as the flag ("--sysid: 300 is outside the allowed range
    [1, 255]", NaN as not finite), a bad file as --config and the file's field; the connection string is
    checked too (see :func:`check_connection`)."""
    from mavbridge.companion.config import CompanionConfig, load_companion_config

    meta = {field.name: field.metadata for field in dataclasses.fields(CompanionConfig)}
    given = {name: value for name, (_, value) in flags.items() if value is not None}
    for name, value in given.items():  # each flag alone first, so that its error names the flag
        flag = flags[name][0]
        if isinstance(value, float) and not math.isfinite(value):
            raise ConfigError(f"{flag}: {value} is not finite; allowed {describe_range(meta[name])}")
        try:
            load_companion_config(None, **{name: value})
        except ConfigError as exc:
            raise ConfigError(f"{flag}: {str(exc).partition(': ')[2] or exc}") from None
    with naming("--config"):
        config = load_companion_config(path, **given)
    flag = "--connect" if "connect" in given else f"--config {path}: connect"
    check_connection(config.connect, flag)
    check_reachable(config.connect, flag)
    return config


def link_flags(args: argparse.Namespace) -> dict[str, tuple[str, Any]]:
    """The CompanionConfig fields of the flags `run` and `check` share, as :func:`config_from_flags` takes them."""
    return {"connect": ("--connect", args.connect), "baud": ("--baud", args.baud),
            "system_id": ("--sysid", args.sysid), "component_id": ("--compid", args.compid),
            "command_timeout_s": ("--command-timeout", args.command_timeout),
            "command_retries": ("--command-retries", args.command_retries),
            "param_budget_s": ("--param-budget", args.param_budget),
            "signing_passphrase_file": ("--signing-passphrase-file", args.signing_passphrase_file)}


def model_line(scenario: Any) -> str:
    """What `run` and `check` say of the hull they fly: the controller's model, never the boat's."""
    return (f"model: {scenario.controller.model} (the hull the NMPC predicts with; the boat's own is not known: "
            f"current and steady loads are estimated in flight)")
