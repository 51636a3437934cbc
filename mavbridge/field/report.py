"""`mavbridge report LOG... [--out DIR]`: what a trial's logs say, printed, as one HTML page and as JSON.

Per log: the whole log's average |roll| (every attitude sample of the autopilot), its modes as segments and
our companion's engagements where its run folder lies beside the log (``segments``), the sea the companion's
wave estimator sees replayed over the log (``sea``), and the roll spectrum (``spectrum``). The log is streamed
once: the estimator runs as the motion samples come (the reading in a child process, ``pipeline``: two
cores), and only compact arrays are kept. Every log is opened (its
format found, its autopilot identified) before any is analysed, so a file that is not a log stops the report
before anything is written; a log without attitude among several is left out with a line (alone, it is the
error). ``DIR/report.html`` (one self-contained page, figures embedded) and ``DIR/report.json`` (the same
figures) are written last, in a fresh folder: nothing already there is overwritten.
"""

from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mavbridge.field.logs import LogError, LogReader, check_out, open_log
from mavbridge.field.pipeline import record_on_two_cores
from mavbridge.field.progress import ProgressLine
from mavbridge.field.sea import SERIES_KEYS, SeaWatch, sea_line
from mavbridge.field.segments import Segment, companion_folder, engagements, mode_segments
from mavbridge.field.spectrum import MIN_WINDOW_S, Spectrum, roll_spectrum
from mavbridge.field.trial import Trial


@dataclass(frozen=True)
class EstimatorSetup:
    """How the companion's wave estimator is made for the report (a new one per log), and what it was told."""

    scenario: Any
    roll_sign: float
    position_lag_s: float

    @property
    def vessel(self) -> str:
        """The controller's model of the hull, which the estimator's response is calibrated on."""
        return str(self.scenario.controller.model)

    def fresh(self) -> Any:
        """A new estimator that has seen nothing, made as `mavbridge run` makes it (the calibration on the vessel
        model takes a few tenths of a second)."""
        from mavbridge.companion.wave_gate import make_wave_source

        return make_wave_source("estimated", self.scenario.sea.waves, self.roll_sign, self.position_lag_s,
                                self.scenario.model_params())

    def row(self) -> dict[str, Any]:
        """For report.json."""
        return {"roll_sign": self.roll_sign, "position_lag_s": self.position_lag_s, "vessel": self.vessel}


def estimator_setup(config_path: str | None, scenario_path: str | None) -> EstimatorSetup:
    """The estimator `mavbridge run` would use with this companion YAML and scenario (defaults: the simulator's
    hull, roll sign +1, and the paper's Balanced scenario's vessel)."""
    from mavbridge.cli.args import single_scenario
    from mavbridge.companion.config import load_companion_config
    from vessel.argtypes import naming

    with naming("--config"):
        config = load_companion_config(config_path)  # the connection is not checked: nothing is connected to
    return EstimatorSetup(single_scenario(scenario_path, None, config.model), config.wave_roll_sign,
                          config.wave_position_lag_s)


@dataclass
class LogReport:
    """Everything the report says of one log."""

    trial: Trial
    whole: dict[str, Any]
    modes: list[Segment]
    companion: Path | None
    engagements: list[Segment]
    sea: SeaWatch
    spectrum: Spectrum | None
    read_s: float


def whole_log(trial: Trial) -> dict[str, Any]:
    """The whole log's attitude figures (degrees): mean |roll| over every sample, max, RMS; pitch RMS."""
    roll, pitch = np.degrees(trial.attitude[:, 1]), np.degrees(trial.attitude[:, 2])
    return {"attitude_samples": int(roll.size), "attitude_rate_hz": round(trial.attitude_rate_hz, 2),
            "duration_s": round(trial.end_s - trial.start_s, 3),
            "avg_roll_deg": round(float(np.mean(np.abs(roll))), 4),
            "max_roll_deg": round(float(np.max(np.abs(roll))), 4),
            "roll_rms_deg": round(float(np.sqrt(np.mean(roll**2))), 4),
            "roll_std_deg": round(float(np.std(roll)), 4), "pitch_rms_deg": round(float(np.sqrt(np.mean(pitch**2))), 4)}


def analyse(reader: LogReader, setup: EstimatorSetup) -> LogReport:
    """Read the log once (with a progress line) and work out what the report says of it."""
    started = time.monotonic()
    progress = ProgressLine(f"report: {reader.info.path.name}")
    sea = SeaWatch(setup.fresh())
    try:
        trial = record_on_two_cores(reader, sea.observe, progress)
    finally:
        progress.done()
    folder = companion_folder(reader.info.path) if reader.info.format != "otter-csv" else None
    engaged = engagements(trial, folder) if folder is not None else []
    roll_deg = np.degrees(trial.attitude[:, 1])
    return LogReport(trial, whole_log(trial), mode_segments(trial), folder, engaged, sea,
                     roll_spectrum(trial.attitude[:, 0], roll_deg), time.monotonic() - started)


