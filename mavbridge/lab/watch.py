"""The realistic run's parts and the watch before it, reused within a process when a run would repeat it.

A realistic run (``experiment.run_scenario``) starts with a watch: the boat drifts, thrusters idle, for
``estimation.watch_s`` while the wave source (the estimator) and the disturbance observer learn
(``SensedPlant.watch``). A tune or a sweep flies many runs that differ only in the controller's weights, and every
one of them would watch the same drift: the weights are run-time parameters of the NLP, and no solve happens during
the watch. So the first such run in a process keeps what the watch leaves (``Watched``: the plant's state, the
sensors with their noise generator, the wave source, the observer's filter, the disturbance handed to the NMPC and
the lines said) and the next run with the same ``watch_key`` starts from copies of it: the same numbers, bit for bit,
as watching afresh, for a fraction of its cost (the watch is about a fifth of a NATO sea run's CPU).

The key is the whole scenario but for its name, description and the controller's run-time weights
(``RUN_TIME_WEIGHTS``), so anything else that changes makes a fresh watch. At most ``CACHE_SIZE`` watches are kept
per process (a tune on three sea seeds needs three, a sweep over ten seeds ten); ``MAVBRIDGE_WATCH_CACHE=0`` in the
environment turns the reuse off (to check it, or to measure the watch itself).

The plant's compiled functions (``sensed_plant.plant_make``: its step and IMU, 1.5–2 MB each in an irregular sea)
are kept apart, a few per process (``MAKES``), by ``plant_key``: what they are built from, so that the runs of a tune
from other start headings share them too. Immutable: each run binds its own arrays.
"""

from __future__ import annotations

import copy
import json
import os
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from mavbridge.lab.scenario import Scenario
from mavbridge.lab.sensed_plant import SensedPlant
from mavbridge.nmpc import RollAwareNmpc
from mavbridge.nmpc.disturbance import DisturbanceObserver
from mavbridge.waves import EstimatorSettings, make_estimator
from mavbridge.waves.inloop import WaveFeed, calibrated_settings, hidden_sea, sensor_model
from mavbridge.waves.phase.bank_source import BankFeed, PredictedSource
from mavbridge.waves.source import ScenarioTruth, TrueSpread
from vessel import ConfigError, WaveField
from vessel.sea.irregular import IrregularWaves
from vessel.sensors import SensorModel

RUN_TIME_WEIGHTS = ("q", "r", "s", "w_dtau_x", "w_dtau_n")  # ``NmpcConfig.weights``: only the NLP's solves use them
CACHE_SIZE = 16  # watches kept per process (each about 100 kB after a NATO sea state 3 watch of 60 s: under 2 MB)
ENVIRONMENT = "MAVBRIDGE_WATCH_CACHE"  # "0", "off" or "no": every run watches afresh


def observe(observer: DisturbanceObserver, nmpc: RollAwareNmpc, t: float, x: np.ndarray, tau: np.ndarray | None,
            say: Callable[[str], None] | None) -> None:
    """One period of the disturbance observer (``tau``: the command in effect from now, None: unknown), and the
    NMPC's later solves predict with its estimate; one line when it settles."""
    if observer.update(t, x, tau, nmpc.model_wave(), nmpc.wave_known) and say is not None:
        say(f"disturbance settled at t = {t:.1f} s: {observer.describe()}")
    nmpc.set_disturbance(observer.estimate)


def watch_key(scenario: Scenario) -> str:
    """What a watch depends on: the scenario as data without its name, description and run-time weights."""
    data = scenario.to_mapping()
    data.pop("name")
    data.pop("description")
    data["controller"] = {k: v for k, v in data["controller"].items() if k not in RUN_TIME_WEIGHTS}
    return json.dumps(data, sort_keys=True)


@dataclass(frozen=True)
class Watched:
    """What a watch leaves: handed out only as copies (``copies``), so that no run changes it."""

    truth: WaveField  # the sea the source may hold (its copies then hold the new run's own, equal sea)
    x: np.ndarray
    held: np.ndarray
    sensors: SensorModel
    source: Any
    observer: dict[str, Any] | None
    disturbance: np.ndarray
    lines: tuple[str, ...]

    def copies(self, truth: WaveField) -> tuple[SensorModel, Any]:
        """The sensors and the wave source as the watch left them (the source's sea made ``truth``)."""
        return copy.deepcopy(self.sensors), copy.deepcopy(self.source, {id(self.truth): truth})


