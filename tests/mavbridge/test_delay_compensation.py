"""Delay compensation: the clock model, the command history, the predictor against the NMPC's model, the
compensator's three modes, and the settings' range checks."""

from __future__ import annotations

import math
import random
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavbridge.companion.config import load_companion_config
from mavbridge.companion.delay import FLOOD_WINDOW_S, PAUSE_MARGIN_S, DelayCompensator
from mavbridge.companion.predict import CommandHistory, StatePredictor
from mavbridge.link.clock_model import ClockModel
from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.problem import NO_DISTURBANCE, discrete_model
from mavbridge.nmpc.wave_model import wave_parameters
from vessel import ConfigError, OceanCurrent, RegularWaves, otter_parameters

RATE = 5.0  # autopilot seconds per wall second (a simulator at --speedup 5)


def feed(clock: ClockModel, delay_s: float, jitter_s: float, seconds: float = 4.0, seed: int = 1,
         boot_s: float = 100.0) -> float:
    """Arrivals every 10 ms of wall time, stamped when sent, arriving ``delay_s`` + U(0, jitter_s) later; returns
    the wall time of the last send."""
    rng = random.Random(seed)
    sent = 0.0
    for i in range(int(seconds / 0.01)):
        sent = i * 0.01
        clock.observe(sent + delay_s + rng.uniform(0.0, jitter_s), boot_s + RATE * sent)
    return sent


def test_clock_fits_the_rate_and_the_fastest_arrival() -> None:
    clock = ClockModel()
    last = feed(clock, 0.08, 0.04)
    wall = last + 0.1
    true_now = 100.0 + RATE * wall
    assert clock.now_s(wall) == pytest.approx(true_now - RATE * 0.08, abs=0.02)  # one-way only: delay unseen
    assert clock.rate == pytest.approx(RATE, rel=0.01)
    clock.observe_round_trip(10.0, 10.16)  # 80 ms each way
    clock.observe_round_trip(11.0, 11.30)  # a slow one: the smallest is kept
    assert clock.one_way_delay_s() == pytest.approx(clock.rate * 0.08)  # half the smallest round trip
    assert clock.now_s(wall) == pytest.approx(true_now, abs=0.02)
    assert clock.age_s(true_now + 1.0, wall) == 0.0  # never negative


def test_between_full_fits_only_a_faster_sample_moves_the_clock() -> None:
    """The refit runs at most every REFIT_S of arrivals; in between, a sample that came faster than any before
    moves the offset at once (a slower one does nothing), and after a reboot the fit starts again at once."""
    clock = ClockModel()
    last = feed(clock, 0.05, 0.0)
    before = clock.now_s(last)
    rate = clock.rate
    clock.observe(last + 0.06, 100.0 + RATE * (last + 0.01))  # 10 ms more late than the rest: no change
    assert clock.now_s(last) == pytest.approx(before) and clock.rate == rate
    clock.observe(last + 0.07, 100.0 + RATE * (last + 0.04))  # 20 ms faster than the rest: at once
    assert clock.now_s(last) == pytest.approx(before + RATE * 0.02)
    assert clock.rate == rate  # no refit within REFIT_S
    for i in range(1, 40):  # REFIT_S later at a new rate: a refit
        wall = last + 0.07 + 0.01 * i
        clock.observe(wall, 100.0 + RATE * (last + 0.04) + 2 * RATE * 0.01 * i)
    clock.now_s(wall)
    assert clock.rate != rate
    clock.observe(wall + 0.01, 1.0)  # a reboot: autopilot time starts again
    assert clock.now_s(wall + 0.01) == pytest.approx(1.0, abs=0.05)


def test_a_period_in_wall_seconds_follows_the_fitted_rate_never_above_real_time() -> None:
    """The companion's step deadline: a 0.1 s period of autopilot time is 20 ms of wall time at --speedup 5, and
    never more than 0.1 s (an unfitted clock, or one that seems slower than the wall)."""
    comp = DelayCompensator(True, False, 1.0, None)
    assert comp.wall_seconds(0.1) == pytest.approx(0.1)  # not fitted yet: rate 1
    feed(comp.clock, 0.01, 0.002)
    comp.clock.now_s(5.0)  # the fit runs when asked
    assert comp.wall_seconds(0.1) == pytest.approx(0.1 / RATE, rel=0.01)
    comp.clock.rate = 0.5
    assert comp.wall_seconds(0.1) == pytest.approx(0.1)


