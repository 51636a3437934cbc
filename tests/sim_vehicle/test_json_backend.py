"""The JSON backend in process: open-loop equality with the normal simulator's plant, and the sensor reply."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest

from sim_vehicle.json_backend.backend import JsonBackend
from sim_vehicle.json_backend.cli import build_parser, build_world, seeded_waves, surface_heave
from sim_vehicle.json_backend.log import write_sea_record
from sim_vehicle.json_backend.model import JsonPhysics, substeps_for
from sim_vehicle.json_backend.protocol import encode_servo_packet, motor_output_to_pwm, pwm_to_motor_output
from sim_vehicle.physics import PHYSICS_DT_S, Physics, ned_velocity
from tests.sim_vehicle.test_json_backend_firmware import parse_reply
from vessel import CalmWater, OceanCurrent, otter_parameters
from vessel.dynamics import rotation_body_to_ned
from vessel.sea.irregular import IrregularWaves
from vessel.sea.irregular_sea import IrregularSea
from vessel.sea.state import SeaState, Start
from vessel.world import World, sea_preset

HEADING_DEG = 30.0


def _x0() -> np.ndarray:
    x0 = np.zeros(14)
    x0[5] = math.radians(HEADING_DEG)
    return x0


def _backend(sea: str, vessel: str = "published") -> JsonBackend:
    return JsonBackend(JsonPhysics(otter_parameters(vessel), sea_preset(sea).waves(), OceanCurrent(), _x0()))


def _run_backend(backend: JsonBackend, left: float, right: float, rate: int, seconds: float,
                 channels: int = 16) -> list[bytes]:
    """Drive the backend as the firmware would: one new frame per step, SERVO1/SERVO3 pulses."""
    pwm = [motor_output_to_pwm(left), 0, motor_output_to_pwm(right)]
    replies = []
    for count in range(round(seconds * rate)):
        reply = backend.handle(encode_servo_packet(rate, count, pwm, channels))
        assert reply is not None
        replies.append(reply)
    return replies


# A small irregular sea (20 components: the plant stays on CasADi's VM, no compile) for the equality tests.
IRREGULAR = SeaState(spectrum=IrregularSea(hs_m=1.75, tp_s=6.0, n_components=20, seed=4))


def _world(sea: str) -> World:
    return World(sea=IRREGULAR if sea == "jonswap" else sea_preset(sea), start=Start(heading_deg=HEADING_DEG))


def _run_simulator(sea: str, left: float, right: float, seconds: float, heave: bool = False) -> np.ndarray:
    """The normal simulator's plant path: Physics.create, shaft_commands from motor outputs, 100 Hz steps."""
    physics = Physics.create(_world(sea), surface_heave=heave)
    n_cmd = physics.shaft_commands((left, right))
    physics.plant.advance(n_cmd, round(seconds / PHYSICS_DT_S))
    return physics.plant.state


@pytest.mark.parametrize("sea", ["calm", "paper"])
@pytest.mark.parametrize("left, right", [(0.7, 0.7), (0.7, 0.3)], ids=["straight", "turn"])
def test_open_loop_equals_the_simulator_at_its_own_step(sea: str, left: float, right: float) -> None:
    """100 Hz frames (the simulator's step): after 60 s the two plants agree to 1e-9 in every state."""
    backend = _backend(sea)
    _run_backend(backend, left, right, 100, 60.0)
    expected = _run_simulator(sea, left, right, 60.0)
    assert backend.physics.time == pytest.approx(60.0, abs=1e-9)
    print(f"{sea} {left:.0%}/{right:.0%}: max |backend - simulator| after 60 s "
          f"{np.max(np.abs(backend.physics.state - expected)):.1e}")
    np.testing.assert_allclose(backend.physics.state, expected, rtol=0, atol=1e-9)
    assert np.hypot(expected[6], expected[7]) > 0.1  # the boat is really moving


