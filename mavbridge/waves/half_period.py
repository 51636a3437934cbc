"""The sensed plant's half control period: its RK4 substeps, compiled once for every plant of the same make
(``mavbridge.nmpc.compiled_model``), or all in one call of the mapped step on CasADi's virtual machine.

A plant step in an irregular sea of 200 components costs the virtual machine ≈ 34 µs (≈ 5 ms per simulated second
at the realistic loop's 0.01 s steps, more than the rest of the loop outside the NMPC); compiled (gcc -O1) ≈ 10 µs,
bit for bit the same numbers, and one library serves every seed and hidden phase.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from mavbridge.nmpc.compiled_model import compiled_model
from vessel.jit import BoundFunction


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


def half_period(step: ca.Function, substeps: int, dt: float) -> MappedHalf | CompiledHalf:
    """The half period of the plant whose one step is ``step`` ((x, u, t) -> x, its numbers inside): compiled when it
    can be, else ``step`` mapped over the substeps."""
    call, compiled = compiled_model(step)
    return CompiledHalf(call, substeps, dt) if compiled else MappedHalf(step, substeps, dt)
