"""The suite's order for its xdist workers: each worker starts with its share of the slowest tests.

pytest-xdist's ``worksteal`` scheduler (``pyproject.toml``) first hands worker i the i-th contiguous slice of the
collection (slice sizes: what is left divided by the workers left), then lets an idle worker steal the *tail* of
the longest queue. Left in file order, the slow process tests (tests/system, a minute each) sit together in the
last slice and are run by one worker while the others steal them one by one; a one-minute test started last
sets the suite's end. ``balanced_order`` instead deals the tests listed in ``expected_durations.txt`` (longest
first, each to the slice with the fewest expected seconds so far) to the heads of the slices, and fills each
slice with the other tests in their file order: every worker starts on long tests, and what is stolen at the
end is short. Without xdist (one worker) the slow tests simply come first. No test is dropped or repeated.

``python -m tests.expected_durations < durations_output`` turns a ``pytest --durations=0`` report into that file.
"""

from __future__ import annotations

import re
import sys
from collections import defaultdict
from collections.abc import Sequence
from pathlib import Path
from typing import TypeVar

T = TypeVar("T")
DURATIONS_FILE = Path(__file__).with_name("expected_durations.txt")
SLOW_S = 8  # tests at least this long (s, all phases) are listed
_REPORT_LINE = re.compile(r"([\d.]+)s (?:call|setup|teardown)\s+(\S+)")


def read_expected(path: Path = DURATIONS_FILE) -> dict[str, float]:
    """Expected seconds by test id from ``path`` (``seconds id`` lines, ``#`` comments); {} if it is missing."""
    if not path.exists():
        return {}
    expected = {}
    for line in path.read_text().splitlines():
        parts = line.split()
        if len(parts) == 2 and not line.lstrip().startswith("#"):
            expected[parts[1]] = float(parts[0])
    return expected


def slice_sizes(count: int, workers: int) -> list[int]:
    """The sizes of worksteal's first slices: worker i gets what is left divided by the workers left."""
    sizes, left = [], count
    for i in range(workers):
        sizes.append(left // (workers - i))
        left -= sizes[-1]
    return sizes


def balanced_order(ids: Sequence[T], expected: dict[T, float], workers: int) -> list[T]:
    """``ids`` reordered so that each worker's first slice starts with its share of the expected-slow ones (see
    the module docstring); the others keep their relative order."""
    sizes = slice_sizes(len(ids), max(1, workers))
    slow = sorted((i for i in ids if i in expected), key=lambda i: -expected[i])
    heads: list[list[T]] = [[] for _ in sizes]
    load = [0.0] * len(sizes)
    for test in slow:  # longest first, to the slice with the least expected time that still has room
        open_slices = [s for s in range(len(sizes)) if len(heads[s]) < sizes[s]]
        chosen = min(open_slices, key=lambda s: load[s])
        heads[chosen].append(test)
        load[chosen] += expected[test]
    rest = iter(i for i in ids if i not in expected)
    order: list[T] = []
    for head, size in zip(heads, sizes, strict=True):
        order.extend(head)
        order.extend(next(rest) for _ in range(size - len(head)))
    return order


def durations_file(report_lines: Sequence[str]) -> str:
    """The contents of ``expected_durations.txt`` from a ``pytest --durations=0`` report (phases summed)."""
    seconds: dict[str, float] = defaultdict(float)
    for line in report_lines:
        if match := _REPORT_LINE.match(line.strip()):
            seconds[match[2]] += float(match[1])
    slow = sorted(((s, test) for test, s in seconds.items() if s >= SLOW_S), reverse=True)
    header = [f"# Expected seconds of the suite's tests of at least {SLOW_S} s (call + setup + teardown), for the "
              "order of", "# tests/expected_durations.py. A test missing here counts as fast; a stale line is "
              "ignored.", "# Made by: python -m tests.expected_durations < the output of pytest -q --durations=0"]
    return "\n".join(header + [f"{s:4.0f} {test}" for s, test in slow]) + "\n"


if __name__ == "__main__":
    sys.stdout.write(durations_file(sys.stdin.read().splitlines()))