@pytest.mark.parametrize("left, right", [(0.7, 0.7), (0.7, 0.3)], ids=["straight", "turn"])
def test_open_loop_equals_the_simulator_in_an_irregular_sea_with_surface_heave(left: float, right: float) -> None:
    """The hull-averaged irregular sea and the heave riding it, as the simulator builds them: 1e-9 after 60 s."""
    world = _world("jonswap")
    waves = world.sea.waves(world.params())
    backend = JsonBackend(JsonPhysics(world.params(), waves, OceanCurrent(), world.plant_state(), surface_heave=True))
    pwm = [motor_output_to_pwm(left), 0, motor_output_to_pwm(right)]
    heave_m, accel_z = [], []
    for count in range(6000):
        reply = parse_reply(backend.handle(encode_servo_packet(100, count, pwm)) or b"")
        heave_m.append(backend.physics.state[2])
        accel_z.append(reply.accel_body[2])
    expected = _run_simulator("jonswap", left, right, 60.0, heave=True)
    print(f"jonswap {left:.0%}/{right:.0%}, surface heave: max |backend - simulator| after 60 s "
          f"{np.max(np.abs(backend.physics.state - expected)):.1e}; heave std {np.std(heave_m):.3f} m")
    np.testing.assert_allclose(backend.physics.state, expected, rtol=0, atol=1e-9)
    paper_heave = _run_simulator("jonswap", left, right, 60.0, heave=False)
    assert abs(paper_heave[2] - expected[2]) > 0.01  # the heave model matters here, so the test can fail
    assert np.std(heave_m) > 0.1 and np.std(accel_z) > 0.3  # it rides the sea, and the accelerometer feels it


@pytest.mark.parametrize("sea", ["calm", "paper"])
@pytest.mark.parametrize("left, right", [(0.7, 0.7), (0.7, 0.3)], ids=["straight", "turn"])
def test_400_hz_frames_agree_with_the_simulator_within_one_percent(sea: str, left: float, right: float) -> None:
    """ArduPilot's 400 Hz against the simulator's 100 Hz: speed and turn rate within 1 % after 60 s."""
    backend = _backend(sea)
    _run_backend(backend, left, right, 400, 60.0)
    x, expected = backend.physics.state, _run_simulator(sea, left, right, 60.0)
    speed, speed_sim = np.hypot(x[6], x[7]), np.hypot(expected[6], expected[7])
    turn = f", turn rate {x[11] / expected[11] - 1:+.1e}" if left != right else ""
    print(f"{sea} {left:.0%}/{right:.0%} at 400 Hz against the simulator's 100 Hz after 60 s: relative error in "
          f"speed {speed / speed_sim - 1:+.1e}{turn}")
    assert speed == pytest.approx(speed_sim, rel=0.01)
    if left != right:
        assert abs(expected[11]) > 0.05
        assert x[11] == pytest.approx(expected[11], rel=0.01)


def test_a_low_frame_rate_is_sub_stepped_to_the_simulators_step() -> None:
    """50 Hz frames are two 10 ms steps each, so 50 Hz reproduces the 100 Hz simulator to 1e-9."""
    assert substeps_for(1 / 50) == 2 and substeps_for(1 / 100) == 1 and substeps_for(1 / 400) == 1
    assert substeps_for(1 / 30) == 4
    backend = _backend("paper")
    _run_backend(backend, 0.7, 0.3, 50, 20.0)
    np.testing.assert_allclose(backend.physics.state, _run_simulator("paper", 0.7, 0.3, 20.0), rtol=0, atol=1e-9)


def test_at_rest_in_calm_water_the_accelerometer_reads_minus_g() -> None:
    """Corrected Otter, level at rest, outputs not driven (PWM 0): accel_body = (0, 0, −9.81) to 1e-6."""
    physics = JsonPhysics(otter_parameters("corrected"), CalmWater(), OceanCurrent(), np.zeros(14))
    backend = JsonBackend(physics)
    for count in range(100):
        reply = parse_reply(backend.handle(encode_servo_packet(400, count, [0] * 16)) or b"")
    np.testing.assert_allclose(reply.accel_body, [0.0, 0.0, -9.81], atol=1e-6)
    np.testing.assert_allclose(reply.gyro, 0.0, atol=1e-12)
    assert physics.n_cmd == (0.0, 0.0)
    np.testing.assert_allclose(reply.quaternion, [1.0, 0.0, 0.0, 0.0], atol=1e-12)


