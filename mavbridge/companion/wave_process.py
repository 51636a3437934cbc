"""The wave estimator in a process of its own, so that its work is not the control step's (issue 32).

In the companion's process the estimator's per-sample work and its fit stages (a fraction of a millisecond
every 0.09 s of samples) were the larger part of the step's time and most of its tail. ``EstimatorProcess`` is
a ``WaveSource`` whose estimator lives in a child process (a fresh interpreter: ``python -m`` this module), on
a Unix socket pair of datagrams (SOCK_SEQPACKET: every message whole or not at all). Unpaced, ``observe`` sends the
sample as one message (``pack_sample``); paced, it holds it, and the samples go together (``flush``: one message,
b"B", never waited for) once a step's command is out (the ``WaveGate``'s ``command_sent``), after a question that is
no step's (the watch before engaging, the cold solve: ``send_held``), before a ``call``, or every BATCH: a socket
call costs a paced step tens of microseconds, and the command need not wait for it. The child takes them in order
and answers after each message (``encode_answers``): the estimate, the latest fit and both slope spreads. Between
samples it works the fit's stages ahead of time (``WindowEstimator.work_ahead``); a stage's outcome still takes
effect at its due sample time, so the answers are the estimator's whenever the child found the time.

A step asks (``answers``) once for the answers as of every sample but the newest (its own ATTITUDE: waiting for
the child to take it would put that wake-up back into the step). Paced, answers as of the previous step's samples
are in time: the loop reads a period's messages together (``DelayCompensator.pause_s``), they go to the child
together after the step's command, and the next step reads answers only until those have come (a step whose
samples were not sent after its command has them sent at the next question: a ``late`` fault).

How long the companion waits for the child (``wait_s``): paced (`mavbridge run` without ``--lockstep``) never,
so a step never waits for another process (and which answers it gets can then depend on timing); in lockstep
and in unpaced replays up to seconds, so that every answer is the one due. Refusing rather than guessing:
answers not in time (``late``: not even as of the previous step's samples) are replaced by the last ones while
those are at most ``STALE_S`` of autopilot time older than the newest sample (an estimate's phase is on the
autopilot clock, so it stays valid), else by none (``stale``); a child that has gone gives none for the rest of
the run (``stopped``); a sample the child has no room for in time is dropped (``dropped``). No answer means no
new estimate: the ``WaveGate`` then holds the last confident wave for ``estimation.hold_s`` as after any loss of
confidence, and plans without the roll term after it. Faults are counted (``faults``, in metrics.json); all but
``late`` (older answers standing in, which changes nothing a pilot need know) are said in the run log when they
start (at most once a minute for each kind) and, for ``stale``, when answers come again.
"""

from __future__ import annotations

import math
import pickle
import select
import signal
import socket
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.waves import EstimatorSettings, make_estimator
from mavbridge.waves.source import (
    COUNT,
    NO_ANSWERS,
    Answers,
    EstimatorFaults,
    MotionSample,
    WaveEstimate,
    answers_of,
    batched,
    decode_answers,
    pack_sample,
    unbatched,
)

MAX_MESSAGE = 1 << 16  # bytes: an answer is under a kilobyte
START_TIMEOUT_S = 60.0  # the child imports numpy and the estimator: seconds on a small computer
WAIT_S = 5.0  # unpaced (lockstep, replays): how long answers and room for a sample are waited for at most
STALE_S = 1.0  # answers older than the newest sample by at most this (autopilot time) stand in for late ones
DRAIN_EVERY = 16  # samples: between steps' questions, answers are read this often (the socket holds hundreds)
BATCH = 16  # paced: samples held at most (steps ask every 2; nobody, once the sea is known before engaging)
CLOSE_WAIT_S = 2.0  # close: how long the child may take to end before it is killed


def _exit(code: int | None) -> str:
    """' (exit code N)' once the child has ended, else nothing."""
    return "" if code is None else f" (exit code {code})"


def _called(message: bytes) -> Any:
    """The result of a call sent by ``EstimatorProcess.call``, or its exception (the child goes on either way)."""
    try:
        call, args = pickle.loads(message)
        return call(*args)
    except Exception as exc:  # whatever the call raised is the caller's answer, never the child's end
        return exc


