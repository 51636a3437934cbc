"""Rover's own outputs, seen: the GUIDED tau form closed on SERVO_OUTPUT_RAW, so Rover's integrators may stay on.

The tau form (``guided.inverse``) picks the turn-rate and speed targets for which Rover's feed-forward and P
terms give the plan's steering and throttle. With Rover's stock gains its integrators add to that (and so does
what the inversion leaves out: the speed target's ramp, filters); the companion cannot follow them from
outside (a copy at 10 Hz drifted from the autopilot's own: see ``guided.inverse``). It can see what they did:
SERVO_OUTPUT_RAW reports the PWM Rover sends to each motor, which through SERVOn_MIN/TRIM/MAX/REVERSED,
MOT_THST_ASYM and the skid mixer (left = throttle + steering, right = throttle − steering) gives back the
throttle and steering its loops produced. ``OutputFeedback`` integrates the difference between what the plan
asked for and what Rover produced (``FEEDBACK_GAIN`` of it per fresh output) into offsets the inversion adds,
so Rover's loops give what the plan asks whatever their integrators hold. Outputs at a motor's limit say
only bound what the loops asked for (the mixer clipped it): they count a quarter as much.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

from mavbridge.companion.outputs import RcCalibration, fraction_from_pwm
from mavbridge.link.connection import LinkError

THROTTLE_LEFT, THROTTLE_RIGHT = 73, 74  # SERVOn_FUNCTION of a skid-steered boat's motors
MOTOR_SERVOS = (1, 3)  # where Rover's boat frames put them (SERVO1, SERVO3); their functions are checked
FEEDBACK_GAIN = 0.5  # share of the plan-minus-Rover difference taken into the offsets at each fresh output
OFFSET_LIMIT = 1.0  # the offsets' bound (throttle and steering fractions)
SATURATED = 0.98  # a motor output this close to ±1 was clipped by the mixer: no evidence about the loops
REQUEST_HOLD_MS = 250  # a request older than this before an output is not the one Rover was flying (2.5 periods)
LOOP_LAG_MS = 20  # Rover applies a new target at its next loop: an output this soon after a send is the old one's
UINT32_US = 1 << 32


@dataclass(frozen=True)
class MotorServo:
    """One motor's output channel: SERVOn_MIN/TRIM/MAX (µs, no dead zone) and REVERSED."""

    number: int
    calibration: RcCalibration
    reversed_: bool

    def output(self, pwm: int) -> float | None:
        """The motor output in [-1, 1] Rover sent as ``pwm`` µs; None without a pulse (0 µs)."""
        if pwm <= 0:
            return None
        out = fraction_from_pwm(pwm, self.calibration)
        return -out if self.reversed_ else out


@dataclass(frozen=True)
class Motors:
    """The two motors' channels and MOT_THST_ASYM (Rover limits reverse to −1/asym, then stretches it back)."""

    left: MotorServo
    right: MotorServo
    asym: float = 1.0

    def throttle_steering(self, pwms: dict[int, int]) -> tuple[float, float, bool] | None:
        """(throttle, steering, clipped) Rover's loops produced, from the servo PWMs by number (``clipped``: a motor
        was at its limit, so the loops asked for at least that much); None when a PWM is missing."""
        outputs = [s.output(pwms.get(s.number, 0)) for s in (self.left, self.right)]
        if outputs[0] is None or outputs[1] is None:
            return None
        left, right = (self._unstretched(out) for out in outputs)
        return 0.5 * (left + right), 0.5 * (left - right), max(abs(left), abs(right)) >= SATURATED

    def _unstretched(self, out: float) -> float:
        return out / self.asym if out < 0 and self.asym > 1 else out


MOTOR_PARAMETERS = tuple(f"SERVO{n}_{k}" for n in MOTOR_SERVOS for k in ("FUNCTION", "MIN", "TRIM", "MAX", "REVERSED"))
ASYM = "MOT_THST_ASYM"


