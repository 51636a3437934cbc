"""argparse types shared by every command line: positive finite quantities (argparse names the flag in front)."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def positive_quantity(what: str, unit: str) -> Callable[[str], float]:
    """An argparse type for a finite number > 0 of ``what`` (e.g. "a distance in metres"), unit ``unit``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what} > 0, got {text!r}") from None
        if not (math.isfinite(value) and value > 0):
            raise argparse.ArgumentTypeError(f"{text!r} is outside the allowed range: finite and > 0 {unit}")
        return value

    parse.__doc__ = f"{what} > 0 {unit}, finite (argparse type)"
    return parse


positive_metres = positive_quantity("a distance in metres", "m")
positive_seconds = positive_quantity("seconds", "s")


SEED_MAX = 2**32 - 1  # numpy's SeedSequence takes any; the simulator's seeds are 32-bit


def seed_number(text: str) -> int:
    """A random seed: a whole number in [0, 2^32 − 1] (argparse type)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number in [0, {SEED_MAX}], got {text!r}") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{value} is outside the allowed range [0, {SEED_MAX}]")
    return value
