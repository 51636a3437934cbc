"""What the boat did, from a log: its parameters as the companion reads them, and its sticks and motors.

The log's PARAM_VALUEs (what a ground station downloaded, or DataFlash's PARM) configure the companion's output
path as the values it reads on the link would (``parameters.values_problem``, ``Output.configure``), refusing
an autopilot it would refuse. ``BoatOutputs`` keeps the latest RC inputs (RC_CHANNELS, the
pilot's sticks or the overrides the autopilot took) and servo outputs (SERVO_OUTPUT_RAW) and turns the
outputs of the ThrottleLeft/Right servos (SERVOn_FUNCTION 73/74) into the motors' outputs in [-1, 1] and,
through the inverse of ArduPilot's skid mixer (the companion's own), into throttle and steering fractions,
comparable with the ones the companion's command means.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from mavbridge.companion.guided.feedback import MotorServo
from mavbridge.companion.outputs import RcCalibration, inverse_skid_mix

THROTTLE_LEFT, THROTTLE_RIGHT = 73, 74  # SERVOn_FUNCTION (ArduPilot's k_throttleLeft / k_throttleRight)
DEFAULT_MOTORS = {THROTTLE_LEFT: 1, THROTTLE_RIGHT: 3}  # the Otter's wiring (deploy/otter-rover.parm)
BOAT_COLUMNS = ("boat_steering_pwm_us", "boat_throttle_pwm_us", "boat_left_servo_us", "boat_right_servo_us",
                "boat_left_motor", "boat_right_motor", "boat_throttle", "boat_steering")


def motor_servos(params: dict[str, float], say: Callable[[str], None]) -> dict[int, MotorServo]:
    """{73: left servo, 74: right servo} from SERVOn_FUNCTION/MIN/TRIM/MAX/REVERSED in the log; the Otter's
    wiring (SERVO1 left, SERVO3 right, 1100/1500/1900 µs) where the log does not say, said once."""
    found = {int(params[f"SERVO{n}_FUNCTION"]): n for n in range(1, 17)
             if params.get(f"SERVO{n}_FUNCTION") in (THROTTLE_LEFT, THROTTLE_RIGHT)}
    if len(found) < 2:
        say("note: the log does not say which servos drive the motors (SERVOn_FUNCTION 73/74): taking SERVO1 "
            "left and SERVO3 right, as deploy/otter-rover.parm wires the Otter")
        found = dict(DEFAULT_MOTORS)
    servos = {}
    for function, n in found.items():
        lo, trim, hi = (params.get(f"SERVO{n}_{k}", d) for k, d in (("MIN", 1100.0), ("TRIM", 1500.0), ("MAX", 1900.0)))
        try:
            calibration = RcCalibration(round(lo), round(trim), round(hi), 0)
        except ValueError:
            say(f"note: SERVO{n}_MIN/TRIM/MAX {lo:g}/{trim:g}/{hi:g} is not a calibration: taking 1100/1500/1900")
            calibration = RcCalibration(1100, 1500, 1900, 0)
        servos[function] = MotorServo(n, calibration, bool(params.get(f"SERVO{n}_REVERSED", 0.0)))
    return servos


@dataclass
class BoatOutputs:
    """The latest RC inputs and servo outputs of the log, as the replay's ``boat_*`` columns."""

    steering_channel: int
    throttle_channel: int
    servos: dict[int, MotorServo]
    columns: dict[str, float] = field(default_factory=dict)

    @classmethod
    def from_parameters(cls, params: dict[str, float], say: Callable[[str], None]) -> BoatOutputs:
        """The channels (RCMAP_ROLL / RCMAP_THROTTLE, else 1 and 3) and motor servos of the log's parameters."""
        return cls(round(params.get("RCMAP_ROLL", 1.0)), round(params.get("RCMAP_THROTTLE", 3.0)),
                   motor_servos(params, say))

    def take(self, msg: Any) -> None:
        """An RC_CHANNELS or SERVO_OUTPUT_RAW of the autopilot."""
        if msg.get_type() == "RC_CHANNELS":
            self.columns["boat_steering_pwm_us"] = float(getattr(msg, f"chan{self.steering_channel}_raw", 0))
            self.columns["boat_throttle_pwm_us"] = float(getattr(msg, f"chan{self.throttle_channel}_raw", 0))
            return
        left, right = self.servos[THROTTLE_LEFT], self.servos[THROTTLE_RIGHT]
        left_pwm = int(getattr(msg, f"servo{left.number}_raw", 0))
        right_pwm = int(getattr(msg, f"servo{right.number}_raw", 0))
        left_out, right_out = left.output(left_pwm), right.output(right_pwm)
        self.columns.update(boat_left_servo_us=float(left_pwm), boat_right_servo_us=float(right_pwm))
        if left_out is None or right_out is None:
            for key in ("boat_left_motor", "boat_right_motor", "boat_throttle", "boat_steering"):
                self.columns[key] = math.nan
            return
        throttle, steering = inverse_skid_mix(left_out, right_out)
        self.columns.update(boat_left_motor=left_out, boat_right_motor=right_out, boat_throttle=throttle,
                            boat_steering=steering)
