"""`mavbridge check`'s requested messages (GPS_RAW_INT, HOME_POSITION): asked again while the autopilot accepts the
request but the message does not come, at most ``REQUEST_ROUNDS`` times, each re-ask a counted command retry; home
asked with GET_HOME_POSITION first (FAILED: no home, said at once), REQUEST_MESSAGE where that is unsupported.

A link that answers by rule (no sockets: what is tested is how often the probe asks; the same through a lossy
relay is ``tests/system/test_link_faults.py``)."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from mavbridge.link.connection import mavlink
from mavbridge.link.retry import RetryPolicy
from mavbridge.preflight.probe import REQUEST_ROUNDS, Probe, home_position, requested
from mavbridge.preflight.report import Report

ACCEPTED, FAILED, UNSUPPORTED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_FAILED, mavlink.MAV_RESULT_UNSUPPORTED
GET_HOME, REQUEST = mavlink.MAV_CMD_GET_HOME_POSITION, mavlink.MAV_CMD_REQUEST_MESSAGE
HOME_ID = (float(mavlink.MAVLINK_MSG_ID_HOME_POSITION),)


class _Message:
    def __init__(self, name: str) -> None:
        self.name = name

    def get_type(self) -> str:
        return self.name


class _RuleLink:
    """Answers each command with ``results[command]`` (None: no ACK at all); HOME_POSITION comes with the request
    numbered ``delivered_on`` (from 1, counting every command; None: never), as the probe's handlers record it."""

    def __init__(self, probe: Probe, results: dict[int, int | None], delivered_on: int | None,
                 with_the_ack: bool = False) -> None:
        self.probe, self.results, self.delivered_on, self.with_the_ack = probe, results, delivered_on, with_the_ack
        self.retry, self.counts, self.sent, self.waits = RetryPolicy(0.3, 25), {}, [], 0

    def _deliver(self) -> bool:
        if self.delivered_on is not None and len(self.sent) >= self.delivered_on:
            self.probe._remember(_Message("HOME_POSITION"))
            return True
        return False

    def command_long(self, command: int, params: tuple[float, ...]) -> int | None:
        self.sent.append(command)
        if self.with_the_ack:
            self._deliver()
        return self.results[command]

    def wait_for(self, predicate: Any, timeout_s: float) -> Any | None:
        self.waits += 1
        return _Message("HOME_POSITION") if self._deliver() else None


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
    link = _RuleLink(probe, {REQUEST: result}, delivered_on)
    message, accepted, last = requested(link, probe.seen, "HOME_POSITION", REQUEST, HOME_ID)
    assert (message is not None) == had and len(link.sent) == requests and last == result
    assert accepted == (requests if result == ACCEPTED else 0)
    assert link.counts.get("retries_command", 0) == requests - 1  # every re-ask counted


def test_a_message_already_seen_or_come_with_the_ack_is_not_waited_for() -> None:
    probe = _probe()
    probe._remember(_Message("HOME_POSITION"))
    link = _RuleLink(probe, {REQUEST: ACCEPTED}, None)
    assert requested(link, probe.seen, "HOME_POSITION", REQUEST, HOME_ID)[1] == 0 and not link.sent and link.waits == 0
    probe = _probe()
    link = _RuleLink(probe, {REQUEST: ACCEPTED}, 1, with_the_ack=True)
    message, accepted, _ = requested(link, probe.seen, "HOME_POSITION", REQUEST, HOME_ID)
    assert message is not None and accepted == 1 and link.waits == 0


def test_no_home_is_told_at_once_where_get_home_position_is_answered() -> None:
    probe = _probe()
    link = _RuleLink(probe, {GET_HOME: FAILED, REQUEST: ACCEPTED}, None)
    home, why = home_position(link, probe.seen)
    assert home is None and link.sent == [GET_HOME] and why == "no home: GET_HOME_POSITION answered FAILED"


def test_home_falls_back_to_request_message_where_get_home_position_is_unsupported() -> None:
    probe = _probe()
    link = _RuleLink(probe, {GET_HOME: UNSUPPORTED, REQUEST: ACCEPTED}, 3)  # the second REQUEST_MESSAGE's answer
    home, why = home_position(link, probe.seen)
    assert home is not None and why == "" and link.sent == [GET_HOME, REQUEST, REQUEST]


def test_the_fail_says_how_often_the_request_was_accepted() -> None:
    """A lossy link, or firmware that accepts the request without a home: the operator reads the count."""
    probe = _probe()
    probe.seen["GPS_RAW_INT"] = SimpleNamespace(fix_type=3, satellites_visible=10, get_type=lambda: "GPS_RAW_INT")
    probe.gps_and_home(_RuleLink(probe, {GET_HOME: ACCEPTED, REQUEST: ACCEPTED}, None))
    home = next(f for f in probe.report.findings if f.item == "home position")
    assert home.status == "FAIL" and f"requested {REQUEST_ROUNDS}×, accepted, nothing came" in home.actual
