"""The companion's start-up, between connecting and the control loop, and its wave hand-over.

``start_flight`` runs the sequence once per run: wait for the autopilot, prepare the output path,
request the streams, load the mission, measure the rates (and pin the fastest IMU stream), check the
waypoints' range before anything moves, make the cold full solve so every step in the loop starts
warm, then set the mode and arm only when the operator asked (``--set-mode``/``--arm``).
``wave_step`` hands the wave source's answer (and its sea statistics) to the NMPC once.
In lockstep with ``--start-at`` the mode switch waits for the first tick (``switch_mode_at_start``): a mode
entered at a wall-clock moment of the startup starts its autopilot controllers (GUIDED's loiter, its
integrators) at a simulated time that differs from run to run, and the run would not repeat.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mavbridge.companion.engage_gate import check_waypoints
from mavbridge.companion.rover_modes import mode_name
from mavbridge.companion.state import IMU_MESSAGES
from mavbridge.companion.supervisor import Supervisor
from mavbridge.link.connection import Link, mavlink
from mavbridge.link.streams import imu_rate, measure_rates, request_streams
from mavbridge.nmpc import RollAwareNmpc
from mavbridge.waves.source import SCENARIO_TRUTH, WaveSource, sea_spread, send_held
from vessel.config import ConfigError

MODE_HEARTBEAT_WAIT_S = 5.0  # wall seconds the first lockstep tick waits for the heartbeat in the new mode


def log_result(log: Callable[[str], None], what: str, result: int | None) -> None:
    """Warn when a command was not accepted."""
    if result != mavlink.MAV_RESULT_ACCEPTED:
        reason = "no answer" if result is None else mavlink.enums["MAV_RESULT"][result].name
        log(f"warning: {what} not accepted ({reason})")


def wave_step(waves: WaveSource, nmpc: RollAwareNmpc, t_s: float) -> dict[str, float]:
    """Ask the wave source for the wave at autopilot time ``t_s`` and hand it to the NMPC (None: no roll term);
    returns the estimate's log columns."""
    estimate = waves.estimate(t_s)
    try:
        nmpc.set_wave(estimate.field() if estimate is not None else None)
    except (ConfigError, ValueError):  # a wave the model refuses (breaking, not finite): no roll term, no crash
        nmpc.set_wave(None)
        estimate = None
    nmpc.set_sea_spread(sea_spread(waves, estimate is not None))
    send_held(waves)  # (the samples asked about go now, as after a step's command)
    return estimate.row() if estimate is not None else {}


def start_flight(c: Any, link: Link) -> None:
    """Autopilot, output path, streams, mission, rates, the cold solve; then mode and arming if asked
    (``c``: the ``Companion`` whose parts this prepares). The operator's consent (``--set-mode``/``--arm``) is
    given to the boot the companion meets: a reboot during this start (the reboot watch is already on)
    clears it, and then nothing is switched or armed, now or at the first tick."""
    consent = c.supervisor.self_commanded = c.set_mode or c.arm
    sysid, compid = link.wait_autopilot(c.config.connect_timeout_s)
    c.log(f"autopilot {sysid}/{compid} on {c.config.connect}; we are {c.config.system_id}/"
          f"{c.config.component_id}; output {c.config.output}" + ("" if c.output.sends else " (dry run)"))
    c.output.prepare(link)
    asked = request_streams(link, c.period_s, c.log)
    if asked in IMU_MESSAGES:  # the fast IMU asked for, not whichever slow one arrives first (Rover's 1 Hz RAW_IMU):
        c.state.use_imu(asked)  # the estimator's first window then has its heave at 20 Hz (measured below, kept)
    c.mission.load(link, c.state.set_home)
    rates = c.events.rates_hz = measure_rates(link, lambda: c.state.attitude_ms, warn=c.log)
    c.log("rates per autopilot second: " + ", ".join(f"{k} {v:g} Hz" for k, v in rates.items()))
    boat = (float(c.state.vector()[0]), float(c.state.vector()[1])) if c.state.ready() else None
    check_waypoints(c.mission.waypoints, c.config.max_range_m, boat)  # before arming or any mode change
    said = choose_imu(c.state, asked, rates)
    if c.waves.name != SCENARIO_TRUTH:
        c.log(said)
    if c.state.ready() and c.mission.waypoints:  # the cold, full solve, so every step in the loop is warm
        t_s = (c.state.attitude_ms or 0) / 1000.0
        wave_step(c.waves, c.nmpc, t_s)
        prepared = c.nmpc.prepare(c.state.vector(), t_s, c.mission.waypoints[0])
        c.log(f"solver {c.scenario.controller.solver} prepared in {prepared.wall_time_s * 1e3:.0f} ms "
              f"({prepared.status})")
    switch_and_arm_if_asked(c, link, consent)


