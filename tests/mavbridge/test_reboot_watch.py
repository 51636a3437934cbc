"""RebootWatch on real MAVLink messages: a reboot needs both the heartbeat gap and time_boot_ms going back;
the heartbeat after a gap reaches the supervisor only once that is decided; consent does not survive it,
nor does a lockstep start's deferred mode switch."""

from __future__ import annotations

from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavbridge.companion.start import (
    DeferredStart,
    deferred_start_refused,
    switch_and_arm_if_asked,
    switch_mode_at_start,
)
from mavbridge.companion.supervisor import Phase, Supervisor
from mavbridge.link.reboot import DECIDE_S, GAP_S, RebootWatch, watch_reboots

ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
MANUAL = mavlink.ROVER_MODE_MANUAL


def heartbeat(armed: bool = True) -> Any:
    return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                             ARMED if armed else mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, MANUAL,
                                             mavlink.MAV_STATE_ACTIVE, 3)


def attitude(ms: int) -> Any:
    return mavlink.MAVLink_attitude_message(ms, 0, 0, 0, 0, 0, 0)


class Run:
    """A RebootWatch fed at given wall times; what it passed on and the reboots it reported."""

    def __init__(self) -> None:
        self.reasons: list[str] = []
        self.logged: list[str] = []
        self.watch = RebootWatch(self.reasons.append, self.logged.append)
        self.passed: list[Any] = []

    def feed(self, msg: Any, at_s: float) -> None:
        self.passed += self.watch.filter(msg, at_s)


def steady(run: Run, until_s: float, start_ms: int = 0, start_s: float = 0.0) -> None:
    """Heartbeats every 0.5 s and ATTITUDE every 0.1 s (autopilot time = wall time here)."""
    t = start_s
    while t < until_s:
        if round(t * 10) % 5 == 0:
            run.feed(heartbeat(), t)
        run.feed(attitude(start_ms + round((t - start_s) * 1000)), t)
        t += 0.1


def test_gap_then_time_back_is_a_reboot_and_the_heartbeat_follows_it() -> None:
    run = Run()
    steady(run, 20.0)
    n = len(run.passed)
    run.feed(heartbeat(armed=False), 20.0 + GAP_S + 0.5)  # the new boot: disarmed
    assert len(run.passed) == n and not run.reasons  # held until time says what it is
    run.feed(attitude(40), 20.0 + GAP_S + 0.6)
    assert len(run.reasons) == 1 and "time_boot_ms 19900 -> 40" in run.reasons[0]
    assert run.passed[-1].base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED == 0  # then it reaches the supervisor
    assert run.watch.streams_due and "asking for the streams again" in run.logged[0]


def test_a_gap_alone_or_time_back_alone_is_not_a_reboot() -> None:
    run = Run()
    steady(run, 20.0)
    run.feed(heartbeat(), 20.0 + GAP_S + 1.0)  # a lossy radio: heartbeats missed
    run.feed(attitude(23_000), 23.0)
    assert not run.reasons and run.passed[-1].get_type() == "HEARTBEAT"
    run.feed(heartbeat(), 23.1)
    run.feed(attitude(10_000), 23.2)  # time back 13 s, heartbeats steady: not a reboot
    assert not run.reasons and "without a heartbeat gap" in run.logged[0]


def test_a_small_step_back_after_a_gap_is_reordering_not_a_reboot() -> None:
    run = Run()
    steady(run, 20.0)
    run.feed(heartbeat(), 20.0 + GAP_S + 0.1)
    run.feed(attitude(19_000), 21.7)  # 900 ms behind: a datagram overtaken
    assert not run.reasons and run.passed[-1].get_type() == "HEARTBEAT"


def test_a_held_heartbeat_is_let_through_when_no_time_comes() -> None:
    run = Run()
    steady(run, 5.0)
    run.feed(heartbeat(), 5.0 + GAP_S)
    n = len(run.passed)
    run.feed(heartbeat(), 5.0 + GAP_S + DECIDE_S + 0.1)
    assert len(run.passed) == n + 1 and not run.reasons


def test_time_back_before_the_first_heartbeat_of_the_new_boot_is_a_reboot() -> None:
    run = Run()
    steady(run, 20.0)
    run.feed(attitude(30), 20.0 + GAP_S + 0.5)  # stamped messages of the new boot overtook its heartbeat
    assert len(run.reasons) == 1


@pytest.mark.parametrize("self_commanded", [True, False])
def test_after_a_reboot_only_a_fresh_arming_in_the_mode_engages(self_commanded: bool) -> None:
    sup = Supervisor(required_mode=MANUAL, link_timeout_s=2.0, self_commanded=self_commanded)
    if not self_commanded:
        sup.on_heartbeat(0.0, False, MANUAL)
    assert sup.on_heartbeat(1.0, True, MANUAL) == Phase.ENGAGED
    sup.rebooted("autopilot rebooted")
    assert sup.phase == Phase.WAITING and not sup.may_command()
    assert sup.on_heartbeat(5.0, False, MANUAL) == Phase.WAITING  # the new boot, disarmed: not taken over
    assert sup.on_heartbeat(9.0, True, MANUAL) == Phase.ENGAGED  # the pilot arms again


