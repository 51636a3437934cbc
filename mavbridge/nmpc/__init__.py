"""The roll-aware NMPC (the paper's controller), no I/O.

``NmpcConfig`` (weights, horizon, discretisation, τ bounds, solver) -> ``RollAwareNmpc(config, params,
waves, current).solve(x0, t, waypoint_ne, deadline_s=None) -> NmpcResult``, with ``prepare(x0, t,
waypoint_ne)`` for the cold, full solve before the loop. Three solvers share one problem definition
(``problem``): ``ipopt``, the reference (the notes' configuration: SX, warm start, max_iter 50); ``rti``,
Gauss–Newton real-time iterations with HPIPM and a compiled, disk-cached linearisation; and ``asrti``,
advanced-step RTI: a converged Gauss–Newton SQP for the predicted next state runs in a background thread
during the period, and the step is one iteration from its plan (the same closed loop as ``ipopt``).
"""

from .config import INTEGRATORS, SOLVERS, NmpcConfig
from .controller import NmpcResult, RollAwareNmpc
from .problem import discrete_model, heading_error, wrap_angle

__all__ = ["INTEGRATORS", "SOLVERS", "NmpcConfig", "NmpcResult", "RollAwareNmpc", "discrete_model",
           "heading_error", "wrap_angle"]
