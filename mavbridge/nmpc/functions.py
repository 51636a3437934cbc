"""The built problem: immutable CasADi Functions and expressions, cached per process by structure.

Building the model, the NLP expressions and the Gauss–Newton linearisation takes a fraction of a second,
compiling the linearisation about a minute (cached on disk). These are pure: a Function's answer depends
only on its inputs, so they are shared by every controller with the same structure. Solver instances
(IPOPT, HPIPM QPs, loaded libraries, worker threads) hold state — iterates, statistics, work memory —
and every backend builds its own from these; nothing stateful is cached here.

The key is (vessel parameters, the built-in wave field or None for the parametric regular wave, current,
the ``structural`` fields of NmpcConfig). Regular waves and calm water are not part of the key: they are
run-time parameters.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import casadi as ca

from vessel import OceanCurrent, OtterParameters, WaveField

from .codegen import compiled_library, load
from .config import NmpcConfig
from .gauss_newton import linearisation
from .layout import Layout
from .problem import build_nlp, discrete_model
from .wave_model import is_parametric


@dataclass(frozen=True)
class ProblemFunctions:
    """One problem structure: its model, NLP expressions, layout and Gauss–Newton linearisation."""

    params: OtterParameters
    fixed_waves: WaveField | None  # a built-in wave field, or None: the wave is a run-time parameter
    current: OceanCurrent
    cfg: NmpcConfig  # the configuration it was first built for (only its structural fields matter)
    step: ca.Function  # (x, u, t, wave) -> x after one period
    nlp: Mapping[str, ca.SX]  # {x, p, f, g}, read-only
    layout: Layout
    linearisation: ca.Function  # (w_aug, p) -> (H, g, A, gap), SX virtual machine

    def linearisation_library(self, codegen: str) -> tuple[Path | None, str]:
        """(compiled library of the linearisation or None, how): ``codegen`` "auto" compiles (cached)."""
        if codegen != "auto":
            return None, "sx-vm (codegen off)"
        try:
            key = build_key(self.params, self.fixed_waves, self.current, self.cfg)
            hash(key)
        except TypeError:  # an unhashable built-in wave field: ask the disk cache every time
            return compiled_library(self.linearisation)
        if key not in _LIBRARIES:
            _LIBRARIES[key] = compiled_library(self.linearisation)
        return _LIBRARIES[key]

    def load_linearisation(self, codegen: str) -> tuple[ca.Function, str]:
        """A new linearisation instance for one solver (compiled when available), and how it runs."""
        library, how = self.linearisation_library(codegen)
        if library is None:  # a private copy: two threads never share one Function's work memory
            return ca.Function.deserialize(self.linearisation.serialize()), how
        return load(self.linearisation, library), how


_FUNCTIONS: dict[tuple, ProblemFunctions] = {}
_LIBRARIES: dict[tuple, tuple[Path | None, str]] = {}


def build_key(params: OtterParameters, fixed_waves: WaveField | None, current: OceanCurrent,
              cfg: NmpcConfig) -> tuple:
    """The cache key of a problem structure."""
    return (params, fixed_waves, current, cfg.structural())


def model_waves(waves: WaveField | None) -> WaveField | None:
    """None when the parametric regular wave represents ``waves`` exactly, else the field itself."""
    return None if is_parametric(waves) else waves


def problem_functions(params: OtterParameters, waves: WaveField | None, current: OceanCurrent,
                      cfg: NmpcConfig) -> ProblemFunctions:
    """The built problem for this structure, from the cache when it was built before in this process."""
    fixed = model_waves(waves)
    key = build_key(params, fixed, current, cfg)
    try:
        cached = _FUNCTIONS.get(key)
    except TypeError:  # an unhashable built-in wave field: build every time
        key, cached = None, None
    if cached is not None:
        return cached
    step = discrete_model(params, fixed, current, cfg)
    nlp, layout = build_nlp(step, cfg)
    built = ProblemFunctions(params=params, fixed_waves=fixed, current=current, cfg=cfg, step=step,
                             nlp=MappingProxyType(dict(nlp)), layout=layout,
                             linearisation=linearisation(step, cfg))
    if key is not None:
        _FUNCTIONS[key] = built
    return built


def cached_structures() -> int:
    """How many problem structures this process has built (for tests and diagnostics)."""
    return len(_FUNCTIONS)