def test_found_armed_after_a_reboot_is_not_consent() -> None:
    sup = Supervisor(required_mode=MANUAL, link_timeout_s=2.0, self_commanded=True)
    sup.on_heartbeat(1.0, True, MANUAL)
    sup.rebooted("autopilot rebooted")
    assert sup.on_heartbeat(5.0, True, MANUAL) == Phase.WAITING  # armed in the mode already: switch out and back


HOLD, GUIDED = mavlink.ROVER_MODE_HOLD, mavlink.ROVER_MODE_GUIDED


def _waiting_in(mode: int) -> Supervisor:
    """A companion started with --set-mode --arm in lockstep: it has consent and saw the boat disarmed in ``mode``."""
    sup = Supervisor(required_mode=GUIDED, link_timeout_s=2.0, self_commanded=True)
    sup.on_heartbeat(0.0, False, mode)
    return sup


def _deferred(sup: Supervisor, arm: bool = True) -> DeferredStart:
    return DeferredStart(mode_seen=sup.mode, mode_changes_seen=sup.mode_changes, arm=arm)


def test_a_deferred_lockstep_switch_goes_ahead_when_nothing_changed() -> None:
    sup = _waiting_in(HOLD)
    deferred = _deferred(sup)
    sup.on_heartbeat(1.0, False, HOLD)
    assert deferred_start_refused(deferred, sup, stop_requested=False) is None


def test_a_reboot_before_the_first_tick_cancels_the_deferred_switch() -> None:
    sup = _waiting_in(HOLD)
    deferred = _deferred(sup)
    sup.rebooted("autopilot rebooted")
    sup.on_heartbeat(6.0, False, HOLD)  # the new boot, same mode: consent still did not carry over
    why = deferred_start_refused(deferred, sup, stop_requested=False)
    assert why is not None and "consent" in why


def test_an_operators_mode_change_while_waiting_is_not_undone_at_the_first_tick() -> None:
    sup = _waiting_in(HOLD)
    deferred = _deferred(sup, arm=False)
    sup.on_heartbeat(3.0, False, MANUAL)  # the pilot chose MANUAL while the companion waited for its tick
    why = deferred_start_refused(deferred, sup, stop_requested=False)
    assert why is not None and "MANUAL" in why


def test_a_mode_change_and_back_while_waiting_is_a_change_too() -> None:
    sup = _waiting_in(HOLD)
    deferred = _deferred(sup, arm=False)
    sup.on_heartbeat(3.0, False, MANUAL)
    sup.on_heartbeat(4.0, False, HOLD)  # back where it was: still someone else's hands on the modes
    why = deferred_start_refused(deferred, sup, stop_requested=False)
    assert why is not None and "changed" in why


def test_a_stop_request_before_the_first_tick_switches_nothing() -> None:
    sup = _waiting_in(HOLD)
    why = deferred_start_refused(_deferred(sup), sup, stop_requested=True)  # a signal the loop has not seen yet
    assert why is not None and "stop" in why


class FakeLink:
    """What switch_mode_at_start calls on the link; ``on_set_mode`` runs inside the answer's wait, as the
    real link's message handlers do."""

    def __init__(self, result: int, on_set_mode: Any = None, on_arm: Any = None) -> None:
        self.calls: list[str] = []
        self.result, self.on_set_mode, self.on_arm = result, on_set_mode, on_arm

    def set_mode(self, mode: int) -> int:
        self.calls.append(f"set_mode {mode}")
        if self.on_set_mode is not None:
            self.on_set_mode()
        return self.result

    def arm(self) -> int:
        self.calls.append("arm")
        if self.on_arm is not None:
            self.on_arm()
        return mavlink.MAV_RESULT_ACCEPTED

    def heartbeat_if_due(self) -> None:
        pass

    def recv(self, timeout: float) -> None:
        self.calls.append("recv")


class FakeCompanion:
    """The parts of the Companion that switch_mode_at_start reads and writes."""

    def __init__(self, sup: Supervisor, stop: bool = False) -> None:
        self.supervisor, self.stop = sup, stop
        self.deferred_start: DeferredStart | None = _deferred(sup)
        self.output = type("Output", (), {"required_mode": GUIDED})()
        self.lines: list[str] = []

    def log(self, line: str) -> None:
        self.lines.append(line)

    def stop_requested(self) -> bool:
        return self.stop


def test_the_first_tick_switches_then_arms_and_waits_for_the_heartbeat_showing_both() -> None:
    sup = _waiting_in(HOLD)
    companion = FakeCompanion(sup)
    link = FakeLink(mavlink.MAV_RESULT_ACCEPTED, on_arm=lambda: sup.on_heartbeat(2.0, True, GUIDED))
    switch_mode_at_start(companion, link, 162_000)
    assert link.calls[:2] == [f"set_mode {GUIDED}", "arm"] and companion.deferred_start is None
    assert sup.phase == Phase.ENGAGED and not any("warning" in line for line in companion.lines)


