"""Run folders that never hold an earlier run: one rule for the simulator's logs and the companion's runs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path


def fresh_folder(path: Path, flag: str, say: Callable[[str], None]) -> Path:
    """``path`` when it is new or empty, else the first free ``path-2``, ``path-3``, … (said in one line
    through ``say``, naming ``flag``), created here so that two runs never pick the same one: a run's logs
    are never overwritten or appended to. FileExistsError when ``path`` is a file; OSError when a folder
    cannot be made."""
    candidate, number = path, 1
    while True:
        try:
            candidate.mkdir(parents=True)
            break
        except FileExistsError:
            if candidate.is_dir() and not any(candidate.iterdir()):
                break  # an empty folder: nothing to lose
            if candidate == path and not path.is_dir():
                raise
        number += 1
        candidate = path.with_name(f"{path.name}-{number}")
    if candidate != path:
        say(f"{flag}: {path} already holds a run; writing this one to {candidate} instead")
    return candidate
