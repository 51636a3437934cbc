"""The roll-aware NMPC (the paper's controller), no I/O.

``NmpcConfig`` (weights, horizon, discretisation, τ bounds, solver) -> ``RollAwareNmpc(config, params,
waves, current).solve(x0, t, waypoint_ne, deadline_s=None) -> NmpcResult``. Two solvers share one problem
definition (``problem``): ``ipopt``, the reference (the notes' configuration: SX, warm start, max_iter 50),
and ``rti``, Gauss–Newton real-time iterations with HPIPM and a compiled, disk-cached linearisation.
"""

from .config import INTEGRATORS, SOLVERS, NmpcConfig
from .controller import NmpcResult, RollAwareNmpc
from .problem import discrete_model, heading_error, wrap_angle

__all__ = ["INTEGRATORS", "SOLVERS", "NmpcConfig", "NmpcResult", "RollAwareNmpc", "discrete_model",
           "heading_error", "wrap_angle"]
