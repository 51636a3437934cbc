"""``bench/wave_estimation.py --closed-loop``: Balanced against Direct per seed, on the estimate or a simulation-only
source, in the paper's sea, a JONSWAP sea (long- or short-crested) or a NATO sea state; and its ``--weights`` flag."""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics

SEAS = {"paper": "estimated.yaml", "jonswap": "jonswap_estimated.yaml", "ss3": "jonswap_estimated.yaml",
        "ss4": "jonswap_estimated.yaml", "short": "jonswap_estimated.yaml"}
SHORT_CRESTED_S = 10.0  # --sea short: the JONSWAP sea with cos-2s spreading, s = 10 (issue 33)


def _sea_runs(sea: str, seed: int, runs: dict) -> dict:
    """The scenario's runs with this seed's sea (irregular: its own components; NATO states from Table I)."""

    out = {}
    for name, sc in runs.items():
        spectrum = sc.world.sea.spectrum
        if spectrum is not None:
            state = {"ss3": 3, "ss4": 4}.get(sea)
            changes: dict = {"seed": seed}
            if state is not None:
                changes.update(sea_state=state, hs_m=None, tp_s=None)
            if sea == "short":
                changes.update(spreading_s=SHORT_CRESTED_S)
            world = dataclasses.replace(sc.world, sea=dataclasses.replace(
                sc.world.sea, spectrum=dataclasses.replace(spectrum, **changes)))
            sc = dataclasses.replace(sc, world=world)
        out[name] = sc
    return out


def _configured(sc: object, seed: int, source: str, watch: float, options: dict) -> object:
    """The run flown on ``source`` with this seed; ``predicted`` (and ``oracle``: its bank from the true sea) with
    the bank of ``options["components"]``, its spread mode, fade and lead; every source on ``options["solver"]``
    when given; ``options["weights"]`` (Q, R, S): Balanced's, and Direct's Q and S (its R stays 0)."""

    oracle, true_slope, true_spread = source == "oracle", source == "trueslope", source == "truestats"
    source = {"oracle": "predicted", "trueslope": "predicted", "truestats": "estimated"}.get(source, source)
    est = dataclasses.replace(sc.estimation, seed=seed, waves=source, watch_s=watch, spread_truth=true_spread,
                              bank_spread=options.get("bank_spread", "full"), bank_fade=options.get("bank_fade", True),
                              bank_lead_s=options.get("bank_lead_s", 1.0), bank_oracle=oracle,
                              bank_select=options.get("bank_select", "compressed"), bank_true_slope=true_slope)
    changes = {"wave_components": options.get("components", 12)} if source == "predicted" else {}
    if options.get("solver"):
        changes["solver"] = options["solver"]
    if options.get("weights"):
        q, r, s = options["weights"]
        changes.update(q=q, s=s, r=r if sc.controller.r > 0 else 0.0)
    return dataclasses.replace(sc, estimation=est, controller=sc.controller.replace(**changes))


def _row(seed: int, source: str, m: dict) -> float:
    """Print one seed's line; returns the cut (%)."""
    direct, balanced = m["direct"], m["balanced"]
    cut = 1 - balanced["avg_roll_deg"] / direct["avg_roll_deg"]
    t_direct, t_bal = direct["time_to_waypoint_s"], balanced["time_to_waypoint_s"]
    bound = 1.2 * t_direct / (1 - cut) if t_direct is not None and cut < 1 else None
    ratio = t_bal / bound if bound is not None and t_bal is not None else None

    def pct(key: str) -> str:
        value = balanced.get(key)
        return "–" if value is None else f"{100 * value:.0f}"

    def sec(value: float | None, digits: int = 1) -> str:
        return "N/A" if value is None else f"{value:.{digits}f}"

    print(f"| {seed} | {source} | {direct['avg_roll_deg']:.2f} | {balanced['avg_roll_deg']:.2f} | {100 * cut:+.1f} "
          f"| {sec(t_direct)} | {sec(t_bal)} | {sec(bound)} | {sec(ratio, 2)} | {pct('confident_fraction')} "
          f"| {pct('sea_statistics_fraction')} | {pct('bank_fraction')} |", flush=True)
    return 100 * cut


def closed_loop_table(seeds: int, watch_s: float | None = None, sea: str = "paper", sources: str = "estimated,truth",
                      options: dict | None = None) -> None:
    """Balanced vs Direct on the estimate, the predictor's bank (``predicted``) and the truth, per seed, in ``sea``;
    ``watch_s`` overrides the scenario's time the estimator watches the drifting boat before the run (0: a cold
    start); ``options``: components (K of the bank), bank_spread, solver (default: the scenario's)."""
    from pathlib import Path

    from mavbridge.lab.experiment import run_scenario
    from mavbridge.lab.scenario import load_scenarios

    options = options or {}
    path = Path(__file__).resolve().parents[1] / "scenarios" / SEAS[sea]
    base = {sc.name: sc for sc in load_scenarios(path)}
    watch = base["balanced"].estimation.watch_s if watch_s is None else watch_s
    solver = options.get("solver") or base["balanced"].controller.solver
    q, r, s = options.get("weights") or (base["balanced"].controller.q, base["balanced"].controller.r,
                                          base["balanced"].controller.s)
    print(f"# closed loop, {sea} sea, heave, hidden phase, default sensors, {seeds} seeds (scenarios/{SEAS[sea]}), "
          f"estimator watching {watch:g} s before the run, solver {solver}, "
          f"Q, S {q:g}, {s:g} (both), Balanced's R {r:g}, "
          f"bank K = {options.get('components', 12)}, spread with the bank: {options.get('bank_spread', 'full')}, "
          f"bank faded: {options.get('bank_fade', True)}, used when confident {options.get('bank_lead_s', 1.0):g} s "
          f"ahead, {options.get('bank_select', 'compressed')} components")
    print("# bound = 1.2 × T_direct / (1 − cut); ratio = T_balanced / bound")
    print("| seed | source | direct avg roll ° | balanced avg roll ° | cut % | direct t_wpt s | balanced t_wpt s "
          "| bound s | ratio | confident % | statistics only % | bank % |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    cuts: dict[str, list[float]] = {source: [] for source in sources.split(",")}
    for seed in range(1, seeds + 1):
        runs = _sea_runs(sea, seed, base)
        for source in cuts:
            m = {name: run_scenario(_configured(runs[name], seed, source, watch, options), None, plots=False).metrics
                 for name in ("direct", "balanced")}
            cuts[source].append(_row(seed, source, m))
    for source, values in cuts.items():
        print(f"# mean cut on the {source}: {statistics.mean(values):+.1f} % over {len(values)} seeds")


def weights_flag(parser: argparse.ArgumentParser, text: str | None) -> tuple[float, float, float] | None:
    """--weights Q,R,S as three finite numbers, each >= 0 (R > 0: Balanced has a roll term); else exit 2."""
    if text is None:
        return None
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) and v >= 0 for v in values) or values[1] <= 0:
        parser.exit(2, f"--weights: {text!r} is not Q,R,S: three numbers >= 0, R > 0\n")
    from mavbridge.nmpc.config import NmpcConfig
    from vessel.config import ConfigError

    try:
        NmpcConfig().replace(q=values[0], r=values[1], s=values[2])
    except ConfigError as exc:
        parser.exit(2, f"--weights: {exc}\n")
    return values
