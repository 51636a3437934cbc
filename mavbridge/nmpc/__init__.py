"""The roll-aware NMPC (the paper's controller), no I/O.

``compile_function``: a CasADi Function compiled to C once and cached on disk (``solvers.codegen``), for other
rooms' per-step model calls; ``compile_native_function`` also answers a caller of the compiled library's C API
on bound buffers (``solvers.native_lib``), microseconds a call instead of CasADi's tens.

``NmpcConfig`` (weights, horizon, discretisation, τ bounds, solver) -> ``RollAwareNmpc(config, params,
waves, current).solve(x0, t, waypoint_ne, deadline_s=None) -> NmpcResult``, with ``prepare(x0, t,
waypoint_ne)`` for the cold, full solve before the loop, ``set_wave(RegularWaves | CalmWater | None)`` for
the wave later solves predict with (a run-time parameter: no rebuild), and ``close()`` / ``with``.

Modules: ``layout`` (named blocks of the decision and parameter vectors), ``wave_model`` (the regular
wave as parameters), ``wave_bank`` (with ``wave_components`` K > 0: K long-crested components of a
phase-resolved sea as parameters, ``set_wave_bank``), ``problem`` (model, costs, NLP), ``functions`` (the
per-process cache of immutable built Functions), ``backend`` (the solver protocol: prepare / solve / advance /
reset / close), and in ``solvers`` four backends: ``ipopt``, the reference (the notes' configuration: SX, warm
start, max_iter 50); ``rti``, Gauss–Newton real-time iterations with HPIPM and a compiled, disk-cached linearisation
(``gauss_newton``, ``codegen``); and ``asrti``, advanced-step RTI: a converged Gauss–Newton SQP for the
predicted next state runs in a background worker during the period, and the step is one iteration from
its plan (the same
closed loop as ``ipopt``); and ``nrti``, asrti with a native preparation/feedback split: the background
also condenses the QP at its plan (``condensed``, C kernels in ``native_source`` loaded by ``native_lib``),
and the step is one C call that puts the measured state into it.

May import: ``vessel`` and ``mavbridge.nmpc`` (with its ``solvers``). Imported by ``mavbridge.companion``,
``mavbridge.lab``, ``mavbridge.sweep`` and ``mavbridge.preflight``.
"""

from mavbridge.nmpc.config import INTEGRATORS, SOLVERS, NmpcConfig
from mavbridge.nmpc.controller import NmpcResult, RollAwareNmpc
from mavbridge.nmpc.layout import PARAMS, Layout, ParameterLayout
from mavbridge.nmpc.problem import discrete_model, heading_error, wrap_angle
from mavbridge.nmpc.solvers.codegen import compiled as compile_function
from mavbridge.nmpc.solvers.native_lib import compiled_native as compile_native_function
from mavbridge.nmpc.wave_model import wave_parameters

__all__ = ["INTEGRATORS", "PARAMS", "SOLVERS", "Layout", "NmpcConfig", "NmpcResult", "ParameterLayout",
           "RollAwareNmpc", "compile_function", "compile_native_function", "discrete_model", "heading_error",
           "wave_parameters", "wrap_angle"]
