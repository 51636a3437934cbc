"""A child process whose output lines a thread collects, stopped by its handle however the test ends."""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


@contextmanager
def collecting(argv: list[str], **popen: Any) -> Iterator[tuple[subprocess.Popen[str], list[str]]]:
    """Start ``argv`` (stdout and stderr together, as text); yield it and the list its lines go into.

    On leaving, a process still running is killed, and the reader has read what was printed."""
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **popen)
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout or ()), daemon=True)
    reader.start()
    try:
        yield proc, lines
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        reader.join(timeout=5)


def wait_for_line(proc: subprocess.Popen[str], lines: list[str], text: str, timeout_s: float) -> None:
    """Until a line holding ``text`` was printed; a clear error if the process ended or the time ran out."""
    deadline = time.monotonic() + timeout_s
    while not any(text in line for line in list(lines)):
        if proc.poll() is not None:
            raise AssertionError(f"the process ended ({proc.returncode}) before printing {text!r}: {lines[-5:]}")
        if time.monotonic() > deadline:
            raise TimeoutError(f"no line with {text!r} within {timeout_s:g} s; the last ones: {lines[-5:]}")
        time.sleep(0.05)
