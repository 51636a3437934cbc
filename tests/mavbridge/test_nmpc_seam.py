"""The NMPC's backend seam: controllers share only immutable built Functions, own and close their solvers
and workers; named parameter layout; structural configuration fields marked on the fields."""

from __future__ import annotations

import dataclasses
import gc
import math
import threading

import numpy as np
import pytest

from mavbridge.nmpc import PARAMS, NmpcConfig, RollAwareNmpc
from mavbridge.nmpc.config import STRUCTURAL
from mavbridge.nmpc.functions import problem_functions
from mavbridge.nmpc.layout import WAVE_NAMES, WEIGHT_NAMES
from mavbridge.nmpc.problem import pack_parameters
from vessel import OceanCurrent, RegularWaves, otter_parameters

WAVES = RegularWaves(1.75, 35.0, 6.0, -math.pi / 2)
TARGET = (85.0, 75.0)


def _start() -> np.ndarray:
    x = np.zeros(12)
    x[5], x[6] = math.pi / 2, 1.0
    return x


def _asrti(**changes: object) -> NmpcConfig:
    return NmpcConfig(horizon=6, solver="asrti", rti_codegen="off", **changes)


def _fly(nmpc: RollAwareNmpc, steps: int, target: tuple[float, float] = TARGET) -> list[np.ndarray]:
    """Prepare, then follow the controller's own plan for ``steps`` periods; the inputs applied."""
    x = _start()
    nmpc.prepare(x, 0.0, target)
    taus = []
    for k in range(steps):
        result = nmpc.solve(x, 0.1 * k, target)
        assert result.success, result.status
        taus.append(result.tau)
        x = result.states[1]
    return taus


def _new_threads(before: set[threading.Thread]) -> set[threading.Thread]:
    return {t for t in threading.enumerate() if t not in before}


def test_two_controllers_share_no_mutable_state() -> None:
    a, b = RollAwareNmpc(_asrti(), otter_parameters(), WAVES), RollAwareNmpc(_asrti(), otter_parameters(), WAVES)
    try:
        assert a._functions is b._functions  # the immutable built problem is shared ...
        assert a._backend is not b._backend  # ... solver instances and workers are not
        assert a._backend.advanced is not b._backend.advanced
        sqp_a, sqp_b = a._backend.sqp, b._backend.sqp
        assert sqp_a is not sqp_b
        if sqp_a.native is not None:  # the compiled conic: the immutable Function shared, each its own buffers
            assert sqp_a.native is not sqp_b.native
            assert not np.shares_memory(sqp_a.native.inputs["h"], sqp_b.native.inputs["h"])
        else:  # called as CasADi's plugin: each its own conic (work memory, stats)
            assert sqp_a.qp is not sqp_b.qp
        assert a._backend.ipopt.solver is not b._backend.ipopt.solver
        x = _start()
        a.prepare(x, 0.0, TARGET)
        b.prepare(x, 0.0, (40.0, -20.0))
        assert not np.shares_memory(a._w, b._w)
        # Interleaved steps towards different waypoints give exactly the inputs of a controller flying alone.
        xa, xb, interleaved = x, x, []
        for k in range(4):
            ra = a.solve(xa, 0.1 * k, TARGET)
            rb = b.solve(xb, 0.1 * k, (40.0, -20.0))
            assert ra.success and rb.success
            interleaved.append(ra.tau)
            xa, xb = ra.states[1], rb.states[1]
        assert ra.stats["background"] == "used" and rb.stats["background"] == "used"
    finally:
        a.close()
        b.close()
    with RollAwareNmpc(_asrti(), otter_parameters(), WAVES) as alone:
        np.testing.assert_array_equal(np.array(interleaved), np.array(_fly(alone, 4)))


def test_closing_one_controller_leaves_the_other_solving() -> None:
    before = set(threading.enumerate())
    a = RollAwareNmpc(_asrti(), otter_parameters(), WAVES)
    _fly(a, 2)
    threads_a = _new_threads(before)
    assert threads_a, "the asrti controller started no worker thread"
    b = RollAwareNmpc(_asrti(), otter_parameters(), WAVES)
    _fly(b, 2)
    threads_b = _new_threads(before | threads_a)
    a.close()
    assert not any(t.is_alive() for t in threads_a), "closing a left its worker running"
    assert all(t.is_alive() for t in threads_b), "closing a stopped b's worker"
    a.close()  # idempotent
    with pytest.raises(RuntimeError, match="after close"):
        a.solve(_start(), 0.0, TARGET)
    x, result = _start(), None
    for k in range(2, 5):  # b carries on, still from its own background solves
        result = b.solve(x, 0.1 * k, TARGET)
        assert result.success
        x = result.states[1]
    assert result.stats["background"] == "used"
    with b:
        pass
    assert b.closed and not any(t.is_alive() for t in threads_b)
    b.close()