def choose_imu(state: Any, asked: str, rates: dict[str, float]) -> str:
    """The IMU kind the wave estimator takes, from the measured ``rates``: the fastest stream, unless the kind
    asked for streams at least as fast, or is silent yet (then it stays the preferred kind, the state falls back
    to a slower one while it is silent and takes it back when it streams: a late start never leaves the estimator
    on Rover's 1 Hz RAW_IMU). Returns the line that says so."""
    imu, imu_hz = imu_rate(rates)
    asked_hz = rates.get(asked, 0.0) if asked in IMU_MESSAGES else None
    if asked_hz == 0.0:
        return f"IMU: {asked} asked for, not streaming yet; " + (
            f"{imu} at {imu_hz:g} Hz meanwhile" if imu else "the GPS height meanwhile")
    if asked_hz is None or imu_hz > asked_hz:
        state.use_imu(imu)
    else:
        imu, imu_hz = asked, asked_hz
    return (f"IMU: {imu} at {imu_hz:g} Hz to the wave estimator" if imu else
            "IMU: no SCALED_IMU/RAW_IMU stream; the wave estimator uses the GPS height")


def switch_and_arm_if_asked(c: Any, link: Link, consent: bool) -> None:
    """The end of the start: the mode switch and arming the operator asked for (``consent``: --set-mode or
    --arm), now or deferred to a later tick (lockstep with --start-at: the first; ``engage_after_s``: the first
    that long after connecting); nothing when a reboot during the start cleared the supervisor's consent."""
    if consent and not c.supervisor.self_commanded:
        c.log("the autopilot rebooted during the start: not switching its mode or arming (consent was given to "
              "the previous boot); waiting for the pilot")
        return
    if c.set_mode and c.config.lockstep and c.config.start_at_s is not None:
        c.deferred_start = DeferredStart(c.supervisor.mode, c.supervisor.mode_changes, c.arm, _engage_ms(c))
        c.log(f"lockstep: the switch to {mode_name(c.output.required_mode)}" + (" and the arming" if c.arm else "")
              + f" wait for the first tick (t = {c.config.start_at_s:g} s), so that every run starts its "
              "autopilot mode at the same time")
        return
    due_ms = _engage_ms(c)
    if (c.set_mode or c.arm) and due_ms > (c.state.attitude_ms or 0):
        c.deferred_start = DeferredStart(c.supervisor.mode, c.supervisor.mode_changes, c.arm, due_ms, c.set_mode)
        what = (f"the switch to {mode_name(c.output.required_mode)}" + (" and the arming" if c.arm else "")
                if c.set_mode else "the arming")
        c.log(f"engaging at t = {due_ms / 1000:.1f} s (autopilot time), {c.config.engage_after_s:g} s after "
              f"connecting, as a pilot would: {what} wait; the estimator watches the sea meanwhile")
        return
    if c.set_mode:
        mode = c.supervisor.expected_mode = c.output.required_mode
        log_result(c.log, f"mode {mode_name(mode)}", link.set_mode(mode))
    if c.arm:
        log_result(c.log, "arming", link.arm())


@dataclass(frozen=True)
class DeferredStart:
    """A mode switch (and arming) that lockstep with ``--start-at`` leaves to the first tick, and the autopilot
    mode seen when it was deferred: a different mode at the tick is someone else's choice, not to be undone."""

    mode_seen: int | None
    mode_changes_seen: int  # the supervisor's count of mode changes then: HOLD → MANUAL → HOLD is a change too
    arm: bool
    due_ms: int = 0  # autopilot time from which the switch may happen (the first tick at or after it)
    switch: bool = True  # switch the mode (--set-mode); False: only arm (--arm alone)


