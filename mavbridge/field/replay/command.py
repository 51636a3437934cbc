"""`mavbridge replay`: the request (the flags) and the command that carries it out."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from mavbridge.field.logs import LogReader, check_out, open_log
from mavbridge.field.progress import ProgressLine
from mavbridge.field.replay.flight import ReplayRequest, prepare_flight, refuse_early, window_of
from mavbridge.field.replay.source import StreamRates
from mavbridge.field.replay.summary import summary_lines, write_rows
from mavbridge.field.trial import record

RUN_CONFIG = "config.yaml"  # a companion's run folder: its settings and scenario, beside its companion.tlog


def run_settings(log: Path) -> dict[str, Any] | None:
    """The companion's settings and scenario from the run folder a companion's own tlog is in (its config.yaml,
    with ``companion`` and ``scenario`` sections), None for any other log."""
    import yaml

    path = log.parent / RUN_CONFIG
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8")) if path.is_file() else None
    except (OSError, yaml.YAMLError):
        return None
    if isinstance(data, dict) and isinstance(data.get("companion"), dict) and isinstance(data.get("scenario"), dict):
        return data
    return None


def _settings(req: ReplayRequest) -> tuple[Any, Any]:
    """(the companion's config, the scenario): the flags', else the run's own config.yaml for a companion's tlog
    (said in a line: the replay then answers as that companion did), else the defaults."""
    from mavbridge.cli.args import refuse_form_without_guided, single_scenario
    from mavbridge.companion.config import CompanionConfig, load_companion_config
    from mavbridge.lab.scenario import scenario_from_mapping
    from vessel.argtypes import naming
    from vessel.config import from_mapping

    run = run_settings(Path(req.log)) if req.config is None or req.scenario is None else None
    where = Path(req.log).parent / RUN_CONFIG
    if run is not None and req.config is None:
        given = {"output": req.output, "attitude_form": req.attitude_form}
        config = from_mapping(CompanionConfig, {**run["companion"], **{k: v for k, v in given.items() if v}},
                              f"{where}: companion")
    else:
        with naming("--config"):
            config = load_companion_config(req.config, output=req.output, attitude_form=req.attitude_form)
    refuse_form_without_guided(req.attitude_form, config.output)
    if run is not None and req.scenario is None:
        scenario = scenario_from_mapping(run["scenario"], f"{where}: scenario", run["scenario"].get("name"))
        scenario = single_scenario(None, req.solver, config.model, scenario)
    else:
        scenario = single_scenario(req.scenario, req.solver, config.model)
    if run is not None:
        print(f"replay: the companion's settings and scenario of this run from {where}"
              + (" (--config given: its settings from there)" if req.config else "")
              + (" (--scenario given: its scenario from there)" if req.scenario else ""))
    return config, scenario


def replay_command(req: ReplayRequest) -> int:
    """Carry out `mavbridge replay` (see the module docstring)."""
    from mavbridge.companion.flight import build_nmpc
    from mavbridge.companion.wave_gate import make_wave_source
    from mavbridge.field.figures import replay_figure
    from mavbridge.field.replay.source import HeldEstimator, answering
    from mavbridge.lab.runlog import fresh_run_folder

    check_out(req.out)
    reader: LogReader = open_log(Path(req.log), req.fmt, req.sysid, outputs=True)
    window = window_of(req)
    config, scenario = _settings(req)
    progress = ProgressLine(f"replay: {reader.info.path.name} (its parameters and mission)")
    rates = StreamRates()
    try:
        trial = record(rates.through(reader.messages(progress)), reader.info)
    finally:
        progress.done()
    refuse_early(req, trial)  # before seconds of building
    waves = HeldEstimator(make_wave_source("estimated", scenario.sea.waves, config.wave_roll_sign,
                                           config.wave_position_lag_s, scenario.model_params()),
                          answering(config.estimator_process, config.lockstep))
    with build_nmpc(scenario, waves, lockstep=True) as nmpc:
        flight = prepare_flight(req, trial, scenario, config, nmpc, waves, print, rates.fastest())
        progress = ProgressLine(f"replay: {reader.info.path.name}")
        try:
            for t, msg in reader.messages(progress):
                if t > window[1] + 1.0:
                    break
                flight.take(t, msg)
            flight.finish()
        finally:
            progress.done()
    for line in summary_lines(flight, trial, req, scenario.controller.solver):
        print(line)
    folder = fresh_run_folder(Path(req.out) if req.out else Path("runs") / time.strftime("replay-%Y%m%d-%H%M%S"))
    write_rows(folder / "replay.csv", flight.rows)
    summary = {"waves": flight.gate.summary(flight.engaged_solve_ms), "steps": len(flight.rows),
               "engaged_at_s": flight.engaged_s, "arrived_at_s": flight.arrived_s, "imu": flight.state.imu_preferred}
    (folder / "replay.json").write_text(json.dumps(summary, indent=2) + "\n")
    (folder / "replay.png").write_bytes(replay_figure(flight.rows, flight.output.name))
    print(f"replay: wrote {folder / 'replay.csv'}, {folder / 'replay.json'} and {folder / 'replay.png'}")
    return 0
