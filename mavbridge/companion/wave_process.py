"""The wave estimator in a process of its own, so that its work is not the control step's (issue 32).

In the companion's process the estimator's per-sample work and its fit stages (a fraction of a millisecond
every 0.09 s of samples) were the larger part of the step's time and most of its tail. ``EstimatorProcess`` is
a ``WaveSource`` whose estimator lives in a child process (a fresh interpreter: ``python -m`` this module), on
a Unix socket pair of datagrams (SOCK_SEQPACKET: every message whole or not at all). ``observe`` sends the sample
as one message (``pack_sample``; a few microseconds; paced, it never waits); the child takes each in order and
sends back its answers after it (``encode_answers``): the estimate, the latest fit and both slope spreads. Between
samples the child works the fit's stages ahead of time (``WindowEstimator.work_ahead``); a stage's outcome
still takes effect at its due sample time, so the answers are the estimator's whenever the child found the time.

A step asks (``answers``) once for the answers as of every sample but the newest (its own ATTITUDE, sent just
before: waiting for the child to take it would put that wake-up back into the step). Paced, answers as of the
previous step's samples are in time: the loop reads a period's messages together (``DelayCompensator.pause_s``).

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

import marshal
import math
import pickle
import select
import signal
import socket
import struct
import subprocess
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from numbers import Real
from typing import Any

import numpy as np

from mavbridge.waves import EstimatorSettings, make_estimator
from mavbridge.waves.source import MotionSample, WaveEstimate, pack_sample, unpack_sample

COUNT = struct.Struct("<q")  # the samples an answer is as of; a call's number
HEAD = struct.Struct("<dB7d8dd")  # answers: t, flags (ANSWER_FLAGS), the estimate's 7 numbers (height, period,
# length, direction, phase, confidence, roll sign), both spreads (4 each), CPU s
ANSWER_FLAGS = ("estimate", "confident", "spread_explained", "spread_alone")  # bit 0, 1, 2, 3
MAX_MESSAGE = 1 << 16  # bytes: an answer is under a kilobyte
START_TIMEOUT_S = 60.0  # the child imports numpy and the estimator: seconds on a small computer
WAIT_S = 5.0  # unpaced (lockstep, replays): how long answers and room for a sample are waited for at most
STALE_S = 1.0  # answers older than the newest sample by at most this (autopilot time) stand in for late ones
DRAIN_EVERY = 16  # samples: between steps' questions, answers are read this often (the socket holds hundreds)
CLOSE_WAIT_S = 2.0  # close: how long the child may take to end before it is killed
SAY_EVERY_S = 60.0  # a fault that keeps happening is said again at most this often (wall clock)
FAULTS = ("late", "stale", "stopped", "dropped")
SAID = ("stale", "stopped", "dropped")  # the faults said in the run log (``late`` is only counted)


@dataclass(frozen=True)
class Answers:
    """What the estimator says once it has taken ``samples`` samples, the last at ``t_s`` (autopilot time)."""

    samples: int
    t_s: float
    latest: WaveEstimate | None = None
    confident: bool = False  # ``estimate`` gives ``latest`` (else None)
    spread_explained: tuple[float, ...] | None = None  # 2×2 NED covariance, row by row
    spread_alone: tuple[float, ...] | None = None
    cpu_s: float = 0.0  # the child's processor time so far


NO_ANSWERS = Answers(0, -math.inf)


def answers_of(estimator: Any, samples: int, t_s: float) -> bytes:
    """The estimator's answers after ``samples`` samples, the last at ``t_s``, as one message (``encode_answers``)."""
    spread = getattr(estimator, "spread", None)
    latest = getattr(estimator, "latest", None)
    est = estimator.estimate(t_s)  # the confident estimate is the latest fit (asked for once, not twice)
    shown = est if est is not None or latest is None else latest(t_s)
    return encode_answers(Answers(samples, t_s, shown, est is not None, _flat(spread(True)) if spread else None,
                                  _flat(spread(False)) if spread else None, time.process_time()))


