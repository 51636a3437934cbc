"""PILOT_STEER_TYPE in MANUAL: steering mirrored when reversing (0), unchanged (3) and two paddles (1)."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from sim_vehicle.harness import SimProcess
from tests.rover import ACRO, ARM, KEEP, MANUAL, SET_MESSAGE_INTERVAL
from tests.waits import command, run_for, set_mode, wait_for

INT8 = 2


def _override(conn, ch1: int, ch3: int) -> None:
    conn.mav.rc_channels_override_send(1, 1, ch1, KEEP, ch3, KEEP, KEEP, KEEP, KEEP, KEEP)


def _set_steer_type(conn, value: int) -> None:
    conn.mav.param_set_send(1, 1, b"PILOT_STEER_TYPE", value, INT8)
    reply = wait_for(conn, "PARAM_VALUE", 5, lambda m: m.param_id == "PILOT_STEER_TYPE")
    assert reply.param_value == value


def _yaw_rate(conn, ch1: int, ch3: int, sim_s: float = 5.0, settle_s: float = 3.0) -> float:
    """Hold ch1/ch3 for ``sim_s`` simulated seconds; mean ATTITUDE yawspeed (rad/s) after ``settle_s``."""
    run_for(conn, settle_s, lambda: _override(conn, ch1, ch3))
    rates: list[float] = []

    def each() -> None:
        _override(conn, ch1, ch3)
        rates.append(wait_for(conn, "ATTITUDE", 2).yawspeed)

    run_for(conn, sim_s - settle_s, each, period_s=0.2)
    assert rates
    return sum(rates) / len(rates)


def _servos(conn, ch1: int, ch3: int) -> tuple[int, int]:
    """Servos 1 and 3 from a SERVO_OUTPUT_RAW sent while ch1/ch3 are still held: the override is sent again
    before each read, so a slow read on a loaded machine cannot outlast RC_OVERRIDE_TIME (simulated seconds)
    and show the sticks released. The second message read is the one returned (the first may predate it)."""
    for _ in range(2):
        _override(conn, ch1, ch3)
        msg = wait_for(conn, "SERVO_OUTPUT_RAW", 5)
    return msg.servo1_raw, msg.servo3_raw


@pytest.fixture
def conn(sim: SimProcess) -> Iterator[Any]:
    """A GCS (sysid 255) link, armed in MANUAL; releases the sticks and disarms afterwards."""
    link = sim.connect()
    assert command(link, SET_MESSAGE_INTERVAL, 36, 100000) == 0  # SERVO_OUTPUT_RAW at 10 Hz
    assert set_mode(link, MANUAL) == 0 and command(link, ARM, 1) == 0
    yield link
    link.mav.rc_channels_override_send(1, 1, 0, 0, 0, 0, 0, 0, 0, 0)
    assert command(link, ARM, 0) == 0
    _set_steer_type(link, 0)


def test_default_type_mirrors_steering_when_reversing(conn) -> None:
    """Type 0: ch1 right turns the boat right going ahead but left (like a car) going astern."""
    _set_steer_type(conn, 0)
    ahead = _yaw_rate(conn, 1700, 1700)
    astern = _yaw_rate(conn, 1700, 1300)
    assert ahead > 0.05 and astern < -0.05, (ahead, astern)


def test_unchanged_type_keeps_steering_when_reversing(conn) -> None:
    """Type 3: ch1 right turns the boat right both ahead and astern."""
    _set_steer_type(conn, 3)
    ahead = _yaw_rate(conn, 1700, 1700)
    astern = _yaw_rate(conn, 1700, 1300)
    assert ahead > 0.05 and astern > 0.05, (ahead, astern)


def test_two_paddles_drive_each_motor(conn) -> None:
    """Type 1: ch1 is the left motor and ch3 the right; opposite paddles spin the boat in place."""
    _set_steer_type(conn, 1)
    right_spin = _yaw_rate(conn, 1900, 1100)
    assert _servos(conn, 1900, 1100) == (1900, 1100)
    left_spin = _yaw_rate(conn, 1100, 1900)
    assert _servos(conn, 1100, 1900) == (1100, 1900)
    assert right_spin > 0.1 and left_spin < -0.1, (right_spin, left_spin)
    run_for(conn, 3.0, lambda: _override(conn, 1700, 1600))  # no dead zone: 1600 is a quarter ahead
    assert _servos(conn, 1700, 1600) == (1700, 1600)


def test_acro_turn_rate_follows_the_same_rule(conn) -> None:
    """ACRO reads the sticks the same way: type 0 asks for a left turn when ch1 is right and ch3 astern."""
    _set_steer_type(conn, 0)
    assert set_mode(conn, ACRO) == 0
    ahead = _yaw_rate(conn, 1700, 1700)
    astern = _yaw_rate(conn, 1700, 1300)
    assert ahead > 0.05 and astern < -0.05, (ahead, astern)
