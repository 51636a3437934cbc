"""One background thread for asrti's and nrti's work ahead: a job handed over and its result taken each step.

What ``ThreadPoolExecutor`` gives a single worker (jobs run in order, a result waited for with a timeout, the
job's exception raised to the taker, shutdown), with less on the control step's path: a job is a lock released
when it ends, not a ``Future`` with its condition variable, and ``submit`` puts it on a ``SimpleQueue`` without the
executor's bookkeeping. The executor's round trip took 9.6 µs on this machine and this one's 5.7 µs, hot; paced,
every step pays two or three times that (issue 32).

``InlineWorker`` has the same face with no thread: a job runs when its result is first asked for. In-process runs
(experiments, sweeps, tuning) wait for every job anyway, and are deterministic: running it there gives the same
numbers as the thread, without two threads' hand-over at every step.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from concurrent.futures import CancelledError
from concurrent.futures import TimeoutError as FuturesTimeout
from typing import Any


class Job:
    """One job's outcome: ``result`` waits for it like a ``Future``'s."""

    __slots__ = ("_args", "_call", "_done", "_error", "_value")

    def __init__(self, call: Callable[..., Any] | None = None, args: tuple = ()) -> None:
        self._call, self._args = call, args
        self._done = threading.Lock()
        self._done.acquire()  # released once the job has ended
        self._value: Any = None
        self._error: BaseException | None = None

    @classmethod
    def finished(cls, value: Any) -> Job:
        """A job that has already ended with ``value`` (a result held for the next step)."""
        job = cls()
        job._value = value
        job._done.release()
        return job

    def cancel(self) -> None:
        """End the job without running it: ``result`` raises ``CancelledError`` (a job dropped at shutdown)."""
        self._call = self._args = None
        self._error = CancelledError()
        self._done.release()

    def run(self) -> None:
        """Run the call (on the worker's thread); its value or exception is kept for ``result``."""
        try:
            if self._call is not None:
                self._value = self._call(*self._args)
        except BaseException as exc:  # the taker's to handle, as a Future's
            self._error = exc
        finally:
            self._call = self._args = None  # (drop its arguments: the plan and parameters)
            self._done.release()

    def done(self) -> bool:
        """True once the job has ended."""
        if self._done.acquire(blocking=False):
            self._done.release()
            return True
        return False

    def result(self, timeout: float | None = None) -> Any:
        """The job's value (its exception raised), waiting ``timeout`` s at most (None: for ever); raises
        ``concurrent.futures.TimeoutError`` when it has not ended in time."""
        if not self._done.acquire(timeout=-1 if timeout is None else max(timeout, 0.0)):
            raise FuturesTimeout
        self._done.release()  # stays ended for later calls
        if self._error is not None:
            raise self._error
        return self._value


class Worker:
    """A thread that runs the jobs handed to it in order, one at a time (see the module docstring)."""

    def __init__(self, name: str) -> None:
        self._jobs: queue.SimpleQueue[Job | None] = queue.SimpleQueue()
        self._closed = False
        self._lock = threading.Lock()  # submit and shutdown: no job is put behind the end
        self._thread = threading.Thread(target=self._serve, name=name, daemon=True)
        self._thread.start()

    def submit(self, call: Callable[..., Any], *args: Any) -> Job:
        """Hand ``call(*args)`` over; its ``Job`` says when it has ended and what it gave."""
        job = Job(call, args)
        with self._lock:
            if self._closed:
                raise RuntimeError("Worker: submit after shutdown")
            self._jobs.put(job)
        return job

    def shutdown(self, wait: bool = True, cancel_futures: bool = False) -> None:
        """End the thread after the job it runs (and, unless ``cancel_futures``, those handed over after it: else
        they end cancelled)."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            while cancel_futures:
                try:
                    job = self._jobs.get_nowait()
                except queue.Empty:
                    break
                if job is not None:
                    job.cancel()
            self._jobs.put(None)
        if wait:
            self._thread.join()

    def _serve(self) -> None:
        while (job := self._jobs.get()) is not None:
            job.run()


class DeferredJob(Job):
    """A job that runs on the taker's thread when its result is first asked for (``InlineWorker``)."""

    __slots__ = ()

    def done(self) -> bool:
        """True: a deferred job is ready whenever it is asked for."""
        return True

    def hand_over(self, worker: Worker) -> Job:
        """This job to run on ``worker``'s thread instead, if it has not run (else itself: its result is kept)."""
        if self._call is None:
            return self
        call, args = self._call, self._args
        self._call = self._args = None
        return worker.submit(call, *args)

    def result(self, timeout: float | None = None) -> Any:
        """Run the job now if it has not run (``timeout`` does not apply: nothing runs elsewhere), then its value."""
        if self._call is not None:
            self.run()
        return super().result(timeout)


class InlineWorker:
    """``Worker``'s face without a thread: each job runs when its result is taken (see the module docstring)."""

    def __init__(self) -> None:
        self._closed = False

    def submit(self, call: Callable[..., Any], *args: Any) -> Job:
        """Keep ``call(*args)`` for whoever takes its result."""
        if self._closed:
            raise RuntimeError("InlineWorker: submit after shutdown")
        return DeferredJob(call, args)

    def shutdown(self, wait: bool = True, cancel_futures: bool = False) -> None:
        """Refuse further jobs (one not taken is simply dropped with its ``Job``)."""
        self._closed = True