def test_in_the_paper_waves_the_reply_is_the_plant_state() -> None:
    """Gyro = the plant's body rates; position, NED velocity and the quaternion's rotation = the plant's."""
    backend = _backend("paper")
    pwm = [motor_output_to_pwm(0.7), 0, motor_output_to_pwm(0.3)]
    peak_roll_rate = 0.0
    for count in range(2400):  # 6 s, one wave period
        reply = parse_reply(backend.handle(encode_servo_packet(400, count, pwm)) or b"")
        x = backend.physics.state
        np.testing.assert_allclose(reply.gyro, x[9:12], rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(reply.position, x[0:3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(reply.velocity, ned_velocity(x), rtol=1e-7, atol=1e-9)
        peak_roll_rate = max(peak_roll_rate, abs(x[9]))
    w, qx, qy, qz = reply.quaternion
    from_q = np.array([
        [1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - w * qz), 2 * (qx * qz + w * qy)],
        [2 * (qx * qy + w * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - w * qx)],
        [2 * (qx * qz - w * qy), 2 * (qy * qz + w * qx), 1 - 2 * (qx * qx + qy * qy)],
    ])
    np.testing.assert_allclose(from_q, np.asarray(rotation_body_to_ned(x[3], x[4], x[5]), float), atol=1e-6)
    assert peak_roll_rate > 0.05  # the boat really rolls in these waves
    assert reply.timestamp == pytest.approx(6.0, abs=1e-12)


def test_pwm_means_what_the_boat_outputs_mean() -> None:
    """SERVOn 1100/1500/1900 µs = full reverse / stop / full ahead; 0 µs (not driven) and junk = stop."""
    assert pwm_to_motor_output(1900) == 1.0 and pwm_to_motor_output(1100) == -1.0
    assert pwm_to_motor_output(1500) == 0.0 and pwm_to_motor_output(1700) == pytest.approx(0.5)
    assert pwm_to_motor_output(0) == 0.0 and pwm_to_motor_output(65535) == 0.0
    assert pwm_to_motor_output(2000) == 1.0  # beyond MAX saturates, as the ESC would
    backend = _backend("calm")
    params = otter_parameters()
    backend.handle(encode_servo_packet(400, 0, [1100, 0, 1900]))
    assert backend.physics.n_cmd == pytest.approx((params.matrices().n_min, params.matrices().n_max))


def test_the_seed_sets_the_regular_seas_phase_and_nothing_else() -> None:
    """Same seed, same phase; another seed, another phase; the rest of the sea and other fields untouched."""
    paper = sea_preset("paper").waves()
    a, b, c = seeded_waves(paper, 7), seeded_waves(paper, 7), seeded_waves(paper, 8)
    assert a == b and a.phase_rad != c.phase_rad and 0 <= a.phase_rad < 2 * math.pi
    assert dataclasses.replace(a, phase_rad=0.0) == paper
    calm = CalmWater()
    assert seeded_waves(calm, 7) is calm


def test_the_seed_hides_an_irregular_seas_time_origin_that_a_twin_can_meet() -> None:
    """Under a seed the simulator's t meets the sea's t + ``hidden_time_origin_s(seed)``: what an in-process
    twin sets as ``IrregularSea.start_s`` to fly the very stretch of sea a simulator run met."""
    from sim_vehicle.scenario import TIME_ORIGIN_MAX_S, hidden_time_origin_s

    sea = IrregularSea(hs_m=1.75, tp_s=6.0, seed=4)
    seeded = seeded_waves(sea.wave_field(otter_parameters()), 7)
    origin = hidden_time_origin_s(7)
    assert 0.0 <= origin < TIME_ORIGIN_MAX_S and origin != hidden_time_origin_s(8)
    twin = dataclasses.replace(sea, start_s=origin + 40.0).wave_field(otter_parameters())
    t = np.linspace(0.0, 30.0, 61)
    np.testing.assert_allclose(seeded.elevation(3.0, -2.0, 40.0 + t), twin.elevation(3.0, -2.0, t), atol=1e-9)


def test_the_simulator_adds_its_hidden_origin_to_the_scenarios_own_start() -> None:
    """A scenario's ``start_s`` and the seed's hidden origin add up in the simulator's plant (no double shift, none
    lost): its sea at t is the scenario's sea, unshifted, at t + start_s + the origin."""
    from sim_vehicle.scenario import hidden_time_origin_s

    sea = IrregularSea(hs_m=1.75, tp_s=6.0, seed=4)
    world = World(sea=SeaState(spectrum=dataclasses.replace(sea, start_s=100.0)))
    physics = Physics.create(world, seed=3)
    plain = sea.wave_field(world.params())
    t = np.linspace(0.0, 20.0, 41)
    shift = 100.0 + hidden_time_origin_s(3)
    np.testing.assert_allclose(physics.plant.waves.elevation(1.0, 2.0, t), plain.elevation(1.0, 2.0, t + shift),
                               atol=1e-9)


@dataclasses.dataclass(frozen=True)
class _ArrayField:
    """A wave field description holding arrays, as an irregular sea does."""

    amplitude_m: np.ndarray
    seed: int
    _cache: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2))

    def elevation(self, north: float, east: float, t: float) -> float:
        return 0.0