def encode_answers(got: Answers) -> bytes:
    """b"A", the count, then b"N" and the numbers packed (HEAD) with the estimate's log figures (``extras``)
    marshalled when they are all numbers (b"M", as plain floats), else pickled (b"P"); or b"Q" and the whole
    ``Answers`` pickled when its numbers do not pack. Unpacking numbers costs the step a fraction of unpickling
    dataclasses (30 µs paced, issue 32)."""
    est = got.latest
    extras = est.extras if est is not None else {}
    try:
        wave = (est.height_m, est.period_s, est.length_m, est.travel_dir_rad, est.phase_rad, est.confidence,
                   est.roll_sign) if est is not None else (0.0,) * 7
        flags = sum(1 << i for i, on in enumerate((est is not None, got.confident, got.spread_explained is not None,
                                                   got.spread_alone is not None)) if on)
        head = HEAD.pack(got.t_s, flags, *wave, *(got.spread_explained or (0.0,) * 4),
                         *(got.spread_alone or (0.0,) * 4), got.cpu_s)
    except (struct.error, TypeError):  # a field that is not a number, a spread that is not four: as they are
        return b"A" + COUNT.pack(got.samples) + b"Q" + pickle.dumps(got)
    if all(isinstance(v, Real) and not isinstance(v, bool) for v in extras.values()):
        tail = b"M" + marshal.dumps({str(k): float(v) for k, v in extras.items()})
    else:
        tail = b"P" + pickle.dumps(extras)
    return b"A" + COUNT.pack(got.samples) + b"N" + head + tail


def decode_answers(message: bytes) -> Answers:
    """The ``Answers`` in a message ``encode_answers`` made."""
    start = 2 + COUNT.size
    if message[start - 1:start] == b"Q":
        return pickle.loads(message[start:])
    values = HEAD.unpack_from(message, start)
    t_s, flags, wave, spreads, cpu_s = values[0], values[1], values[2:9], values[9:17], values[17]
    est = None
    if flags & 1:
        tail = message[start + HEAD.size:]
        extras = marshal.loads(tail[1:]) if tail[:1] == b"M" else pickle.loads(tail[1:])
        est = WaveEstimate(*wave[:6], extras=extras, roll_sign=wave[6])
    return Answers(COUNT.unpack_from(message, 1)[0], t_s, est, bool(flags & 2), spreads[:4] if flags & 4 else None,
                   spreads[4:] if flags & 8 else None, cpu_s)


def _flat(covariance: np.ndarray | None) -> tuple[float, ...] | None:
    """A 2×2 covariance as four plain floats, row by row (None stays None)."""
    return None if covariance is None else tuple(np.asarray(covariance, float).ravel().tolist())


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
            if data[:1] in (b"S", b"P"):
                sample = unpack_sample(data)
                estimator.observe(sample)
                samples += 1
                sock.send(answers_of(estimator, samples, sample.t_s))
            elif data[:1] == b"C":  # a call in this process (the real-time settings): its number and result back
                sock.send(data[:1 + COUNT.size] + pickle.dumps(_called(data[1 + COUNT.size:])))
            else:  # b"X", or b"" at the companion's end
                return
    except OSError:  # the companion's end has gone
        return


