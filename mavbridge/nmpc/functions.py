"""The built problem: immutable CasADi Functions and expressions, cached per process by structure.

Building the model, the NLP expressions and the Gauss–Newton linearisation takes a fraction of a second,
compiling the linearisation about a minute (cached on disk). These are pure: a Function's answer depends
only on its inputs, so they are shared by every controller with the same structure. Solver instances
(IPOPT, HPIPM QPs, loaded libraries, worker threads) hold state — iterates, statistics, work memory —
and every backend builds its own from these; nothing stateful is cached here.

The key is (vessel parameters, the built-in wave field or None for the parametric regular wave, current,
the ``structural`` fields of NmpcConfig). Regular waves and calm water are not part of the key: they are
run-time parameters.

Both caches are bounded (least recently used first out): a built-in wave field (an irregular sea fed as
truth) is keyed by its identity and every run builds a new one, so without a bound a long sweep would
keep every run's structure (about 8 MB each). Parametric structures keep ``KEEP_PARAMETRIC``, built-in
fields ``KEEP_FIXED`` (the run in progress, and one more); an evicted structure is only rebuilt.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Hashable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Generic, TypeVar

import casadi as ca
import numpy as np

from mavbridge.nmpc.config import NmpcConfig
from mavbridge.nmpc.inputs import model_matrix
from mavbridge.nmpc.layout import Layout
from mavbridge.nmpc.problem import build_nlp, discrete_model
from mavbridge.nmpc.solvers.codegen import HOT_FLAGS, cache_dir, compiled_library, compiler, load
from mavbridge.nmpc.solvers.condensed import BlockLinearisation, block_instance, compile_block_linearisation
from mavbridge.nmpc.solvers.gauss_newton import linearisation
from mavbridge.nmpc.wave_model import is_parametric
from vessel import OceanCurrent, OtterParameters, WaveField
from vessel.sea.wind import Wind


@dataclass(frozen=True)
class ProblemFunctions:
    """One problem structure: its model, NLP expressions, layout and Gauss–Newton linearisation."""

    params: OtterParameters
    fixed_waves: WaveField | None  # a built-in wave field, or None: the wave is a run-time parameter
    current: OceanCurrent
    wind: Wind | None  # a wind built in (simulation truth, a bound only); None: still air
    cfg: NmpcConfig  # the configuration it was first built for (only its structural fields matter)
    step: ca.Function  # (x, u, t, wave) -> x after one period
    nlp: Mapping[str, ca.SX]  # {x, p, f, g}, read-only
    layout: Layout
    linearisation: ca.Function  # (w_aug, p) -> (H, g, A, gap), SX virtual machine
    input_matrix: np.ndarray | None = None  # B (τ = B·u) of propeller-thrust inputs; None when u is τ
    # the condensing's block linearisations built for this structure, by ``block_linearisation``'s key
    _blocks: dict[tuple, tuple[ca.Function, Path | None, str]] = field(default_factory=dict, compare=False,
                                                                      repr=False)

    def linearisation_library(self, codegen: str) -> tuple[Path | None, str]:
        """(compiled library of the linearisation or None, how): ``codegen`` "auto" compiles (cached; ``HOT_FLAGS``:
        it runs every step)."""
        if codegen != "auto":
            return None, "sx-vm (codegen off)"
        try:
            key = build_key(self.params, self.fixed_waves, self.current, self.cfg, self.wind)
            hash(key)
        except TypeError:  # an unhashable built-in wave field: ask the disk cache every time
            return compiled_library(self.linearisation, HOT_FLAGS)
        cached = _libraries(self.fixed_waves).get(key)
        if cached is None:
            cached = compiled_library(self.linearisation, HOT_FLAGS)
            _libraries(self.fixed_waves).put(key, cached)
        return cached

    def block_linearisation(self, cfg: NmpcConfig) -> tuple[BlockLinearisation, str]:
        """A new instance of the condensing's block linearisation (``condensed.block_instance``: its buffers its own)
        for a backend with configuration ``cfg`` (whose structural fields are this structure's), and how it runs.
        The Function and its compiled library are built once per process for each key: the structural fields and
        ``rti_codegen`` (all of ``cfg`` it reads), the compiler and the cache directory; the model step and the input
        matrix are this structure's."""
        key: Any = (cfg.structural(), cfg.rti_codegen, compiler(), cache_dir())
        built = self._blocks.get(key)
        if built is None:
            built = compile_block_linearisation(self.step, cfg, self.input_matrix)
            if built[1] is not None or "failed" not in built[2]:  # (a failed compile is tried again next time)
                self._blocks[key] = built
        return block_instance(*built)

    def load_linearisation(self, codegen: str) -> tuple[ca.Function, str]:
        """A new linearisation instance for one solver (compiled when available), and how it runs."""
        library, how = self.linearisation_library(codegen)
        if library is None:  # a private copy: two threads never share one Function's work memory
            return ca.Function.deserialize(self.linearisation.serialize()), how
        return load(self.linearisation, library), how


KEEP_PARAMETRIC = 16  # structures with the parametric wave: one per structural configuration in use
KEEP_FIXED = 2  # structures on a built-in wave field: never the same field object in two runs

V = TypeVar("V")


class BoundedCache(Generic[V]):
    """A mapping that keeps the ``capacity`` most recently used entries."""

    def __init__(self, capacity: int) -> None:
        self.capacity = capacity
        self._entries: OrderedDict[Hashable, V] = OrderedDict()

    def get(self, key: Hashable) -> V | None:
        """The entry (now the most recent), or None; TypeError for an unhashable key."""
        value = self._entries.get(key)
        if value is not None:
            self._entries.move_to_end(key)
        return value

    def put(self, key: Hashable, value: V) -> None:
        """Store ``value`` as the most recent entry, dropping the least recently used beyond capacity."""
        self._entries[key] = value
        self._entries.move_to_end(key)
        while len(self._entries) > self.capacity:
            self._entries.popitem(last=False)

    def clear(self) -> None:
        """Forget every entry (a process then builds as a fresh one would)."""
        self._entries.clear()

    def __len__(self) -> int:
        return len(self._entries)


_FUNCTIONS: BoundedCache[ProblemFunctions] = BoundedCache(KEEP_PARAMETRIC)
_FIXED_FUNCTIONS: BoundedCache[ProblemFunctions] = BoundedCache(KEEP_FIXED)
_LIBRARIES: BoundedCache[tuple[Path | None, str]] = BoundedCache(KEEP_PARAMETRIC)
_FIXED_LIBRARIES: BoundedCache[tuple[Path | None, str]] = BoundedCache(KEEP_FIXED)


def _functions(fixed_waves: WaveField | None) -> BoundedCache[ProblemFunctions]:
    return _FUNCTIONS if fixed_waves is None else _FIXED_FUNCTIONS


def _libraries(fixed_waves: WaveField | None) -> BoundedCache[tuple[Path | None, str]]:
    return _LIBRARIES if fixed_waves is None else _FIXED_LIBRARIES


def build_key(params: OtterParameters, fixed_waves: WaveField | None, current: OceanCurrent,
              cfg: NmpcConfig, wind: Wind | None = None) -> tuple:
    """The cache key of a problem structure."""
    return (params, fixed_waves, current, cfg.structural(), wind)


def model_waves(waves: WaveField | None) -> WaveField | None:
    """None when the parametric regular wave represents ``waves`` exactly, else the field itself."""
    return None if is_parametric(waves) else waves


def problem_functions(params: OtterParameters, waves: WaveField | None, current: OceanCurrent,
                      cfg: NmpcConfig, wind: Wind | None = None) -> ProblemFunctions:
    """The built problem for this structure, from the cache when it was built before in this process."""
    fixed = model_waves(waves)
    key = build_key(params, fixed, current, cfg, wind)
    try:
        cached = _functions(fixed).get(key)
    except TypeError:  # an unhashable built-in wave field: build every time
        key, cached = None, None
    if cached is not None:
        return cached
    step = discrete_model(params, fixed, current, cfg, wind)
    matrix = model_matrix(cfg, params)
    nlp, layout = build_nlp(step, cfg, matrix)
    built = ProblemFunctions(params=params, fixed_waves=fixed, current=current, wind=wind, cfg=cfg, step=step,
                             nlp=MappingProxyType(dict(nlp)), layout=layout,
                             linearisation=linearisation(step, cfg, matrix), input_matrix=matrix)
    if key is not None:
        _functions(fixed).put(key, built)
    return built


def cached_structures() -> int:
    """How many problem structures this process keeps (for tests and diagnostics)."""
    return len(_FUNCTIONS) + len(_FIXED_FUNCTIONS)
