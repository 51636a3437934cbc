"""The GUIDED path's tau form: targets that make Rover's loops (our simulator's copy of them) give the
plan's steering and throttle."""

from __future__ import annotations

from pathlib import Path

import pytest

from mavbridge.companion.guided.inverse import (
    LOOP_PARAMETERS,
    OPTIONAL_LOOP_PARAMETERS,
    SURGE_MARGIN_MPS,
    RoverLoops,
    default_speed,
    loop_targets,
)
from mavbridge.companion.outputs import inverse_skid_mix, motor_output
from sim_vehicle.rover.control import NavState, SpeedControl, SteeringControl
from sim_vehicle.rover.params import ParamTable, read_parm
from vessel import otter_parameters, tau_to_shaft_speeds

PARAMS = otter_parameters()


def _loops(table: ParamTable) -> RoverLoops:
    return RoverLoops.from_values({name: table[name] for name in LOOP_PARAMETERS})


@pytest.mark.parametrize(("tau_x", "tau_n", "u", "r"), [
    (150.0, 0.0, 1.8, 0.0), (120.0, 20.0, 1.5, 0.1), (80.0, -30.0, 1.0, -0.15), (0.0, 10.0, 0.2, 0.05),
    (-40.0, 0.0, -0.3, 0.0), (140.0, -5.0, 2.4, 0.02)])
def test_rovers_loops_fed_the_targets_output_the_plans_steering_and_throttle(
        tau_x: float, tau_n: float, u: float, r: float) -> None:
    table = ParamTable()
    rate, speed = loop_targets(PARAMS, _loops(table), tau_x, tau_n, u, r)
    mats = PARAMS.matrices()
    n_left, n_right = tau_to_shaft_speeds(PARAMS, tau_x, tau_n)
    throttle, steering = inverse_skid_mix(motor_output(n_left, mats.n_max, mats.n_min),
                                          motor_output(n_right, mats.n_max, mats.n_min))
    nav = NavState(yaw=0.0, yaw_rate=r, vn=u)
    speed_loop = SpeedControl(table)
    speed_loop.reset(speed)  # the ramp already at the target; dt 0: integrators untouched
    assert speed_loop.throttle_for_speed(speed, nav, 0.0) == pytest.approx(throttle, abs=1e-9)
    assert SteeringControl(table).steering_for_rate(rate, nav, 0.0) == pytest.approx(steering, abs=1e-9)


def test_turn_rate_target_is_held_within_the_autopilots_limit() -> None:
    table = ParamTable()
    loops = _loops(table)
    assert loops.rate_for_steering(1.0, 0.35) == pytest.approx(loops.rate_max_rad_s)
    assert loops.rate_for_steering(-1.0, -0.35) == pytest.approx(-loops.rate_max_rad_s)


@pytest.mark.parametrize(("name", "value"), [("CRUISE_SPEED", 0.0), ("CRUISE_THROTTLE", None),
                                             ("ATC_SPEED_P", float("nan")), ("ATC_STR_RAT_MAX", -1.0),
                                             ("ATC_SPEED_FF", -0.1)])
def test_unusable_gains_are_refused_by_name(name: str, value: float | None) -> None:
    table = ParamTable()
    values: dict[str, float | None] = {n: table[n] for n in LOOP_PARAMETERS}
    values[name] = value
    with pytest.raises(ValueError, match=name):
        RoverLoops.from_values(values)



def test_an_integrator_or_d_term_on_is_refused_by_name() -> None:
    """Rover's integrators would wind up against the inverted targets, and a D term kicks at each new one: the tau
    form needs all four at 0 (the D gains absent, as in our simulator, read as 0)."""
    table = ParamTable()
    values: dict[str, float | None] = {name: table[name] for name in LOOP_PARAMETERS}
    assert "ATC_STR_RAT_I" in (_loops(table).gain_problem() or "")
    values.update(ATC_STR_RAT_I=0.0, ATC_SPEED_I=0.0)
    assert RoverLoops.from_values(values).gain_problem() is None
    values["ATC_SPEED_I"] = 0.2
    assert "ATC_SPEED_I is 0.2" in (RoverLoops.from_values(values).gain_problem() or "")
    values.update(ATC_SPEED_I=0.0, ATC_STR_RAT_D=0.01)
    assert "ATC_STR_RAT_D is 0.01" in (RoverLoops.from_values(values).gain_problem() or "")
    values.update(ATC_STR_RAT_D=None, ATC_SPEED_D=float("nan"))
    with pytest.raises(ValueError, match="ATC_SPEED_D"):
        RoverLoops.from_values(values)


def test_newer_firmwares_speed_feed_forward_is_inverted_too() -> None:
    """Real Rover adds ATC_SPEED_FF x target to the cruise feed-forward: the speed target accounts for it."""
    table = ParamTable()
    values: dict[str, float | None] = {name: table[name] for name in LOOP_PARAMETERS}
    values["ATC_SPEED_FF"] = 0.1
    loops = RoverLoops.from_values(values)
    cruise = table["CRUISE_THROTTLE"] / 100 / table["CRUISE_SPEED"]
    target = loops.speed_for_throttle(0.7, 1.4)
    throttle = (cruise + 0.1) * target + table["ATC_SPEED_P"] * (target - 1.4)  # AR_AttitudeControl's sum
    assert throttle == pytest.approx(0.7, abs=1e-12)
    assert loops.speed_ff == pytest.approx(cruise + 0.1)