def motors_from(values: dict[str, float]) -> Motors:
    """The motor channels from the autopilot's parameter values (``MOTOR_PARAMETERS``, ``ASYM`` where answered);
    LinkError (one line) when SERVO1/3 are not skid steering's ThrottleLeft/ThrottleRight or a value is missing."""
    functions = {n: values.get(f"SERVO{n}_FUNCTION") for n in MOTOR_SERVOS}
    by_function = {int(f): n for n, f in functions.items() if f is not None}
    if set(by_function) != {THROTTLE_LEFT, THROTTLE_RIGHT}:
        raise LinkError(f"attitude_form tau: SERVO1_FUNCTION/SERVO3_FUNCTION are {functions[1]}/{functions[3]}; the "
                        "output feedback needs skid steering's ThrottleLeft (73) and ThrottleRight (74) there")

    def servo(n: int) -> MotorServo:
        missing = [k for k in ("MIN", "TRIM", "MAX", "REVERSED") if f"SERVO{n}_{k}" not in values]
        if missing:
            raise LinkError(f"attitude_form tau: SERVO{n}_{missing[0]} was not read; the output feedback needs it")
        try:
            calibration = RcCalibration(*(round(values[f"SERVO{n}_{k}"]) for k in ("MIN", "TRIM", "MAX")), 0)
        except ValueError as exc:
            raise LinkError(f"attitude_form tau: SERVO{n}: {exc}") from None
        return MotorServo(n, calibration, bool(values[f"SERVO{n}_REVERSED"]))

    asym = values.get(ASYM)
    return Motors(servo(by_function[THROTTLE_LEFT]), servo(by_function[THROTTLE_RIGHT]),
                  float(asym) if asym is not None and asym >= 1 else 1.0)


def unwrap_us(time_usec: int, near_ms: int) -> int:
    """SERVO_OUTPUT_RAW's time (a uint32 of µs since boot, wrapping every 71.6 min) in ms, on the lap of
    ``near_ms`` (the autopilot's time_boot_ms now)."""
    laps = round((near_ms * 1000 - time_usec) / UINT32_US)
    return (time_usec + laps * UINT32_US) // 1000


class OutputFeedback:
    """Offsets (throttle, steering) that make Rover's loops produce what the plan asked (module docstring)."""

    def __init__(self, motors: Motors, gain: float = FEEDBACK_GAIN) -> None:
        self.motors, self.gain = motors, gain
        self.throttle_offset = self.steering_offset = 0.0
        self._asked: deque[tuple[int, float, float]] = deque(maxlen=20)  # (autopilot ms, throttle, steering)
        self._output: tuple[int, dict[int, int]] | None = None  # the newest SERVO_OUTPUT_RAW: (µs, pwm by n)
        self._used_us: int | None = None
        self.outputs_seen = self.outputs_used = 0

    def on_message(self, msg: Any) -> None:
        """Keep the newest SERVO_OUTPUT_RAW (a link handler)."""
        if msg.get_type() == "SERVO_OUTPUT_RAW":
            numbers = (self.motors.left.number, self.motors.right.number)
            self._output = (int(msg.time_usec), {n: int(getattr(msg, f"servo{n}_raw", 0)) for n in numbers})
            self.outputs_seen += 1

    def asked(self, now_ms: int, throttle: float, steering: float) -> None:
        """What the plan asked for at autopilot time ``now_ms`` (before the offsets)."""
        self._asked.append((now_ms, throttle, steering))

    def forget(self, offsets: bool = False) -> None:
        """Drop the requests (the plan's targets stopped: the final approach, a stand-down); with ``offsets``
        the offsets too (Rover's loops restart after a mode change: what they needed before is no evidence)."""
        self._asked.clear()
        if offsets:
            self.throttle_offset = self.steering_offset = 0.0

    def update(self, now_ms: int) -> None:
        """Take a fresh output into the offsets: the plan's request then against what Rover produced."""
        if self._output is None or self._output[0] == self._used_us:
            return
        time_usec, pwms = self._output
        self._used_us = time_usec
        produced = self.motors.throttle_steering(pwms)
        at_ms = unwrap_us(time_usec, now_ms) - LOOP_LAG_MS
        request = next((r for r in reversed(self._asked) if r[0] <= at_ms), None)
        if produced is None or request is None or at_ms - request[0] > REQUEST_HOLD_MS:
            return  # (an old request: the plan's targets stopped since, e.g. the final approach or a stand-down)
        throttle, steering, clipped = produced
        if clipped and abs(request[1]) + abs(request[2]) >= SATURATED:
            return  # the plan itself asked for the limit: a clipped output is what it asked
        # clipped: the loops asked for at least the limit, so the difference is a bound; take a quarter of it
        gain = self.gain * (0.25 if clipped else 1.0)
        self.throttle_offset = _bounded(self.throttle_offset + gain * (request[1] - throttle))
        self.steering_offset = _bounded(self.steering_offset + gain * (request[2] - steering))
        self.outputs_used += 1


def _bounded(value: float) -> float:
    return max(-OFFSET_LIMIT, min(OFFSET_LIMIT, value)) if math.isfinite(value) else 0.0
