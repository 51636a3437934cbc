"""What the companion knows about the sea: one small interface between the loop and its wave knowledge.

A real boat is told nothing about the waves. The control loop therefore sees the sea only through a
``WaveSource``: it feeds the source every motion sample the autopilot streams (``observe``) and asks it,
once per control step, for the dominant wave it should plan against (``estimate``). Two sources fly:

* ``ScenarioTruth`` — the scenario's sea, *simulation truth*, named as such in every log; it never
  looks at the motion and always answers with full confidence;
* an estimator (``mavbridge.waves``) that fits the dominant wave to the boat's own motion;

and, for simulation only, ``TrueSpread``: an estimator whose slope statistics are the sea's true ones (a bound
on what the estimated statistics can give; named as simulation truth in the run's metrics).

A ``WaveEstimate`` is one regular component on the autopilot's clock, NED frame, positions relative to
home: ζ(N, E, t) = (H/2)·sin(ω t − k (N cos χ + E sin χ) + ε), t in autopilot seconds (time_boot_ms/1000).
``None`` from ``estimate`` means "no confident estimate": the controller then flies without its roll term.

Also here, free of the companion's imports since the estimator's own process imports this module: what goes
between the companion and that process (``pack_sample``, ``batched``, ``encode_answers``), ``send_held``, and the
process's faults (``EstimatorFaults``).
"""

from __future__ import annotations

import marshal
import math
import pickle
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from numbers import Real
from typing import Any, Protocol

import numpy as np

from vessel import CalmWater, RegularWaves, WaveField

SCENARIO_TRUTH = "scenario-truth"


@dataclass(frozen=True)
class MotionSample:
    """One instant of what an ArduPilot Rover streams, on the autopilot's clock (SI, radians, NED).

    ``attitude`` = (φ, θ, ψ) rad, ``rates`` = body (p, q, r) rad/s (ATTITUDE); ``position_ned`` m
    relative to home and ``velocity_ned`` m/s (GLOBAL_POSITION_INT / LOCAL_POSITION_NED);
    ``accel_body`` = specific force in the body frame, m/s² (SCALED_IMU / RAW_IMU), None if not streamed.
    """

    t_s: float
    attitude: np.ndarray
    rates: np.ndarray
    position_ned: np.ndarray
    velocity_ned: np.ndarray
    accel_body: np.ndarray | None = None


SAMPLE = struct.Struct("<17d")  # t, attitude 3, rates 3, position 3, velocity 3, has IMU, specific force 3
ENTRY = struct.Struct("<I")  # a batch's entries (``batched``): each sample's length, then the sample


def pack_sample(sample: MotionSample) -> bytes:
    """A motion sample as one message (b"S" + 17 doubles), or pickled (b"P") unless every vector is 3 numbers
    (the estimator then judges it, as in the companion's process). Arrays give their numbers as plain floats in one
    call each (unpacking an array makes a numpy scalar of each number: 3 µs a sample)."""
    att, rates, pos, vel, accel = (sample.attitude, sample.rates, sample.position_ned, sample.velocity_ned,
                                   sample.accel_body)
    try:
        if len(att) == len(rates) == len(pos) == len(vel) == 3 and (accel is None or len(accel) == 3):
            try:
                values = (*att.tolist(), *rates.tolist(), *pos.tolist(), *vel.tolist())
            except AttributeError:  # not all arrays
                values = (*att, *rates, *pos, *vel)
            force = (0.0, 0.0, 0.0) if accel is None else accel.tolist() if isinstance(accel, np.ndarray) else accel
            return b"S" + SAMPLE.pack(sample.t_s, *values, float(accel is not None), *force)
    except (struct.error, TypeError):
        pass
    return b"P" + pickle.dumps(sample)


def unpack_sample(data: bytes) -> MotionSample:
    """The sample ``pack_sample`` made."""
    if data[:1] == b"P":
        return pickle.loads(data[1:])
    v = SAMPLE.unpack(data[1:])
    return MotionSample(v[0], np.array(v[1:4]), np.array(v[4:7]), np.array(v[7:10]), np.array(v[10:13]),
                        np.array(v[14:17]) if v[13] else None)


def batched(packed: list[bytes]) -> bytes:
    """Samples packed by ``pack_sample`` as one message: b"B", then each one's length and bytes (``ENTRY``)."""
    return b"B" + b"".join(ENTRY.pack(len(one)) + one for one in packed)