def test_clock_starts_again_after_a_reboot_and_ignores_a_stamp_far_ahead() -> None:
    clock = ClockModel()
    feed(clock, 0.0, 0.0, boot_s=500.0)
    clock.observe_round_trip(0.0, 0.1)
    clock.now_s(4.0)  # (the companion asks every control step; the check uses the last fit)
    clock.observe(4.0, 1e6)  # a forged or corrupt stamp
    assert clock.rejected == 1
    feed(clock, 0.0, 0.0, seconds=1.0, boot_s=0.0)  # time_boot_ms back to 0: a new boot
    assert clock.round_trip_s is None
    assert clock.now_s(1.0) == pytest.approx(RATE * 1.0, abs=0.05)
    with pytest.raises(ValueError, match="no time-stamped message"):
        ClockModel().now_s(0.0)


def test_history_gives_the_command_in_effect_on_each_piece() -> None:
    history = CommandHistory()
    assert [(a, b, list(t)) for a, b, t in history.segments(0.0, 1.0)] == [(0.0, 1.0, [0.0, 0.0])]
    history.add(1.0, np.array([10.0, 1.0]))
    history.add(1.1, np.array([20.0, 2.0]))
    history.add(1.5, np.array([30.0, 3.0]))
    pieces = [(a, b, list(t)) for a, b, t in history.segments(1.05, 1.6)]
    assert pieces == [(1.05, 1.1, [10.0, 1.0]), (1.1, 1.5, [20.0, 2.0]), (1.5, 1.6, [30.0, 3.0])]
    history.add(0.2, np.array([1.0, 0.0]))  # a new boot's clock: the old commands are forgotten
    assert len(history.entries) == 1


def test_history_read_from_the_newest_is_the_whole_history_read() -> None:
    """``segments`` reads back from the newest command (issue 32): the same pieces as reading every command, in
    random histories with repeated times, windows before, inside and after them, and empty ones."""
    rng = random.Random(1)
    for _ in range(2000):
        history, t = CommandHistory(), 0.0
        for _ in range(rng.randint(0, 80)):
            t += rng.choice([0.0, 0.05, 0.1, 0.3])
            history.add(t, np.array([rng.random(), rng.random()]))
        t0 = rng.uniform(-1.0, t + 1.0)
        t1 = t0 + rng.choice([0.0, 0.05, 0.2, 5.0])
        current, pieces, start = np.zeros(2), [], t0
        for when, tau in history.entries:
            current = tau if when <= t0 else current
        for when, tau in history.entries:
            if t0 < when < t1:
                pieces.append((start, when, current))
                start, current = when, tau
        pieces.append((start, t1, current))
        want = [(a, b, list(tau)) for a, b, tau in pieces if b > a]
        assert [(a, b, list(tau)) for a, b, tau in history.segments(t0, t1)] == want, (t0, t1)


@pytest.mark.parametrize("wave", [None, RegularWaves(height_m=1.75, length_m=20.0, travel_dir_rad=0.7)],
                         ids=["calm", "regular"])
