"""The wave estimator in a process of its own (``mavbridge.companion.wave_process``), the companion's default.

Its answers must be the estimator's own, one sample behind (a step's own ATTITUDE is not waited for), whatever
work the child did ahead of time; a child that is stopped or gone must never stall the step nor leave a stale
wave planned against for long: late answers stand in for at most a second of autopilot time, then no roll term.
These run the real child process over a real socket pair.
"""

from __future__ import annotations

import math
import os
import signal
from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest

from mavbridge.companion.flight import build_nmpc
from mavbridge.companion.start import wave_step
from mavbridge.companion.wave_gate import WaveGate, make_wave_source
from mavbridge.companion.wave_process import BATCH, STALE_S, EstimatorProcess
from mavbridge.lab.scenario import Scenario
from mavbridge.waves import EstimatorSettings, WindowEstimator
from mavbridge.waves.kinematic import KinematicBoat, motion_samples
from mavbridge.waves.source import Answers, MotionSample, WaveEstimate, decode_answers, encode_answers
from vessel import RegularWaves, otter_parameters

SYNC_S = 60.0  # where a test waits for the child's answers: returns when they come, fails only if they never do
SEA = RegularWaves(1.75, 35.0, 6.0, math.radians(-90.0), phase_rad=0.7)  # the paper's


def _samples(seconds: float, seed: int = 2) -> list[MotionSample]:
    return list(motion_samples(KinematicBoat(SEA, 1.5, lambda t: 0.4), seconds, seed=seed, t0=300.0))


@pytest.fixture
def child() -> Iterator[EstimatorProcess]:
    source = EstimatorProcess(EstimatorSettings(), wait_s=SYNC_S)  # unpaced: it waits for every answer due
    yield source
    source.close()


@pytest.fixture
def paced() -> Iterator[EstimatorProcess]:
    source = EstimatorProcess(EstimatorSettings(), wait_s=0.0)  # paced: it never waits
    yield source
    source.close()


def test_its_answers_are_the_estimators_own_one_sample_behind(child: EstimatorProcess) -> None:
    inline = WindowEstimator()
    confident = 0
    for i, sample in enumerate(_samples(40.0)):
        child.observe(sample)
        if i % 2:  # a control step every other sample, as at 20 Hz ATTITUDE and 10 Hz control
            got, want = child.estimate(sample.t_s), inline.estimate(sample.t_s)
            assert got == want, (i, got, want)
            assert child.latest(sample.t_s) == inline.latest(sample.t_s)
            for explained in (True, False):
                a, b = child.spread(explained), inline.spread(explained)
                assert (a is None and b is None) or np.array_equal(a, b), (i, explained)
            confident += got is not None
        inline.observe(sample)  # the inline one takes the sample after answering: the child's answers lag one
    assert confident > 50, confident  # the confident path was compared, not only "no wave"
    assert not any(child.faults.values()), child.faults
    assert child.cpu_s > 0.0  # the estimator's work was the child's


def test_working_the_fit_ahead_changes_no_answer() -> None:
    early, on_time = WindowEstimator(), WindowEstimator()
    worked = confident = 0
    for sample in _samples(30.0, seed=4):
        early.observe(sample)
        on_time.observe(sample)
        while early.work_ahead():  # as the child does between samples
            worked += 1
        assert early.estimate(sample.t_s) == on_time.estimate(sample.t_s)
        assert early.latest(sample.t_s) == on_time.latest(sample.t_s)
        assert early.encounter_frequency() == on_time.encounter_frequency()
        assert early.cold_starts == on_time.cold_starts
        confident += on_time.estimate(sample.t_s) is not None
    assert worked > 20 and early.fits == on_time.fits > 10 and early.cold_starts >= 1
    assert confident > 100, confident  # the confident answers were compared, not only "no wave"


