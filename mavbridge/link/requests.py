"""The link's request services that wait for an answer and retry (COMMAND_LONG until its COMMAND_ACK,
PARAM_REQUEST_READ until its PARAM_VALUE), by the rules in ``mavbridge.link.retry``.

They are functions of any link with the few members named in ``RequestLink`` (``mavbridge.link.connection.Link`` is the
one in use), so the retry logic sits apart from the receiving and filtering it relies on.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any, Protocol

os.environ.setdefault("MAVLINK20", "1")  # before pymavlink is imported (as in mavbridge.link.connection)
from pymavlink import mavutil

from mavbridge.link.retry import IN_PROGRESS_FACTOR, RetryPolicy, ask, count_retry, give_up_line

mavlink = mavutil.mavlink


class RequestLink(Protocol):
    """What a request needs of a link: the autopilot, our id, the policy, give-up lines, counts, send and wait."""

    target: tuple[int, int] | None
    system_id: int
    retry: RetryPolicy
    log: Callable[[str], None]
    counts: dict[str, int]

    def send(self, name: str, *args: Any) -> None: ...

    def wait_for(self, predicate: Callable[[Any], bool], timeout_s: float) -> Any | None: ...

    def drain(self, limit: int = 5000) -> int: ...


def command_name(command: int) -> str:
    """MAV_CMD_... name of a command number (the number if the dialect has none)."""
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else str(command)


def _count_retry(link: RequestLink, kind: str) -> Callable[[], None]:
    """A callback that counts one retry of ``kind`` (``retry.RETRY_KINDS``) in the link's counts."""
    def count() -> None:
        count_retry(link.counts, kind)
    return count


def command_long(link: RequestLink, command: int, params: tuple[float, ...],
                 policy: RetryPolicy | None = None) -> int | None:
    """COMMAND_LONG to the autopilot, resent (``confirmation`` + 1) until a COMMAND_ACK for it arrives.

    After MAV_RESULT_IN_PROGRESS nothing is resent; the final ACK is awaited ten timeouts. Returns the
    result, or None after the last try (one line says so).
    """
    assert link.target is not None, "wait_autopilot() first"
    policy = policy or link.retry
    target = link.target
    p = list(params) + [0.0] * (7 - len(params))
    name = command_name(command)
    link.drain()  # a late or duplicated ACK of an earlier command must not stand for this one

    def is_ack(m: Any) -> bool:
        return (m.get_type() == "COMMAND_ACK" and m.command == command
                and getattr(m, "target_system", 0) in (0, link.system_id))

    kind = "stream" if command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL else "command"
    ack, tries = ask(lambda attempt: link.send("command_long", target[0], target[1], command, min(attempt, 255),
                                               *p), link.wait_for, is_ack, policy, _count_retry(link, kind))
    if ack is not None and ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
        wait_s = policy.timeout_s * IN_PROGRESS_FACTOR
        ack = link.wait_for(lambda m: is_ack(m) and m.result != mavlink.MAV_RESULT_IN_PROGRESS, wait_s)
        if ack is None:
            link.log(f"link: COMMAND_LONG {name}: IN_PROGRESS, then no final COMMAND_ACK within {wait_s:g} s")
            return None
    if ack is None:
        link.log(give_up_line(f"COMMAND_LONG {name}", "COMMAND_ACK", tries, policy.timeout_s))
        return None
    return int(ack.result)


def read_parameter(link: RequestLink, name: str, policy: RetryPolicy | None = None) -> float | None:
    """PARAM_REQUEST_READ by name, resent on each timeout; the value, or None (with a give-up line) when no answer
    came."""
    assert link.target is not None, "wait_autopilot() first"
    policy = policy or link.retry
    target = link.target
    reply, tries = ask(lambda _attempt: link.send("param_request_read", target[0], target[1], name.encode(), -1),
                       link.wait_for, lambda m: m.get_type() == "PARAM_VALUE" and m.param_id == name, policy,
                       _count_retry(link, "param"))
    if reply is None:
        link.log(give_up_line(f"PARAM_REQUEST_READ {name}", "PARAM_VALUE", tries, policy.timeout_s))
        return None
    return float(reply.param_value)