def test_a_turn_rate_limit_of_zero_is_no_limit_as_in_rover() -> None:
    table = ParamTable()
    values: dict[str, float | None] = {name: table[name] for name in LOOP_PARAMETERS}
    values["ATC_STR_RAT_MAX"] = 0.0
    loops = RoverLoops.from_values(values)
    assert loops.rate_for_steering(1.0, 0.35) == pytest.approx((1.0 + loops.rate_p * 0.35) / (loops.rate_ff +
                                                                                              loops.rate_p))
    assert loops.rate_for_steering(1.0, 0.35) > _loops(table).rate_max_rad_s
    table.set("ATC_STR_RAT_MAX", 0.0, save=False)  # our simulator's Rover loops: no limit either (a 0.6 rad/s
    table.set("ATC_STR_RAT_FF", 1.0, save=False)  # target, beyond 20 deg/s, followed unsaturated)
    nav = NavState(yaw=0.0, yaw_rate=0.6, vn=1.0)
    assert SteeringControl(table).steering_for_rate(0.6, nav, 0.0) == pytest.approx(0.6)


def test_full_throttle_needs_at_most_its_target_at_the_fastest_speed_planned_for() -> None:
    """Rover caps its speed target at WP_SPEED: full throttle passes at every forward speed up to the hull's
    calm-water full speed plus the waves' surge when WP_SPEED is at least that speed's target; the form says so
    below it (3 m/s), not at the parm file's 3.5 m/s."""
    loops = _loops(ParamTable())
    fastest = 2.08 * 100 / 80 + SURGE_MARGIN_MPS
    needed = loops.full_throttle_target_mps()
    assert needed == pytest.approx(loops.speed_for_throttle(1.0, fastest)) and 3.0 < needed < 3.5
    for u in (-2.6, -1.0, 0.0, 1.0, 2.0, 2.6, 3.3, fastest):
        assert abs(loops.speed_for_throttle(1.0 if u >= 0 else -1.0, u)) <= needed + 1e-12
    assert "WP_SPEED 3 m/s caps" in (loops.wp_speed_problem(3.0) or "")
    assert ">= 3.04" in (loops.wp_speed_problem(3.0) or "")
    assert loops.wp_speed_problem(3.5) is None and loops.wp_speed_problem(needed) is None


def test_what_flies_but_not_as_planned_is_said() -> None:
    """WP_SPEED cutting full throttle, ATC_BRAKE 0 and parameters the autopilot did not answer for: warnings."""
    table = ParamTable()
    values: dict[str, float | None] = {name: table[name] for name in LOOP_PARAMETERS}
    said = RoverLoops.from_values(values).warnings(2.0)
    assert len(said) == 2 and "WP_SPEED 2 m/s caps" in said[0]
    assert said[1].startswith("ATC_SPEED_FF, ATC_SPEED_D, ATC_STR_RAT_D, ATC_BRAKE absent"), said
    values.update(ATC_SPEED_FF=0.0, ATC_SPEED_D=0.0, ATC_STR_RAT_D=0.0, ATC_BRAKE=0.0)
    said = RoverLoops.from_values(values).warnings(3.5)
    assert len(said) == 1 and said[0].startswith("ATC_BRAKE is 0"), said
    values["ATC_BRAKE"] = 1.0
    assert RoverLoops.from_values(values).warnings(3.5) == []


def test_rovers_default_speed_scales_thrust() -> None:
    assert default_speed({"WP_SPEED": 3.5, "CRUISE_SPEED": 2.08}.get) == 3.5
    assert default_speed({"WP_SPEED": 0.0, "CRUISE_SPEED": 2.08}.get) == 2.08
    assert default_speed({}.get) is None  # never an assumed speed: the companion refuses GUIDED then


def test_the_boats_parm_files_give_the_tau_form_what_it_needs() -> None:
    """otter-rover.parm with otter-guided-tau.parm over Rover's defaults (our simulator's): integrators off and a
    WP_SPEED that lets full throttle through, so the companion neither refuses the form nor warns."""
    deploy = Path(__file__).resolve().parents[2] / "deploy"
    table = ParamTable()
    files = {**read_parm(deploy / "otter-rover.parm"), **read_parm(deploy / "otter-guided-tau.parm")}
    values = {name: files.get(name, table[name]) for name in LOOP_PARAMETERS}
    values.update({name: files.get(name) for name in (*OPTIONAL_LOOP_PARAMETERS, "ATC_BRAKE")})
    loops = RoverLoops.from_values(values)
    assert loops.gain_problem() is None
    assert loops.warnings(files["WP_SPEED"]) == []