def start_child(settings: EstimatorSettings) -> tuple[socket.socket, subprocess.Popen, str]:
    """(our end of the socket pair, non-blocking: a paced step never waits to send; the child; its estimator's name)
    once the child has built its estimator from ``settings``: a fresh interpreter, not a fork of one with threads
    (nrti's worker). RuntimeError (the child ended or killed) if it is not ready within START_TIMEOUT_S."""
    ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    child = subprocess.Popen([sys.executable, "-m", __name__, str(theirs.fileno())], pass_fds=(theirs.fileno(),),
                             stdin=subprocess.DEVNULL)
    theirs.close()
    try:
        ours.sendall(pickle.dumps(settings))
        waiting = select.poll()
        waiting.register(ours, select.POLLIN)
        ready = waiting.poll(START_TIMEOUT_S * 1000.0) and ours.recv(MAX_MESSAGE)
        if not ready:
            raise EOFError
    except (EOFError, OSError):
        if child.poll() is None:
            child.kill()
        code = child.wait(CLOSE_WAIT_S)
        ours.close()
        raise RuntimeError(f"the wave estimator's process did not start within {START_TIMEOUT_S:g} s"
                           f"{_exit(code)}") from None
    ours.setblocking(False)
    return ours, child, ready[1:].decode()


def serve(sock: socket.socket) -> None:
    """The child: the estimator (its settings the first message); every sample taken in order and answered, the
    fit worked ahead while none waits; returns when the companion's end closes or says so."""
    for stop in (signal.SIGINT, signal.SIGTERM):  # Ctrl-C, systemd's stop: the companion's to handle (it stands down
        signal.signal(stop, signal.SIG_IGN)  # first, and needs its answers until then); its socket's end stops this
    estimator = make_estimator(pickle.loads(sock.recv(MAX_MESSAGE)))
    ahead = getattr(estimator, "work_ahead", None)
    waiting = select.poll()
    waiting.register(sock, select.POLLIN)
    sock.send(b"R" + estimator.name.encode())
    samples = 0
    try:
        while True:
            if ahead is not None and not waiting.poll(0) and ahead():
                continue
            data = sock.recv(MAX_MESSAGE)
            if data[:1] in (b"S", b"P", b"B"):
                taken = unbatched(data)
                for sample in taken:
                    estimator.observe(sample)
                    samples += 1
                if taken:  # (a batch is answered after its last sample only)
                    sock.send(answers_of(estimator, samples, taken[-1].t_s))
            elif data[:1] == b"C":  # a call in this process (the real-time settings): its number and result back
                sock.send(data[:1 + COUNT.size] + pickle.dumps(_called(data[1 + COUNT.size:])))
            else:  # b"X", or b"" at the companion's end
                return
    except OSError:  # the companion's end has gone
        return


@dataclass
class HeldSamples:
    """Paced: the samples packed and not sent yet; they go together (``EstimatorProcess.flush``)."""

    packed: list[bytes] = field(default_factory=list)
    newest_t: float = -math.inf  # the newest finite time among them (autopilot s)
    asked: bool = False  # a question came while they were held (they go once the step's command is out)

    def add(self, sample: MotionSample) -> None:
        """One more, packed."""
        self.packed.append(pack_sample(sample))
        if math.isfinite(sample.t_s):
            self.newest_t = sample.t_s

    def take(self) -> tuple[list[bytes], float]:
        """(the samples packed, the newest finite time among them), none held from now."""
        taken = self.packed, self.newest_t
        self.packed, self.newest_t, self.asked = [], -math.inf, False
        return taken


