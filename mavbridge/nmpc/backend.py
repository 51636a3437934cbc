"""The seam between the controller and a solver: the backend protocol and what one solve returns.

The controller (``RollAwareNmpc``) owns everything that is the same for every solver: the stored plan and
its shifting, the parameter vector (measured state, time, waypoint, weights, wave), the fallback policy
and the input limits. A backend owns its solver instances and their lifetime:

* ``prepare(w0, p, lbw, ubw)`` — the cold solve to convergence before the loop (and the place to get
  ready: a worker started, a solver warmed up);
* ``solve(w0, p, lbw, ubw, lam_w0, lam_g0)`` — one real-time step from a warm guess (no duals: a cold
  solve, as after a failure);
* ``advance(w_plan, p, tau)`` — the step's input ``tau`` has been applied: work ahead for the next
  period (asrti starts its background solve here; a preparation phase would go here too);
* ``reset()`` — forget any work ahead (a new run); ``close()`` — free solvers and workers, idempotent;
* optionally ``prepared_feedback(p)`` — the step on work prepared for exactly this p, needing no warm guess (nrti:
  the native feedback), or None; the controller then makes the warm guess and calls ``solve``.

``BackendLifetime`` is the controller's side of that lifetime: ``close()``, ``with``, and refusing after close.

p is laid out as ``layout.PARAMS``; w as ``layout.Layout``. A backend never raises for a solver
failure: it answers with an unusable ``SolveOutcome``.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from typing import Protocol, Self

import numpy as np


@dataclass
class SolveOutcome:
    """A backend's answer: the primal/dual iterate and whether it may be applied."""

    w: np.ndarray | None
    lam_w: np.ndarray | None
    lam_g: np.ndarray | None
    usable: bool
    status: str
    iterations: int
    violation: float = float("nan")
    start: np.ndarray | None = None  # the iterate the solve started from, when not the caller's guess
    wait_s: float = 0.0  # time spent waiting for work of the previous period (not this step's cost)
    stats: dict = field(default_factory=dict)  # backend-specific figures for the log

    @classmethod
    def failed(cls, status: str) -> SolveOutcome:
        """An outcome with no iterate at all (the solver raised)."""
        return cls(w=None, lam_w=None, lam_g=None, usable=False, status=status, iterations=0)


class NmpcBackend(Protocol):
    """What the controller needs from a solver (see the module docstring)."""

    name: str

    def prepare(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray) -> SolveOutcome:
        """Cold solve to convergence from the guess ``w0``."""
        ...

    def solve(self, w0: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lam_w0: np.ndarray | None, lam_g0: np.ndarray | None) -> SolveOutcome:
        """One step from a warm guess (cold when the duals are None)."""
        ...

    def advance(self, w_plan: np.ndarray, p: np.ndarray, tau: np.ndarray) -> None:
        """Work ahead for the next period after ``tau`` was applied (may do nothing)."""
        ...

    def reset(self) -> None:
        """Drop any work ahead."""
        ...

    def close(self) -> None:
        """Free solver instances and workers; calling it again does nothing."""
        ...


class BackendLifetime:
    """A controller's hold on its backend: ``close()`` (or leaving a ``with`` block) stops the worker and frees the
    solvers, once; a controller dropped without ``close()`` still stops its worker (the finalizer holds the backend
    only); a closed controller refuses to solve (``_check_open``)."""

    _backend: NmpcBackend
    _closed: bool
    _finalizer: weakref.finalize

    def _own_backend(self, backend: NmpcBackend) -> None:
        self._backend, self._closed = backend, False
        self._finalizer = weakref.finalize(self, backend.close)

    def close(self) -> None:
        """Stop the background worker and free the solver instances; calling it again does nothing."""
        if self._closed:
            return
        self._closed = True
        self._finalizer()  # backend.close(), once

    @property
    def closed(self) -> bool:
        """True after ``close()``."""
        return self._closed

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError(f"{type(self).__name__}: solve after close()")
