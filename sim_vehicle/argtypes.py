"""argparse types shared by the simulator's two command lines (`sim-vehicle` and `--json-backend`)."""

from __future__ import annotations

import argparse
import math

SEED_MAX = 2**32 - 1  # as the irregular seas' seeds


def seed_number(text: str) -> int:
    """A sea seed: a whole number in [0, 2^32 − 1]."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seed must be an integer in [0, {SEED_MAX}], got {text!r}") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"seed must be an integer in [0, {SEED_MAX}], got {value}")
    return value


def finite_number(text: str) -> float:
    """A finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def positive_seconds(text: str) -> float:
    """A positive duration in s (simulated or physics time)."""
    value = finite_number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"duration must be > 0 s, got {text}")
    return value
