"""The sensed plant's half control period: its RK4 substeps, compiled once for every plant of the same make, or on
CasADi's virtual machine.

A plant step in an irregular sea of 200 components costs the virtual machine ≈ 34 µs (≈ 5 ms per simulated second
at the realistic loop's 0.01 s steps, more than the rest of the loop outside the NMPC); compiled (gcc -O1) ≈ 10 µs.
Compiled as it is, with the sea's numbers as constants, it would be compiled anew for every seed and every hidden
phase, a second or two each time; so the step's numeric constants are made an input (``vessel.jit.
constants_as_input``: the same operations in the same order, each constant read from the input instead) and the
library, cached on disk by its content (``mavbridge.nmpc.solvers.codegen``), serves every plant of that make. It is
compiled without contracting a product and a sum into one rounding, as the virtual machine never does: the same
roundings, so a run gives the figures it gave on the virtual machine. Without a C compiler (or when the build
fails, or the step holds what ``constants_as_input`` does not rebuild) all substeps run in one call of the mapped
step on the virtual machine.
"""

from __future__ import annotations

import functools

import casadi as ca
import numpy as np

from vessel.jit import BoundFunction, constants_as_input

FLAGS = ("-O1", "-ffp-contract=off")  # no fused multiply-add: the virtual machine's roundings, one per operation


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
    """The substeps as successive calls of the compiled one-step function, its constants set once."""

    def __init__(self, step: ca.Function, substeps: int, dt: float, constants: np.ndarray) -> None:
        self._call = BoundFunction(step)
        self._call.inputs[3][:] = constants
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


@functools.lru_cache(maxsize=16)
def _compiled(serialized: str) -> ca.Function | None:
    """The compiled function of a make (from the disk cache when built before), once per process; None without a C
    compiler or when the build fails."""
    from mavbridge.nmpc.solvers.codegen import compiled_library, load

    function = ca.Function.deserialize(serialized)
    library, _ = compiled_library(function, FLAGS)
    return load(function, library) if library is not None else None


def half_period(step: ca.Function, substeps: int, dt: float) -> MappedHalf | CompiledHalf:
    """The half period of the plant whose one step is ``step`` ((x, u, t) -> x, its numbers inside): compiled when it
    can be, else ``step`` mapped over the substeps."""
    try:
        generic, constants = constants_as_input(step)
    except ValueError:
        return MappedHalf(step, substeps, dt)
    compiled = _compiled(generic.serialize())
    if compiled is None:
        return MappedHalf(step, substeps, dt)
    return CompiledHalf(compiled, substeps, dt, constants)