def report_lines(r: LogReport) -> list[str]:
    """What the terminal shows of one log."""
    info, w = r.trial.info, r.whole
    lines = [f"report: {info.path} ({info.format}; {info.source or 'unknown source'}; "
             f"starts {info.start_text or 'at an unknown time'}; {w['duration_s']:.1f} s; read in {r.read_s:.1f} s)"]
    if info.stopped:
        lines.append(f"  cut short: {info.stopped}")
    lines += [f"  note: {note}" for note in info.notes]
    lines.append(f"average roll (whole log) {w['avg_roll_deg']:.3f} deg over {w['attitude_samples']} attitude samples "
                 f"at {w['attitude_rate_hz']:g} Hz (max {w['max_roll_deg']:.2f} deg, RMS {w['roll_rms_deg']:.2f} deg)")
    lines.append("segments by mode:")
    lines += [f"  {seg.line()}" for seg in r.modes]
    if r.companion is not None:
        lines.append(f"engagements of our companion ({r.companion}):")
        lines += [f"  {seg.line()}" for seg in r.engagements] or ["  none overlaps this log"]
    lines.append(sea_line(r.sea.summary()))
    spec = r.spectrum
    if spec is None:
        lines.append(f"roll spectrum: none (no stretch without gaps of {MIN_WINDOW_S:g} s or more)")
    else:
        peak = f"peak {spec.peak_hz:.3f} Hz (period {1 / spec.peak_hz:.2f} s)" if spec.peak_hz else "flat"
        lines.append(f"roll spectrum: {peak}, {spec.used()}")
    return lines


def _finite(values: np.ndarray, digits: int = 4) -> list[float | None]:
    return [round(float(v), digits) if math.isfinite(v) else None for v in values]


def report_json(r: LogReport, setup: EstimatorSetup) -> dict[str, Any]:
    """Everything the page shows of one log, as data."""
    t, info = r.trial, r.trial.info

    def place(lat_lon: tuple[float, float] | None) -> dict[str, float] | None:
        local = t.local(lat_lon)
        return None if lat_lon is None or local is None else {
            "lat_deg": lat_lon[0], "lon_deg": lat_lon[1], "north_m": round(local[0], 3), "east_m": round(local[1], 3)}

    return {"log": str(info.path), "format": info.format, "source": info.source, "start": info.start_text,
            "cut_short": info.stopped, "notes": info.notes, **r.whole, "imu": t.imu, "refused_messages": t.rejected,
            "modes": [seg.row() for seg in r.modes],
            "companion_run": None if r.companion is None else str(r.companion),
            "engagements": [seg.row() for seg in r.engagements],
            "home": place(t.home), "origin": place(t.origin), "waypoints": [place(p) for p in t.waypoints],
            "sea": {"estimator": setup.row(), "summary": r.sea.summary(),
                    "series": {key: _finite(r.sea.column(key)) for key in SERIES_KEYS}},
            "spectrum": None if r.spectrum is None else r.spectrum.row()}


def default_out() -> Path:
    """runs/report-YYYYmmdd-HHMMSS."""
    return Path("runs") / time.strftime("report-%Y%m%d-%H%M%S")


def open_all(paths: list[str], fmt: str, sysid: int | None) -> list[LogReader]:
    """Every log opened (format and autopilot found) before any is analysed: a bad one is the error."""
    return [open_log(Path(p), fmt, sysid) for p in paths]


def analyse_all(readers: list[LogReader], setup: EstimatorSetup) -> list[LogReport]:
    """The reports of the logs that hold attitude; LogError when none does."""
    reports, refused = [], []
    for reader in readers:
        try:
            reports.append(analyse(reader, setup))
        except LogError as exc:
            if len(readers) == 1:
                raise
            refused.append(exc)
            sys.stderr.write(f"mavbridge report: left out: {exc}\n")
    if not reports:
        raise refused[0]
    return reports


def report_command(paths: list[str], fmt: str, sysid: int | None, config: str | None, scenario: str | None,
                   out: str | None, command_line: str) -> int:
    """Carry out `mavbridge report`: read, print, then write the page and the JSON into a fresh folder."""
    from mavbridge.field.page import write_page
    from mavbridge.lab.runlog import fresh_run_folder

    check_out(out)
    readers = open_all(paths, fmt, sysid)
    setup = estimator_setup(config, scenario)
    reports = analyse_all(readers, setup)
    for r in reports:
        print("\n".join(report_lines(r)))
    folder = fresh_run_folder(Path(out) if out else default_out())
    data = {"command": command_line, "estimator": setup.row(), "logs": [report_json(r, setup) for r in reports]}
    (folder / "report.json").write_text(json.dumps(data, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    write_page(folder / "report.html", reports, data)
    print(f"report: wrote {folder / 'report.html'} and {folder / 'report.json'}")
    return 0
