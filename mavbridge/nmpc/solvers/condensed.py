"""The preparation phase of the native RTI: the Gauss–Newton QP at a plan, condensed to the input steps.

``block_linearisation`` is ``gauss_newton.linearisation`` with its output kept as dense stage blocks
(AB_k = ∂f_aug/∂[z, u], H_k, g_k, gap_k; the terminal stage padded to the stage size) instead of the
assembled sparse matrices, so the native kernels read them without any conversion. It is built from the
same residuals (the ``vessel`` model through ``problem.discrete_model``, single source) and compiled
once into the disk cache (``codegen``).

``Condenser.condense(w_aug, p)`` evaluates it at a plan and hands the blocks to ``nrti_condense`` (C),
which eliminates the states: the result, a ``CondensedQp``, is a dense QP in the N·nu input steps whose
gradient is affine in the initial-state offset dz0; its active set at dz0 = 0 (the plan itself) is solved here
too, as the feedback's starting guess. The preparation's SQP iterates in the condenser's own arrays (``iterate``,
or all its iterations in one C call, ``converge``: nrti_converge calls the compiled linearisation itself) and
keeps only its last QP (``keep``). All of this runs before the measurement arrives.
"""

from __future__ import annotations

import ctypes
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.inputs import InputSpace, input_space
from mavbridge.nmpc.layout import NU, NX, ROLL_SPREAD_NAMES, WEIGHT_NAMES, parameter_layout, wave_input_size
from mavbridge.nmpc.solvers.codegen import HOT_FLAGS, compiled_library, load
from mavbridge.nmpc.solvers.gauss_newton import CSE, HESSIAN_REG, NZ, _input_change_residuals, _state_residuals
from mavbridge.nmpc.solvers.native_lib import BoxQp, CompiledFunction, ptr

NZU = NZ + NU
KEEP = object()  # ``Condenser.bind``: the QP's own factor
QP_MAX_ITER = 40  # block-principal-pivoting iterations per QP (one or two when the guess is right)
QP_TOL = 1e-9  # bound and multiplier tolerance of the box QP (N, N·m and cost units)


def _stage_function(step: ca.Function, cfg: NmpcConfig,
                    matrix: np.ndarray | None = None) -> tuple[ca.Function, ca.Function]:
    """(stage, terminal) block Functions of the augmented OCP (see the module docstring)."""
    z, u, t = ca.SX.sym("z", NZ), ca.SX.sym("u", NU), ca.SX.sym("t")
    on = ca.SX.sym("on")  # 0 for stage 0: no cost on the fixed initial state
    waypoint, weights = ca.SX.sym("wp", 2), ca.SX.sym("weights", len(WEIGHT_NAMES))
    wave = ca.SX.sym("wave", wave_input_size(cfg.wave_components))
    spread = ca.SX.sym("roll_spread", len(ROLL_SPREAD_NAMES))
    zu = ca.vertcat(z, u)
    f_aug = ca.vertcat(step(z[0:NX], u, t, wave), u)
    res = ca.vertcat(*_input_change_residuals(u, z[NX:NZ], weights, matrix),
                     on * _state_residuals(z[0:NX], waypoint, weights, cfg, spread))
    J = ca.jacobian(res, zu)
    reg = HESSIAN_REG * ca.SX.eye(NZU)
    stage = ca.Function("nrti_stage", [z, u, t, on, waypoint, weights, wave, spread],
                        [f_aug, ca.densify(ca.jacobian(f_aug, zu)), ca.densify(2 * (J.T @ J) + reg),
                         ca.densify(2 * (J.T @ res))], CSE)
    r_end = _state_residuals(z[0:NX], waypoint, weights, cfg, spread)
    J_end = ca.jacobian(r_end, zu)  # zero u columns: the terminal block padded to the stage size
    terminal = ca.Function("nrti_terminal", [z, u, waypoint, weights, spread],
                           [ca.densify(2 * (J_end.T @ J_end) + reg), ca.densify(2 * (J_end.T @ r_end))], CSE)
    return stage, terminal