class WatchCache:
    """The last few watches of this process, by ``watch_key`` (least recently used dropped first)."""

    def __init__(self, size: int = CACHE_SIZE) -> None:
        self.size = size
        self._kept: OrderedDict[str, Watched] = OrderedDict()
        self.hits = 0
        self._lock = threading.Lock()  # (runs in threads of one process would otherwise race on the order)

    @staticmethod
    def enabled() -> bool:
        """False when ``MAVBRIDGE_WATCH_CACHE`` says off."""
        return os.environ.get(ENVIRONMENT, "1").strip().lower() not in ("0", "off", "no", "false")

    def get(self, key: str) -> Watched | None:
        """The watch kept under ``key`` (now the most recent), or None."""
        with self._lock:
            found = self._kept.get(key)
            if found is not None:
                self._kept.move_to_end(key)
                self.hits += 1
            return found

    def put(self, key: str, watched: Watched) -> None:
        """Keep ``watched``, dropping the least recently used beyond ``size``."""
        with self._lock:
            self._kept[key] = watched
            self._kept.move_to_end(key)
            while len(self._kept) > self.size:
                self._kept.popitem(last=False)

    def clear(self) -> None:
        """Forget every watch, and count hits from 0."""
        with self._lock:
            self._kept.clear()
            self.hits = 0


WATCHES = WatchCache()
MAKES_SIZE = 4  # plants' compiled functions kept per process (1.5-2 MB each in a 200-component irregular sea)
MAKES = WatchCache(MAKES_SIZE)  # by ``plant_key``: a tune's start headings and weights share their seed's plant


def plant_key(scenario: Scenario) -> str:
    """What the plant's functions (``sensed_plant.plant_make``) are built from: the hull, the sea (its hidden
    phases' seed where they are hidden), current and wind (in ``sea``), the plant's kind and step, surface heave."""
    data, est = scenario.to_mapping(), scenario.estimation
    return json.dumps({"vessel": data["vessel"], "sea": data["sea"], "plant": scenario.plant,
                       "plant_dt_s": scenario.plant_dt_s, "surface_heave": est.surface_heave,
                       "hidden_seed": est.seed if est.hidden_phase else None}, sort_keys=True, default=str)


def wave_source(scenario: Scenario, truth: WaveField) -> Any:
    """The wave source of a realistic run (estimator, its wrappers, or the truth), before it has seen anything."""
    est, cfg, params = scenario.estimation, scenario.controller, scenario.model_params()  # (the companion's side)
    if est.waves not in ("estimated", "predicted"):
        return ScenarioTruth(truth)
    settings = (calibrated_settings(params, est.surface_heave, est.roll_sign) if est.calibrate
                else EstimatorSettings(roll_sign=est.roll_sign))
    source: Any = make_estimator(settings)
    if est.spread_truth:
        if not isinstance(truth, IrregularWaves):
            raise ConfigError("estimation.spread_truth: needs an irregular sea (sea.spectrum): its slope "
                              "covariance is what replaces the estimator's")
        source = TrueSpread(source, truth.slope_covariance())
    if est.waves == "predicted":
        if cfg.wave_components < 1:
            raise ConfigError("estimation.waves: predicted needs controller.wave_components >= 1 (the bank's "
                              "size K); allowed [1, 256]")
        irregular = truth if isinstance(truth, IrregularWaves) else None
        source = PredictedSource(source, cfg.wave_components, est.roll_sign, est.bank_lead_s,
                                 oracle=irregular if est.bank_oracle else None, select=est.bank_select,
                                 horizon_s=cfg.horizon * cfg.period_s,
                                 true_slope=irregular if est.bank_true_slope else None)
    return source


