"""The identification sequence as data, and the state machine that flies it (autopilot time, one call a period).

What `mavbridge identify` needs from a log, and the leg that gives it:

- surge speed against the command, forward and reverse: throttle held at 0.3, 0.6 and 1.0 of full forward and
  at −0.5 and −1.0 (full reverse), each long enough for three steady 5 s windows after the speed settles, the
  heading held by a small proportional steering (``HEADING_GAIN``) on the partial steps; the full steps run
  unsteered (any steering there takes thrust off one motor: the command would not be steady);
- the propellers' asymmetry: the heading holds at throttle 0.3 and 0.6 (two holds at two throttles, which tell a
  weaker propeller from a steady wind or current moment);
- Nomoto K and T: a 20°/20° zig-zag at throttle 0.6 (steering ±``ZIGZAG_STEERING``,
  switched each time the heading passes 20° either side of the leg's first heading);
- roll period and damping: hard turns in place (full steering at zero throttle), braked for a second — full
  opposite steering until the yaw rate, predicted ``brake_lead`` ahead, would have stopped, then steering in
  proportion against the rate predicted for when the command acts (``BRAKE_PROPORTIONAL_RAD_S``) — then released
  with the sticks at neutral while roll decays; two each way. The sharp stop is what rolls the hull; the yaw rate
  must be near zero for the decay that follows to be free.

  The sticks act late: the link's delay (the state's age plus the uplink's one-way delay, which the companion
  measures with TIMESYNC, passed in as ``command``'s ``delay_s``), the autopilot's loop and the motors' lag
  (neither measured). The brake looks the measured delay plus ``BRAKE_MARGIN_S`` ahead, at least ``BRAKE_LEAD_S``
  (which alone covers about a control period of delay, all there is when nothing is measured); the delay counts
  up to ``BRAKE_DELAY_MAX_S``. Within the delay the boat still answers the commands already sent, so the
  prediction runs the hard turn's own first-order yaw model (its steady rate and its largest spin-up
  acceleration, ``Nomoto``) from the sampled yaw rate under the commands in flight; without a model, at the yaw
  rate's present rate of change. On the plant with the sticks two or three periods late, a brake looking the
  fixed 0.15 s ahead left 3–8°/s of turn to the decay; looking the delay ahead, under 2°/s.

The legs keep the boat near where it started: every leg under way that chooses a heading points it back at the
start once the boat is more than ``HOME_RADIUS_M`` away. Every leg has a longest duration, so the whole
sequence has one too (``limit_s``). Steering is the skid mixer's fraction (left motor = throttle + steering,
right = throttle − steering), positive turning to starboard.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

HEADING_GAIN = 1.0  # steering fraction per radian of heading error, on the legs that hold a heading
HOLD_STEERING = 0.3  # at most this much steering to hold a heading on a throttle step
HOME_STEERING = 0.5  # ... and to turn back towards the start
HOME_RADIUS_M = 20.0  # farther than this from the start, a leg that chooses a heading points home
HOME_ALIGNED_RAD = math.radians(10.0)  # the turn home ends this close to the bearing
ZIGZAG_RAD = math.radians(20.0)
ZIGZAG_STEERING = 0.3
ZIGZAG_SWITCHES = 10
BRAKE_LEAD_S = 0.15  # the full brake ends when the yaw rate would stop this much ahead, at least ...
BRAKE_MARGIN_S = 0.1  # ... and the measured command delay plus this (the autopilot's loop, the motors' lag)
BRAKE_DELAY_MAX_S = 0.6  # a measured command delay counts up to this much
PREDICT_STEP_S = 0.02  # the brake's prediction of the yaw rate integrates its Nomoto model in steps of at most this
MIN_SPIN_T_S = 0.05  # the hard turn's Nomoto T is taken as at least this (two close, noisy gyro samples read as a
#                      huge spin-up acceleration, a T of milliseconds no hull has)
BRAKE_PROPORTIONAL_RAD_S = math.radians(30.0)  # after it, steering against the yaw rate in proportion: full at this


@dataclass(frozen=True)
class Leg:
    """One leg: ``kind`` hold (throttle, heading held), home (turn towards the start), zigzag, spin (full steering
    ``steering`` at zero throttle), brake (steering against the yaw rate at zero throttle) or coast (neutral);
    ``seconds`` its duration (hold, spin, brake, coast) or longest duration (home, zigzag)."""

    name: str
    kind: str
    seconds: float
    throttle: float = 0.0
    steering: float = 0.0


SEQUENCE: tuple[Leg, ...] = (
    Leg("settle", "coast", 5.0),
    Leg("throttle 0.3", "hold", 25.0, 0.3),
    Leg("throttle 0.6", "hold", 20.0, 0.6),
    Leg("turn home", "home", 20.0, 0.3),
    Leg("throttle 1.0", "hold", 20.0, 1.0),
    Leg("stop", "coast", 10.0),
    Leg("reverse 0.5", "hold", 25.0, -0.5),
    Leg("reverse 1.0", "hold", 20.0, -1.0),
    Leg("stop", "coast", 10.0),
    Leg("turn home", "home", 20.0, 0.3),
    Leg("zig-zag 20/20", "zigzag", 70.0, 0.6, ZIGZAG_STEERING),
    Leg("stop", "coast", 10.0),
    *(leg for steering in (1.0, -1.0, 1.0, -1.0) for leg in (
        Leg(f"hard turn {'right' if steering > 0 else 'left'}", "spin", 3.0, 0.0, steering),
        Leg("brake", "brake", 1.0),
        Leg("roll decay", "coast", 5.0))),
)


LEG_LATE_S = 0.25  # a leg ends at the first command at or after its duration: up to a period late, a slow one too


def limit_s(legs: tuple[Leg, ...] = SEQUENCE) -> float:
    """The longest the sequence can take (s of autopilot time): its legs' longest durations, each ended up to
    ``LEG_LATE_S`` late (the flight's time limit, so that it never cuts the last roll decay short)."""
    return sum(leg.seconds + LEG_LATE_S for leg in legs)


@dataclass(frozen=True)
class Sticks:
    """One period's command: throttle and steering fractions in [−1, 1], and the leg that gave them."""

    leg: str
    throttle: float
    steering: float


@dataclass(frozen=True)
class Pose:
    """What the sequence reads of the boat: NED position (m), heading (rad) and yaw rate (rad/s)."""

    north: float
    east: float
    yaw: float
    yaw_rate: float
    sample_s: float | None = None  # when the attitude was sampled (s of autopilot time); None: at the command's time


def wrap(angle: float) -> float:
    """An angle in (−π, π]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def _clip(value: float, limit: float) -> float:
    return min(max(value, -limit), limit)


def command_delay(delay_s: float | None) -> float:
    """The command delay the brake allows for (s): a measured one (the state's age plus the uplink's one-way
    delay, what the companion's delay compensation measures) bounded to [0, ``BRAKE_DELAY_MAX_S``]; 0 when none
    is measured (``BRAKE_LEAD_S`` alone then covers a delay of about a control period)."""
    if delay_s is None or not math.isfinite(delay_s):
        return 0.0
    return min(max(delay_s, 0.0), BRAKE_DELAY_MAX_S)


def brake_lead(delay_s: float) -> float:
    """How far ahead (s) the full brake looks for the yaw rate to stop: the command delay plus
    ``BRAKE_MARGIN_S``, never less than ``BRAKE_LEAD_S``."""
    return max(BRAKE_LEAD_S, delay_s + BRAKE_MARGIN_S)


@dataclass(frozen=True)
class Nomoto:
    """The hard turn's yaw as a first-order model, ṙ = (K·steering − r) / T: ``gain`` K (rad/s per unit
    steering) its steady rate, ``time_constant`` T (s) from its largest spin-up acceleration (K/T)."""

    gain: float
    time_constant: float

    def rate_after(self, rate: float, seconds: float, steering_at: Callable[[float], float]) -> float:
        """The yaw rate ``seconds`` on from ``rate`` (rad/s) under ``steering_at(s since now)``, the steering held
        over each step and the model stepped exactly (stable for any T > 0: an explicit Euler step diverged once a
        noisy spin-up gave T under the step)."""
        steps = max(1, math.ceil(seconds / PREDICT_STEP_S))
        dt = seconds / steps
        decay = math.exp(-dt / max(self.time_constant, MIN_SPIN_T_S))
        for k in range(steps):
            steady = self.gain * steering_at(k * dt)
            rate = steady + (rate - steady) * decay
        return rate


class IdentifySequence:
    """Flies ``legs`` from the first call on; ``command`` gives each period's sticks, None once it is over."""

    def __init__(self, legs: tuple[Leg, ...] = SEQUENCE) -> None:
        self.legs = legs
        self.index = -1
        self.leg_start_s = 0.0
        self.start: tuple[float, float] | None = None
        self.heading = 0.0  # the leg's heading reference (rad)
        self.sign = 1.0  # the zig-zag's steering sign
        self.switches = 0
        self.aligned_since_s: float | None = None
        self.last_spin = 0.0  # the last hard turn's steering, which the brake opposes
        self.braking_fully = False
        self.spin: tuple[float, float] = (0.0, 0.0)  # the hard turn's last yaw rate and largest acceleration its way
        self.delay_s = 0.0  # the command delay allowed for (``command_delay``)
        self.issued: deque[tuple[float, float]] = deque()  # (t s, steering) of the recent commands, oldest first
        self.yaw_accel = 0.0  # rad/s², from the last two calls' yaw rates
        self.last_rate: tuple[float, float] | None = None  # (t s, yaw rate rad/s) of the last call

    @property
    def leg(self) -> Leg | None:
        """The leg being flown (None before the first call and after the last leg)."""
        return self.legs[self.index] if 0 <= self.index < len(self.legs) else None

    def _home_bearing(self, pose: Pose) -> float:
        assert self.start is not None
        return math.atan2(self.start[1] - pose.east, self.start[0] - pose.north)

    def _away_m(self, pose: Pose) -> float:
        assert self.start is not None
        return math.hypot(pose.north - self.start[0], pose.east - self.start[1])

    def _begin(self, index: int, t_s: float, pose: Pose) -> None:
        self.index, self.leg_start_s = index, t_s
        self.switches, self.sign, self.aligned_since_s = 0, 1.0, None
        leg = self.leg
        if leg is None:
            return
        far = self._away_m(pose) > HOME_RADIUS_M
        self.heading = self._home_bearing(pose) if leg.kind == "home" or (far and leg.kind == "zigzag") else pose.yaw
        if leg.kind == "spin":
            self.last_spin, self.spin = leg.steering, (0.0, 0.0)
        self.braking_fully = leg.kind == "brake"

    def _done(self, leg: Leg, t_s: float, pose: Pose) -> bool:
        """The leg is over: its time is up, or what it waits for happened."""
        elapsed = t_s - self.leg_start_s
        if elapsed >= leg.seconds:
            return True
        if leg.kind == "zigzag":
            return self.switches >= ZIGZAG_SWITCHES
        if leg.kind == "home":
            aligned = abs(wrap(self._home_bearing(pose) - pose.yaw)) < HOME_ALIGNED_RAD
            self.aligned_since_s = (self.aligned_since_s or t_s) if aligned else None
            return self.aligned_since_s is not None and t_s - self.aligned_since_s >= 2.0
        return False

    def _steering(self, leg: Leg, t_s: float, pose: Pose) -> float:
        if leg.kind == "hold":  # at full command any steering takes thrust off one motor: those steps run unsteered
            if leg.throttle == 0 or abs(leg.throttle) >= 1.0:
                return 0.0
            return _clip(HEADING_GAIN * wrap(self.heading - pose.yaw), HOLD_STEERING)
        if leg.kind == "home":
            return _clip(HEADING_GAIN * wrap(self._home_bearing(pose) - pose.yaw), HOME_STEERING)
        if leg.kind == "zigzag":
            off = wrap(pose.yaw - self.heading)
            if self.sign * off >= ZIGZAG_RAD:
                self.sign, self.switches = -self.sign, self.switches + 1
            return self.sign * leg.steering
        if leg.kind == "spin":
            way = math.copysign(1.0, leg.steering)
            self.spin = (pose.yaw_rate, max(self.spin[1], self.yaw_accel * way))
            return leg.steering
        if leg.kind == "brake":
            return self._brake(t_s, pose)
        return 0.0

    def _brake(self, t_s: float, pose: Pose) -> float:
        """Full steering against the last hard turn until the yaw rate, predicted to ``BRAKE_LEAD_S`` after this
        command acts (``delay_s`` on), would have stopped, then against the rate predicted for when it acts, in
        proportion. The commands in flight meanwhile are the sequence's own (``issued``)."""
        if self.braking_fully and self._rate_at(t_s, pose, brake_lead(self.delay_s), -self.last_spin) \
                * self.last_spin > 0:
            return -self.last_spin
        self.braking_fully = False
        return _clip(-self._rate_at(t_s, pose, self.delay_s, 0.0) / BRAKE_PROPORTIONAL_RAD_S, 1.0)

    def _spin_model(self) -> Nomoto | None:
        """The last hard turn's Nomoto model, None when it did not turn its way or speed up doing so."""
        rate, accel = self.spin
        gain = rate / self.last_spin if self.last_spin else 0.0
        if gain <= 0.0 or accel <= 0.0:
            return None
        return Nomoto(gain, gain / accel)

    def _rate_at(self, t_s: float, pose: Pose, ahead_s: float, steering: float) -> float:
        """The yaw rate ``ahead_s`` after ``t_s`` (rad/s), this command being ``steering``: the hard turn's model
        from the sampled rate under the commands in effect then (each acting ``delay_s`` after it was issued); at
        the present rate of change without a model."""
        sampled = t_s if pose.sample_s is None else min(pose.sample_s, t_s)
        horizon = t_s + ahead_s - sampled
        model = self._spin_model()
        if model is None:
            return pose.yaw_rate + self.yaw_accel * horizon
        issued = [*self.issued, (t_s, steering)]

        def steering_at(since_s: float) -> float:
            acting = sampled + since_s - self.delay_s
            return next((u for at, u in reversed(issued) if at <= acting + 1e-9), 0.0)

        return model.rate_after(pose.yaw_rate, horizon, steering_at)

    def _track_yaw_accel(self, t_s: float, pose: Pose) -> None:
        """The yaw rate's rate of change between attitude samples: a sample seen again (ATTITUDE slower than the
        control period) changes nothing, where taken at the command's time it would read as no deceleration."""
        sampled = t_s if pose.sample_s is None else pose.sample_s
        if self.last_rate is not None and sampled > self.last_rate[0]:
            self.yaw_accel = (pose.yaw_rate - self.last_rate[1]) / (sampled - self.last_rate[0])
        if self.last_rate is None or sampled > self.last_rate[0] or sampled < self.last_rate[0] - 1.0:
            self.last_rate = (sampled, pose.yaw_rate)  # (a clock gone back a second or more starts afresh)

    def command(self, t_s: float, pose: Pose, delay_s: float | None = None) -> Sticks | None:
        """The sticks for autopilot time ``t_s`` (s) and the boat's ``pose``, ``delay_s`` the command delay measured
        (s: from the pose's sample to the command acting; None: not measured); None once the sequence is over."""
        self.delay_s = command_delay(delay_s)
        self._track_yaw_accel(t_s, pose)
        if self.start is None:
            self.start = (pose.north, pose.east)
            self._begin(0, t_s, pose)
        leg = self.leg
        while leg is not None and self._done(leg, t_s, pose):
            self._begin(self.index + 1, t_s, pose)
            leg = self.leg
        if leg is None:
            return None
        sticks = Sticks(leg.name, leg.throttle, self._steering(leg, t_s, pose))
        if self.issued and t_s < self.issued[-1][0] - 1.0:  # the autopilot's clock went back (a reboot): afresh
            self.issued.clear()
        self.issued.append((t_s, sticks.steering))
        while self.issued and self.issued[0][0] < t_s - BRAKE_DELAY_MAX_S - 1.0:
            self.issued.popleft()
        return sticks
