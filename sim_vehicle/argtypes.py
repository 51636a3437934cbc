"""argparse types shared by the simulator's two command lines (`sim-vehicle` and `--json-backend`)."""

from __future__ import annotations

import argparse
import math

from vessel.argtypes import SEED_MAX, seed_number  # noqa: F401  (the one seed rule, re-exported)


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


def sea_state_number(text: str) -> int:
    """A NATO sea state number in [0, 8] (the paper's Table I)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"sea state must be an integer in [0, 8], got {text!r}") from None
    if not 0 <= value <= 8:
        raise argparse.ArgumentTypeError(f"sea state must be an integer in [0, 8], got {value}")
    return value


def parameter_names(text: str) -> frozenset[str]:
    """``NAME,NAME,...``: parameter names (upper case, 1-16 of A-Z, 0-9, _); whether each exists is checked once
    the parameter table is loaded."""
    names = [part.strip().upper() for part in text.split(",")]
    for name in names:
        if not (1 <= len(name) <= 16 and all(c.isupper() or c.isdigit() or c == "_" for c in name)):
            raise argparse.ArgumentTypeError(f"expected NAME,NAME,... of parameter names, got {text!r}")
    return frozenset(names)
