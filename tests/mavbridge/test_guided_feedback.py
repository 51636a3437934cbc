"""The tau form closed on SERVO_OUTPUT_RAW: with Rover's stock integrators on, its loops still give the plan's
steering and throttle, because the companion sees their outputs and offsets its targets.

The autopilot here is our simulator's copy of Rover's loops, skid mixer and output scaling at 50 Hz (its stock
gains: turn-rate I 0.5, speed I 0.2, the speed target's ramp), the companion's inversion and feedback at 10 Hz
reading the motors' PWM as SERVO_OUTPUT_RAW carries it.
"""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavbridge.companion.guided.feedback import Motors, MotorServo, OutputFeedback, unwrap_us
from mavbridge.companion.guided.inverse import LOOP_PARAMETERS, RoverLoops, loop_targets
from mavbridge.companion.outputs import RcCalibration, skid_fractions
from sim_vehicle.rover.control import NavState, SpeedControl, SteeringControl
from sim_vehicle.rover.mixer import output_to_pwm, skid_mix
from sim_vehicle.rover.params import ParamTable
from vessel import otter_parameters

PARAMS = otter_parameters()
MOTORS = Motors(MotorServo(1, RcCalibration(1000, 1500, 2000, 0), False),
                MotorServo(3, RcCalibration(1100, 1500, 1900, 0), True), asym=1.0)


def _pwm(servo: MotorServo, out: float) -> int:
    cal = servo.calibration
    return output_to_pwm(out, cal.minimum, cal.trim, cal.maximum, servo.reversed_)


@pytest.mark.parametrize("out", [-0.9, -0.3, 0.0, 0.25, 0.8])
@pytest.mark.parametrize("servo", [MOTORS.left, MOTORS.right])
def test_a_motor_output_comes_back_from_its_pwm(servo: MotorServo, out: float) -> None:
    assert servo.output(_pwm(servo, out)) == pytest.approx(out, abs=0.003)  # the µs rounding


def test_the_mixers_throttle_and_steering_come_back_and_a_clipped_output_is_flagged() -> None:
    left, right = skid_mix(0.2, 0.5)  # steering, throttle
    pwms = {s.number: _pwm(s, o) for s, o in ((MOTORS.left, left), (MOTORS.right, right))}
    throttle, steering, clipped = MOTORS.throttle_steering(pwms)
    assert throttle == pytest.approx(0.5, abs=0.005) and steering == pytest.approx(0.2, abs=0.005) and not clipped
    full = {1: 2000, 3: 1100}  # both motors at +1 (the right one reversed)
    assert MOTORS.throttle_steering(full) == (1.0, 0.0, True) and MOTORS.throttle_steering({1: 1500}) is None


def test_the_uint32_microsecond_clock_is_unwrapped_near_the_autopilots_time() -> None:
    assert unwrap_us(123_456_000, 123_400) == 123_456
    laps = 2 ** 32
    late = 5_000_000_000  # 83 min after boot, past the first wrap
    assert unwrap_us(late - laps, late // 1000 - 30) == late // 1000


def _fly(feedback: bool, seconds: float = 30.0) -> list[tuple[float, float, float, float]]:
    """Rover's stock loops at 50 Hz fed the tau form's targets at 10 Hz while the hull does not follow them
    (its speed and turn rate held where the plan's τ would not keep them, so the integrators wind); returns
    (asked throttle, produced throttle, asked steering, produced steering) per control step."""
    table = ParamTable()
    loops = RoverLoops.from_values({name: table[name] for name in LOOP_PARAMETERS})
    speed_loop, steer_loop = SpeedControl(table), SteeringControl(table)
    feedback_loop = OutputFeedback(MOTORS) if feedback else None
    nav = NavState(yaw=0.0, yaw_rate=0.05, vn=1.2)
    out, rows, pwms = None, [], {1: 1500, 3: 1500}
    for step in range(round(seconds * 10)):
        now_ms = 100_000 + 100 * step
        tau_x, tau_n = 90.0 + 30 * math.sin(0.2 * step / 10), 12.0 * math.cos(0.5 * step / 10)
        _, _, throttle, steering = skid_fractions(PARAMS, tau_x, tau_n)
        offsets = (0.0, 0.0)
        if feedback_loop is not None:
            feedback_loop.update(now_ms)
            feedback_loop.asked(now_ms, throttle, steering)
            offsets = (feedback_loop.throttle_offset, feedback_loop.steering_offset)
        rate, speed = loop_targets(PARAMS, loops, tau_x, tau_n, nav.forward_speed, nav.yaw_rate, offsets)
        for tick in range(5):  # the autopilot's 50 Hz loop until the next target
            produced_t = speed_loop.throttle_for_speed(speed, nav, 0.02)
            produced_s = steer_loop.steering_for_rate(rate, nav, 0.02)
            left, right = skid_mix(produced_s, produced_t)
            pwms = {s.number: _pwm(s, o) for s, o in ((MOTORS.left, left), (MOTORS.right, right))}
            if feedback_loop is not None and tick == 4:
                out = mavlink.MAVLink_servo_output_raw_message((now_ms + 80) * 1000, 0, pwms[1], 0, pwms[3], 0, 0, 0,
                                                               0, 0)
                feedback_loop.on_message(out)
        rows.append((throttle, produced_t, steering, produced_s))
    return rows


def test_with_the_stock_integrators_the_feedback_makes_rover_output_what_the_plan_asks() -> None:
    def worst(rows: list[tuple[float, float, float, float]]) -> tuple[float, float]:
        late = rows[100:]  # after 10 s
        return (max(abs(a - p) for a, p, _, _ in late), max(abs(a - p) for _, _, a, p in late))

    open_throttle, open_steering = worst(_fly(False))
    closed_throttle, closed_steering = worst(_fly(True))
    assert open_throttle > 0.15 or open_steering > 0.15  # the integrators wound: the open inversion is off
    assert closed_throttle < 0.05 and closed_steering < 0.05, (closed_throttle, closed_steering)


def _output_at(feedback: OutputFeedback, at_ms: int, left: float, right: float) -> None:
    pwms = {s.number: _pwm(s, o) for s, o in ((MOTORS.left, left), (MOTORS.right, right))}
    feedback.on_message(mavlink.MAVLink_servo_output_raw_message(at_ms * 1000, 0, pwms[1], 0, pwms[3], 0, 0, 0, 0, 0))


def test_an_output_is_paired_only_with_a_request_rover_was_still_flying() -> None:
    """After the plan's targets stop (the final approach, a stand-down, a pilot's turn), a fresh output is not
    compared with the last request of seconds before; a stand-down forgets the offsets too."""
    feedback = OutputFeedback(MOTORS)
    feedback.asked(10_000, 0.5, 0.0)
    _output_at(feedback, 13_000, 0.2, 0.2)  # three seconds later: Rover flies something else by now
    feedback.update(13_000)
    assert feedback.outputs_used == 0 and feedback.throttle_offset == 0.0
    feedback.asked(13_100, 0.5, 0.0)
    _output_at(feedback, 13_180, 0.2, 0.2)  # the loops give 0.2 where 0.5 was asked
    feedback.update(13_200)
    assert feedback.outputs_used == 1 and feedback.throttle_offset == pytest.approx(0.5 * 0.3, abs=0.01)
    feedback.forget()
    _output_at(feedback, 13_280, 0.2, 0.2)
    feedback.update(13_300)
    assert feedback.outputs_used == 1 and feedback.throttle_offset > 0.1  # no request: nothing new, kept
    feedback.forget(offsets=True)
    assert feedback.throttle_offset == feedback.steering_offset == 0.0
