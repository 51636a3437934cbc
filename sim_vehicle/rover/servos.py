"""The motor outputs: skid mix, PWM on the SERVOn outputs that hold ThrottleLeft/Right, and what the ESCs read."""

from __future__ import annotations

from dataclasses import dataclass, field

from sim_vehicle.rover.mixer import output_to_pwm, pwm_to_output, skid_mix
from sim_vehicle.rover.params import ParamTable

THROTTLE_LEFT, THROTTLE_RIGHT = 73, 74  # SERVOn_FUNCTION values (ArduPilot's SRV_Channel k_throttleLeft/Right)
MOTOR_OUTPUTS = (1, 3)  # the SERVOn outputs the Otter's ESCs are wired to
N_SERVOS = 16


@dataclass(frozen=True)
class ServoState:
    """PWM on outputs 1..16 (µs, 0 = no pulse) and the left/right motor outputs in [-1, 1] the ESCs decode."""

    pwm: list[int] = field(default_factory=lambda: [0] * N_SERVOS)
    motors: tuple[float, float] = (0.0, 0.0)


def skid_config_ok(params: ParamTable) -> bool:
    """Both or neither of ThrottleLeft/ThrottleRight must be assigned to outputs."""
    functions = {params[f"SERVO{n}_FUNCTION"] for n in MOTOR_OUTPUTS}
    return (THROTTLE_LEFT in functions) == (THROTTLE_RIGHT in functions)


def servo_outputs(params: ParamTable, armed: bool, steering: float, throttle: float) -> ServoState:
    """Mix steering/throttle in [-1, 1], write PWM to the ThrottleLeft/Right outputs, decode them as the ESCs do.

    Disarmed, the outputs sit at trim, or carry no pulse at all with MOT_SAFE_DISARM = 1.
    """
    pwm = [0] * N_SERVOS
    if armed and skid_config_ok(params):
        left, right = skid_mix(steering, throttle, params["MOT_STR_THR_MIX"], params["MOT_THST_ASYM"])
    else:
        left = right = 0.0
    outs = {THROTTLE_LEFT: 0.0, THROTTLE_RIGHT: 0.0}
    for n in MOTOR_OUTPUTS:
        function = int(params[f"SERVO{n}_FUNCTION"])
        if function not in outs:
            continue
        lo, trim, hi = params[f"SERVO{n}_MIN"], params[f"SERVO{n}_TRIM"], params[f"SERVO{n}_MAX"]
        rev = params[f"SERVO{n}_REVERSED"] != 0
        demand = left if function == THROTTLE_LEFT else right
        silent = not armed and params["MOT_SAFE_DISARM"] == 1
        pwm[n - 1] = 0 if silent else output_to_pwm(demand, lo, trim, hi, rev)
        outs[function] = pwm_to_output(pwm[n - 1], lo, trim, hi, rev)
    motors = (outs[THROTTLE_LEFT], outs[THROTTLE_RIGHT]) if armed else (0.0, 0.0)
    return ServoState(pwm, motors)
