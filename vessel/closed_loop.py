"""Plants for in-process closed-loop runs, built from a :class:`~vessel.world.World` and a control period.

Both hold the input over one control period and advance by ``period_s / dt_s`` RK4 steps of ``dt_s``:

* :class:`TauPlant` — the paper's set-up: the rigid-body model driven by (τ_X, τ_N) directly;
* :class:`PropellerPlant` — :class:`~vessel.plant.Plant` with shaft dynamics and saturation, driven by
  the shaft-speed commands.

States are NED/body as everywhere: x = [N, E, D, φ, θ, ψ, u, v, w, p, q, r] (m, rad, m/s, rad/s).
"""

from __future__ import annotations

import numpy as np

from vessel.config import ConfigError
from vessel.dynamics import rigid_body_ode
from vessel.plant import Plant, rk4_step
from vessel.world import World


def substeps_per_period(period_s: float, dt_s: float) -> int:
    """How many plant steps of ``dt_s`` make one control period; ConfigError unless dt divides it."""
    if not (dt_s > 0 and period_s > 0):
        raise ConfigError(f"plant_dt_s: {dt_s!r} s and period_s: {period_s!r} s must both be > 0")
    ratio = period_s / dt_s
    if abs(ratio - round(ratio)) > 1e-6:
        raise ConfigError(f"plant_dt_s: {dt_s:g} s must divide the control period {period_s:g} s")
    return round(ratio)


class TauPlant:
    """The rigid-body model driven by (τ_X, τ_N), RK4 at dt, input held over one control period."""

    def __init__(self, world: World, period_s: float, dt_s: float) -> None:
        params = world.params()
        ode = rigid_body_ode(params, world.sea.waves(params), world.sea.current(), wind=world.sea.wind())
        self.dt = dt_s
        self.substeps = substeps_per_period(period_s, dt_s)
        self._period = rk4_step(ode, self.dt).mapaccum(self.substeps)
        self._offsets = (self.dt * np.arange(self.substeps))[np.newaxis, :]  # substep start times after t (s)
        self.x = world.rigid_state()

    @property
    def rigid_state(self) -> np.ndarray:
        """The 12 rigid-body states."""
        return self.x.copy()

    @property
    def shaft_speeds(self) -> tuple[float, float] | None:
        """Not modelled in this plant."""
        return None

    def advance(self, t: float, tau: np.ndarray, n_cmd: tuple[float, float]) -> None:
        """One control period from time t with τ = (τ_X N, τ_N N·m) held; ``n_cmd`` is not used."""
        held = np.repeat(np.asarray(tau, dtype=float).reshape(-1, 1), self.substeps, axis=1)
        out = np.asarray(self._period(self.x, held, t + self._offsets))
        x_next = out[:, -1]
        if not np.all(np.isfinite(x_next)):
            raise FloatingPointError(f"plant state became non-finite at t = {t:.2f} s")
        self.x = x_next


class PropellerPlant:
    """:class:`~vessel.plant.Plant` (shaft dynamics, saturation) driven by the shaft-speed commands."""

    def __init__(self, world: World, period_s: float, dt_s: float) -> None:
        params = world.params()
        self.plant = Plant(params, world.sea.waves(params), world.sea.current(), dt=dt_s, integrator="rk4",
                           x0=world.plant_state(), wind=world.sea.wind())
        self.substeps = substeps_per_period(period_s, dt_s)

    @property
    def rigid_state(self) -> np.ndarray:
        """The 12 rigid-body states."""
        return self.plant.state[0:12]

    @property
    def shaft_speeds(self) -> tuple[float, float] | None:
        """Actual shaft speeds (rad/s)."""
        s = self.plant.state
        return float(s[12]), float(s[13])

    def advance(self, t: float, tau: np.ndarray, n_cmd: tuple[float, float]) -> None:
        """One control period with the shaft-speed commands (rad/s, left/right) held; ``tau`` is not used."""
        self.plant.advance(n_cmd, self.substeps)