def test_a_controller_dropped_without_close_stops_its_worker() -> None:
    before = set(threading.enumerate())
    nmpc = RollAwareNmpc(_asrti(), otter_parameters(), WAVES)
    _fly(nmpc, 2)
    threads = _new_threads(before)
    assert threads
    del nmpc
    gc.collect()
    assert not any(t.is_alive() for t in threads)


@pytest.mark.parametrize("solver", ["ipopt", "rti"])
def test_every_backend_closes_idempotently(solver: str) -> None:
    with RollAwareNmpc(NmpcConfig(horizon=5, solver=solver, rti_codegen="off"), otter_parameters(), WAVES) as n:
        assert n.solve(_start(), 0.0, TARGET).success
    assert n.closed
    n.close()
    with pytest.raises(RuntimeError, match="after close"):
        n.prepare(_start(), 0.0, TARGET)


def test_structural_fields_are_marked_on_the_fields_and_key_the_build() -> None:
    marked = {f.name for f in dataclasses.fields(NmpcConfig) if f.metadata.get(STRUCTURAL)}
    assert marked == {"horizon", "period_s", "substeps", "integrator", "inputs", "min_speed_mps", "min_speed_fade_m",
                      "roll_fade_m", "min_speed_weight", "wave_components", "heading_limit_deg",
                      "heading_limit_weight"}
    cfg = NmpcConfig(horizon=5)
    assert dict(cfg.structural()) == {name: getattr(cfg, name) for name in marked}
    built = problem_functions(otter_parameters(), WAVES, OceanCurrent(), cfg)
    # Weights, solver, bounds and the regular wave are not structural: the same built problem serves them.
    for other, waves in ((cfg.replace(r=0.0, solver="rti", tau_x_max_n=100.0), WAVES),
                         (cfg, RegularWaves(1.0, 50.0, 7.0, 0.3, phase_rad=1.0)), (cfg, None)):
        assert problem_functions(otter_parameters(), waves, OceanCurrent(), other) is built
    assert problem_functions(otter_parameters(), WAVES, OceanCurrent(), cfg.replace(horizon=6)) is not built
    assert problem_functions(otter_parameters(), WAVES, OceanCurrent(), cfg.replace(inputs="propellers")) is not built


def test_parameter_layout_names_every_block() -> None:
    assert [name for name, _ in PARAMS.blocks] == ["x0", "t", "waypoint", "u_prev", "weights", "wave", "roll_spread",
                                                   "disturbance"]
    assert PARAMS.size == 12 + 1 + 2 + 2 + len(WEIGHT_NAMES) + len(WAVE_NAMES) + 3 + 4
    x0 = np.arange(12.0)
    p = pack_parameters(x0, 3.5, np.array([85.0, 75.0]), np.array([20.0, -1.0]), (5.0, 1550.0, 2.0, 1.0, 1.0),
                        np.arange(7.0) + 100)
    blocks = PARAMS.unpack(p)
    np.testing.assert_array_equal(blocks.x0, x0)
    assert blocks.t == 3.5
    np.testing.assert_array_equal(blocks.u_prev, [20.0, -1.0])
    assert p[PARAMS.index("weights", "r")] == 1550.0
    assert p[PARAMS.index("wave", "phase_rad")] == 105.0
    np.testing.assert_array_equal(blocks.disturbance, np.zeros(4))  # nothing known: the model as before
    with pytest.raises(KeyError, match="no parameter block"):
        PARAMS.slice("wind")
    with pytest.raises(KeyError, match="name a member"):
        PARAMS.index("weights")
    with pytest.raises(ValueError, match="'waypoint' needs 2"):
        PARAMS.pack(x0=x0, t=0.0, waypoint=[1.0], u_prev=[0, 0], weights=np.zeros(5), wave=np.zeros(7),
                    roll_spread=np.zeros(3), disturbance=np.zeros(4))


