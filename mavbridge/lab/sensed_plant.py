"""The realistic in-process plant: the boat in the true (hidden-phase) sea, sensed at 20 Hz into a wave source.

``SensedPlant`` runs the rigid-body model driven by τ (or, with propellers, the plant with shaft dynamics) at
``dt_s``, the input held over a control period; every half period (the ATTITUDE rate) the true state goes through
``vessel.sensors.SensorModel`` and, as a ``MotionSample``, into a ``WaveSource``; the IMU's specific force comes from
the plant's own ẋ (``vessel.imu.specific_force``). What the estimator and the experiment do with it:
``mavbridge.waves.inloop``.

A half period's substeps are compiled once for every plant of the same make (``mavbridge.nmpc.compiled_model``), or
run all in one call of the mapped step on CasADi's virtual machine. A plant step in an irregular sea of 200
components costs the virtual machine ≈ 34 µs (≈ 5 ms per simulated second at 0.01 s steps, more than the rest of the
loop outside the NMPC); compiled (gcc -O1, no contraction) ≈ 10 µs, bit for bit the same numbers, and one library
serves every seed and hidden phase.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mavbridge.nmpc.compiled_model import ModelMake, bind, model_make
from mavbridge.waves.inloop import SAMPLES_PER_PERIOD, SETTLE_S
from mavbridge.waves.source import MotionSample, WaveSource
from vessel import WaveField
from vessel.closed_loop import substeps_per_period
from vessel.dynamics import OceanCurrent, plant_ode, rigid_body_ode
from vessel.imu import specific_force
from vessel.jit import BoundFunction
from vessel.plant import plant_step, rk4_step
from vessel.sea.wind import Wind
from vessel.sensors import SensorModel


class MappedHalf:
    """All substeps of a half period in one call of ``step.mapaccum`` (the virtual machine), bound to arrays."""

    def __init__(self, step: ca.Function, substeps: int, dt: float) -> None:
        self._call = BoundFunction(step.mapaccum(substeps))
        self._offsets = dt * np.arange(substeps)  # the substeps' times: t0 + dt·k
        self.substeps = substeps

    def hold(self, u: np.ndarray) -> None:
        """The input held over the coming half periods."""
        self._call.inputs[1].reshape(self.substeps, -1)[:] = u  # column-major 2 × k: u at every substep

    def run(self, x: np.ndarray, t0: float) -> np.ndarray:
        """The state a half period after (x, t0): a view, valid until the next run."""
        x_in, _, t_in = self._call.inputs
        x_in[:] = x
        np.add(t0, self._offsets, out=t_in)
        self._call()
        return self._call.outputs[0][-x_in.size:]  # the last substep's state (the last column)


class CompiledHalf:
    """The substeps as successive calls of the compiled one-step function (``compiled_model``: its constants set)."""

    def __init__(self, call: BoundFunction, substeps: int, dt: float) -> None:
        self._call = call
        self._offsets = dt * np.arange(substeps)  # (their sums with t0 are the mapped step's times)
        self._times = np.zeros(substeps)

    def hold(self, u: np.ndarray) -> None:
        """The input held over the coming half periods."""
        self._call.inputs[1][:] = u

    def run(self, x: np.ndarray, t0: float) -> np.ndarray:
        """The state a half period after (x, t0): a view, valid until the next run."""
        x_in, _, t_in, _ = self._call.inputs
        out = self._call.outputs[0]
        x_in[:] = x
        for k, t in enumerate(np.add(t0, self._offsets, out=self._times).tolist()):
            if k:
                x_in[:] = out
            t_in[0] = t
            self._call()
        return out


def half_period(step: ModelMake, substeps: int, dt: float) -> MappedHalf | CompiledHalf:
    """The half period of the plant whose one step is ``step`` ((x, u, t) -> x, its numbers inside): compiled when it
    can be, else ``step`` mapped over the substeps."""
    call, compiled = bind(step)
    return CompiledHalf(call, substeps, dt) if compiled else MappedHalf(step.function, substeps, dt)


@dataclass(frozen=True)
class PlantMake:
    """The plant's functions before they are bound to arrays (immutable: one serves every plant built from the same
    arguments, ``plant_make``'s): its step over ``dt_s`` and the IMU's specific force, and its state's size."""

    step: ModelMake
    imu: ModelMake
    nx: int


def plant_make(params: Any, waves: WaveField, current: OceanCurrent, dt_s: float, surface_heave: bool,
               wind: Wind | None = None, propellers: bool = False) -> PlantMake:
    """The functions of ``SensedPlant``'s plant (its arguments of the same names)."""
    if propellers:
        ode = plant_ode(params, waves, current, surface_heave, wind)
        step = plant_step(params, waves, current, dt_s, "rk4", surface_heave, wind)
    else:
        ode = rigid_body_ode(params, waves, current, surface_heave, wind)
        step = rk4_step(ode, dt_s)
    nx = ode.size1_in(0)
    x, u, t = ca.SX.sym("x", nx), ca.SX.sym("u", 2), ca.SX.sym("t")
    xdot = ode(x, u, t)
    imu = ca.Function("imu", [x, u, t], [specific_force(x[6:12], xdot[6:12], x[3], x[4], params.g)])
    return PlantMake(model_make(step), model_make(imu), nx)


