"""A model function compiled once for every model of the same make, bound to preallocated arrays.

The loop's models (the sensed plant's step and IMU, the disturbance observer's prediction) hold their numbers as
constants: the sea's components and hidden phase, the hull's. Compiled as they are they would be compiled anew for
each seed, a second or two each time; with their constants made an input (``vessel.jit.constants_as_input``: the
same operations in the same order, each constant read from the input instead) one library, cached on disk by its
content (``mavbridge.nmpc.solvers.codegen``), serves every model of that make, and one process loads it once. It is
built without contracting a product and a sum into one rounding (``-ffp-contract=off``), as CasADi's virtual
machine never does, so it evaluates bit for bit what the virtual machine does. Without a C compiler, when the build
fails or when the function holds what ``constants_as_input`` does not rebuild, the function runs on the virtual
machine, bound just the same.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from vessel.jit import BoundFunction, constants_as_input

FLAGS = ("-O1", "-ffp-contract=off")  # no fused multiply-add: the virtual machine's roundings, one per operation


@functools.lru_cache(maxsize=32)
def _compiled(serialized: str) -> ca.Function | None:
    """The compiled function of a make (from the disk cache when built before), once per process; None without a C
    compiler or when the build fails."""
    from mavbridge.nmpc.solvers.codegen import compiled_library, load

    function = ca.Function.deserialize(serialized)
    library, _ = compiled_library(function, FLAGS)
    return load(function, library) if library is not None else None


@functools.lru_cache(maxsize=32)
def _generic(serialized: str) -> tuple[ca.Function, np.ndarray] | None:
    """The compiled function of this function's make and its constants; None when it runs on the virtual machine.
    Once per process for each function (the same model again, a sweep's runs on one sea, rebuilds nothing)."""
    try:
        generic, constants = constants_as_input(ca.Function.deserialize(serialized))
    except ValueError:
        return None
    compiled = _compiled(generic.serialize())
    if compiled is None:
        return None
    constants.setflags(write=False)
    return compiled, constants


@dataclass(frozen=True)
class ModelMake:
    """A model function and, where it compiles, its make's compiled function and constants: immutable, so one serves
    every run with the same model (each binds its own arrays: ``bind``)."""

    function: ca.Function
    compiled: tuple[ca.Function, np.ndarray] | None  # None: it runs on the virtual machine


def model_make(function: ca.Function) -> ModelMake:
    """``function``'s make (compiled once per process, see ``_generic``), not yet bound to arrays."""
    from mavbridge.nmpc.solvers.codegen import compiler

    return ModelMake(function, _generic(function.serialize()) if compiler() is not None else None)  # (no rebuild
    # without a compiler)


def bind(make: ModelMake) -> tuple[BoundFunction, bool]:
    """(the make's function bound to arrays of its own, compiled): compiled, its inputs are the model's and then the
    constants, already filled in (the caller fills the first ``function.n_in()`` as ever); else the model itself on
    the virtual machine."""
    if make.compiled is None:
        return BoundFunction(make.function), False
    compiled, constants = make.compiled
    bound = BoundFunction(compiled)
    bound.inputs[-1][:] = constants
    return bound, True


def compiled_model(function: ca.Function) -> tuple[BoundFunction, bool]:
    """(``function`` bound to arrays, compiled): ``bind`` of its ``model_make``."""
    return bind(model_make(function))
