"""The companion's pure parts: RC/attitude outputs through ArduPilot's mixer, and the supervisor."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavbridge.companion.outputs import (
    RcCalibration,
    RcSetup,
    attitude_command,
    fraction_from_pwm,
    inverse_skid_mix,
    pwm_from_fraction,
    rc_command,
)
from mavbridge.companion.supervisor import Phase, Supervisor
from vessel import otter_parameters, shaft_speeds_to_tau

PARAMS = otter_parameters()
CAL = RcCalibration()


@pytest.mark.parametrize("fraction", np.linspace(-1, 1, 41))
def test_pwm_mapping_inverts_ardupilots_dead_zone_reading(fraction: float) -> None:
    pwm = pwm_from_fraction(fraction, CAL)
    assert CAL.minimum <= pwm <= CAL.maximum
    assert fraction_from_pwm(pwm, CAL) == pytest.approx(fraction, abs=1.0 / 370)
    if fraction != 0:
        assert abs(pwm - CAL.trim) > CAL.dead_zone  # never lost inside the dead zone


def _ardupilot_skid_mix(throttle: float, steering: float) -> tuple[float, float]:
    """ArduPilot's skid mixer at default settings (scaled by 1/(|t|+|s|) when saturated)."""
    total = abs(throttle) + abs(steering)
    scale = 1.0 / total if total > 1 else 1.0
    return (throttle + steering) * scale, (throttle - steering) * scale


@pytest.mark.parametrize(("tau_x", "tau_n"), [(100.0, 0.0), (60.0, 20.0), (40.0, -30.0), (-30.0, 5.0),
                                              (150.0, 73.6), (0.0, -50.0)])
@pytest.mark.parametrize("steer_type", [0, 2, 3])
def test_rc_override_reproduces_the_requested_forces_through_the_mixer(tau_x: float, tau_n: float,
                                                                        steer_type: int) -> None:
    command = rc_command(PARAMS, tau_x, tau_n, RcSetup(steer_type=steer_type))
    throttle = fraction_from_pwm(command.throttle_pwm, CAL)
    steering = fraction_from_pwm(command.steering_pwm, CAL)
    if steer_type in (0, 2) and throttle < 0:
        steering = -steering  # ArduPilot reverses the steering stick while the throttle stick is negative
    left, right = _ardupilot_skid_mix(throttle, steering)
    mats = PARAMS.matrices()
    n = [out * mats.n_max if out >= 0 else out * abs(mats.n_min) for out in (left, right)]
    got = np.array([float(v) for v in shaft_speeds_to_tau(PARAMS, n[0], n[1])])
    want = np.array([float(v) for v in shaft_speeds_to_tau(PARAMS, command.n_left, command.n_right)])
    np.testing.assert_allclose(got, want, atol=2.0)  # PWM is whole microseconds
    if tau_n > 1 and tau_x > 0:
        assert command.steering_pwm > CAL.trim  # more left thrust: steer right (starboard)


def test_reversed_channels_are_mirrored_about_trim_and_two_paddles_are_refused() -> None:
    plain = rc_command(PARAMS, 60.0, 20.0, RcSetup())
    mirrored = rc_command(PARAMS, 60.0, 20.0, RcSetup(steering_reversed=True, throttle_reversed=True))
    assert mirrored.steering_pwm == 2 * CAL.trim - plain.steering_pwm
    assert mirrored.throttle_pwm == 2 * CAL.trim - plain.throttle_pwm
    with pytest.raises(ValueError, match="PILOT_STEER_TYPE"):
        RcSetup(steer_type=1)
    with pytest.raises(ValueError, match="RCMAP"):
        RcSetup(steering_channel=3, throttle_channel=3)


def test_inverse_mix_never_saturates_the_forward_mixer() -> None:
    rng = np.random.default_rng(4)
    for left, right in rng.uniform(-1, 1, size=(500, 2)):
        throttle, steering = inverse_skid_mix(left, right)
        assert abs(throttle) + abs(steering) <= 1 + 1e-12
        assert _ardupilot_skid_mix(throttle, steering) == pytest.approx((left, right))


def test_attitude_command_wraps_heading_and_clips_thrust() -> None:
    states = np.zeros((41, 12))
    states[:, 5] = np.linspace(3.0, 3.5, 41)
    states[:, 6] = 3.0
    command = attitude_command(states, wp_speed_mps=2.0, lookahead_steps=40)
    assert -math.pi < command.yaw_rad <= math.pi
    assert command.yaw_rad == pytest.approx(3.5 - 2 * math.pi)
    assert command.thrust == 1.0
    w, _, _, z = command.quaternion()
    assert 2 * math.atan2(z, w) == pytest.approx(command.yaw_rad)
    with pytest.raises(ValueError, match="WP_SPEED"):
        attitude_command(states, wp_speed_mps=0.0)


