"""How every command line says a count: "1 row", "2 rows", never "1 rows" or "row(s)". Here, in ``vessel`` (which
imports nothing of ours), so that the simulator, the companion and the mission tool all speak alike."""

from __future__ import annotations


def counted(n: int, singular: str, plural: str | None = None) -> str:
    """'1 waypoint', '0 waypoints', '2 control ticks': ``n`` and the noun in the number it takes (``plural``
    defaults to ``singular`` + "s"; the last word of a phrase is the one inflected)."""
    return f"{n} {singular if n == 1 else (plural or singular + 's')}"