def block_linearisation(step: ca.Function, cfg: NmpcConfig, matrix: np.ndarray | None = None) -> ca.Function:
    """(w_aug, p) -> (AB nz×N·nzu, H nzu×(N+1)·nzu, g nzu×(N+1), gap nz×N), all dense, stage-major
    (``matrix``: B of propeller-thrust inputs, None when u is τ)."""
    P = cfg.horizon
    stage, terminal = _stage_function(step, cfg, matrix)
    n = P * NZU + NZ
    w = ca.MX.sym("w", n)
    blocks = parameter_layout(cfg.wave_components)
    p = ca.MX.sym("p", blocks.size)
    par = blocks.unpack(p)
    W = ca.reshape(w[0:P * NZU], NZU, P)
    Z, U = W[0:NZ, :], W[NZ:, :]
    z_end = w[P * NZU:]
    times = par.t + ca.DM(np.arange(P) * cfg.period_s).T
    flags = ca.DM([[0.0] + [1.0] * (P - 1)])
    F, AB, Hs, gs = stage.map(P)(Z, U, times, flags, ca.repmat(par.waypoint, 1, P), ca.repmat(par.weights, 1, P),
                                 ca.repmat(blocks.wave_input(p), 1, P), ca.repmat(par.roll_spread, 1, P))
    H_end, g_end = terminal(z_end, ca.DM.zeros(NU), par.waypoint, par.weights, par.roll_spread)
    gap = F - ca.horzcat(Z[:, 1:], z_end)
    return ca.Function("nrti_blocks", [w, p], [AB, ca.horzcat(Hs, H_end), ca.horzcat(gs, g_end), gap],
                       ["w", "p"], ["AB", "H", "g", "gap"])


class VmBlocks:
    """The block linearisation in CasADi's SX virtual machine with ``CompiledFunction``'s face (``bind``, ``call``,
    its own output buffers), for when nothing is compiled: the ``Condenser`` then works the same way on either."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = load(fn, None)
        self.n_in = [fn.nnz_in(i) for i in range(fn.n_in())]
        self.outputs = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        self._inputs: tuple[np.ndarray, ...] = ()

    def __call__(self, *inputs: np.ndarray) -> list[np.ndarray]:
        """Evaluate at ``inputs``; answers this instance's output buffers."""
        self.bind(*inputs)
        return self.call()

    def bind(self, *inputs: np.ndarray) -> None:
        """Evaluate at these arrays (their contents at each ``call``)."""
        self._inputs = inputs

    def call(self) -> list[np.ndarray]:
        """Evaluate at the inputs last bound; answers this instance's output buffers (flat, column-major)."""
        for out, value in zip(self.outputs, self.fn(*self._inputs), strict=True):
            out[:] = np.asarray(value).ravel(order="F")
        return self.outputs


BlockLinearisation = CompiledFunction | VmBlocks


def compile_block_linearisation(step: ca.Function, cfg: NmpcConfig,
                                matrix: np.ndarray | None = None) -> tuple[ca.Function, Path | None, str]:
    """(``block_linearisation``, its compiled library or None, how): compiled (disk-cached, ``HOT_FLAGS``: it runs a
    few times every step) when a compiler exists and ``cfg.rti_codegen`` is "auto". Immutable: shared by every
    instance (``block_instance``) of one problem structure (``ProblemFunctions.block_linearisation``)."""
    fn = block_linearisation(step, cfg, matrix)
    library, how = compiled_library(fn, HOT_FLAGS) if cfg.rti_codegen == "auto" else (None, "sx-vm (codegen off)")
    return fn, library, how


def block_instance(fn: ca.Function, library: Path | None, how: str) -> tuple[BlockLinearisation, str]:
    """(w_aug, p) -> [AB, H, g, gap] flat column-major, into the instance's own output buffers: ``library`` (``fn``
    compiled) called through its C API, or without one a private copy of ``fn`` in CasADi's SX VM (outputs
    converted; two threads never share one Function's work memory)."""
    if library is not None:
        n_out, n_in = ([f(i) for i in range(n)] for f, n in ((fn.nnz_out, fn.n_out()), (fn.nnz_in, fn.n_in())))
        return CompiledFunction(library, fn.name(), n_out, n_in), how
    return VmBlocks(ca.Function.deserialize(fn.serialize())), how