def realistic_parts(scenario: Scenario, nmpc: RollAwareNmpc, observer: DisturbanceObserver | None,
                    progress: Callable[[str], None] | None) -> tuple[SensedPlant, WaveFeed]:
    """The sensed plant in the hidden-phase sea and the wave feed (estimator or truth) of a realistic run, after
    the watch: watched here, or its state taken from a watch of this process with the same ``watch_key``. The
    observer (when given) and the NMPC's disturbance are left as the watch leaves them; the NMPC knows no wave."""
    est, cfg = scenario.estimation, scenario.controller
    say = (lambda line: progress(f"[{scenario.name}] {line}")) if progress is not None else None
    if nmpc.takes_waves:  # nothing known of the sea while it watches (the observer predicts with the NMPC's wave)
        nmpc.set_wave(None)
    plant_params = scenario.plant_params()
    waves = scenario.sea.waves(plant_params)
    truth = hidden_sea(waves, est.seed) if est.hidden_phase else waves
    key = watch_key(scenario) if est.watch_s > 0 and WatchCache.enabled() else None
    kept = WATCHES.get(key) if key is not None else None
    sensors, source = kept.copies(truth) if kept is not None else (sensor_model(est.sensors, est.seed),
                                                                  wave_source(scenario, truth))
    make_key = plant_key(scenario) if WatchCache.enabled() else None
    plant = SensedPlant(plant_params, truth, scenario.sea.current(), scenario.world.rigid_state(), cfg.period_s,
                        scenario.plant_dt_s, est.surface_heave, sensors, source,
                        wind=scenario.sea.wind(), propellers=scenario.plant == "propellers",
                        make=MAKES.get(make_key) if make_key is not None else None)
    if make_key is not None:
        MAKES.put(make_key, plant.make)
    bank = BankFeed(source, est.bank_spread, fade=est.bank_fade) if est.waves == "predicted" else None
    feed = WaveFeed(est.waves, source, truth, cfg.horizon * cfg.period_s, say, est.hold_s, bank)
    if kept is not None:
        _resume(kept, plant, nmpc, observer, say)
        return plant, feed
    lines: list[str] = []
    plant.watch(est.watch_s, cfg.period_s, _watcher(nmpc, observer, lines, say))
    if key is not None:
        WATCHES.put(key, _taken(truth, plant, nmpc, observer, lines))
    return plant, feed


def _watcher(nmpc: RollAwareNmpc, observer: DisturbanceObserver | None, lines: list[str],
             say: Callable[[str], None] | None) -> Callable[[float, np.ndarray], None] | None:
    """What the companion does each watched period: the observer's update (thrusters idle); its lines said and
    kept in ``lines`` (a run that reuses the watch says them again)."""
    if observer is None:
        return None

    def told(line: str) -> None:
        lines.append(line)
        if say is not None:
            say(line)

    return lambda t, x: observe(observer, nmpc, t, x, np.zeros(2), told)


def _taken(truth: WaveField, plant: SensedPlant, nmpc: RollAwareNmpc, observer: DisturbanceObserver | None,
           lines: list[str]) -> Watched:
    """Copies of everything the watch left (the plant's own numbers, its sensors, the wave source, the observer's
    filter, the NMPC's disturbance); the compiled functions bound to arrays are not copied (they hold no state), the
    plant's unbound ones are kept apart (``MAKES``: immutable, each run binds its own arrays)."""
    x, held = plant.state()
    return Watched(truth, x, held, copy.deepcopy(plant.sensors), copy.deepcopy(plant.source, {id(truth): truth}),
                   observer.state() if observer is not None else None, nmpc.disturbance.copy(), tuple(lines))


def _resume(kept: Watched, plant: SensedPlant, nmpc: RollAwareNmpc, observer: DisturbanceObserver | None,
            say: Callable[[str], None] | None) -> None:
    """Put a fresh run where the kept watch left its own (the sensors and the source already are copies of it)."""
    plant.set_state(kept.x, kept.held)
    if observer is not None:
        if kept.observer is None:
            raise RuntimeError("watch_key: a watch without an observer reused by a run with one")
        observer.restore(kept.observer)
    nmpc.set_disturbance(kept.disturbance)
    for line in kept.lines:
        if say is not None:
            say(line)