def test_a_stopped_child_gives_its_last_answers_for_a_second_then_no_wave() -> None:
    lines: list[str] = []
    source = EstimatorProcess(EstimatorSettings(), wait_s=SYNC_S, log=lines.append)
    try:
        samples = _samples(40.0)
        for sample in samples[:600]:  # 30 s at 20 Hz: confident
            source.observe(sample)
        last = samples[599]
        assert source.estimate(last.t_s) is not None
        source.wait_s = 0.0  # paced: never waits
        os.kill(source.pid, signal.SIGSTOP)  # the child cannot answer from here on
        try:
            for sample in samples[600:610]:  # half a second: within STALE_S, the previous answers (same wave)
                source.observe(sample)
                assert source.estimate(sample.t_s) is not None
            assert source.faults["late"] >= 9 and not source.faults["stale"]
            later = [s for s in samples[610:] if s.t_s - last.t_s > STALE_S + 0.2][:3]
            for sample in later:
                source.observe(sample)
                assert source.estimate(sample.t_s) is None and source.spread(False) is None
            assert source.faults["stale"] == 3
        finally:
            os.kill(source.pid, signal.SIGCONT)
        source.wait_s = SYNC_S
        source.observe(samples[-1])
        assert source.latest(samples[-1].t_s) is not None  # answers again once it runs
        said = [line for line in lines if "estimator's process" in line]
        assert len(said) == 2 and "answers again" in said[-1], said  # stale once, then answers again (late: counted)
    finally:
        source.close()


def test_a_child_that_is_gone_means_no_wave_said_once_and_nothing_raises(child: EstimatorProcess) -> None:
    lines: list[str] = []
    gate = WaveGate(child, lines.append)
    samples = _samples(20.0)
    for sample in samples[:200]:
        gate.observe(sample)
    os.kill(child.pid, signal.SIGKILL)
    child._child.wait(10.0)  # gone, its end of the socket closed: the next send fails every time
    for sample in samples[200:260]:
        gate.observe(sample)  # sending to a dead child does not raise
        assert child.estimate(sample.t_s) is None and child.spread(True) is None
    assert child.faults["stopped"] >= 1
    assert sum("stopped" in line for line in lines) == 1


def test_a_call_runs_in_the_child_and_odd_samples_are_taken_as_the_estimator_takes_them(
        child: EstimatorProcess) -> None:
    assert child.call(os.getpid) == child.pid != os.getpid()
    odd = MotionSample(1.0, np.array([0.1, 0.0]), np.zeros(3), np.zeros(3), np.zeros(3))  # a 2-vector attitude
    child.observe(odd)
    child.observe(odd)
    assert child.latest(1.0) is None and child.faults["stopped"] == 0  # dropped by the estimator, as inline


def test_the_companion_factory_gives_the_process_only_when_asked() -> None:
    inline = make_wave_source("estimated", None, -1.0, 0.0, otter_parameters())
    assert isinstance(inline, WindowEstimator)
    source = make_wave_source("estimated", None, -1.0, 0.0, otter_parameters(), process=True)
    try:
        assert isinstance(source, EstimatorProcess) and source.name == inline.name
        assert source.settings == inline.s and source.settings.roll_sign == -1.0  # calibrated as the inline one
        lines: list[str] = []
        source.use_log(lines.append)
    finally:
        source.close()
    assert source._child.poll() is not None  # closed: the child has ended
    assert not any(source.faults.values()) and lines == []  # an orderly end is no fault, and nothing is said
    source.close()  # idempotent


def test_answers_that_came_before_their_step_are_kept_for_it(child: EstimatorProcess) -> None:
    """In lockstep the child often answers a step's own sample before the step asks for the one before it: that
    newer answer must wait for the next step, not be passed over (it would never come again)."""
    samples = _samples(10.0)
    for i, sample in enumerate(samples[:100]):
        child.observe(sample)
        assert child.call(os.getpid, timeout_s=SYNC_S) == child.pid  # in order: every sample so far is answered
        child.wait_s = 0.0  # so that an answer passed over shows at once as a fault
        assert child.answers().samples == i  # as of every sample but the newest, which has come too
        child.wait_s = SYNC_S
    assert not any(child.faults.values()), child.faults


def test_answers_nobody_asks_for_are_not_hoarded(child: EstimatorProcess) -> None:
    """Steps stop asking while the pilot has the boat (or at the waypoint); the samples keep coming, and what the
    companion keeps of the answers must not grow with them."""
    samples = _samples(60.0)
    for sample in samples:
        child.observe(sample)
    assert len(child._kept) <= 2
    assert child.answers().samples == len(samples) - 1 and not any(child.faults.values())