def test_prediction_over_one_period_is_the_nmpcs_own_model_step(wave: RegularWaves | None) -> None:
    """The NMPC's model integrated by RK4 in its two 0.05 s substeps (the predictor's steps; the NMPC's own
    default integrator is Euler, coarser on the stiff heave) gives the predictor's state."""
    params, current = otter_parameters("published"), OceanCurrent()
    cfg = NmpcConfig().replace(integrator="rk4", substeps=2)
    step = discrete_model(params, None, current, cfg)
    predictor = StatePredictor(params, current)
    x = np.array([1.0, 2.0, 0.01, 0.05, -0.02, 0.3, 1.2, 0.1, 0.0, 0.02, 0.01, -0.05])
    tau = np.array([80.0, 5.0])
    history = CommandHistory()
    history.add(0.0, tau)
    expected = np.asarray(step(x, tau, 3.0, np.concatenate([wave_parameters(wave), NO_DISTURBANCE]))).ravel()
    predicted = predictor.predict(x, 3.0, 3.0 + cfg.period_s, history, wave)
    assert np.allclose(predicted, expected, rtol=1e-9, atol=1e-9), predicted - expected
    assert not np.allclose(predicted, x, atol=1e-3)  # it did move the boat
    assert np.array_equal(predictor.predict(x, 3.0, 3.0, history, wave), x)  # no time, no change
    disturbance = np.array([0.3, -0.4, 0.0, 2.0])  # the NMPC's estimated current and yaw moment are predicted with
    expected = np.asarray(step(x, tau, 3.0, np.concatenate([wave_parameters(wave), disturbance]))).ravel()
    predicted = predictor.predict(x, 3.0, 3.0 + cfg.period_s, history, wave, disturbance)
    assert np.allclose(predicted, expected, rtol=1e-9, atol=1e-9) and predicted[1] < step(x, tau, 3.0, np.concatenate(
        [wave_parameters(wave), NO_DISTURBANCE])).full().ravel()[1]  # the current to the West moved it West


def arrivals(comp: DelayCompensator, boot_s: float = 50.0) -> None:
    """The second of arrivals (rate 1, no delay) that ended just now: stamps boot_s .. boot_s + 0.95."""
    now = time.monotonic()
    for i in range(20):
        comp.clock.observe(now - 1.0 + i * 0.05, boot_s + i * 0.05)


def test_compensator_modes_lockstep_off_on_and_the_prediction_limit() -> None:
    lockstep = DelayCompensator(True, True, 1.0, None)
    arrivals(lockstep)
    assert lockstep.compensate(50.0) == (0.0, 50.0)  # time waits for the command: age zero by construction
    off = DelayCompensator(False, False, 1.0, None)
    arrivals(off)
    age, plan = off.compensate(50.5)
    assert age > 0.4 and plan == 50.5  # measured, not acted on
    params, current = otter_parameters("published"), OceanCurrent()
    on = DelayCompensator(True, False, 1.0, StatePredictor(params, current))
    arrivals(on)
    on.clock.observe_round_trip(0.0, 0.4)  # 0.2 s each way
    age, plan = on.compensate(50.5)
    assert plan == pytest.approx(50.5 + age + 0.2, abs=1e-6)
    limited = DelayCompensator(True, False, 0.3, StatePredictor(params, current))
    arrivals(limited)
    assert limited.compensate(50.0)[1] == pytest.approx(50.3)
    summary = on.summary()
    assert summary["compensation"] == "on" and summary["state_age_s_median"] == pytest.approx(age, abs=1e-4)


def test_the_command_delay_is_the_states_age_plus_the_uplinks_delay_and_none_in_lockstep() -> None:
    """What the identification's brake is told: measured where a real boat's companion measures it."""
    lockstep = DelayCompensator(True, True, 1.0, None)
    arrivals(lockstep)
    assert lockstep.command_delay_s(50.5) is None
    assert DelayCompensator(False, False, 1.0, None).command_delay_s(50.5) is None  # no arrival yet
    comp = DelayCompensator(False, False, 1.0, None)
    arrivals(comp)
    without = comp.command_delay_s(50.5)
    comp.clock.observe_round_trip(0.0, 0.4)  # 0.2 s each way (the clock's now moves on by it too)
    with_round_trip = comp.command_delay_s(50.5)
    assert without is not None and with_round_trip is not None
    assert without == pytest.approx(comp.ages_s[0], abs=1e-9) and without > 0.4
    assert with_round_trip == pytest.approx(comp.ages_s[1] + 0.2, abs=1e-9)
    assert with_round_trip - without == pytest.approx(0.4, abs=0.01)  # the age grows by the downlink's 0.2 s too