def test_rate_form_sends_the_plans_yaw_rate_as_rover_reads_it() -> None:
    """The rate form carries the plan's r at the look-ahead step in body_yaw_rate with q ignored; Rover's
    reading of the packed message (sim_vehicle.rover.guided) is a turn-rate target, not a heading."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    from sim_vehicle.rover.guided import from_attitude

    states = np.zeros((41, 12))
    states[:, 5] = 1.0
    states[:, 6] = 1.5
    states[:, 11] = np.linspace(0.0, 0.2, 41)
    command = attitude_command(states, wp_speed_mps=2.0, lookahead_steps=10, form="rate")
    assert command.yaw_rate_rad_s == pytest.approx(0.05)
    heading_only = attitude_command(states, wp_speed_mps=2.0, lookahead_steps=10)
    assert heading_only.yaw_rate_rad_s is None
    mav = mavlink.MAVLink(None, srcSystem=255, srcComponent=191)
    for cmd, want_heading, want_rate in ((command, None, 0.05), (heading_only, 1.0, None)):
        packed = mav.set_attitude_target_encode(0, 1, 1, cmd.type_mask, list(cmd.quaternion()), 0.0, 0.0,
                                                cmd.yaw_rate_rad_s or 0.0, cmd.thrust).pack(mav)
        msg = mav.decode(bytearray(packed))
        target = from_attitude(msg.type_mask, list(msg.q), msg.body_yaw_rate, msg.thrust, 2.0, 0.0)
        assert target is not None and target.speed == pytest.approx(1.5)
        assert (target.heading is None) == (want_heading is None) and (target.rate is None) == (want_rate is None)
        assert (target.rate or target.heading) == pytest.approx(want_rate or want_heading, rel=1e-6)
    with pytest.raises(ValueError, match="attitude_form"):
        attitude_command(states, wp_speed_mps=2.0, form="yaw")


def test_supervisor_engages_only_armed_in_its_mode() -> None:
    sup = Supervisor(required_mode=0)
    assert sup.on_heartbeat(0.0, armed=False, mode=0) == Phase.WAITING
    assert sup.on_heartbeat(1.0, armed=True, mode=4) == Phase.WAITING
    assert sup.on_heartbeat(2.0, armed=True, mode=0) == Phase.ENGAGED
    assert sup.may_command()


def test_finding_the_boat_already_armed_in_the_mode_is_not_consent() -> None:
    sup = Supervisor(required_mode=0)
    assert sup.on_heartbeat(0.0, True, 0) == Phase.WAITING  # a pilot driving in MANUAL, or a restart mid-run
    assert "switch out" in sup.reason
    assert sup.on_heartbeat(0.5, True, 4) == Phase.WAITING
    assert sup.on_heartbeat(1.0, True, 0) == Phase.ENGAGED  # the pilot's switch into MANUAL is the consent
    told = Supervisor(required_mode=0, self_commanded=True)
    assert told.on_heartbeat(0.0, True, 0) == Phase.ENGAGED  # --arm / --set-mode given: the operator consented


def test_human_mode_change_ends_the_run_for_good() -> None:
    sup = Supervisor(required_mode=0)
    sup.on_heartbeat(0.0, False, 0)
    sup.on_heartbeat(0.1, True, 0)
    assert sup.on_heartbeat(0.5, True, 4) == Phase.TAKEN_OVER
    assert sup.on_heartbeat(1.0, True, 0) == Phase.TAKEN_OVER  # never re-engages behind the pilot
    assert not sup.may_command()


def test_disarm_ends_the_run() -> None:
    sup = Supervisor(required_mode=15, self_commanded=True)
    sup.on_heartbeat(0.0, True, 15)
    assert sup.on_heartbeat(0.5, False, 15) == Phase.TAKEN_OVER


def test_link_loss_suspends_and_resumes() -> None:
    sup = Supervisor(required_mode=0, link_timeout_s=2.0, self_commanded=True)
    sup.on_heartbeat(0.0, True, 0)
    assert sup.tick(1.9) == Phase.ENGAGED
    assert sup.tick(2.1) == Phase.LINK_LOST and not sup.may_command()
    sup.on_heartbeat(7.0, True, 0)
    assert sup.tick(7.0) == Phase.ENGAGED


def test_arrival_is_final_and_own_mode_change_is_not_a_takeover() -> None:
    sup = Supervisor(required_mode=0, self_commanded=True)
    sup.on_heartbeat(0.0, True, 0)
    sup.arrived()
    sup.expected_mode = 4
    assert sup.on_heartbeat(1.0, True, 4) == Phase.ARRIVED


def test_dry_run_computes_without_arming_or_mode() -> None:
    sup = Supervisor(required_mode=0, dry_run=True)
    assert sup.on_heartbeat(0.0, False, 4) == Phase.ENGAGED
    assert sup.on_heartbeat(0.5, False, 10) == Phase.ENGAGED  # the pilot drives; shadow mode keeps computing