def test_no_answers_yet_is_late_not_stale_and_odd_times_do_not_stop_it() -> None:
    lines: list[str] = []
    source = EstimatorProcess(EstimatorSettings(), wait_s=0.0, log=lines.append)
    try:
        os.kill(source.pid, signal.SIGSTOP)
        try:
            for sample in _samples(2.0)[:5]:
                source.observe(sample)
                assert source.estimate(sample.t_s) is None
        finally:
            os.kill(source.pid, signal.SIGCONT)
        assert source.faults["late"] >= 1 and source.faults["stale"] == 0, source.faults
        assert not any("1 s of autopilot time" in line for line in lines), lines
        source.wait_s = SYNC_S
        nan_time = MotionSample(float("nan"), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
        source.observe(nan_time)
        source.observe(_samples(2.0)[6])
        assert source.answers().samples == 6 and source._sent_t == _samples(2.0)[6].t_s
    finally:
        source.close()


def test_answers_are_packed_as_numbers_and_come_back_equal() -> None:
    """Answers go over as packed numbers (issue 32: unpickling cost the step 30 µs paced): every field comes back
    equal; figures that are numpy numbers come back as plain floats, any other figure (text, a flag) as it was;
    answers whose numbers do not pack come back whole."""
    est = WaveEstimate(1.75, 6.0, 35.0, -1.2, 0.7, 0.9, {"mode": 3.0, "fit": np.float64(0.25), "n": 40}, -1.0)
    got = Answers(41, 12.5, est, True, (1e-4, 0.0, 0.0, 2e-4), None, 3.5)
    back = decode_answers(encode_answers(got))
    assert back == got and type(back.latest.extras["fit"]) is float
    for extras in ({"label": "1"}, {"flag": True}):
        odd = replace(got, latest=replace(est, extras=extras), confident=False, spread_alone=(1.0,) * 4)
        assert decode_answers(encode_answers(odd)).latest.extras == extras
        assert type(next(iter(decode_answers(encode_answers(odd)).latest.extras.values()))) is type(
            next(iter(extras.values())))
    unpackable = replace(got, latest=replace(est, confidence=None), spread_explained=())
    assert decode_answers(encode_answers(unpackable)) == unpackable
    nothing = Answers(3, 0.5)
    assert decode_answers(encode_answers(nothing)) == nothing


def test_paced_answers_as_of_the_last_steps_samples_are_in_time() -> None:
    """The loop reads a period's messages together, so a step's two samples go to the child at once: answers as
    of the previous step's samples are in time (no fault); older ones are late."""
    source = EstimatorProcess(EstimatorSettings(), wait_s=SYNC_S)
    try:
        samples = _samples(10.0)
        for sample in samples[:40]:
            source.observe(sample)
        assert source.answers().samples == 39
        assert source.call(os.getpid, timeout_s=SYNC_S) == source.pid  # in order: all 40 answered
        source.wait_s = 0.0  # paced
        os.kill(source.pid, signal.SIGSTOP)  # no answer from here on
        try:
            source.observe(samples[40])  # a period's two samples, read together before the step
            source.observe(samples[41])
            assert source.answers().samples == 40 and not any(source.faults.values()), source.faults
            source.flush()  # (the step's command is out: its samples go)
            source.observe(samples[42])
            source.observe(samples[43])
            assert source.answers().samples == 40 and source.faults["late"] == 1, source.faults  # not as of 42
        finally:
            os.kill(source.pid, signal.SIGCONT)
    finally:
        source.close()


def test_paced_samples_go_to_the_child_together_after_the_steps_command(paced: EstimatorProcess) -> None:
    """Paced, a period's samples are held and sent as one message once the step's command is out (``flush``: a
    socket call costs a paced step tens of microseconds, and the command need not wait for it); the child answers
    once, after the last, and those answers are the estimator's own as of the previous step's samples."""
    source = paced
    inline, confident = WindowEstimator(), 0
    samples = _samples(40.0)
    for i, sample in enumerate(samples):
        source.observe(sample)
        if i % 2 == 0:
            assert len(source._held.packed) == 1 and source._sent == i  # held, not sent
            continue
        got = source.estimate(sample.t_s)  # the step: answers as of the last step's samples; its own still held
        assert len(source._held.packed) == 2 and source._sent == i - 1
        source.flush()  # the command is out: both samples go now
        assert source._held.packed == [] and source._sent == i + 1
        asked = source.answers().samples
        assert asked == max(i - 1, 0) or (i == 1 and asked == 0), (i, asked)
        want = inline.estimate(samples[i - 2].t_s) if i > 1 else None
        assert got == want, (i, got, want)
        confident += got is not None
        inline.observe(samples[i - 1])
        inline.observe(sample)
        assert source.call(os.getpid, timeout_s=SYNC_S) == source.pid  # in order: this batch is answered
    source._take_waiting()
    assert [count for count, _ in source._kept] == [len(samples)]  # one answer a batch: none as of an odd count
    assert confident > 50, confident
    assert source.faults == {"late": 1, "stale": 0, "stopped": 0, "dropped": 0}  # (the first step: none yet)


def test_paced_samples_nobody_asks_for_go_in_batches_and_their_answers_are_read(paced: EstimatorProcess) -> None:
    source = paced
    samples = _samples(30.0)
    for sample in samples[:BATCH * 3 + 5]:
        source.observe(sample)
    assert source._sent == BATCH * 3 and len(source._held.packed) == 5
    assert source.call(os.getpid, timeout_s=SYNC_S) == source.pid  # (a call sends the held samples first)
    assert source._sent == BATCH * 3 + 5 and source._held.packed == []
    source._take_waiting()
    assert len(source._kept) <= 2 and source._kept[-1][0] == BATCH * 3 + 5
    assert not any(source.faults.values()), source.faults


def test_a_step_after_a_spell_without_questions_gets_the_last_batchs_answers(paced: EstimatorProcess) -> None:
    """While the pilot has the boat nobody asks; the samples go in batches of BATCH. The first step after that must
    read on to the answers as of the last batch sent, not stop at an older one (it would be over a second old:
    stale, and no roll term on the step that engages)."""
    lines: list[str] = []
    source = paced
    source.use_log(lines.append)
    samples = _samples(40.0)
    for i, sample in enumerate(samples[:40]):  # steps asking every other sample
        source.observe(sample)
        if i % 2:
            source.answers()
            source.flush()
            assert source.call(os.getpid, timeout_s=SYNC_S) == source.pid
    for sample in samples[40:40 + BATCH * 12 + 10]:  # then nobody asks: 12 batches sent, 10 samples held
        source.observe(sample)
    last_batch = 40 + BATCH * 12
    assert source._sent == last_batch and len(source._held.packed) == 10
    while not (source._kept and source._kept[-1][0] >= last_batch - BATCH):  # the one before it read, and
        assert source._ready(SYNC_S, write=False)  # ... (answers come in order) only that one:
        source._take_waiting(until=last_batch - BATCH)
    assert source._kept[-1][0] < last_batch  # (not read yet: observe's read came before them)
    assert source._ready(SYNC_S, write=False)  # the last batch's answers wait, unread
    got = source.answers()
    assert got.samples == last_batch, got.samples
    assert source.faults == {"late": 1, "stale": 0, "stopped": 0, "dropped": 0}, source.faults  # (1: the first)
    assert lines == []


def test_samples_held_while_paced_go_first_when_it_waits_again(paced: EstimatorProcess) -> None:
    source = paced
    samples = _samples(5.0)
    for sample in samples[:3]:
        source.observe(sample)  # held
    source.wait_s = SYNC_S  # (lockstep from here: every answer waited for)
    source.observe(samples[3])  # the three held go first; this one alone, answered as itself
    assert source.answers().samples == 3 and not any(source.faults.values()), source.faults
    source.observe(samples[4])
    assert source.answers().samples == 4 and not any(source.faults.values()), source.faults


def test_a_steps_samples_not_sent_after_its_command_go_at_the_next_question_late(paced: EstimatorProcess) -> None:
    """Should a step's samples not go after its command (``flush`` not called), the next step's question sends
    them: its answers are as of what had gone before (the ones due), and the lost period is a ``late`` fault."""
    source = paced
    samples = _samples(5.0)
    for sample in samples[:2]:
        source.observe(sample)
    source.answers()  # a step (none yet: late) ...
    source.flush()  # ... whose command went out
    assert source.call(os.getpid, timeout_s=SYNC_S) == source.pid  # (its samples answered)
    source.observe(samples[2])
    source.observe(samples[3])
    assert source.answers().samples == 2 and source.faults["late"] == 1, source.faults  # in time; no flush after it
    source.observe(samples[4])
    source.observe(samples[5])
    assert source.answers().samples == 2 and source.faults["late"] == 2, source.faults  # its samples a period late
    assert source._sent == 6 and source._held.packed == []  # (all four went at this question)
    assert source.call(os.getpid, timeout_s=SYNC_S) == source.pid
    source.observe(samples[6])
    source.observe(samples[7])
    assert source.answers().samples == 6 and source.faults["late"] == 2, source.faults  # back in step


def test_the_gate_sends_the_held_samples_once_the_command_is_out(paced: EstimatorProcess) -> None:
    """``WaveGate.command_sent`` (called by the companion after each command) sends the period's samples; their cost
    is the next step's."""
    gate = WaveGate(paced, log=lambda _line: None)
    for sample in _samples(1.0)[:2]:
        gate.observe(sample)
    assert len(paced._held.packed) == 2 and paced._sent == 0
    gate.command_sent()
    assert paced._held.packed == [] and paced._sent == 2 and gate._observe_s > 0.0


def _answered(source: EstimatorProcess) -> None:
    """Wait until the child has answered every sample sent (without sending the held ones, as ``call`` would)."""
    while not (source._kept and source._kept[-1][0] >= source._sent):
        assert source._ready(SYNC_S, write=False), "the child did not answer"
        source._take_waiting()


def test_the_watch_before_engaging_sends_what_it_asked_about(paced: EstimatorProcess) -> None:
    """Before engaging the gate asks every 0.1 s whether the sea is known (until it is), and no step's command
    follows to send the samples: the watch sends them itself. Its answers are then as of every sample sent before it
    asked, and none is late."""
    gate = WaveGate(paced, log=lambda _line: None)
    asked: list[tuple[int, int]] = []  # (samples sent before the question, samples its answers are as of)
    for sample in _samples(20.0)[:300]:
        gate.observe(sample)
        before = paced._sent
        gate.watch(sample.t_s)
        if paced._sent > before:  # it asked: what it asked about has gone
            assert paced._held.packed == []
            asked.append((before, paced._chosen[1].samples))
            _answered(paced)
    assert gate.watched_confident_s is not None and len(asked) >= 20, len(asked)
    assert all(got == before for before, got in asked), asked
    assert not any(paced.faults.values()), paced.faults


def test_the_cold_solve_sends_what_it_asked_about(paced: EstimatorProcess) -> None:
    """The cold solve before the loop (``start.wave_step``) asks with no command after it: it sends what it asked
    about, so the first step's answers are as of those samples, with no fault."""
    scenario = Scenario(name="balanced")
    samples = _samples(5.0)
    with build_nmpc(replace(scenario, controller=scenario.controller.replace(horizon=5)), paced) as nmpc:
        for sample in samples[:3]:
            paced.observe(sample)
        wave_step(paced, nmpc, samples[2].t_s)  # (late: nothing answered yet)
    assert paced._held.packed == [] and paced._sent == 3
    _answered(paced)
    faults = dict(paced.faults)
    for sample in samples[3:5]:
        paced.observe(sample)
    assert paced.answers().samples == 3 and paced.faults == faults, paced.faults


def test_a_batch_dropped_after_a_step_leaves_no_late_fault_behind(paced: EstimatorProcess) -> None:
    """A step's samples the child had no room for after its command are dropped (and counted so); the next step
    must neither wait for answers as of them, which can never come (a late fault), nor take the last step's answers
    again for its own (a drop leaves as many sent as before)."""
    source, samples = paced, iter(_samples(120.0))
    os.kill(source.pid, signal.SIGSTOP)  # the socket fills
    try:
        while not source.faults["dropped"]:
            source.observe(next(samples))
        for _ in range(2):  # a step while it is full: its question, then its samples after its command
            source.observe(next(samples))
        source.answers()
        dropped, late = source.faults["dropped"], source.faults["late"]
        source.flush()
        assert source.faults["dropped"] == dropped + 2, source.faults
    finally:
        os.kill(source.pid, signal.SIGCONT)
    _answered(source)
    sent = source._sent
    for _ in range(2):
        source.observe(next(samples))
    assert source.answers().samples == sent and source.faults["late"] == late, source.faults