def test_only_the_answer_to_our_own_timesync_counts() -> None:
    comp = DelayCompensator(True, False, 1.0, None)
    comp._pending.append(123)
    comp.on_message(mavlink.MAVLink_timesync_message(tc1=0, ts1=123))  # a request, not an answer
    comp.on_message(mavlink.MAVLink_timesync_message(tc1=5, ts1=999))  # someone else's
    assert comp.clock.round_trip_s is None
    comp.on_message(mavlink.MAVLink_timesync_message(tc1=5, ts1=123))
    assert comp.clock.round_trip_s is not None


@pytest.mark.parametrize("field, value", [("max_prediction_s", 6.0), ("max_prediction_s", -0.1),
                                          ("delay_compensation", "yes")])
def test_settings_are_range_checked(field: str, value: object) -> None:
    with pytest.raises(ConfigError, match=field):
        load_companion_config(None, **{field: value})


def test_bad_yaml_field_is_one_line_and_exit_2(tmp_path: Path) -> None:
    config = tmp_path / "companion.yaml"
    config.write_text("max_prediction_s: 9\n")
    done = subprocess.run([sys.executable, "-m", "mavbridge.cli", "run", "--config", str(config), "--out",
                           str(tmp_path / "never")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "max_prediction_s" in done.stderr and "[0, 5] s" in done.stderr


@pytest.mark.parametrize("rate", [1.0, RATE])
def test_running_fit_matches_a_full_pass_over_the_window(rate: float) -> None:
    """The rate and offset kept per arrival (issue 32: no pass over the window in a control step) against the exact
    fit over the window, every refit of a 10-minute stream at 30 Hz with exponential jitter and 20 ms spikes, from
    the first fit: the rate the same to rounding once the window is full, the offset within 0.2 ms of wall time."""
    rng = random.Random(3)
    clock = ClockModel()
    rate_errors, offset_errors = [], []
    for i in range(600 * 30):
        sent = i / 30
        wall = 50.0 + sent + 0.002 + rng.expovariate(1 / 0.002) + (0.02 if rng.random() < 0.01 else 0.0)
        clock.observe(wall, 200.0 + rate * sent)
        fitted = clock._fitted_wall_s
        clock.now_s(wall)
        if clock._fitted_wall_s == fitted:
            continue
        w, a = (np.array(column) for column in zip(*clock.samples, strict=True))
        offset_errors.append(abs(-float(np.min(clock.rate * w - a)) - clock.offset_s) / rate)
        if sent > 10.0:
            centred = w - w.mean()
            rate_errors.append(abs(float(np.dot(centred, a - a.mean()) / np.dot(centred, centred)) - clock.rate))
    assert len(offset_errors) > 2000  # every REFIT_S of ten minutes
    assert max(rate_errors) < 1e-9 * rate
    assert max(offset_errors[40:]) < 2e-4  # (the first seconds, while the rate is found, err more: below)
    assert max(offset_errors) < 2e-3


def test_the_running_fit_survives_arrivals_out_of_order_and_reboots() -> None:
    """A reboot, then wall times out of order by more than the window (the first bucket's fastest sample leaves
    the window at once): the sums stay the window's, the clock finite, and nothing is rejected."""
    clock = ClockModel()
    feed(clock, 0.0, 0.0)
    for wall, stamp in ((120.0, 70.0), (105.0, 70.01), (120.1, 70.1)):  # (a reboot: 70 s, the clock was at 120)
        clock.observe(wall, stamp)
        assert clock._sums.n == len(clock.samples)
    for wall, stamp in ((120.15, 70.15), (120.3, 70.3), (121.0, 71.0), (190.0, 1.1), (200.5, 1.5)):
        assert math.isfinite(clock.now_s(wall))
        clock.observe(wall, stamp)
        assert clock._sums.n == len(clock.samples)
    assert clock.rejected == 0


def assert_rests_until(comp: DelayCompensator, next_tick_s: float, longest_s: float, wake_s: float) -> None:
    """The rest asked for now ends at ``wake_s`` (monotonic s; none if past), at most ``longest_s`` from now: within
    what the clock moved while it was asked, however slowly the test runs."""
    before = time.monotonic()
    rest = comp.pause_s(next_tick_s, longest_s)
    after = time.monotonic()

    def expected(at: float) -> float:
        return min(longest_s, max(0.0, wake_s - at))

    assert expected(after) <= rest <= expected(before), (rest, wake_s - before, wake_s - after)


def test_the_loop_rests_until_the_next_tick_can_arrive_and_no_longer() -> None:
    """The rest ends PAUSE_MARGIN_S before the earliest wall time the next tick's ATTITUDE can arrive (the fastest
    arrival's line, at the tick plus the smallest recent lag), never beyond ``longest_s``, and is 0 once that time
    has passed."""
    comp = DelayCompensator(True, False, 1.0, None)
    assert comp.pause_s(51.0, 0.1) == 0.0  # no arrival yet: read at once
    now = time.monotonic()
    for i in range(100):  # a second of arrivals at rate 1, 5 ms late, the newest stamped 50.99 just now
        comp.clock.observe(now - 0.99 + i * 0.01 + 0.005, 50.0 + i * 0.01)
    arrival = comp.clock.earliest_arrival_s(51.04)
    assert arrival == pytest.approx(now + 0.055, abs=1e-6)
    assert_rests_until(comp, 51.04, 0.1, arrival - PAUSE_MARGIN_S)
    assert comp.pause_s(51.04, 0.01) <= 0.01  # never longer than asked
    assert comp.pause_s(50.5, 0.1) == 0.0  # that tick's messages can be here already
    assert comp.pause_s(None, 0.1) == 0.0  # no tick yet
    comp.ticked(0.02)  # the ATTITUDE that made a step due came 20 ms past its tick, the next one 7 ms past
    comp.ticked(0.007)
    assert_rests_until(comp, 51.04, 0.1, arrival + 0.007 - PAUSE_MARGIN_S)  # the next ATTITUDE: smallest lag later
    comp.overslept(0.003)  # a rest ended 3 ms late (a busy computer): the next ones end that much earlier
    comp.overslept(-0.001)  # (early counts as on time)
    assert_rests_until(comp, 51.04, 0.1, arrival + 0.007 - PAUSE_MARGIN_S - 0.003)
    comp.overslept(0.09)  # a rare long one (a blocked write) counts at most half the longest rest: rests go on
    assert_rests_until(comp, 51.04, 0.1, arrival + 0.007 - PAUSE_MARGIN_S - 0.05)
    fresh = DelayCompensator(True, False, 1.0, None)  # a lag is rested at most half of the longest rest
    now = time.monotonic()
    for i in range(100):
        fresh.clock.observe(now - 0.99 + i * 0.01 + 0.005, 50.0 + i * 0.01)
    fresh.ticked(0.015)
    assert_rests_until(fresh, 50.99, 0.02, fresh.clock.earliest_arrival_s(50.99) + 0.01 - PAUSE_MARGIN_S)
    lockstep = DelayCompensator(True, True, 1.0, None)
    for i in range(100):
        lockstep.clock.observe(now - 0.99 + i * 0.01, 50.0 + i * 0.01)
    assert lockstep.pause_s(51.04, 0.1) == 0.0  # the autopilot waits for the command: never rest


def test_no_rest_before_the_rate_is_fitted_nor_while_a_round_trip_is_out() -> None:
    """A simulator's speedup is unknown until MIN_SPAN_S of arrivals (a rest at rate 1 would be ten ticks at
    --speedup 10); a TIMESYNC answer is timed on its arrival, so the loop reads at once while ours is out."""
    comp = DelayCompensator(True, False, 1.0, None)
    now = time.monotonic()
    for i in range(20):  # 0.2 s of arrivals: under MIN_SPAN_S
        comp.clock.observe(now - 0.2 + i * 0.01, 50.0 + i * 0.01)
    assert comp.pause_s(50.25, 0.1) == 0.0 and not comp.clock.rate_fitted
    for i in range(20, 100):
        comp.clock.observe(now - 0.2 + i * 0.01, 50.0 + i * 0.01)
    comp.clock.now_s()  # (the fit runs when asked)
    assert comp.clock.rate_fitted
    tick = 51.5  # half a second ahead: a rest, however slowly the test runs
    assert comp.pause_s(tick, 0.1) > 0.0
    comp._pending.append(777)  # our request, just sent
    comp._last_stamp, comp._last_request = 777, time.monotonic()
    assert comp.pause_s(tick, 0.1) == 0.0
    comp.on_message(mavlink.MAVLink_timesync_message(tc1=5, ts1=777))  # its answer
    assert comp.clock.round_trip_s is not None and comp.pause_s(tick, 0.1) > 0.0
    comp.clock.observe(now + 1.0, 1.0)  # the autopilot rebooted: its rate is unknown again
    assert not comp.clock.rate_fitted and comp.pause_s(1.05, 0.1) == 0.0


def test_what_waited_in_the_socket_is_not_timed() -> None:
    """After a rest (or a long step) the loop reads what waited in the socket: when it came is unknown, so it
    does not move the clock model (the rest's own lateness would move its line, and the next rest, later). A
    TIMESYNC answer still times its round trip: no rest while it is awaited, so at most the read's own wait."""
    comp = DelayCompensator(True, False, 1.0, None)
    comp.backlog = True
    comp.on_message(mavlink.MAVLink_attitude_message(5000, 0, 0, 0, 0, 0, 0))
    assert not comp.clock.ready()
    comp._pending.append(321)
    comp._last_stamp, comp._last_request = 321, time.monotonic()
    comp._pending.append(320)  # an older request's answer read with the backlog: it may have waited a rest
    comp.on_message(mavlink.MAVLink_timesync_message(tc1=5, ts1=320))
    assert comp.clock.round_trip_s is None and 320 not in comp._pending
    comp.on_message(mavlink.MAVLink_timesync_message(tc1=5, ts1=321))  # the newest, while the loop reads at once
    assert comp.clock.round_trip_s is not None and 321 not in comp._pending
    comp.backlog = False
    comp.on_message(mavlink.MAVLink_attitude_message(5100, 0, 0, 0, 0, 0, 0))
    assert comp.clock.ready() and comp.clock.samples[-1][1] == pytest.approx(5.1)


def test_no_rest_once_nothing_was_timed_for_two_periods() -> None:
    """If every rest ended after the tick's messages came (the link became faster than the model's line), nothing
    would be timed again and the line would stay behind: after two periods without a timed arrival the loop reads
    at once, and the next arrival moves the line."""
    comp = DelayCompensator(True, False, 1.0, None)
    now = time.monotonic()
    for i in range(100):  # a second of arrivals that ended half a second ago
        comp.clock.observe(now - 1.5 + i * 0.01, 50.0 + i * 0.01)
    assert comp.pause_s(52.0, 0.1) == 0.0
    comp.clock.observe(time.monotonic(), 51.5)
    assert comp.pause_s(52.0, 1.0) > 0.0  # (a 1 s period: timed within two, however slowly the test runs)


def test_a_flood_stops_the_rests_until_a_window_without_one() -> None:
    """Refused messages (foreign, bad, ...): more than FLOOD_READ in one read stops the rests at once; a steady
    flood too slow for that in any one read (the reads come fast once the loop does not rest) keeps them stopped
    while a window refuses more than FLOOD_READ a period on average; a window without ends it."""
    comp, period = DelayCompensator(True, False, 1.0, None), 0.1
    comp.judge_flood(5, 0, period, 100.0)  # the first read: a window begins
    assert not comp.flooding
    comp.judge_flood(45, 5, period, 100.1)  # 40 in one read
    assert comp.flooding
    total, now = 45, 100.1
    while now < 100.1 + FLOOD_WINDOW_S:  # 10 in each read every 2 ms: 5000 a second, never 32 in one read
        now += 0.002
        comp.judge_flood(total + 10, total, period, now)
        total += 10
        assert comp.flooding
    for _ in range(int(FLOOD_WINDOW_S / 0.05) + 1):  # a window of a stray one every 50 ms (20 a second)
        now += 0.05
        comp.judge_flood(total + 1, total, period, now)
        total += 1
    assert not comp.flooding