def test_a_closed_controllers_ipopt_serves_the_next_one_and_only_it() -> None:
    """The IPOPT instance of a closed controller is reused by the next controller of that structure
    (building one takes seconds), never by two live ones, and the reused instance plans the same."""
    from mavbridge.nmpc.solvers import ipopt

    cfg = NmpcConfig(horizon=6, solver="ipopt")
    first = RollAwareNmpc(cfg, otter_parameters(), WAVES)
    taus_first = _fly(first, 3)
    instance = first._backend.solver
    first.close()
    key = first._backend._pool_key
    assert any(solver is instance for solver in ipopt._IDLE[key])
    second, third = RollAwareNmpc(cfg, otter_parameters(), WAVES), RollAwareNmpc(cfg, otter_parameters(), WAVES)
    try:
        assert second._backend.solver is instance  # taken from the idle pool ...
        assert third._backend.solver is not instance  # ... by one controller only
        assert not any(solver is instance for solver in ipopt._IDLE[key])
        np.testing.assert_array_equal(np.array(_fly(second, 3)), np.array(taus_first))
    finally:
        second.close()
        third.close()
    assert any(solver is instance for solver in ipopt._IDLE[key])
    assert len(ipopt._IDLE[key]) <= ipopt.IDLE_PER_KEY


def test_a_controller_on_a_fixed_wave_field_keeps_no_idle_instance() -> None:
    """A built-in field (an irregular sea as truth) is keyed by its identity and every run builds a new one:
    its IPOPT instance (≈150 MB at P = 10) could never be taken again, so closing drops it."""
    from mavbridge.nmpc.solvers import ipopt
    from vessel import IrregularSea

    field = IrregularSea(hs_m=1.75, tp_s=6.0, n_components=10, seed=1).wave_field(otter_parameters())
    before = ipopt.idle_instances()
    with RollAwareNmpc(NmpcConfig(horizon=3, solver="ipopt"), otter_parameters(), field) as nmpc:
        assert nmpc._functions.fixed_waves is field and nmpc._backend._pool_key is None
        assert nmpc.solve(_start(), 0.0, TARGET).success
    assert ipopt.idle_instances() == before


def test_the_idle_pool_is_bounded_over_all_structures(monkeypatch: pytest.MonkeyPatch) -> None:
    """Structures that never come back (a sweep over horizons or vessel parameters) do not pile up: beyond
    IDLE_TOTAL the instance returned longest ago is dropped, and the pool still serves the newest."""
    from mavbridge.nmpc.solvers import ipopt

    monkeypatch.setattr(ipopt, "_IDLE", {})
    monkeypatch.setattr(ipopt, "IDLE_TOTAL", 2)
    instances = []
    for horizon in (2, 3, 4):
        nmpc = RollAwareNmpc(NmpcConfig(horizon=horizon, solver="ipopt"), otter_parameters(), WAVES)
        instances.append((nmpc._backend._pool_key, nmpc._backend.solver))
        nmpc.close()
    assert ipopt.idle_instances() == 2
    (oldest_key, _), *newer = instances
    assert not ipopt._IDLE.get(oldest_key)  # the horizon-2 instance went first
    assert all(any(s is solver for s in ipopt._IDLE[key]) for key, solver in newer)
    with RollAwareNmpc(NmpcConfig(horizon=4, solver="ipopt"), otter_parameters(), WAVES) as again:
        assert again._backend.solver is newer[-1][1]


def test_structures_on_fixed_wave_fields_do_not_pile_up() -> None:
    """Every run on an irregular sea as truth builds its own field object, so its structure never comes back:
    the build cache keeps at most KEEP_FIXED of them (a long sweep grew ≈ 8 MB per run), the newest still
    served from the cache, and the parametric structures are untouched."""
    from mavbridge.nmpc import functions
    from vessel import IrregularSea

    cfg = NmpcConfig(horizon=2, solver="ipopt", rti_codegen="off")
    parametric = problem_functions(otter_parameters(), WAVES, OceanCurrent(), cfg)
    fields = [IrregularSea(hs_m=1.75, tp_s=6.0, n_components=10, seed=seed).wave_field(otter_parameters())
              for seed in range(functions.KEEP_FIXED + 3)]
    built = [problem_functions(otter_parameters(), field, OceanCurrent(), cfg) for field in fields]
    assert len(functions._FIXED_FUNCTIONS) == functions.KEEP_FIXED
    assert problem_functions(otter_parameters(), fields[-1], OceanCurrent(), cfg) is built[-1]
    assert problem_functions(otter_parameters(), fields[0], OceanCurrent(), cfg) is not built[0]  # evicted
    assert problem_functions(otter_parameters(), WAVES, OceanCurrent(), cfg) is parametric


def test_the_build_cache_drops_the_least_recently_used_entry() -> None:
    from mavbridge.nmpc.functions import BoundedCache

    cache: BoundedCache[int] = BoundedCache(2)
    cache.put("a", 1)
    cache.put("b", 2)
    assert cache.get("a") == 1  # "b" is now the least recently used
    cache.put("c", 3)
    assert (cache.get("a"), cache.get("b"), cache.get("c"), len(cache)) == (1, None, 3, 2)
