"""The model's yaw time constant fitted by flying the model through a log's commands: a hull of known T_yaw flown
through a zig-zag (its yaw rate with the attitude's noise) gives that T_yaw back, where the Nomoto T does not."""

from __future__ import annotations

import math

import numpy as np

from mavbridge.companion.identify_run.sequence import SEQUENCE, IdentifySequence, Leg, Pose
from mavbridge.identify.series import Stretch
from mavbridge.identify.yaw import fit_nomoto
from mavbridge.identify.yawfield import YawReplay, steering_of, yaw_time_constant
from vessel import OtterParameters, Plant

DT = 0.05


def zigzag_log(params: OtterParameters, noise_rad_s: float) -> Stretch:
    """The sequence's zig-zag flown on the plant, in the replay's columns: the propulsion command (left, right motor
    outputs), the steering (the same two), the yaw rate (rad/s) and the speed (m/s)."""
    m = params.matrices()
    legs = (Leg("steady", "hold", 20.0, 0.6), *[leg for leg in SEQUENCE if leg.kind == "zigzag"])
    sequence, plant, t, rows = IdentifySequence(legs), Plant(params, dt=0.01, integrator="rk4"), 0.0, []
    x = plant.state
    rng = np.random.default_rng(1)
    while (sticks := sequence.command(t, Pose(float(x[0]), float(x[1]), float(x[5]), float(x[11])))) is not None:
        outs = [min(max(sticks.throttle + k * sticks.steering, -1.0), 1.0) for k in (1.0, -1.0)]
        for _ in range(2):
            if sequence.index == 1:
                rows.append((*outs, *outs, float(x[11]) + noise_rad_s * rng.standard_normal(), float(x[6])))
            x = plant.advance(tuple(o * float(m.n_max) for o in outs), 5)
            t += DT
    y = np.array(rows)
    return Stretch(np.arange(len(y)) * DT, y)


def test_the_model_flown_through_the_log_gives_its_yaw_time_constant_back() -> None:
    true = OtterParameters().replace(yaw_time_constant=0.7)
    log = zigzag_log(true, noise_rad_s=math.radians(2.3))  # the yaw rate of a 0.2 deg attitude, differenced
    replay = YawReplay("motors", ("left", "right"), [log], speed=True)
    got = yaw_time_constant(OtterParameters(), replay)
    assert got is not None and abs(got / 0.7 - 1) < 0.1, got
    nomoto = fit_nomoto([Stretch(log.t, np.column_stack([steering_of("motors", log.y[:, 0], log.y[:, 1]),
                                                         log.y[:, 4]]))])
    assert nomoto is not None and abs(nomoto.T / 0.7 - 1) > 0.2  # the first-order T is not the field


def test_commands_the_model_cannot_follow_give_no_field() -> None:
    log = zigzag_log(OtterParameters(), noise_rad_s=0.0)
    still = Stretch(log.t, np.column_stack([log.y[:, :4], np.zeros(log.t.size), log.y[:, 5]]))  # it never turns
    assert yaw_time_constant(OtterParameters(), YawReplay("motors", ("left", "right"), [still], True)) is None
