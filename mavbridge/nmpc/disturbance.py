"""What the boat meets that the model lacks, estimated in flight from the boat's own motion.

A real boat is told neither the current nor the wind, nor how its hull and propellers differ from the model. The
observer estimates the slowly varying part of all of it as four numbers the NMPC's model takes (the
``disturbance`` block, ``layout.DISTURBANCE_NAMES``): a current (NED, m/s) and a steady surge force (N) and yaw
moment (N·m). It is the offset-free MPC's disturbance model: each control period the model predicts the measured
state from the previous one under the command that was in effect; the error in the body velocities (u, v) and
the yaw rate r updates the estimate through a Kalman filter on a random walk, whose Jacobian is the model's own
(CasADi), so no gain is hand-tuned per hull.

Waves the wave model does not explain make the one-period errors large and fast; the filter's measurement noise
is sized for them and its random walk for a current that changes over minutes, so the estimate settles in
tens of seconds and does not follow the wave. It runs from connection on, also while the boat drifts with its
thrusters idle before engaging (the purest look at the current), and never while a pilot drives (the thrust is
then unknown): ``update`` is given the command in effect, or nothing.

Everything here is the companion's own knowledge: the measured state and the commands it sent. Nothing of the
simulator's truth enters.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from mavbridge.nmpc.compiled_model import compiled_model
from mavbridge.nmpc.layout import DISTURBANCE_NAMES, NX
from mavbridge.nmpc.model_state import on_mean_surface
from mavbridge.nmpc.problem import discrete_model

MEASURED = (6, 7, 11)  # u, v (m/s, body), r (rad/s): what the errors are taken in
SETTLED_CURRENT_STD = 0.08  # m/s: the current's standard deviation under which the estimate counts as settled
SETTLED_STEPS = 50  # ... held for this many periods
IDLE = np.zeros(2)  # τ with the thrusters idle (disarmed, or neutral sent)
# what ``update`` changes: all the rest is made from the NMPC and the settings at construction
LEARNT = ("estimate", "covariance", "_previous", "updates", "settled_at_s", "_calm_steps")


@dataclass(frozen=True)
class ObserverSettings:
    """The filter's noise model (standard deviations) and the estimate's limits, per disturbance element."""

    # The surge force is held at 0 (std 0): along the heading it cannot be told from a current until the boat turns,
    # and a wave's mean push along its travel would pass into it; a thrust that differs from the model shows as a
    # current against the heading instead (the block keeps it for a model that knows better).
    initial_std: tuple[float, float, float, float] = (0.5, 0.5, 0.0, 5.0)
    drift_std_per_sqrt_s: tuple[float, float, float, float] = (0.01, 0.01, 0.0, 0.15)
    measurement_std: tuple[float, float, float] = (0.05, 0.08, 0.03)  # u, v (m/s), r (rad/s) over one period
    limits: tuple[float, float, float, float] = (2.0, 2.0, 60.0, 20.0)
    # While the model knows no wave (before the estimate is confident, or after it dropped out) the waves' forces
    # are in every error: the errors weigh this much less (variance), so the estimate does not learn the sea
    unknown_wave_noise_factor: float = 10.0


class DisturbanceObserver:
    """The estimate (``estimate``: current N, E m/s, surge force N, yaw moment N·m) and its covariance."""

    def __init__(self, nmpc: Any, settings: ObserverSettings | None = None) -> None:
        self.settings = settings or ObserverSettings()
        self.period_s = float(nmpc.config.period_s)
        functions = nmpc._functions  # the NMPC's own model (the same hull, wave field and built-in current)
        step = discrete_model(nmpc.params, functions.fixed_waves, functions.current, nmpc.config.replace(inputs="tau"),
                              functions.wind)
        x, tau, t = ca.SX.sym("x", NX), ca.SX.sym("tau", 2), ca.SX.sym("t")
        wave = ca.SX.sym("wave", step.size1_in(3))
        y = step(x, tau, t, wave)[list(MEASURED)]
        n = len(DISTURBANCE_NAMES)
        jac = ca.jacobian(y, wave)[:, wave.numel() - n:]
        # bound to preallocated arrays (no DM conversions per period), compiled once per make of model (see
        # ``compiled_model``: the same numbers); the Jacobian dense, column-major
        self._predict, _ = compiled_model(
            ca.Function("disturbance_prediction", [x, tau, t, wave], [y, ca.densify(jac)]))
        self.estimate = np.zeros(n)
        self.covariance = np.diag(np.square(self.settings.initial_std))
        self._drift = np.diag(np.square(self.settings.drift_std_per_sqrt_s)) * self.period_s
        self._noise = np.diag(np.square(self.settings.measurement_std))
        self._noise_unknown_wave = self._noise * self.settings.unknown_wave_noise_factor
        self._identity = np.eye(n)
        self._limits = np.asarray(self.settings.limits, float)
        self._previous: tuple[np.ndarray, np.ndarray, float, np.ndarray, bool] | None = None
        self.updates = 0
        self.settled_at_s: float | None = None
        self._mean_surface = nmpc.config.heave_feedback == "none"  # a hull riding the sea: as the NMPC does
        self._calm_steps = 0

    def update(self, t: float, x: np.ndarray, tau: np.ndarray | None, wave: np.ndarray,
               wave_known: bool = True) -> bool:
        """One period: compare the measured state ``x`` at ``t`` with the model's prediction from the previous call
        (the command in effect since then and the wave input the NMPC plans with), and correct the estimate.
        ``tau`` is the command in effect from now on (τ_X N, τ_N N·m), None when it is not known (a pilot drives):
        the next period is then not used. ``wave_known``: the model knows the sea (a wave, or calm water); while it
        does not, the errors hold the waves' forces and weigh less. Returns True when the estimate settled now."""
        x = on_mean_surface(x) if self._mean_surface else np.asarray(x, float)  # the state as the NMPC's model sees it
        previous, self._previous = self._previous, None
        if tau is not None and np.all(np.isfinite(x)):
            self._previous = (x.copy(), np.asarray(tau, float).copy(), float(t), np.asarray(wave, float).copy(),
                              wave_known)
        if previous is None or not math.isclose(t - previous[2], self.period_s, rel_tol=0.25):
            return False  # no command known over the period, or a gap: nothing to compare
        x0, tau0, t0, wave0, known = previous
        wave0[wave0.size - self.estimate.size:] = self.estimate
        predicted, jac = self._prediction(x0, tau0, t0, wave0)
        noise = self._noise if known else self._noise_unknown_wave
        self._correct(x[list(MEASURED)] - predicted, jac, noise)
        return self._settled(t)

    def _prediction(self, x: np.ndarray, tau: np.ndarray, t: float, wave: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The model's measured velocities one period on from (x, τ, t, wave) and their Jacobian in the disturbance
        (3 × 4, C order as the ordinary call's result was: the filter's products then sum in the same order)."""
        x_in, tau_in, t_in, wave_in = self._predict.inputs[0:4]
        x_in[:], tau_in[:], t_in[0], wave_in[:] = x, tau, t, wave
        self._predict()
        predicted, jac = self._predict.outputs
        return predicted.copy(), jac.reshape(-1, len(MEASURED)).T.copy()

    def _correct(self, error: np.ndarray, jac: np.ndarray, noise: np.ndarray) -> None:
        """The Kalman filter's update of the random-walk disturbance from the velocity errors."""
        p = self.covariance + self._drift
        jp = jac @ p  # (once: the same product served both uses)
        s = jp @ jac.T + noise
        gain = np.linalg.solve(s, jp).T
        self.estimate = np.minimum(np.maximum(self.estimate + gain @ error, -self._limits), self._limits)
        self.covariance = (self._identity - gain @ jac) @ p
        self.updates += 1

    def _settled(self, t: float) -> bool:
        """True once, when the current's uncertainty has stayed small for ``SETTLED_STEPS`` periods."""
        if self.settled_at_s is not None:
            return False
        small = math.sqrt(max(self.covariance[0, 0], self.covariance[1, 1])) < SETTLED_CURRENT_STD
        self._calm_steps = self._calm_steps + 1 if small else 0
        if self._calm_steps < SETTLED_STEPS:
            return False
        self.settled_at_s = t
        return True

    def state(self) -> dict[str, Any]:
        """A copy of all the filter has learnt (``restore`` puts it into an observer of the same model): what a
        watch before a run leaves, kept by ``mavbridge.lab.watch`` for the next run that would repeat it."""
        return copy.deepcopy({name: getattr(self, name) for name in LEARNT})

    def restore(self, state: dict[str, Any]) -> None:
        """Continue from ``state`` (``state()`` of an observer of the same NMPC model and settings)."""
        for name, value in copy.deepcopy(state).items():
            setattr(self, name, value)

    def row(self) -> dict[str, float]:
        """CSV columns: the estimate (current NED m/s, surge force N, yaw moment N·m) and the current's std."""
        names = ("dist_current_north_m_s", "dist_current_east_m_s", "dist_surge_force_n", "dist_yaw_moment_nm")
        row = dict(zip(names, (float(v) for v in self.estimate), strict=True))
        row["dist_current_std_m_s"] = math.sqrt(max(self.covariance[0, 0], self.covariance[1, 1]))
        return row

    def describe(self) -> str:
        """One line: 'current 0.48 m/s to 3°, yaw moment +0.40 N·m' (and the surge force where it is estimated)."""
        north, east, surge, yaw = (float(v) for v in self.estimate)
        towards = math.degrees(math.atan2(east, north))
        surge_text = f", surge force {surge:+.1f} N" if self.settings.initial_std[2] > 0 else ""
        return f"current {math.hypot(north, east):.2f} m/s to {towards:.0f}°{surge_text}, yaw moment {yaw:+.2f} N·m"

    def metrics(self) -> dict[str, Any]:
        """For metrics.json: the final estimate, when it settled, how many periods it used."""
        north, east, surge, yaw = (round(float(v), 4) for v in self.estimate)
        return {"current_north_m_s": north, "current_east_m_s": east, "surge_force_n": surge, "yaw_moment_nm": yaw,
                "settled_at_s": self.settled_at_s, "updates": self.updates}


def observe_period(observer: DisturbanceObserver | None, nmpc: Any, state: Any, now_ms: int, tau: np.ndarray | None,
                   stale_s: float, log: Callable[[str], None], x: np.ndarray | None = None) -> None:
    """One control period: the observer compares the boat's state (when fresh; ``x``: the state vector the step
    already made, else made here) with the model's prediction under the command in effect since the last period
    (``tau`` is the one from now on; None: unknown, a pilot drives), and the NMPC's later solves predict with its
    estimate (handed over only when it moved). One line when it settles."""
    if observer is None or not state.ready():
        return
    fresh = state.age_ms(now_ms) <= stale_s * 1000
    before = observer.updates
    if observer.update(now_ms / 1000.0, state.vector() if x is None else x, tau if fresh else None,
                       nmpc.model_wave(), nmpc.wave_known):
        log(f"disturbance settled at t = {now_ms / 1000:.1f} s: {observer.describe()} (estimated from the boat's "
            f"motion)")
    if observer.updates != before:
        nmpc.set_disturbance(observer.estimate)
