"""The pilot's sticks as Rover reads them: RC channel 1 (steering) and 3 (throttle), PILOT_STEER_TYPE."""

from __future__ import annotations

from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.rc import RcInput, stick

# PILOT_STEER_TYPE: how the steering and throttle sticks are read (Rover's pilot_steer_type_t)
STEER_DEFAULT, STEER_TWO_PADDLES, STEER_DIR_REVERSED_WHEN_REVERSING, STEER_DIR_UNCHANGED_WHEN_REVERSING = 0, 1, 2, 3
STEERING_CHANNEL, THROTTLE_CHANNEL = 1, 3


def stick_position(params: ParamTable, rc: RcInput, channel: int, now: float, dead_zone: bool = True) -> float:
    """Pilot stick of ``channel`` (1 steering, 3 throttle) in [-1, 1] after its dead zone (or without it,
    as RC_Channel::norm_input reads a channel)."""
    pwm = rc.pwm(channel, now, params["RC_OVERRIDE_TIME"])
    return stick(
        pwm,
        params[f"RC{channel}_MIN"],
        params[f"RC{channel}_TRIM"],
        params[f"RC{channel}_MAX"],
        params[f"RC{channel}_DZ"] if dead_zone else 0.0,
        params[f"RC{channel}_REVERSED"] != 0,
    )


def reverses_steering(params: ParamTable) -> bool:
    """True if PILOT_STEER_TYPE flips the steering stick while going backwards (types 0 and 2)."""
    return int(params["PILOT_STEER_TYPE"]) not in (STEER_TWO_PADDLES, STEER_DIR_UNCHANGED_WHEN_REVERSING)


def pilot_input(params: ParamTable, rc: RcInput, now: float) -> tuple[float, float]:
    """The pilot's steering and throttle in [-1, 1] as Rover's Mode::get_pilot_input reads them.

    PILOT_STEER_TYPE 0/2 (and unknown values) mirror the steering while the throttle stick is below
    trim, so the boat turns like a car reversing; 3 leaves it alone; 1 reads ch1 as the left and ch3
    as the right paddle (each -1..1, no dead zone), which the skid mixer turns back into exactly those
    two motor outputs. (Rover also zeroes both while the radio-failsafe condition holds; not modelled.)
    """
    if int(params["PILOT_STEER_TYPE"]) == STEER_TWO_PADDLES:
        left = stick_position(params, rc, STEERING_CHANNEL, now, dead_zone=False)
        right = stick_position(params, rc, THROTTLE_CHANNEL, now, dead_zone=False)
        return 0.5 * (left - right), 0.5 * (left + right)
    steering = stick_position(params, rc, STEERING_CHANNEL, now)
    throttle = stick_position(params, rc, THROTTLE_CHANNEL, now)
    if throttle < 0 and reverses_steering(params):
        steering = -steering
    return steering, throttle