def unbatched(message: bytes) -> list[MotionSample]:
    """The samples of one message: a sample (b"S", b"P") or a batch (``batched``)."""
    if message[:1] != b"B":
        return [unpack_sample(message)]
    samples, at = [], 1
    while at < len(message):
        (size,) = ENTRY.unpack_from(message, at)
        samples.append(unpack_sample(message[at + ENTRY.size:at + ENTRY.size + size]))
        at += ENTRY.size + size
    return samples


def sea_spread(source: object, explained: bool) -> np.ndarray | None:
    """The source's NED slope covariance (2×2, rad²) not explained by its wave, if it measures one
    (``WaveEstimator.spread``; ``explained``: its confident wave is in use), else None."""
    spread = getattr(source, "spread", None)
    return spread(explained) if spread is not None else None


def spread_line(covariance_ned: np.ndarray) -> str:
    """One line of a slope covariance: RMS slope (°) and the principal (roll-producing) axis (° NED, mod 180)."""
    c = np.asarray(covariance_ned, float)
    axis = 0.5 * math.atan2(2 * c[0, 1], c[0, 0] - c[1, 1])
    rms = math.sqrt(max(c[0, 0] + c[1, 1], 0.0))
    return f"slope RMS {math.degrees(rms):.1f} deg along {math.degrees(axis) % 180:.0f} deg"


@dataclass(frozen=True)
class WaveEstimate:
    """The dominant regular wave: true (not encounter) period, NED travel direction, phase on the autopilot clock."""

    height_m: float
    period_s: float
    length_m: float
    travel_dir_rad: float
    phase_rad: float
    confidence: float = 1.0  # 0 (nothing known) .. 1 (certain)
    extras: dict[str, float] = field(default_factory=dict)  # estimator-specific figures for the log
    roll_sign: float = 1.0  # how the hull rolls with the slope across it: +1 the paper's plant, −1 geometric

    def field(self) -> RegularWaves:
        """The estimate as a wave field the NMPC can predict with, rolling the hull with the estimate's sign
        (the one the estimator read the slope with), so that the prediction rolls as the boat does."""
        return RegularWaves(self.height_m, self.length_m, self.period_s, self.travel_dir_rad,
                            phase_rad=self.phase_rad, paper_roll_sign=self.roll_sign > 0)

    def row(self) -> dict[str, float]:
        """Per-step log columns, units in the names."""
        return {"wave_height_m": self.height_m, "wave_period_s": self.period_s,
                "wave_length_m": self.length_m, "wave_dir_deg": math.degrees(self.travel_dir_rad),
                "wave_phase_rad": self.phase_rad, "wave_confidence": self.confidence}


@dataclass
class EstimateHold:
    """The estimate, or for ``hold_s`` after the confidence dropped the last confident one: its phase is
    referred to the autopilot clock and the NED frame, so it stays valid while the boat turns (where the
    estimator loses and regains its lock) as long as the period was right. Never across the clock going
    back (a reboot): that phase belongs to the old clock. Used by the companion and the in-process loop."""

    hold_s: float = 0.0
    _held: WaveEstimate | None = None
    _held_t: float = -math.inf

    def apply(self, est: WaveEstimate | None, t_s: float) -> WaveEstimate | None:
        """``est`` if there is one (and remember it), else the held one while it may be held, else None."""
        if est is not None:
            self._held, self._held_t = est, t_s
            return est
        if t_s < self._held_t:
            self._held = None
        return self._held if t_s - self._held_t <= self.hold_s else None