@dataclass
class FeedbackBuffers:
    """The feedback step's preallocated inputs and outputs (owned by one backend, used by its main thread)."""

    dz0: np.ndarray  # initial-state offset [x̂ − x_plan, u_prev − u_prev,plan] (nz)
    w_out: np.ndarray  # the new plan, the controller's layout
    du: np.ndarray  # the input steps (N·nu)
    work: np.ndarray
    iwork: np.ndarray

    @classmethod
    def allocate(cls, horizon: int) -> FeedbackBuffers:
        """Buffers for a horizon of ``horizon`` stages."""
        n = horizon * NU
        return cls(dz0=np.zeros(NZ), w_out=np.zeros((horizon + 1) * NX + horizon * NU), du=np.zeros(n),
                   work=np.zeros(n * n + 2 * n + 2 * NZ), iwork=np.zeros(3 * n, np.intc))


@dataclass
class CondensedQp:
    """One prepared QP: the condensed data, the plan it linearises, and the feedback call's arguments."""

    p: np.ndarray  # the parameters it was prepared for
    w_aug: np.ndarray  # the plan (augmented layout)
    arrays: tuple[np.ndarray, ...]  # Hc, gc, Gc, lo, hi, state0, AB, gap: kept alive for ``args``
    args: tuple  # nrti_feedback's arguments, pointers into ``arrays``, ``factor`` and the backend's FeedbackBuffers
    guess_status: int  # the box QP's answer at dz0 = 0 (> 0 solved)
    factor: np.ndarray | None = None  # the Cholesky factor of Hc's free block at ``state0`` (the preparation's), so
    # that the feedback's first iteration only substitutes; None: it factors

    @property
    def state0(self) -> np.ndarray:
        """The active set the feedback's box QP starts from (−1 lower, 0 free, 1 upper; ``arrays[5]``)."""
        return self.arrays[5]