class SensedPlant:
    """The boat in the true sea, driven by τ (the rigid body: the paper's set-up) or, with ``propellers``, by the
    shaft-speed commands through the propellers' dynamics and saturation (so a thrust the model does not know
    shows); feeds a wave source with sensor readings at 20 Hz."""

    def __init__(self, params: Any, waves: WaveField, current: OceanCurrent, x0: np.ndarray, period_s: float,
                 dt_s: float, surface_heave: bool, sensors: SensorModel, source: WaveSource,
                 wind: Wind | None = None, propellers: bool = False, make: PlantMake | None = None) -> None:
        """``make``: ``plant_make`` of these same arguments, built before (by default built here)."""
        self.propellers = propellers
        self.make = make or plant_make(params, waves, current, dt_s, surface_heave, wind, propellers)
        self.dt = dt_s
        self.half_s = period_s / SAMPLES_PER_PERIOD
        self.substeps = substeps_per_period(self.half_s, dt_s)
        # a half period's substeps bound to preallocated arrays (no DM conversions per call); compiled in an
        # irregular sea (see ``half_period``)
        self._half = half_period(self.make.step, self.substeps, dt_s)
        self._imu, _ = bind(self.make.imu)
        nx = self.make.nx
        self.x = np.concatenate([np.asarray(x0, float)[:12], np.zeros(nx - 12)])
        self.sensors, self.source = sensors, source
        self._input = np.zeros(2)  # τ (N, N·m), or the shaft-speed commands (rad/s) with propellers

    @property
    def rigid_state(self) -> np.ndarray:
        """The 12 rigid-body states."""
        return self.x[:12].copy()

    @property
    def shaft_speeds(self) -> tuple[float, float] | None:
        """Actual shaft speeds (rad/s) with propellers; None for the τ-driven body."""
        return (float(self.x[12]), float(self.x[13])) if self.propellers else None

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the plant's own state and the input it holds (the sensors and the wave source keep theirs)."""
        return self.x.copy(), self._input.copy()

    def set_state(self, x: np.ndarray, held: np.ndarray) -> None:
        """Continue from ``state()`` of a plant of the same make (a watch kept by ``mavbridge.lab.watch``)."""
        self.x, self._input = np.array(x, float), np.array(held, float)
        self._half.hold(self._input)

    def sense(self, t: float) -> None:
        """Sample the sensors at ``t`` (true state, last applied τ for the IMU) and feed the wave source."""
        x_in, u_in, t_in = self._imu.inputs[0:3]
        x_in[:] = self.x
        u_in[:] = self._input
        t_in[0] = t
        self._imu()
        reading = self.sensors.sample(t, self.x[0:6], self.x[6:12], self._imu.outputs[0])
        self.source.observe(MotionSample(reading.t_s, reading.attitude, reading.rates, reading.position_ned,
                                         reading.velocity_ned, reading.accel_body))

    def watch(self, seconds: float, period_s: float,
              on_period: Callable[[float, np.ndarray], None] | None = None) -> None:
        """The boat drifting with idle thrusters for ``seconds`` before t = 0, sensed as in the run (the wave
        source learns; the run's clock then starts at 0 where this ends). It has floated unwatched for
        ``SETTLE_S`` before that: the model starts at rest on a calm waterline, and no skipper's companion
        connects while the hull is still being dropped into the sea (its first seconds heave and pitch as no
        boat afloat does). ``on_period(t, x)``: what the companion sees each watched period (the rigid state),
        thrusters idle."""
        steps, settle = round(seconds / period_s), round(SETTLE_S / period_s) if seconds > 0 else 0
        for i in range(settle + steps):
            t = (i - steps - settle) * period_s
            if i >= settle:
                self.sense(t)
                if on_period is not None:
                    on_period(t, self.rigid_state)
            self.advance(t, np.zeros(2), (0.0, 0.0), sensed=i >= settle)

    def advance(self, t: float, tau: np.ndarray, n_cmd: tuple[float, float], sensed: bool = True) -> None:
        """One control period from ``t`` with τ (or, with propellers, ``n_cmd``) held, sensing at each half period
        inside it (``sensed``; not while the hull settles unwatched)."""
        self._input = np.asarray(n_cmd if self.propellers else tau, float)
        self._half.hold(self._input)
        for i in range(SAMPLES_PER_PERIOD):
            t0 = t + i * self.half_s
            if i > 0 and sensed:
                self.sense(t0)
            x_next = self._half.run(self.x, t0)
            if not np.isfinite(x_next).all():
                raise FloatingPointError(f"plant state became non-finite at t = {t0:.2f} s")
            self.x = x_next.copy()
