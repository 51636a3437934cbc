"""The identification sequence flown on the plant in-process: every leg in order, over before its time limit,
near where it started; the zig-zag switches at 20° either side; the sticks it would send as the autopilot reads
them (steering mirrored in reverse where PILOT_STEER_TYPE reverses it)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from mavbridge.companion.identify_run.flight import ScriptedRc, ScriptedStep, model_tau
from mavbridge.companion.identify_run.sequence import (
    BRAKE_DELAY_MAX_S,
    BRAKE_LEAD_S,
    SEQUENCE,
    ZIGZAG_RAD,
    IdentifySequence,
    Nomoto,
    Pose,
    Sticks,
    brake_lead,
    command_delay,
    limit_s,
)
from mavbridge.companion.outputs import RcSetup, fraction_from_pwm
from mavbridge.preflight.rules import Context
from vessel import OtterParameters, Plant

PERIOD_S = 0.1


def fly_on_plant(params: OtterParameters) -> tuple[list[tuple[float, str, float, float, float]], float]:
    """(rows of t, leg, north, east, yaw) of the whole sequence on the plant, and when it ended (s)."""
    m = params.matrices()
    plant = Plant(params, dt=0.01, integrator="rk4")
    sequence, x, t, rows = IdentifySequence(), plant.state, 0.0, []
    while (sticks := sequence.command(t, Pose(float(x[0]), float(x[1]), float(x[5]), float(x[11])))) is not None:
        outs = [min(max(sticks.throttle + k * sticks.steering, -1.0), 1.0) for k in (1.0, -1.0)]
        n = [o * float(m.n_max) if o >= 0 else o * abs(float(m.n_min)) for o in outs]
        x = plant.advance((n[0], n[1]), 10)
        t = round(t + PERIOD_S, 6)
        rows.append((t, sticks.leg, float(x[0]), float(x[1]), float(x[5])))
        assert t <= limit_s() + PERIOD_S, "the sequence outlived its time limit"
    return rows, t


def test_the_sequence_flies_every_leg_in_order_within_its_limits_near_where_it_started() -> None:
    rows, ended = fly_on_plant(OtterParameters())
    legs = [rows[0][1]] + [b[1] for a, b in itertools.pairwise(rows) if a[1] != b[1]]
    expected = [leg.name for leg in SEQUENCE]
    assert legs == [name for k, name in enumerate(expected) if k == 0 or name != expected[k - 1]]
    assert ended < limit_s()
    away = max(math.hypot(n, e) for _, _, n, e, _ in rows)
    assert 20.0 < away < 100.0, away  # under way, and back towards the start on each leg that chooses a heading


def test_the_zig_zag_turns_about_20_degrees_either_side() -> None:
    rows, _ = fly_on_plant(OtterParameters())
    yaw = np.unwrap([r[4] for r in rows if r[1] == "zig-zag 20/20"])
    swing = yaw - yaw[0]
    assert math.radians(20) <= swing.max() < math.radians(40) and -math.radians(40) < swing.min() <= -ZIGZAG_RAD


def _pwm_read_back(throttle: float, steering: float, setup: RcSetup) -> tuple[float, float]:
    path = ScriptedRc(OtterParameters(), Context(255, "rc_override", 0.1, 2.0), lambda _line: None)
    path.setup = setup
    step = ScriptedStep(Sticks("test", throttle, steering), model_tau(OtterParameters(), Sticks("t", throttle, 0.0)))
    columns = path.compute(step, 0).columns
    return (fraction_from_pwm(columns["throttle_pwm_us"], setup.throttle),
            fraction_from_pwm(columns["steering_pwm_us"], setup.steering))


def test_the_sticks_reach_the_autopilot_as_they_were_meant() -> None:
    throttle, stick = _pwm_read_back(0.6, 0.3, RcSetup())
    assert math.isclose(throttle, 0.6, abs_tol=0.005) and math.isclose(stick, 0.3, abs_tol=0.005)
    throttle, stick = _pwm_read_back(-0.5, 0.3, RcSetup(steer_type=0))  # reversed in reverse: sent mirrored
    assert math.isclose(throttle, -0.5, abs_tol=0.005) and math.isclose(stick, -0.3, abs_tol=0.005)
    _, stick = _pwm_read_back(-0.5, 0.3, RcSetup(steer_type=3))
    assert math.isclose(stick, 0.3, abs_tol=0.005)


def test_the_logged_tau_is_what_the_model_gives_for_the_sticks() -> None:
    params = OtterParameters()
    tau_x, tau_n = model_tau(params, Sticks("full", 1.0, 0.0))
    assert math.isclose(tau_x, params.bollard_pull_forward_kgf * params.g, rel_tol=0.02) and abs(tau_n) < 1e-9
    assert model_tau(params, Sticks("right", 0.6, 0.3))[1] > 0  # more thrust on the left turns to starboard


def fly_brakes(delay_steps: int, told_s: float | None) -> tuple[list[float], list[float]]:
    """The sequence on the plant with the sticks acting ``delay_steps`` control periods late and the command delay
    ``told_s`` given to the sequence (None: not measured): per brake, the largest yaw rate left over its roll
    decay, and the largest roll rate once the boat turns slower than 3°/s (rad/s)."""
    params = OtterParameters()
    m = params.matrices()
    plant = Plant(params, dt=0.01, integrator="rk4")
    sequence, x, t = IdentifySequence(), plant.state, 0.0
    sent: list[Sticks] = []
    turning_after: list[float] = []
    rolling: list[float] = []
    previous = ""
    while (sticks := sequence.command(t, Pose(float(x[0]), float(x[1]), float(x[5]), float(x[11])),
                                      told_s)) is not None:
        sent.append(sticks)
        late = sent[max(0, len(sent) - 1 - delay_steps)]
        outs = [min(max(late.throttle + k * late.steering, -1.0), 1.0) for k in (1.0, -1.0)]
        x = plant.advance(tuple(o * float(m.n_max) if o >= 0 else o * abs(float(m.n_min)) for o in outs), 10)
        t = round(t + PERIOD_S, 6)
        if sticks.leg == "brake" and previous != "brake":
            turning_after.append(0.0)
            rolling.append(-1.0)  # (not yet turning slowly)
        previous = sticks.leg
        if sticks.leg not in ("brake", "roll decay"):
            continue
        if rolling[-1] < 0 and abs(x[11]) < math.radians(3.0):
            rolling[-1] = 0.0
        if rolling[-1] >= 0:
            rolling[-1] = max(rolling[-1], abs(float(x[9])))
        if sticks.leg == "roll decay":
            turning_after[-1] = max(turning_after[-1], abs(float(x[11])))
    return turning_after, rolling


@pytest.mark.parametrize("delay_steps", [0, 1, 2, 3])
def test_the_brake_stops_the_turn_sharply_and_leaves_roll_free_to_decay(delay_steps: int) -> None:
    """Each hard turn's brake, flown with the sticks acting up to three control periods late (the link, the
    autopilot's loop, a SiK radio, the motors' lag) and that delay told to the sequence as the companion measures
    it, leaves the boat turning slower than the 3°/s a free decay is looked for at, and still rolling (its roll
    rate above 1°/s once it turns that slowly, against the gyro's 0.1°/s of noise)."""
    turning_after, rolling = fly_brakes(delay_steps, delay_steps * PERIOD_S)
    assert len(turning_after) == 4 and len(rolling) == 4
    assert max(turning_after) < math.radians(3.0), [math.degrees(v) for v in turning_after]
    assert min(rolling) > math.radians(1.0), [math.degrees(v) for v in rolling]


@pytest.mark.parametrize("delay_steps", [2, 3])
def test_a_brake_not_told_the_delay_leaves_the_turn_going(delay_steps: int) -> None:
    """The same delays not told (the fixed 0.15 s lead, all there is when nothing is measured): the full brake
    runs on after the yaw rate is past stopping and the decay starts turning faster than 3°/s, as a second reader
    found."""
    turning_after, _ = fly_brakes(delay_steps, None)
    assert len(turning_after) == 4
    assert max(turning_after) > math.radians(3.0), [math.degrees(v) for v in turning_after]


def test_a_measured_delay_counts_up_to_its_bound_and_nothing_measured_is_none() -> None:
    assert command_delay(None) == 0.0 and command_delay(math.nan) == 0.0 and command_delay(-0.1) == 0.0
    assert command_delay(0.25) == pytest.approx(0.25) and command_delay(5.0) == BRAKE_DELAY_MAX_S
    assert brake_lead(0.0) == BRAKE_LEAD_S and brake_lead(0.3) > 0.3


def test_the_yaw_rates_change_is_taken_between_attitude_samples_not_commands() -> None:
    seq = IdentifySequence()
    seq.command(0.0, Pose(0.0, 0.0, 0.0, 0.5, sample_s=0.0))
    seq.command(0.1, Pose(0.0, 0.0, 0.0, 0.4, sample_s=0.1))
    assert seq.yaw_accel == pytest.approx(-1.0)
    seq.command(0.2, Pose(0.0, 0.0, 0.0, 0.4, sample_s=0.1))  # the same ATTITUDE again (a slow stream)
    assert seq.yaw_accel == pytest.approx(-1.0), "a sample seen twice read as the turn no longer slowing"
    seq.command(0.3, Pose(0.0, 0.0, 0.0, 0.2, sample_s=0.3))
    assert seq.yaw_accel == pytest.approx(-1.0)  # over the 0.2 s between the two samples, not the 0.1 s since


@pytest.mark.parametrize("time_constant", [0.5, 0.009, 0.001])
def test_the_brakes_prediction_stays_bounded_whatever_t_a_noisy_spin_up_gives(time_constant: float) -> None:
    """Full opposite steering from the turn's steady rate: the predicted rate heads for −K and never past it, even
    for a T far under the prediction's step (an Euler step gave −1348 rad/s at T = 9 ms)."""
    rate = Nomoto(0.6, time_constant).rate_after(0.6, 0.7, lambda _s: -1.0)
    assert -0.6 <= rate < 0.6


def test_commands_issued_before_the_autopilots_clock_went_back_are_forgotten() -> None:
    sequence = IdentifySequence()
    pose = Pose(0.0, 0.0, 0.0, 0.0, None)
    for t in np.arange(100.0, 103.0, 0.1):
        sequence.command(float(t), pose)
    sequence.command(0.5, pose)  # a reboot: the autopilot's time starts again
    assert [at for at, _ in sequence.issued] == [0.5]