def test_a_stop_request_at_the_first_tick_neither_switches_nor_arms() -> None:
    companion = FakeCompanion(_waiting_in(HOLD), stop=True)
    link = FakeLink(mavlink.MAV_RESULT_ACCEPTED)
    switch_mode_at_start(companion, link, 162_000)
    assert link.calls == [] and "stop" in companion.lines[-1]


def test_a_refused_mode_switch_is_not_followed_by_arming() -> None:
    companion = FakeCompanion(_waiting_in(HOLD))
    link = FakeLink(mavlink.MAV_RESULT_DENIED)
    switch_mode_at_start(companion, link, 162_000)
    assert link.calls == [f"set_mode {GUIDED}"] and "not arming" in companion.lines[-1]


def test_a_reboot_seen_while_the_switch_is_answered_stops_the_arming() -> None:
    sup = _waiting_in(HOLD)
    companion = FakeCompanion(sup)
    link = FakeLink(mavlink.MAV_RESULT_ACCEPTED, on_set_mode=lambda: sup.rebooted("autopilot rebooted"))
    switch_mode_at_start(companion, link, 162_000)
    assert "arm" not in link.calls and "consent" in companion.lines[-1]


def test_the_reboot_watch_cancels_a_deferred_switch() -> None:
    """watch_reboots' callback forgets the lockstep start's deferred switch (consent given to the old boot)."""
    sup = _waiting_in(HOLD)
    companion = FakeCompanion(sup)
    companion.events = type("Events", (), {"engaged_at_ms": None})()  # type: ignore[attr-defined]
    companion._on_heartbeat = lambda msg: None  # type: ignore[attr-defined]
    companion.period_s = 0.1  # type: ignore[attr-defined]
    link = type("LinkParts", (), {})()
    link.handlers, link.counts, link.idle_hooks = [companion._on_heartbeat], {}, []
    watch = watch_reboots(link, companion)
    assert companion.deferred_start is not None
    watch.on_reboot("autopilot rebooted")
    assert companion.deferred_start is None and not sup.self_commanded


def _starting(sup: Supervisor, lockstep: bool, engage_after_s: float = 0.0) -> FakeCompanion:
    """A companion at the end of start_flight, launched with --set-mode --arm (``lockstep``: and --start-at),
    connected at autopilot time 100 s, its start done at 104 s."""
    companion = FakeCompanion(sup)
    companion.deferred_start = None
    companion.set_mode = companion.arm = True  # type: ignore[attr-defined]
    config = {"lockstep": lockstep, "start_at_s": 162.0 if lockstep else None, "engage_after_s": engage_after_s}
    companion.config = type("Config", (), config)()  # type: ignore[attr-defined]
    companion.events = type("Events", (), {"connected_at_ms": 100_000})()  # type: ignore[attr-defined]
    companion.state = type("State", (), {"attitude_ms": 104_000})()  # type: ignore[attr-defined]
    return companion


@pytest.mark.parametrize("lockstep", [False, True])
def test_a_reboot_during_the_start_cancels_the_switch_and_the_arming(lockstep: bool) -> None:
    sup = _waiting_in(HOLD)  # consent taken at the start of start_flight ...
    sup.rebooted("autopilot rebooted")  # ... and cleared by a reboot seen during it
    companion, link = _starting(sup, lockstep), FakeLink(mavlink.MAV_RESULT_ACCEPTED)
    switch_and_arm_if_asked(companion, link, consent=True)
    assert link.calls == [] and companion.deferred_start is None and "rebooted" in companion.lines[-1]


@pytest.mark.parametrize("lockstep", [False, True])
def test_without_a_reboot_the_start_switches_and_arms_or_defers_both(lockstep: bool) -> None:
    sup = _waiting_in(HOLD)
    companion, link = _starting(sup, lockstep), FakeLink(mavlink.MAV_RESULT_ACCEPTED)
    switch_and_arm_if_asked(companion, link, consent=True)
    if lockstep:
        assert link.calls == [] and companion.deferred_start == DeferredStart(HOLD, sup.mode_changes, True, 100_000)
    else:
        assert link.calls == [f"set_mode {GUIDED}", "arm"] and companion.deferred_start is None


@pytest.mark.parametrize(("engage_after_s", "deferred"), [(3.0, False), (30.0, True)])
def test_engage_after_defers_the_switch_and_the_arming_until_that_long_after_connecting(
        engage_after_s: float, deferred: bool) -> None:
    """--engage-after 30: connected at 100 s, ready at 104 s, the switch and the arming wait for 130 s; a wait
    already over when the start is done (3 s) changes nothing."""
    sup = _waiting_in(HOLD)
    companion, link = _starting(sup, False, engage_after_s), FakeLink(mavlink.MAV_RESULT_ACCEPTED)
    switch_and_arm_if_asked(companion, link, consent=True)
    if deferred:
        assert link.calls == [] and companion.deferred_start == DeferredStart(HOLD, sup.mode_changes, True, 130_000)
        assert "engaging at t = 130.0 s" in companion.lines[-1]
    else:
        assert link.calls == [f"set_mode {GUIDED}", "arm"] and companion.deferred_start is None