@dataclass
class EstimatorProcess:
    """A ``WaveSource`` whose estimator runs in a child process (see the module docstring); ``close`` ends it."""

    settings: EstimatorSettings
    wait_s: float = WAIT_S  # 0: paced, never wait (see the module docstring)
    log: Callable[[str], None] = print
    name: str = "estimated"
    faults: dict[str, int] = field(init=False, default_factory=lambda: dict.fromkeys(FAULTS, 0))
    _said_at: dict[str, float] = field(init=False, default_factory=dict)  # when each fault was last said (wall)
    _answers: Answers = field(init=False, default=NO_ANSWERS)
    _kept: deque[tuple[int, bytes]] = field(init=False, default_factory=lambda: deque(maxlen=2))
    # answers received, not yet used (count, message): only the newest as of sent − 1 and the one for sent matter
    _sent: int = field(init=False, default=0)  # samples sent
    _sent_t: float = field(init=False, default=-math.inf)  # the newest one's time (autopilot s)
    _stopped: bool = field(init=False, default=False)
    _chosen: tuple[int, Answers] = field(init=False, default=(-1, NO_ANSWERS))  # a step's answers, asked once
    _floor: int = field(init=False, default=0)  # samples sent when the last step asked: answered by now, or late
    _calls: int = field(init=False, default=0)
    _closing: bool = field(init=False, default=False)
    _stale_said: bool = field(init=False, default=False)  # a stale spell was said: say when answers come again

    def __post_init__(self) -> None:
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self._sock = ours  # a fresh interpreter, not a fork of one with threads (nrti's worker):
        self._child = subprocess.Popen([sys.executable, "-m", __name__, str(theirs.fileno())],
                                       pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        theirs.close()
        self._poll = select.poll()
        self._poll.register(ours, select.POLLIN)
        try:
            ours.sendall(pickle.dumps(self.settings))
            ready = self._ready(START_TIMEOUT_S, write=False) and ours.recv(MAX_MESSAGE)
            if not ready:
                raise EOFError
        except (EOFError, OSError):
            self.close()
            raise RuntimeError(f"the wave estimator's process did not start within {START_TIMEOUT_S:g} s"
                               f"{_exit(self._child.poll())}") from None
        self.name = ready[1:].decode()
        ours.setblocking(False)  # a paced step never waits to send

    @property
    def pid(self) -> int:
        """The child's process id."""
        return self._child.pid

    def observe(self, sample: MotionSample) -> None:
        """Send one motion sample to the estimator (dropped, and said, if the child has no room for it in time)."""
        if self._send(pack_sample(sample), "dropped"):
            self._sent += 1
            if math.isfinite(sample.t_s):
                self._sent_t = sample.t_s
        if self._sent % DRAIN_EVERY == 0:  # its answers read now and then between steps: the socket never fills
            self._take_waiting()

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
        """The estimator's answers as of every sample but the newest (see the module docstring), waited for at
        most ``wait_s``; late or stale ones as the module docstring says. Asked once per sample count: every
        question of a step gets the same answers."""
        wanted = max(self._sent - 1, 0)
        if self._chosen[0] == wanted:
            return self._chosen[1]
        floor, self._floor = min(self._floor, wanted), self._sent
        deadline = time.perf_counter() + self.wait_s
        while not self._stopped:
            self._take_waiting()
            if self._current(wanted).samples == wanted:
                return self._choose(wanted, self._answers, recovered=True)
            left = deadline - time.perf_counter()
            if left <= 0 or not self._ready(left, write=False):
                break
        if self._stopped:
            return self._choose(wanted, NO_ANSWERS)
        age = self._sent_t - self._answers.t_s
        if self._answers is not NO_ANSWERS and self._answers.samples >= floor and 0.0 <= age <= STALE_S:
            return self._choose(wanted, self._answers, recovered=True)  # as of the last step's samples: in time
        fresh = 0.0 <= age <= STALE_S or self._answers is NO_ANSWERS  # (nothing yet: late, not stale)
        self._fault("late" if fresh else "stale")
        return self._choose(wanted, self._answers if fresh else NO_ANSWERS)

    def _choose(self, wanted: int, answers: Answers, recovered: bool = False) -> Answers:
        """The step's answers, kept for its other questions; says when answers come again after a stale spell."""
        if recovered and self._stale_said:
            self._stale_said = False
            self.log(f"waves ({self.name}): the estimator's process answers again")
        self._chosen = (wanted, answers)
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

    def _take_waiting(self) -> tuple[bytes, Any] | None:
        """Read every message waiting, without blocking: answers kept (unpacked only when asked for); a call's
        (tag, result) returned (None if none came)."""
        result = None
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
        return result

    def _send(self, data: bytes, full: str | None) -> bool:
        """Send one message; with the socket full, wait ``wait_s`` at most for room (reading the answers that
        hold it up meanwhile); False when there is none (the fault ``full`` counted, if named)."""
        deadline = time.perf_counter() + self.wait_s
        while not self._stopped:
            try:
                self._sock.send(data)
                return True
            except BlockingIOError:
                left = deadline - time.perf_counter()
                if left <= 0 or not self._ready(left, write=True):
                    if full is not None:
                        self._fault(full)
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

    def _fault(self, kind: str) -> None:
        """Count a fault; say it (if one of SAID) when it starts, and again at most once every SAY_EVERY_S while it
        goes on."""
        self.faults[kind] += 1
        now = time.monotonic()
        if kind not in SAID or now - self._said_at.get(kind, -math.inf) < SAY_EVERY_S:
            return
        self._said_at[kind] = now
        self._stale_said |= kind == "stale"
        what = {"stale": f"has not answered for over {STALE_S:g} s of autopilot time: no new estimate",
                "stopped": f"stopped{_exit(self._child.poll())}: no new estimate for the rest of the run",
                "dropped": "had no room for a sample: dropped"}[kind]
        self.log(f"waves ({self.name}): the estimator's process {what} ({self.faults[kind]} so far)")


if __name__ == "__main__":  # the child (``EstimatorProcess`` starts it with its end of the socket pair); the
    # module's own names, not this script's, so that what it pickles (a call's result) unpickles in the companion
    from mavbridge.companion.wave_process import serve as serve_here

    serve_here(socket.socket(fileno=int(sys.argv[1])))
