"""Argument types and loaders shared by the `mavbridge` subcommands (run, demo, check)."""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections.abc import Callable
from typing import Any

from vessel.argtypes import positive_metres as positive_metres  # re-exported for the CLIs
from vessel.config import ConfigError

OUTPUTS = ("rc_override", "attitude_target")  # mirrors mavbridge.companion (kept import-light)
REAL_TIME_SOLVER = "asrti"  # the default of run, check, demo and the service; ipopt (the paper's) only by name
SOLVER_HELP = (f"NMPC solver (default {REAL_TIME_SOLVER}, the real-time one, whatever the scenario file says; "
               "ipopt is the paper's reference: too slow for real time here)")
WAVE_SOURCES = ("estimated", "scenario")  # estimated from the boat's motion, or the scenario's sea (simulation)


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


def single_scenario(path: str | None, solver: str | None) -> Any:
    """The one run a --scenario file defines (default: the paper's Balanced run), with --solver applied."""
    from .scenario import Scenario, load_scenarios

    if path:
        scenarios = load_scenarios(path)
        if len(scenarios) != 1:
            raise ConfigError(f"--scenario: {path} defines {len(scenarios)} runs; give a single-run scenario")
        scenario = scenarios[0]
    else:
        scenario = Scenario(name="balanced")
    if solver:
        scenario = dataclasses.replace(scenario, controller=scenario.controller.replace(solver=solver))
    return scenario