def _engage_ms(c: Any) -> int:
    """Autopilot time (ms) at which the operator's --set-mode/--arm take effect: ``engage_after_s`` after the first
    attitude the companion saw (its connection). (The loop ticks from ``--start-at`` on, so a deferred switch
    never happens before it either.)"""
    connected = c.events.connected_at_ms if c.events.connected_at_ms is not None else (c.state.attitude_ms or 0)
    return connected + round(c.config.engage_after_s * 1000)


def consent_lapsed(supervisor: Supervisor, stop_requested: bool) -> str | None:
    """Why the companion may no longer switch or arm on its own, or None: the run ended, a stop was asked
    for (a signal seen before the loop could end the run), or a reboot cleared the consent."""
    if supervisor.phase.final:
        return f"the run ended ({supervisor.phase.value})"
    if stop_requested:
        return "a stop was requested"
    if not supervisor.self_commanded:
        return "consent lapsed (the autopilot rebooted since the start)"
    return None


def deferred_start_refused(deferred: DeferredStart, supervisor: Supervisor, stop_requested: bool) -> str | None:
    """Why the deferred switch must not happen at the first tick, or None when it may: ``consent_lapsed``, or
    someone changed the autopilot's mode (even and back) while the companion waited."""
    lapsed = consent_lapsed(supervisor, stop_requested)
    if lapsed is not None:
        return lapsed
    if supervisor.mode != deferred.mode_seen or supervisor.mode_changes != deferred.mode_changes_seen:
        return (f"the mode changed (now {mode_name(supervisor.mode) if supervisor.mode is not None else 'none'}) "
                "while waiting: someone else's choice")
    return None


def switch_mode_at_start(c: Any, link: Link, now_ms: int) -> None:
    """The deferred end of the start, at the first tick at or after its due time: lockstep with ``--start-at``
    (the simulator holds that tick, so Rover's GUIDED starts from the same state at the same time in every run),
    or ``engage_after_s`` after connecting (the pilot's moment). Sets the output's mode (then arms, if asked)
    and waits for the heartbeat that shows it, so the step right after it commands. Refuses (and says why) when
    the switch is no longer the operator's wish."""
    deferred, c.deferred_start = c.deferred_start, None
    refused = deferred_start_refused(deferred, c.supervisor, c.stop_requested())
    mode, at = c.output.required_mode, f"at t = {now_ms / 1000:.1f} s"
    what = f"switching to {mode_name(mode)}" if deferred.switch else "arming"
    if refused is not None:
        c.log(f"not {what} {at}: {refused}")
        return
    result = mavlink.MAV_RESULT_ACCEPTED
    if deferred.switch:
        c.supervisor.expected_mode = mode
        result = link.set_mode(mode)
        log_result(c.log, f"mode {mode_name(mode)} {at}", result)
    if deferred.arm:
        lapsed = consent_lapsed(c.supervisor, c.stop_requested())  # the answer's wait ran the handlers
        if result != mavlink.MAV_RESULT_ACCEPTED or lapsed is not None:
            c.log(f"not arming {at}: " + (lapsed or f"the switch to {mode_name(mode)} was not accepted"))
            return
        log_result(c.log, f"arming {at}", link.arm())
    _await_heartbeat_in(c, link, mode if deferred.switch else None, deferred.arm)


def _await_heartbeat_in(c: Any, link: Link, mode: int | None, armed: bool) -> None:
    """Wait (at most MODE_HEARTBEAT_WAIT_S wall) for a heartbeat in ``mode`` (None: any) and armed, when the
    companion armed, so the step right after commands; ends early on a stop or an ended run."""
    def settled() -> bool:  # the heartbeat shows it, or there is nothing left to wait for
        shown = (mode is None or c.supervisor.mode == mode) and (c.supervisor.armed or not armed)
        return shown or c.supervisor.phase.final or c.stop_requested()

    deadline = time.monotonic() + MODE_HEARTBEAT_WAIT_S
    while not settled() and time.monotonic() < deadline:
        link.heartbeat_if_due()
        link.recv(0.05)
    if not settled():
        where = f"in {mode_name(mode)} " if mode is not None else ""
        c.log(f"warning: no heartbeat {'armed ' if armed else ''}{where}within {MODE_HEARTBEAT_WAIT_S:g} s of the "
              "switch")