@dataclass
class EstimatorProcess:
    """A ``WaveSource`` whose estimator runs in a child process (see the module docstring); ``close`` ends it."""

    settings: EstimatorSettings
    wait_s: float = WAIT_S  # 0: paced, never wait (see the module docstring)
    log: Callable[[str], None] = print
    name: str = "estimated"
    _faults: EstimatorFaults = field(init=False, default_factory=lambda: EstimatorFaults(STALE_S))
    _answers: Answers = field(init=False, default=NO_ANSWERS)
    _kept: deque[tuple[int, bytes]] = field(init=False, default_factory=lambda: deque(maxlen=2))  # (count, answers)
    _sent: int = field(init=False, default=0)  # samples sent
    _sent_t: float = field(init=False, default=-math.inf)  # the newest one's time (autopilot s)
    _held: HeldSamples = field(init=False, default_factory=HeldSamples)  # paced: not sent yet (``flush``)
    _stopped: bool = field(init=False, default=False)
    _chosen: tuple[int, Answers] = field(init=False, default=(-1, NO_ANSWERS))  # a step's answers, asked once
    _floor: int = field(init=False, default=0)  # samples sent or held when the last step asked: answered by now
    _calls: int = field(init=False, default=0)
    _closing: bool = field(init=False, default=False)

    def __post_init__(self) -> None:
        self._sock, self._child, self.name = start_child(self.settings)
        self.pid = self._child.pid  # the child's process id
        self._faults.prefix = f"waves ({self.name}): the estimator's process "
        self._poll = select.poll()
        self._poll.register(self._sock, select.POLLIN)

    @property
    def faults(self) -> dict[str, int]:
        """Each fault's count (``waves.source.ESTIMATOR_FAULTS``)."""
        return self._faults.counts

    def observe(self, sample: MotionSample) -> None:
        """One motion sample to the estimator: paced (``wait_s`` 0) held for the next ``flush``, else sent now after
        any held ones (dropped, and said, if the child has no room for it in time)."""
        if self.wait_s > 0.0 and self._held.packed:
            self.flush()  # (held while paced: sent first, and the new one alone, so that it is answered as itself)
        self._held.add(sample)
        if self.wait_s <= 0.0 and len(self._held.packed) < BATCH:
            return
        self.flush()
        if self.wait_s <= 0.0 or self._sent % DRAIN_EVERY == 0:  # answers read now and then between steps' questions
            self._take_waiting()  # (the pilot has the boat, the waypoint is reached): the socket never fills

    def flush(self) -> None:
        """Send the samples held as one message (dropped, and said, if the child has no room for it in time)."""
        if self._held.packed:
            held, held_t = self._held.take()
            if self._send(held[0] if len(held) == 1 else batched(held), "dropped", len(held)):
                self._sent += len(held)
                self._sent_t = held_t if math.isfinite(held_t) else self._sent_t
            else:  # (a step that asked counted on them: what has gone is what can be answered)
                self._floor = min(self._floor, self._sent)

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The wave to plan against (None while not confident, or without answers); see ``answers``."""
        answers = self.answers()
        return answers.latest if answers.confident else None

    def latest(self, t_s: float) -> WaveEstimate | None:
        """The current fit whatever its confidence (for logs); see ``answers``."""
        return self.answers().latest

    def spread(self, explained: bool) -> np.ndarray | None:
        """The NED slope covariance (2×2, rad²) the wave does not explain; see ``answers``."""
        answers = self.answers()
        flat = answers.spread_explained if explained else answers.spread_alone
        return None if flat is None else np.array(flat).reshape(2, 2)

    def use_log(self, log: Callable[[str], None]) -> None:
        """Say faults in ``log`` (the companion's run log) from now on."""
        self.log = log

    @property
    def cpu_s(self) -> float:
        """The child's processor time (s) as of the answers last used."""
        return self._answers.cpu_s

    def call(self, function: Callable[..., Any], *args: Any, timeout_s: float = 10.0) -> Any:
        """``function(*args)`` run in the child (importable by name; e.g. the real-time settings): its result, or
        the exception it raised; None when the child does not answer in time."""
        self.flush()  # (the samples before it, taken before it)
        self._calls += 1
        tag = b"C" + COUNT.pack(self._calls)
        if not self._send(tag + pickle.dumps((function, args)), None):
            return None
        deadline = time.perf_counter() + timeout_s
        while not self._stopped and self._ready(max(deadline - time.perf_counter(), 0.0), write=False):
            result = self._take_waiting()
            if result is not None and result[0] == tag:
                return result[1]
        return None

    def close(self) -> None:
        """End the child (idempotent): told to stop, its last answers read meanwhile; killed after CLOSE_WAIT_S."""
        deadline = time.monotonic() + CLOSE_WAIT_S
        self._closing = True  # its end of the socket closing now is no fault
        if self._child.poll() is None and self._send(b"X", None):
            while self._child.poll() is None and time.monotonic() < deadline and not self._stopped:
                if self._ready(0.05, write=False):
                    self._take_waiting()
        try:  # its socket closes before its interpreter has ended: the rest of the time for that
            self._child.wait(max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            self._child.kill()
            self._child.wait(CLOSE_WAIT_S)
        self._sock.close()

    def answers(self) -> Answers:
        """The answers as of every sample but the newest, waited for ``wait_s`` at most (see the module docstring);
        the same to every question of a step. Paced, read only until those as of the samples sent before it came;
        the step's own samples stay held until its command is out (``flush``)."""
        wanted = max(self._sent + len(self._held.packed) - 1, 0)  # (counting the held: they go before the next step)
        key = self._sent + len(self._held.packed) + self.faults["dropped"]  # samples observed: a step's own are new
        if self._chosen[0] == key:
            return self._chosen[1]
        before = self._sent  # (the last step's samples, or after a spell without questions, the last batch's)
        if self._held.asked:  # the last step's samples did not go after its command: they go now, a period late
            self._floor = min(self._floor, before)  # (answers as of what that step had sent are the ones due now)
            self._fault("late")
            self.flush()
        if self.wait_s > 0.0:
            self.flush()  # (samples held while paced: waited for now, with the rest)
        floor, self._floor = min(self._floor, wanted), self._sent + len(self._held.packed)
        self._held.asked = bool(self._held.packed)
        deadline = time.perf_counter() + self.wait_s
        while not self._stopped:
            self._take_waiting(until=wanted if self.wait_s > 0.0 else max(floor, before))
            if self._current(wanted).samples == wanted:
                return self._choose(key, self._answers, recovered=True)
            left = deadline - time.perf_counter()
            if left <= 0 or not self._ready(left, write=False):
                break
        if self._stopped:
            return self._choose(key, NO_ANSWERS)
        age = max(self._sent_t, self._held.newest_t) - self._answers.t_s  # (as of the newest sample, sent or held)
        if self._answers is not NO_ANSWERS and self._answers.samples >= floor and 0.0 <= age <= STALE_S:
            return self._choose(key, self._answers, recovered=True)  # as of the last step's samples: in time
        fresh = 0.0 <= age <= STALE_S or self._answers is NO_ANSWERS  # (nothing yet: late, not stale)
        self._fault("late" if fresh else "stale")
        return self._choose(key, self._answers if fresh else NO_ANSWERS)

    def _choose(self, key: int, answers: Answers, recovered: bool = False) -> Answers:
        """The step's answers, kept for its other questions; says when answers come again after a stale spell."""
        if recovered:
            self._faults.recovered(self.log)
        self._chosen = (key, answers)
        return answers

    def _current(self, wanted: int) -> Answers:
        """The newest answers as of at most ``wanted`` samples (unpacked now if they came since); newer ones kept."""
        found = None
        while self._kept and self._kept[0][0] <= wanted:
            found = self._kept.popleft()[1]
        if found is not None:
            self._answers = decode_answers(found)
        return self._answers

    def _ready(self, timeout_s: float, write: bool) -> bool:
        """True when a message waits to be read (``write``: or there is room to send one) within the timeout."""
        self._poll.modify(self._sock, select.POLLIN | (select.POLLOUT if write else 0))
        return bool(self._poll.poll(max(timeout_s, 0.0) * 1000.0))

    def _take_waiting(self, until: int | None = None) -> tuple[bytes, Any] | None:
        """Read the messages waiting, without blocking: answers kept (unpacked when asked for), a call's (tag, result)
        returned; ``until``: only until answers as of that many samples are kept (an empty read costs as a full one)."""
        result = None
        have = self._kept[-1][0] if self._kept else -1 if self._answers is NO_ANSWERS else self._answers.samples
        if until is not None and have >= until:
            return None
        while not self._stopped:
            try:
                data = self._sock.recv(MAX_MESSAGE)
            except BlockingIOError:
                break
            except OSError:
                data = b""
            if not data:  # the child's end closed
                self._stop()
            elif data[:1] == b"C":
                result = (data[:1 + COUNT.size], pickle.loads(data[1 + COUNT.size:]))
            elif data[:1] == b"A":
                self._kept.append((COUNT.unpack_from(data, 1)[0], data))
                if until is not None and self._kept[-1][0] >= until:
                    break
        return result

    def _send(self, data: bytes, full: str | None, samples: int = 1) -> bool:
        """Send one message; with the socket full, wait ``wait_s`` at most for room (reading the answers that
        hold it up meanwhile); False when there is none (the fault ``full`` counted once per sample, if named)."""
        deadline = time.perf_counter() + self.wait_s
        while not self._stopped:
            try:
                self._sock.send(data)
                return True
            except BlockingIOError:
                left = deadline - time.perf_counter()
                if left <= 0 or not self._ready(left, write=True):
                    if full is not None:
                        self._fault(full, samples)
                    return False
                self._take_waiting()
            except OSError:
                self._stop()
        return False

    def _stop(self) -> None:
        """The child's end has closed: no answers from now on (a fault unless we are closing it)."""
        if not self._stopped:
            self._stopped = True
            if not self._closing:
                self._fault("stopped")

    def _fault(self, kind: str, times: int = 1) -> None:
        """Count a fault, and say it as ``EstimatorFaults`` does."""
        self._faults.count(kind, self.log, lambda: _exit(self._child.poll()), times)


if __name__ == "__main__":  # the child (``EstimatorProcess`` starts it with its end of the socket pair); the
    # module's own names, not this script's, so that what it pickles (a call's result) unpickles in the companion
    from mavbridge.companion.wave_process import serve as serve_here

    serve_here(socket.socket(fileno=int(sys.argv[1])))