class WaveSource(Protocol):
    """Where the loop's wave knowledge comes from (see the module docstring)."""

    name: str

    def observe(self, sample: MotionSample) -> None:
        """Take one motion sample (called for every ATTITUDE-rate sample, in time order)."""
        ...

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The wave to plan against at autopilot time ``t_s``; None while not confident."""
        ...


@dataclass
class ScenarioTruth:
    """The scenario's own sea handed to the controller: simulation only, never on a real boat."""

    waves: WaveField
    name: str = SCENARIO_TRUTH

    def observe(self, sample: MotionSample) -> None:
        """Truth needs no observations."""

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The true regular wave (calm water: None, i.e. nothing to mitigate)."""
        w = self.waves
        if isinstance(w, CalmWater) or not isinstance(w, RegularWaves):
            return None
        return WaveEstimate(w.height_m, w.period_s, w.length_m, w.travel_dir_rad, w.phase_rad, 1.0,
                            roll_sign=w.roll_sign)


class TrueSpread:
    """An estimator whose slope statistics are replaced by the sea's true ones: simulation only, never on a real
    boat. Wherever the estimator gives a slope covariance (``spread``), this gives ``covariance_ned`` (2×2 NED,
    rad², e.g. ``IrregularWaves.slope_covariance``), so a closed loop on it bounds what the estimated statistics
    can give; while the estimator's own wave is in use, only the share of it that the estimator leaves unexplained
    (its own unexplained-to-whole ratio of slope variance), so that the wave is not counted twice. Everything else
    (samples, the regular wave, the log) is the estimator's."""

    def __init__(self, estimator: object, covariance_ned: np.ndarray) -> None:
        self.estimator = estimator
        self.covariance_ned = np.array(covariance_ned, float)
        self.name = f"{getattr(estimator, 'name', 'estimated')}, true slope statistics (simulation)"

    def __getattr__(self, name: str) -> object:
        """What this class does not define is the estimator's (never for dunders, or before ``__init__``)."""
        if name.startswith("__") or "estimator" not in self.__dict__:
            raise AttributeError(name)
        return getattr(self.__dict__["estimator"], name)

    def observe(self, sample: MotionSample) -> None:
        """The estimator watches the sample."""
        self.estimator.observe(sample)  # type: ignore[attr-defined]

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The estimator's regular wave."""
        return self.estimator.estimate(t_s)  # type: ignore[attr-defined]

    def spread(self, explained: bool) -> np.ndarray | None:
        """The true covariance (its unexplained share while the estimator's wave is in use) whenever the
        estimator has one of its own; None while it has none (a blind or young estimator flies Direct as before)."""
        own = sea_spread(self.estimator, explained)
        if own is None:
            return None
        if not explained:
            return self.covariance_ned.copy()
        whole = sea_spread(self.estimator, False)
        share = float(np.trace(own)) / float(np.trace(whole)) if whole is not None and np.trace(whole) > 0 else 1.0
        return self.covariance_ned * min(max(share, 0.0), 1.0)


# --- what an estimator in a process of its own says back (``mavbridge.companion.wave_process``) ---------------

COUNT = struct.Struct("<q")  # the samples an answer is as of; a call's number
HEAD = struct.Struct("<dB7d8dd")  # answers: t, flags (ANSWER_FLAGS), the estimate's 7 numbers (height, period,
# length, direction, phase, confidence, roll sign), both spreads (4 each), CPU s
ANSWER_FLAGS = ("estimate", "confident", "spread_explained", "spread_alone")  # bit 0, 1, 2, 3


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


def send_held(source: WaveSource) -> None:
    """The samples ``source`` holds go to it now (an estimator in a process of its own holds a paced period's, to
    send them together); nothing for a source that holds none."""
    flush = getattr(source, "flush", None)
    if flush is not None:
        flush()


SAY_EVERY_S = 60.0  # an estimator process's fault that keeps happening is said again at most this often (wall clock)
ESTIMATOR_FAULTS = ("late", "stale", "stopped", "dropped")
ESTIMATOR_SAID = ("stale", "stopped", "dropped")  # the faults said in the run log (``late`` is only counted)


@dataclass
class EstimatorFaults:
    """The wave estimator process's faults (``companion.wave_process``), counted; those of ESTIMATOR_SAID said when
    they start and again at most once every SAY_EVERY_S while they go on (wall clock), and after a stale spell that
    answers come again."""

    stale_s: float  # autopilot s: answers older than this are stale (said in the stale line)
    prefix: str = ""  # what each line starts with (which process)
    counts: dict[str, int] = field(default_factory=lambda: dict.fromkeys(ESTIMATOR_FAULTS, 0))
    _said_at: dict[str, float] = field(default_factory=dict)  # when each fault was last said (wall)
    _stale_said: bool = False  # a stale spell was said: say when answers come again

    def count(self, kind: str, say: Callable[[str], None], exit_text: Callable[[], str], times: int = 1) -> None:
        """``times`` faults of ``kind``; said through ``say`` if due (``exit_text``: the child's exit code, if it ended,
        asked only then)."""
        self.counts[kind] += times
        now = time.monotonic()
        if kind not in ESTIMATOR_SAID or now - self._said_at.get(kind, -math.inf) < SAY_EVERY_S:
            return
        self._said_at[kind] = now
        self._stale_said |= kind == "stale"
        what = {"stale": f"has not answered for over {self.stale_s:g} s of autopilot time: no new estimate",
                "stopped": f"stopped{exit_text()}: no new estimate for the rest of the run",
                "dropped": "had no room for a sample: dropped"}[kind]
        say(f"{self.prefix}{what} ({self.counts[kind]} so far)")

    def recovered(self, say: Callable[[str], None]) -> None:
        """Answers came in time: said once after a stale spell was said."""
        if self._stale_said:
            self._stale_said = False
            say(f"{self.prefix}answers again")
