"""`mavbridge check`'s requested messages (GPS_RAW_INT, HOME_POSITION): asked again while the autopilot accepts the
request but the message does not come, at most ``REQUEST_ROUNDS`` times, each re-ask a counted command retry.

A link that answers by rule (no sockets: what is tested is how often the probe asks; the same through a lossy
relay is ``tests/system/test_link_faults.py``)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from mavbridge.link.connection import mavlink
from mavbridge.link.retry import RetryPolicy
from mavbridge.preflight.probe import REQUEST_ROUNDS, Probe
from mavbridge.preflight.report import Report

ACCEPTED, FAILED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_FAILED


class _Message:
    def __init__(self, name: str) -> None:
        self.name = name

    def get_type(self) -> str:
        return self.name


class _RuleLink:
    """Answers each REQUEST_MESSAGE with ``result`` (None: no ACK at all); the message comes with the request
    numbered ``delivered_on`` (from 1; None: never), as the probe's handlers would record it."""

    def __init__(self, probe: Probe, result: int | None, delivered_on: int | None) -> None:
        self.probe, self.result, self.delivered_on = probe, result, delivered_on
        self.retry, self.counts, self.requests, self.waits = RetryPolicy(0.3, 25), {}, 0, 0

    def command_long(self, command: int, params: tuple[float, ...]) -> int | None:
        assert command == mavlink.MAV_CMD_REQUEST_MESSAGE
        self.requests += 1
        return self.result

    def wait_for(self, predicate: Any, timeout_s: float) -> Any | None:
        self.waits += 1
        if self.delivered_on is not None and self.requests >= self.delivered_on:
            msg = _Message("HOME_POSITION")
            self.probe._remember(msg)
            return msg if predicate(msg) else None
        return None


def _probe() -> Probe:
    return Probe(SimpleNamespace(), SimpleNamespace(controller=SimpleNamespace(period_s=0.1)), Report())


@pytest.mark.parametrize(("result", "delivered_on", "requests", "had"), [
    (ACCEPTED, 1, 1, True),  # the first answer comes
    (ACCEPTED, 3, 3, True),  # lost twice on the way
    (ACCEPTED, None, REQUEST_ROUNDS, False),  # accepted, never sent (ArduPilot with no home): the count ends it
    (FAILED, None, 1, False),  # refused: not asked again
    (None, None, 1, False),  # no ACK after the command's own resends: not asked again
], ids=["first", "third", "never", "refused", "no-ack"])
def test_a_requested_message_is_asked_again_only_while_accepted_and_lost(result: int | None, delivered_on: int | None,
                                                                          requests: int, had: bool) -> None:
    probe = _probe()
    link = _RuleLink(probe, result, delivered_on)
    message, accepted = probe.requested(link, mavlink.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION")
    assert (message is not None) == had and link.requests == requests
    assert accepted == (requests if result == ACCEPTED else 0)
    assert link.counts.get("retries_command", 0) == requests - 1  # every re-ask counted


def test_a_message_already_seen_is_not_asked_for() -> None:
    probe = _probe()
    probe._remember(_Message("HOME_POSITION"))
    link = _RuleLink(probe, ACCEPTED, None)
    assert probe.requested(link, mavlink.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION")[1] == 0
    assert link.requests == 0 and link.waits == 0


class _WithTheAck(_RuleLink):
    """The message arrives with the ACK (handlers record it while the command waits for its answer)."""

    def command_long(self, command: int, params: tuple[float, ...]) -> int | None:
        self.probe._remember(_Message("HOME_POSITION"))
        return super().command_long(command, params)


def test_a_message_that_came_with_the_ack_is_not_waited_for() -> None:
    probe = _probe()
    link = _WithTheAck(probe, ACCEPTED, None)
    message, accepted = probe.requested(link, mavlink.MAVLINK_MSG_ID_HOME_POSITION, "HOME_POSITION")
    assert message is not None and accepted == 1 and link.waits == 0


def test_the_fail_says_how_often_the_request_was_accepted() -> None:
    """A lossy link or no home yet: the operator reads which from the count."""
    probe = _probe()
    probe.seen["GPS_RAW_INT"] = SimpleNamespace(fix_type=3, satellites_visible=10, get_type=lambda: "GPS_RAW_INT")
    probe.gps_and_home(_RuleLink(probe, ACCEPTED, None))
    home = next(f for f in probe.report.findings if f.item == "home position")
    assert home.status == "FAIL" and f"requested {REQUEST_ROUNDS}×, accepted, nothing came" in home.actual
