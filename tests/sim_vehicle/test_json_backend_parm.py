"""deploy/otter-json-sitl.parm: reasons on every line, values the backend and the model agree with."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sim_vehicle.json_backend.protocol import (
    FRAME_RATE_MAX_HZ,
    FRAME_RATE_MIN_HZ,
    LEFT_CHANNEL,
    RIGHT_CHANNEL,
    SERVO_MAX_US,
    SERVO_MIN_US,
    SERVO_TRIM_US,
)
from sim_vehicle.rover.params import ParamTable, read_parm
from vessel import CalmWater, Plant, otter_parameters

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"
JSON_PARM = DEPLOY / "otter-json-sitl.parm"
BOAT_PARM = DEPLOY / "otter-rover.parm"


@pytest.fixture(scope="module")
def parm() -> dict[str, float]:
    return read_parm(JSON_PARM)


def _steady(left_frac: float, right_frac: float, seconds: float = 200.0) -> tuple[float, float]:
    """(surge m/s, yaw rate rad/s) of the published Otter in calm water after ``seconds`` at these shaft speeds."""
    params = otter_parameters("published")
    n_max = params.matrices().n_max
    plant = Plant(params, CalmWater(), dt=0.01)
    plant.advance((left_frac * n_max, right_frac * n_max), round(seconds / 0.01))
    x = plant.state
    return float(x[6]), float(x[11])


def test_every_parameter_line_has_its_reason_above() -> None:
    """Each run of NAME,VALUE lines starts right after a comment line (its reason), never after a blank."""
    previous = ""
    for number, line in enumerate(JSON_PARM.read_text(encoding="utf-8").splitlines(), 1):
        if line and not line.startswith("#"):
            assert previous, f"line {number} ({line}) has no reason above it"
        previous = line


def test_outputs_are_what_the_backend_reads(parm: dict[str, float]) -> None:
    """Boat frame, ThrottleLeft on SERVO1 and ThrottleRight on SERVO3, with the pulse range the backend maps."""
    assert parm["FRAME_CLASS"] == 2
    assert parm[f"SERVO{LEFT_CHANNEL + 1}_FUNCTION"] == 73
    assert parm[f"SERVO{RIGHT_CHANNEL + 1}_FUNCTION"] == 74
    for servo in (LEFT_CHANNEL + 1, RIGHT_CHANNEL + 1):
        assert (parm[f"SERVO{servo}_MIN"], parm[f"SERVO{servo}_TRIM"], parm[f"SERVO{servo}_MAX"]) == \
            (SERVO_MIN_US, SERVO_TRIM_US, SERVO_MAX_US)
    assert FRAME_RATE_MIN_HZ <= parm["SIM_RATE_HZ"] <= FRAME_RATE_MAX_HZ
    assert parm["SIM_RATE_HZ"] > 50  # above Rover's loop rate


def test_cruise_speed_is_the_models_speed_at_cruise_throttle(parm: dict[str, float]) -> None:
    """CRUISE_SPEED = the model's steady straight-line speed at CRUISE_THROTTLE on both shafts (1 %)."""
    throttle = parm["CRUISE_THROTTLE"] / 100
    surge, _ = _steady(throttle, throttle)
    assert parm["CRUISE_SPEED"] == pytest.approx(surge, rel=0.01)
    assert abs(parm["CRUISE_SPEED"] - parm["WP_SPEED"]) < 0.25 * parm["WP_SPEED"]  # feed-forward where it runs


def test_steering_feed_forward_is_one_over_the_models_turn_rate(parm: dict[str, float]) -> None:
    """ATC_STR_RAT_FF = 1 / (turn rate at full steering) and ATC_STR_RAT_MAX = that rate in deg/s (2 %)."""
    _, rate = _steady(1.0, -1.0, 120.0)
    assert parm["ATC_STR_RAT_FF"] == pytest.approx(1 / rate, rel=0.02)
    assert parm["ATC_STR_RAT_MAX"] == pytest.approx(math.degrees(rate), rel=0.02)


def test_turn_g_limit_is_the_firmwares_smallest_above_the_hulls(parm: dict[str, float]) -> None:
    """The hull's own lateral acceleration at 100 %/0 % is below 0.1 g, the firmware's minimum TURN_MAX_G."""
    surge, rate = _steady(1.0, 0.0, 120.0)
    assert abs(surge * rate) / 9.81 < parm["TURN_MAX_G"] == 0.1


def test_boat_values_are_the_boat_files(parm: dict[str, float]) -> None:
    """Every parameter of deploy/otter-rover.parm is here with the same value: the firmware runs as on the boat."""
    boat = read_parm(BOAT_PARM)
    missing = sorted(set(boat) - set(parm))
    different = sorted(name for name in boat if name in parm and parm[name] != boat[name])
    assert not missing and not different, f"missing {missing}, different {different}"


def test_the_readme_commands_parse() -> None:
    """The middle-step commands in deploy/README.md use flags that exist, with values that validate."""
    import shlex

    from mavbridge.cli import build_parser as mavbridge_parser
    from sim_vehicle.json_backend.cli import build_parser as backend_parser

    text = (DEPLOY / "README.md").read_text(encoding="utf-8")
    section = text[text.index("## 5a."):text.index("## 6.")]
    commands = [shlex.split(line.split("#")[0]) for line in section.replace("\\\n", " ").splitlines()
                if line.startswith(("sim-vehicle ", "mavbridge ", "Tools/autotest/sim_vehicle.py "))]
    kinds = [c[0] for c in commands]
    assert kinds.count("sim-vehicle") == 1 and kinds.count("mavbridge") == 2
    assert kinds.count("Tools/autotest/sim_vehicle.py") == 1
    for argv in commands:
        if argv[0] == "sim-vehicle":
            args = backend_parser().parse_args(argv[1:])
            assert args.json_backend == ("127.0.0.1", 9002)
        elif argv[0] == "mavbridge":
            assert mavbridge_parser().parse_args(argv[1:]).connect == "tcp:127.0.0.1:5763"
        else:
            assert "--model" in argv and "JSON:127.0.0.1" in argv
            assert f"--add-param-file=/path/to/this/repo/deploy/{JSON_PARM.name}" in argv


def test_simulators_defaults_have_the_same_feed_forwards(parm: dict[str, float]) -> None:
    """sim-vehicle's GUIDED/AUTO speed and turn feed-forwards are the ones matched to the model here, so a
    companion in GUIDED meets the same loops on our simulator as on the firmware with this file."""
    defaults = ParamTable()
    for name in ("CRUISE_SPEED", "CRUISE_THROTTLE", "ATC_STR_RAT_FF", "ATC_STR_RAT_MAX", "WP_SPEED"):
        assert defaults[name] == pytest.approx(parm[name], rel=1e-6), name