def test_sea_record_holds_any_dataclass_sea(tmp_path: Path) -> None:
    """sea.json: seed, every public field (arrays as lists), the current and the start state."""
    path = tmp_path / "sea.json"
    write_sea_record(path, 3, _ArrayField(np.array([0.5, 0.25]), 3), OceanCurrent(0.2, 1.0),  # type: ignore[arg-type]
                     "published", _x0())
    record = json.loads(path.read_text())
    assert record["seed"] == 3
    assert record["waves"] == {"type": "_ArrayField", "amplitude_m": [0.5, 0.25], "seed": 3}
    assert record["current"]["speed_mps"] == 0.2
    assert record["x0"][5] == pytest.approx(math.radians(HEADING_DEG))


def test_a_gap_in_frame_counts_is_counted_and_stepped_once() -> None:
    """Frames 0, 1, 5: three frames the backend never saw are counted; frame 5 still steps one period."""
    backend = _backend("calm")
    pwm = [motor_output_to_pwm(0.5), 0, motor_output_to_pwm(0.5)]
    for count in (0, 1, 5):
        reply = parse_reply(backend.handle(encode_servo_packet(400, count, pwm)) or b"")
    assert backend.stats.skipped == 3 and backend.stats.stepped == 3
    assert reply.timestamp == pytest.approx(3 / 400, abs=1e-12)
    assert backend.handle(encode_servo_packet(400, 5, pwm)) == reply.raw and backend.stats.repeats == 1


def test_world_from_a_scenario_and_flags_as_the_simulator_reads_it() -> None:
    """--scenario gives vessel, sea and start pose; --sea and --heading given too override their parts."""
    root = Path(__file__).resolve().parents[2]
    args = build_parser().parse_args(["--json-backend", "9002", "--scenario", str(root / "scenarios/balanced.yaml")])
    vessel, waves, current, x0, wind = build_world(args)
    assert str(vessel) == "published" and waves == sea_preset("paper").waves() and current == OceanCurrent()
    assert wind is None  # still air: the scenario has none
    assert x0[5] == pytest.approx(math.radians(90.0)) and x0.shape == (14,)
    args = build_parser().parse_args(["--scenario", str(root / "scenarios/balanced.yaml"), "--sea", "calm",
                                      "--heading", "-45", "--json-backend", "0.0.0.0:9100"])
    _, waves, _, x0, _ = build_world(args)
    assert waves == CalmWater() and x0[5] == pytest.approx(math.radians(-45.0))
    assert args.json_backend == ("0.0.0.0", 9100)
    args = build_parser().parse_args(["--json-backend", "9002", "--vessel", "corrected"])
    vessel, *_ = build_world(args)
    assert str(vessel) == "corrected"  # --vessel sets the plant, as sim-vehicle's own flag


def test_a_lower_frame_count_that_is_not_zero_restarts_the_run() -> None:
    """Frames 0-199, then 50 (a firmware restarted mid-count): the run starts again from the initial state."""
    backend, fresh = _backend("paper"), _backend("paper")
    pwm = [motor_output_to_pwm(0.8), 0, motor_output_to_pwm(0.2)]
    for count in range(200):
        backend.handle(encode_servo_packet(400, count, pwm))
    restarted = parse_reply(backend.handle(encode_servo_packet(400, 50, pwm)) or b"")
    first = parse_reply(fresh.handle(encode_servo_packet(400, 0, pwm)) or b"")
    assert backend.stats.resets == 1 and backend.stats.skipped == 0
    assert restarted.raw == first.raw and restarted.timestamp == pytest.approx(1 / 400, abs=1e-12)
    assert parse_reply(backend.handle(encode_servo_packet(400, 51, pwm)) or b"").raw == \
        parse_reply(fresh.handle(encode_servo_packet(400, 1, pwm)) or b"").raw


def test_heave_and_sea_state_flags() -> None:
    """An irregular sea heaves the hull by default, a regular one does not; --heave overrides; --sea-state N
    is the simulator's NATO sea; the sea is averaged over the world's own hull."""
    def world(*flags: str) -> tuple[object, bool]:
        args = build_parser().parse_args(["--json-backend", "9002", *flags])
        _, waves, _, _, _ = build_world(args)
        return waves, surface_heave(args, waves)

    waves, heave = world("--sea", "jonswap:1.75,6,-90")
    assert isinstance(waves, IrregularWaves) and heave
    assert world("--sea", "jonswap:1.75,6,-90", "--heave", "paper")[1] is False
    assert world("--sea", "paper")[1] is False and world("--sea", "paper", "--heave", "surface")[1] is True
    waves, heave = world("--sea-state", "4")
    assert isinstance(waves, IrregularWaves) and heave
    expected = IrregularSea(sea_state=4).wave_field(otter_parameters())
    np.testing.assert_array_equal(waves.amplitude_m, expected.amplitude_m)
