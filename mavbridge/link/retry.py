"""How the companion retries a MAVLink request on a lossy link, by the MAVLink services' rules.

Command protocol: a COMMAND_LONG without a COMMAND_ACK is sent again with ``confirmation`` one higher;
after MAV_RESULT_IN_PROGRESS the sender stops resending and waits much longer for the final ACK. Parameter
protocol: PARAM_REQUEST_READ is repeated until a PARAM_VALUE of that name arrives (the start's reads, many at
once, within one budget of wall time: ``mavbridge.link.param_reads``). Mission protocol: each
request (list, item) is repeated on its timeout, at most 5 times. An autopilot does not de-duplicate
retries (ArduPilot ignores ``confirmation``), so only idempotent requests are retried: arming an armed
vehicle, setting the mode it is in, asking for a parameter or a rate again.

Every give-up is one line naming what failed after how many tries. Every resend is counted, in all and by
kind (``count_retry``: parameter reads, mission download, commands, stream requests).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from vessel.argtypes import positive_seconds
from vessel.config import bounded

IN_PROGRESS_FACTOR = 10.0  # after IN_PROGRESS, wait this many timeouts for the final ACK (no resend)
MISSION_TIMEOUT_S = 1.5  # the mission protocol's default timeout per request
MISSION_MIN_RETRIES = 5  # ... and its retry count (a larger --command-retries raises it)


@dataclass(frozen=True)
class RetryPolicy:
    """Timeout per try (wall seconds: a link property) and how many times a request is sent again."""

    timeout_s: float = 1.0
    retries: int = 5

    def __post_init__(self) -> None:
        if not (math.isfinite(self.timeout_s) and self.timeout_s > 0):
            raise ValueError(f"command_timeout_s: {self.timeout_s!r} is outside the allowed range > 0 s")
        if self.retries < 0:
            raise ValueError(f"command_retries: {self.retries!r} is outside the allowed range >= 0")

    @property
    def tries(self) -> int:
        """Sends in all: the first and the retries."""
        return self.retries + 1

    def for_mission(self) -> RetryPolicy:
        """The mission protocol's timeout, with at least its 5 retries."""
        return RetryPolicy(max(self.timeout_s, MISSION_TIMEOUT_S), max(self.retries, MISSION_MIN_RETRIES))


@dataclass(frozen=True)
class RetrySettings:
    """The retry fields of the companion's YAML (CompanionConfig inherits them; `mavbridge check` reads them)."""

    command_timeout_s: float = bounded(1.0, 0.0, 60.0, "s", "wall wait per COMMAND_ACK / PARAM_VALUE before "
                                       "sending again", lo_open=True)
    command_retries: int = bounded(5, 0, 1000, "", "a command is sent again this many times (the mission "
                                   "protocol's requests at least 5 times)")
    param_budget_s: float = bounded(60.0, 1.0, 600.0, "s", "wall time all the parameter reads that decide the "
                                    "commands may take together at start (each asked again every command_timeout_s); "
                                    "one still unread then: the companion refuses to engage, naming it")

    def retry_policy(self) -> RetryPolicy:
        """These settings as the link's policy."""
        return RetryPolicy(self.command_timeout_s, self.command_retries)


Wait = Callable[[Callable[[Any], bool], float], Any]


def ask(send: Callable[[int], None], wait: Wait, answer: Callable[[Any], bool], policy: RetryPolicy,
        on_retry: Callable[[], None] = lambda: None) -> tuple[Any, int]:
    """Send (``send(attempt)``) until ``wait(answer, timeout)`` returns a reply; (reply or None, tries made)."""
    for attempt in range(policy.tries):
        if attempt:
            on_retry()
        send(attempt)
        reply = wait(answer, policy.timeout_s)
        if reply is not None:
            return reply, attempt + 1
    return None, policy.tries


RETRY_KINDS = ("param", "mission", "command", "stream")  # parameter reads, mission download, commands, stream requests


def count_retry(counts: dict[str, int], kind: str) -> None:
    """Count one resend in the link's counts: in all (``retries``) and by kind (``retries_<kind>``)."""
    counts["retries"] = counts.get("retries", 0) + 1
    counts[f"retries_{kind}"] = counts.get(f"retries_{kind}", 0) + 1


def give_up_line(what: str, awaited: str, tries: int, timeout_s: float) -> str:
    """The one line logged when a request is abandoned."""
    return f"link: {what}: no {awaited} after {tries} {'try' if tries == 1 else 'tries'} ({timeout_s:g} s each)"


def retry_count(text: str) -> int:
    """argparse type: a whole number >= 0 (argparse names the flag in front of the error)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number >= 0, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"{value} is outside the allowed range >= 0")
    return value


def add_retry_arguments(parser: Any) -> None:
    """--command-timeout and --command-retries (run and check share them)."""
    parser.add_argument("--command-timeout", type=positive_seconds, metavar="S",
                        help="wait this long (wall s) for each COMMAND_ACK / PARAM_VALUE before sending again, "
                             "(0, 60] s (default 1, or the YAML's command_timeout_s)")
    parser.add_argument("--command-retries", type=retry_count, metavar="N",
                        help="send a command again this many times before giving up, [0, 1000] "
                             "(default 5, or the YAML's command_retries)")
    parser.add_argument("--param-budget", type=positive_seconds, metavar="S",
                        help="wall seconds all parameter reads at start may take together, each asked again every "
                             "--command-timeout; one still unread then is named and the companion refuses to engage "
                             "(default 60, range [1, 600], or the YAML's param_budget_s)")
