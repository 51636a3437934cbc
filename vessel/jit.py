"""Compile large CasADi functions to machine code with the system C compiler, when one is installed.

CasADi's virtual machine spends ≈ 5 ns per instruction; a plant step in a 100-component irregular sea
has ≈ 12 000 instructions (≈ 55 µs, 180× real time at dt = 0.01 s), the paper's regular sea ≈ 2 400. The
same expression compiled by gcc -O1 runs ≈ 4× faster (≈ 14 µs, 700×) after a one-off compile of one to
three seconds. The compiled function evaluates the identical expression graph; without a compiler (or if
compiling fails) the virtual machine is used and a warning is logged.

``BoundFunction`` calls a function through CasADi's buffer interface (preallocated arrays, no DM conversions per
call); ``constants_as_input`` makes a function's numeric constants an input, so that one compiled library serves
every model of the same make (``mavbridge.nmpc.compiled_model`` caches it on disk).
"""

from __future__ import annotations

import logging
import shutil
import tempfile

import casadi as ca
import numpy as np

LOG = logging.getLogger(__name__)
AUTO_COMPILE_INSTRUCTIONS = 5000  # above this, compiling pays for itself within a minute of simulation
COMPILERS = ("gcc", "cc", "clang")


def find_compiler() -> str | None:
    """The first C compiler on PATH, or None."""
    for name in COMPILERS:
        if shutil.which(name):
            return name
    return None


def worth_compiling(function: ca.Function) -> bool:
    """True for functions large enough that compiling beats the virtual machine in a long run."""
    return function.n_instructions() > AUTO_COMPILE_INSTRUCTIONS and find_compiler() is not None


def compiled(function: ca.Function) -> ca.Function:
    """``function`` compiled to machine code (same inputs and outputs), or ``function`` itself if impossible."""
    compiler = find_compiler()
    if compiler is None:
        LOG.warning("no C compiler found (%s): %s runs on CasADi's virtual machine", ", ".join(COMPILERS),
                    function.name())
        return function
    names_in = function.name_in()
    symbols = [ca.SX.sym(name, function.sparsity_in(i)) for i, name in enumerate(names_in)]
    options = {"jit": True, "compiler": "shell",
               "jit_options": {"compiler": compiler, "flags": ["-O1"], "directory": tempfile.gettempdir()}}
    try:
        return ca.Function(function.name(), symbols, function.call(symbols), names_in, function.name_out(),
                           options)
    except RuntimeError as exc:
        LOG.warning("compiling %s failed (%s): using CasADi's virtual machine", function.name(),
                    str(exc).splitlines()[0] if str(exc) else exc)
        return function


class BoundFunction:
    """A CasADi Function bound to preallocated numpy arrays and evaluated through its buffer interface.

    CasADi's ordinary Python call converts every argument to a DM and every result back (≈ 20–40 µs for a small
    function); bound once, an evaluation is the function's own work plus ≈ 0.2 µs. ``inputs[i]`` and
    ``outputs[i]`` hold each argument's and result's nonzeros (dense: the matrix column-major); fill the inputs,
    call, read the outputs. The numbers are those of the ordinary call: the same function evaluates them.
    """

    def __init__(self, function: ca.Function) -> None:
        self.function = function
        self.inputs = [np.zeros(function.nnz_in(i)) for i in range(function.n_in())]
        self.outputs = [np.zeros(function.nnz_out(i)) for i in range(function.n_out())]
        buffer, self._evaluate = function.buffer()
        for i, array in enumerate(self.inputs):
            buffer.set_arg(i, memoryview(array))
        for i, array in enumerate(self.outputs):
            buffer.set_res(i, memoryview(array))
        self._buffer = buffer  # keeps the buffer (and so the bindings) alive

    def __call__(self) -> None:
        """Evaluate on the current inputs into the outputs."""
        self._evaluate()


def constants_as_input(function: ca.Function) -> tuple[ca.Function, np.ndarray]:
    """``function`` (an SX function) with its numeric constants made one more input: (the function of (its inputs,
    constants), the constants' values).

    The same operations on the same operands in the same order, instruction by instruction; only where an operand
    was a constant it is read from the new input, so given the values it evaluates exactly what ``function`` does.
    A model with different numbers (another seed of a sea, another phase) but the same structure then gives the same
    function, whose compiled code (cached by content) serves them all. Raises ValueError for an operation with
    more than two operands (a call of another function inside), or a sparse input or output (the rebuild reads and
    writes dense vectors), which this does not rebuild.
    """
    sparse = [f"input {i}" for i in range(function.n_in()) if not function.sparsity_in(i).is_dense()]
    sparse += [f"output {i}" for i in range(function.n_out()) if not function.sparsity_out(i).is_dense()]
    if sparse:
        raise ValueError(f"constants_as_input: {', '.join(sparse)} sparse; only dense functions are rebuilt")
    inputs = [ca.SX.sym(function.name_in(i), function.sparsity_in(i)) for i in range(function.n_in())]
    nonzeros = [ca.vertsplit(ca.vec(x), 1) if x.nnz() else [] for x in (ca.densify(s) for s in inputs)]
    outputs = [[ca.SX(0)] * function.nnz_out(i) for i in range(function.n_out())]
    n_const = sum(function.instruction_id(k) == ca.OP_CONST for k in range(function.n_instructions()))
    constants = ca.SX.sym("constants", n_const)
    values: list[float] = []
    work: dict[int, ca.SX] = {}
    for k in range(function.n_instructions()):
        op, args, res = function.instruction_id(k), function.instruction_input(k), function.instruction_output(k)
        if op == ca.OP_CONST:
            work[res[0]] = constants[len(values)]
            values.append(function.instruction_constant(k))
        elif op == ca.OP_INPUT:
            work[res[0]] = nonzeros[args[0]][args[1]]
        elif op == ca.OP_OUTPUT:
            outputs[res[0]][res[1]] = work[args[0]]
        elif len(args) == 1:
            work[res[0]] = ca.SX.unary(op, work[args[0]])
        elif len(args) == 2:
            work[res[0]] = ca.SX.binary(op, work[args[0]], work[args[1]])
        else:
            raise ValueError(f"{function.name()}: operation {op} with {len(args)} operands is not rebuilt")
    results = [ca.reshape(ca.vertcat(*out), function.size_out(i)) if out else ca.SX(function.sparsity_out(i))
               for i, out in enumerate(outputs)]
    rebuilt = ca.Function(function.name(), [*inputs, constants], results,
                          [*function.name_in(), "constants"], function.name_out())
    return rebuilt, np.asarray(values, float)