class Condenser:
    """Linearise, condense and pre-solve at a plan; holds work buffers, so one thread at a time: nrti's
    background preparation, and before the loop its first QP on the main thread (``prepare_now``, while no
    preparation is in flight: ``warm_up`` waits for the worker).

    The SQP's iterations (``iterate``, or all of them in one C call: ``converge``) work in the condenser's own
    arrays, every pointer into them taken once: an intermediate iteration's QP is thrown away as soon as its step
    is taken, and only the last one is copied out (``keep``), to stay valid while the next preparation runs."""

    def __init__(self, lib: ctypes.CDLL, lin: BlockLinearisation, cfg: NmpcConfig, buffers: FeedbackBuffers,
                 space: InputSpace | None = None) -> None:
        """``space``: the inputs' box (default: the τ box, for τ inputs only)."""
        P = cfg.horizon
        space = space or input_space(cfg, None)
        self.lib, self.lin, self.cfg, self.buffers = lib, lin, cfg, buffers
        n = P * NU
        self.n = n
        self.Gam = np.zeros((P + 1) * NZ * n)
        self.Phi = np.zeros((P + 1) * NZ * NZ)
        self.c = np.zeros((P + 1) * NZ)
        self.tmp = np.zeros(4 * NZ * NZ + 2 * NZ + 2 * NU * NZ)  # nrti_condense's recursion (W, λ, Y, Wᵀ)
        self.u_index = np.array([k * NZU + NZ + i for k in range(P) for i in range(NU)])
        self.u_low = np.tile(space.low, P)
        self.u_high = np.tile(space.high, P)
        self.box = BoxQp(lib, n, QP_MAX_ITER, QP_TOL)
        # the iteration's QP: the linearisation's inputs (bound once) and outputs, the condensed data, the bounds
        # and the active set its box QP starts from, in the order of CondensedQp.arrays
        self.w_aug, self.p = np.zeros(lin.n_in[0]), np.zeros(lin.n_in[1])
        lin.bind(self.w_aug, self.p)
        AB, Hs, gs, gap = lin.outputs
        Hc, gc, Gc, lo, hi = np.zeros(n * n), np.zeros(n), np.zeros(n * NZ), np.zeros(n), np.zeros(n)
        self.arrays = (Hc, gc, Gc, lo, hi, np.zeros(n, np.intc), AB, gap, self.w_aug)
        self._condense_args = (P, NZ, NU, *(ptr(a) for a in (AB, Hs, gs, gap, self.Gam, self.Phi, self.c, Hc, gc, Gc,
                                                                self.tmp)))
        self._iteration: tuple[FeedbackBuffers | None, tuple] = (None, ())  # (buffers, nrti_feedback's arguments)
        self._native: tuple[FeedbackBuffers | None, tuple] = (None, ())  # (buffers, nrti_converge's arguments)
        self._start = np.zeros((P + 1) * NX + P * NU)  # ``converge``'s starting plan and input before it
        self._u_prev = np.zeros(NU)
        self._iterations = ctypes.c_int(0)
        stages = np.arange(P)[:, None] * NZU  # ``augment``: where w's x_k, u_k and x_N go, and u_prev_k+1 = u_k
        self._from_w = np.concatenate([(stages + np.r_[0:NX, NZ:NZU]).ravel(), P * NZU + np.arange(NX)])
        self._u_prev_from = (stages + np.arange(NZ, NZU)).ravel()
        self._u_prev_to = self._u_prev_from + NZU - NU

    @property
    def active(self) -> np.ndarray:
        """The active set the iteration's box QP starts from (−1 lower, 0 free, 1 upper); ``iterate`` leaves in it
        the set the QP ended with, the next iteration's start."""
        return self.arrays[5]

    def _condense_at(self, w_aug: np.ndarray | None, p: np.ndarray) -> None:
        """Linearise at the plan ``w_aug`` (None: the one ``augment`` put in place) for ``p`` and condense, into the
        iteration's arrays."""
        if w_aug is not None:
            np.copyto(self.w_aug, w_aug)
        np.copyto(self.p, p)
        self.lin.call()
        self.lib.nrti_condense(*self._condense_args)
        U = self.w_aug[self.u_index]
        _, _, _, lo, hi = self.arrays[:5]
        np.minimum(np.subtract(self.u_low, U, out=lo), 0.0, out=lo)
        np.maximum(np.subtract(self.u_high, U, out=hi), 0.0, out=hi)

    def converge(self, w: np.ndarray, u_prev: np.ndarray, p: np.ndarray, buffers: FeedbackBuffers,
                 budget_s: float) -> tuple[int, int] | None:
        """``iterate`` from the plan ``w`` (the controller's layout, ``u_prev`` before it) until every input step
        is at most ``as_step_tol`` (at most ``as_max_iterations``, none begun after ``budget_s`` seconds), in one C
        call (the same C calls, per iteration, as ``iterate``'s): (last status, iterations) — status < 0 when a QP
        failed or a plan was not finite — with the last QP in place for ``keep``. None when the linearisation is
        not compiled code (the caller then loops over ``iterate``)."""
        if not isinstance(self.lin, CompiledFunction):
            return None
        if self._native[0] is not buffers:
            self._native = (buffers, self._converge_args(buffers))
        np.copyto(self._start, w)
        np.copyto(self._u_prev, u_prev)
        np.copyto(self.p, p)
        head, tail = self._native[1]
        status = self.lib.nrti_converge(*head, budget_s, *tail)
        return status, int(self._iterations.value)

    def _converge_args(self, b: FeedbackBuffers) -> tuple[tuple, tuple]:
        """nrti_converge's arguments before and after its budget (all of them fixed for these buffers)."""
        lin = self.lin
        assert isinstance(lin, CompiledFunction)
        Hc, gc, Gc, lo, hi, state0, _, _, w_aug = self.arrays
        head = (self.cfg.horizon, NX, NZ, NU, self.cfg.as_max_iterations, self.cfg.as_step_tol)
        tail = (ctypes.cast(lin.fn, ctypes.c_void_p).value, lin.arg, lin.res, *lin._work,
                *(ptr(a) for a in (self._start, self._u_prev, self.u_low, self.u_high, w_aug, self.Gam, self.Phi,
                                   self.c, self.tmp, Hc, gc, Gc, lo, hi, state0, b.dz0)), QP_MAX_ITER, QP_TOL,
                *(ptr(a) for a in (b.w_out, b.du, b.work, b.iwork)), ctypes.byref(self._iterations))
        return head, tail

    def augment(self, w: np.ndarray, u_prev: np.ndarray) -> None:
        """Put the plan ``w`` (the controller's layout) in place for ``iterate`` in the augmented layout, ``u_prev``
        the input before its first stage: ``GaussNewtonSqp.to_aug`` into the iteration's array, by one gather."""
        self.w_aug[self._from_w] = w
        self.w_aug[NX:NZ] = u_prev
        self.w_aug[self._u_prev_to] = self.w_aug[self._u_prev_from]

    def iterate(self, w_aug: np.ndarray | None, p: np.ndarray, buffers: FeedbackBuffers) -> int:
        """One SQP iteration: the QP at the plan ``w_aug`` (augmented layout; None: ``augment``'s) for ``p``, solved
        at ``buffers.dz0`` from ``active`` (which then holds the QP's final active set); the step is in ``buffers``.
        Answers nrti_feedback's status (> 0 solved, 0 its iteration cap, < 0 failed). Nothing is allocated."""
        if self._iteration[0] is not buffers:
            self._iteration = (buffers, self._feedback_args(self.arrays, buffers))
        self._condense_at(w_aug, p)
        status = self.lib.nrti_feedback(*self._iteration[1])
        np.copyto(self.active, buffers.iwork[2 * self.n:3 * self.n])  # (nrti_feedback's own copy of the set)
        return status

    def keep(self, status: int, factor: np.ndarray | None) -> CondensedQp:
        """The last ``iterate``'s QP copied out (the next preparation overwrites the iteration's arrays), its feedback
        writing into the backend's buffers and starting from ``factor`` (see ``bind``)."""
        arrays = tuple(a.copy() for a in self.arrays)
        qp = CondensedQp(p=self.p.copy(), w_aug=arrays[-1], arrays=arrays, args=(), guess_status=status)
        return self.bind(qp, factor=factor)

    def condense(self, w_aug: np.ndarray, p: np.ndarray) -> CondensedQp:
        """The prepared QP at the plan ``w_aug`` (augmented layout) for the parameters ``p``, in arrays of its own,
        with its active set at dz0 = 0 solved here (``guess_status``); its feedback writes into the backend's
        buffers."""
        self._condense_at(w_aug, p)
        arrays = tuple(a.copy() for a in self.arrays)
        Hc, gc, _, lo, hi, state0 = arrays[:6]
        state0[:] = 0  # all free: solved from scratch
        _, status = self.box.solve(Hc, gc, lo, hi, state0)
        return CondensedQp(p=self.p.copy(), w_aug=arrays[-1], arrays=arrays,
                           args=self._feedback_args(arrays, self.buffers), guess_status=status)

    def bind(self, qp: CondensedQp, buffers: FeedbackBuffers | None = None, factor: Any = KEEP) -> CondensedQp:
        """The same prepared QP with its feedback call writing into ``buffers`` (default: the backend's), starting
        from ``factor`` (``CondensedQp.factor``; default: the QP's own; None: none). With a factor, the QP's starting
        active set is made read-only: the factor is of that set's free block, and no other."""
        factor = qp.factor if factor is KEEP else factor
        if factor is not None:
            qp.state0.flags.writeable = False
        return dataclasses.replace(qp, factor=factor,
                                   args=self._feedback_args(qp.arrays, buffers or self.buffers, factor))

    def _feedback_args(self, arrays: tuple[np.ndarray, ...], b: FeedbackBuffers,
                       factor: np.ndarray | None = None) -> tuple:
        return (self.cfg.horizon, NX, NZ, NU, *(ptr(a) for a in arrays), ptr(b.dz0), QP_MAX_ITER, QP_TOL,
                ptr(b.w_out), ptr(b.du), ptr(b.work), ptr(b.iwork), None if factor is None else ptr(factor))
