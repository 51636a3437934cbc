"""asrti's and nrti's background thread (``mavbridge.nmpc.solvers.worker``): what a one-thread executor gives."""

from __future__ import annotations

import threading
from concurrent.futures import CancelledError
from concurrent.futures import TimeoutError as FuturesTimeout

import numpy as np
import pytest

from mavbridge.nmpc.layout import PARAMS
from mavbridge.nmpc.solvers.worker import InlineWorker, Job, Worker

WAIT_S = 60.0  # the longest a test waits for an event: returns as soon as it happens


def test_jobs_run_in_order_on_one_thread_and_results_wait_for_them() -> None:
    worker = Worker("test")
    gate, ran = threading.Event(), []
    try:
        first = worker.submit(lambda: (gate.wait(WAIT_S), ran.append(threading.current_thread().name))[1])
        second = worker.submit(lambda x: ran.append(x) or x * 2, 21)
        with pytest.raises(FuturesTimeout):
            second.result(timeout=0.0)  # the first still holds the thread
        assert not first.done() and not second.done()
        gate.set()
        assert second.result(timeout=WAIT_S) == 42 and first.done()
        assert ran == ["test", 21]
        assert second.result() == 42  # asked again: the same answer
    finally:
        worker.shutdown()


def test_a_jobs_exception_is_the_takers_and_the_thread_goes_on() -> None:
    worker = Worker("test")
    try:
        failing = worker.submit(lambda: 1 / 0)
        with pytest.raises(ZeroDivisionError):
            failing.result(timeout=WAIT_S)
        assert worker.submit(int, "7").result(timeout=WAIT_S) == 7
    finally:
        worker.shutdown()


def test_shutdown_ends_the_thread_after_its_job_and_drops_the_rest_when_told() -> None:
    worker = Worker("test")
    started, gate = threading.Event(), threading.Event()
    running = worker.submit(lambda: (started.set(), gate.wait(WAIT_S))[1])
    queued = worker.submit(int, "1")
    assert started.wait(WAIT_S)
    worker.shutdown(wait=False, cancel_futures=True)  # the queued job dropped now, the running one left to end
    gate.set()
    worker._thread.join(WAIT_S)
    assert not worker._thread.is_alive()
    assert running.result(timeout=0.0) is True and queued.done()
    with pytest.raises(CancelledError):
        queued.result()
    with pytest.raises(RuntimeError, match="after shutdown"):
        worker.submit(int)
    worker.shutdown()  # again: nothing


def test_a_finished_job_holds_its_value() -> None:
    assert Job.finished((1, 2)).result(timeout=0.0) == (1, 2)


def test_an_inline_job_runs_on_the_takers_thread_when_taken_and_only_then() -> None:
    worker, ran = InlineWorker(), []
    job = worker.submit(lambda x: ran.append(threading.current_thread().name) or x * 2, 21)
    assert ran == [] and job.done()  # kept, not run: ready whenever it is asked for
    assert job.result(timeout=0.0) == 42 and ran == [threading.current_thread().name]
    assert job.result() == 42 and len(ran) == 1  # asked again: the same answer, not a second run
    failing = worker.submit(lambda: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        failing.result()
    dropped = worker.submit(ran.append, "never")
    dropped.cancel()
    with pytest.raises(CancelledError):
        dropped.result()
    worker.shutdown()
    assert "never" not in ran
    with pytest.raises(RuntimeError, match="after shutdown"):
        worker.submit(int, "7")


def test_in_process_runs_prepare_inline_and_paced_flight_gets_its_thread() -> None:
    from mavbridge.nmpc import NmpcConfig
    from mavbridge.nmpc.functions import problem_functions
    from mavbridge.nmpc.solvers.asrti import AdvancedStep
    from vessel.dynamics import OceanCurrent
    from vessel.params import OtterParameters
    from vessel.sea.waves import CalmWater

    cfg = NmpcConfig(horizon=6, solver="asrti", rti_codegen="off", as_worker="inline")
    step = AdvancedStep(problem_functions(OtterParameters(), CalmWater(), OceanCurrent(), cfg), cfg)
    ran_on: list[str] = []

    def job(*args: object) -> tuple:
        ran_on.append(threading.current_thread().name)
        return None, args[1], 0.0, 0

    step._solve = job  # (the background solve itself is not what is tested here)
    try:
        assert isinstance(step._worker(), InlineWorker)
        step.start(np.zeros(3), np.zeros(PARAMS.size), np.zeros(2))  # a job pending when the flight becomes paced
        step.pace(100.0)  # paced (a long period: the waits below end with the job, not by timing luck)
        assert isinstance(step._worker(), Worker) and step.cfg.as_worker == "thread"
        step.take(np.zeros(PARAMS.size))
        assert ran_on == ["asrti"], "the pending job ran on the caller's thread, not the worker's"
        step.start(np.zeros(3), np.zeros(PARAMS.size), np.zeros(2))
        step.cancel()  # a thread's job is let end and forgotten
        assert len(ran_on) == 2
    finally:
        step.close()


def test_a_reset_drops_an_inline_job_unrun() -> None:
    from mavbridge.nmpc import NmpcConfig
    from mavbridge.nmpc.functions import problem_functions
    from mavbridge.nmpc.solvers.asrti import AdvancedStep
    from vessel.dynamics import OceanCurrent
    from vessel.params import OtterParameters
    from vessel.sea.waves import CalmWater

    cfg = NmpcConfig(horizon=6, solver="asrti", rti_codegen="off", as_worker="inline")
    step = AdvancedStep(problem_functions(OtterParameters(), CalmWater(), OceanCurrent(), cfg), cfg)
    ran: list[bool] = []
    step._solve = lambda *args: ran.append(True)
    try:
        step.start(np.zeros(3), np.zeros(PARAMS.size), np.zeros(2))
        step.cancel()
        assert ran == [] and step.take(np.zeros(PARAMS.size)) == (None, {})
    finally:
        step.close()
