"""The report as one self-contained HTML page: tables of the figures, and the pictures embedded as base64 PNG.

Nothing is fetched when the page opens (no scripts, no fonts, no links to files): it can be mailed or opened
from a USB stick. An overview table leads when the report holds several logs.
"""

from __future__ import annotations

import base64
import html
import time
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from mavbridge.field.figures import attitude_figure, path_figure, sea_figure, spectrum_figure
from mavbridge.field.figures_log import log_figure
from mavbridge.field.logs import plural
from mavbridge.field.sea import SERIES_KEYS, sea_line

STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.25em; border-bottom: 1px solid #ccc; margin-top: 2em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: right; }
td:first-child, th:first-child { text-align: left; }
.figures img { max-width: 100%; margin: 0.4em 0; }
.note { color: #555; font-size: 0.9em; } .warn { color: #a40; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


def _e(value: Any) -> str:
    return html.escape(str(value))


def _num(value: Any, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}" if isinstance(value, float) else _e(value)


def table(header: Sequence[str], rows: Iterable[Sequence[Any]]) -> str:
    """An HTML table of already formatted cells."""
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_e(c)}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def image(png: bytes, alt: str) -> str:
    """An <img> holding the PNG itself."""
    return f'<img alt="{_e(alt)}" src="data:image/png;base64,{base64.b64encode(png).decode()}">'


def segments_table(segments: Sequence[Any]) -> str:
    """Stretches with their figures."""
    return table(("stretch", "from (s)", "to (s)", "duration (s)", "distance (m)", "mean speed (m/s)",
                  "avg roll (deg)", "max roll (deg)", "samples"),
                 ((s.label, _num(s.start_s, 1), _num(s.end_s, 1), _num(s.duration_s, 1), _num(s.distance_m, 1),
                   _num(s.mean_speed_m_s), _num(s.avg_roll_deg), _num(s.max_roll_deg), s.samples) for s in segments))


def _facts(entry: dict[str, Any]) -> str:
    rows = [("format", entry["format"]), ("source", entry["source"]), ("starts", entry["start"] or "–"),
            ("duration", f"{entry['duration_s']:.1f} s"),
            ("attitude samples", f"{entry['attitude_samples']} at {entry['attitude_rate_hz']:g} Hz"),
            ("average roll (whole log)", f"{entry['avg_roll_deg']:.3f} deg"),
            ("max roll", f"{entry['max_roll_deg']:.2f} deg"), ("roll RMS", f"{entry['roll_rms_deg']:.2f} deg"),
            ("pitch RMS", f"{entry['pitch_rms_deg']:.2f} deg"), ("IMU used", entry["imu"] or "none")]
    if entry["spectrum"] and entry["spectrum"]["peak_hz"]:
        rows.append(("roll spectrum peak", f"{entry['spectrum']['peak_hz']:.3f} Hz "
                                           f"(period {entry['spectrum']['peak_period_s']:.2f} s)"))
    return table(("", ""), rows)


def log_section(report: Any, entry: dict[str, Any]) -> str:
    """One log: its facts, notes, segments, engagements, the sea, and its figures (the sea's only when the log
    can show one)."""
    trial = report.trial
    parts = [f"<h2>{_e(trial.info.path.name)}</h2>", f'<p class="note">{_e(trial.info.path)}</p>', _facts(entry)]
    if trial.info.stopped:
        parts.append(f'<p class="warn">Cut short: {_e(trial.info.stopped)}</p>')
    if trial.info.notes:
        parts.append("<ul>" + "".join(f'<li class="note">{_e(n)}</li>' for n in trial.info.notes) + "</ul>")
    parts += ["<h3>Segments by mode</h3>", segments_table(report.modes)]
    if report.companion is not None:
        parts += [f"<h3>Engagements of our companion</h3><p class=\"note\">run folder {_e(report.companion)}</p>",
                  segments_table(report.engagements) if report.engagements else "<p>none overlaps this log</p>"]
    estimator = entry["sea"]["estimator"]
    parts += ["<h3>The sea, as the companion's wave estimator sees it</h3>",
              f"<p>{_e(sea_line(entry['sea']['summary']))}</p>",
              f'<p class="note">estimator: roll sign {estimator["roll_sign"]:+g}, GPS lag '
              f"{estimator['position_lag_s']:g} s, hull response calibrated on the {_e(estimator['vessel'])} Otter "
              f"model; replayed over {report.sea.samples} motion samples</p>"]
    series = {key: report.sea.column(key) for key in SERIES_KEYS}
    if report.spectrum is not None:
        parts.append(f'<p class="note">roll spectrum: {_e(report.spectrum.used())}</p>')
    figures = [image(path_figure(trial), "path"),
               image(attitude_figure(trial, report.modes, report.engagements), "roll and pitch"),
               image(log_figure(trial), "heading, speed and what the log holds over time"),
               image(spectrum_figure(report.spectrum), "roll spectrum")]
    if not report.sea.blind():  # a log that cannot show a sea gets its one line, not empty panels
        figures.append(image(sea_figure(series), "wave estimate over time"))
    parts.append('<div class="figures">' + "".join(figures) + "</div>")
    return "\n".join(parts)


def overview(data: dict[str, Any]) -> str:
    """One row per log, when there are several."""
    rows = []
    for entry in data["logs"]:
        sea = entry["sea"]["summary"]
        rows.append((Path(entry["log"]).name, _num(entry["duration_s"], 1), _num(entry["avg_roll_deg"]),
                     _num(entry["roll_rms_deg"]), _num(sea.get("confident_fraction")),
                     _num(sea.get("period_s_median")), _num(sea.get("confidence_median"))))
    return "<h2>Overview</h2>" + table(("log", "duration (s)", "avg roll (deg)", "roll RMS (deg)",
                                        "sea confident (share)", "sea period (s)", "confidence"), rows)


def write_page(path: Path, reports: Sequence[Any], data: dict[str, Any]) -> None:
    """report.html: a self-contained page of every log."""
    body = [f"<h1>Trial report: {plural(len(reports), 'log')}</h1>",
            f'<p class="note">made by <code>{_e(data["command"])}</code> on {time.strftime("%Y-%m-%d %H:%M")}</p>']
    if len(reports) > 1:
        body.append(overview(data))
    body += [log_section(r, entry) for r, entry in zip(reports, data["logs"], strict=True)]
    page = (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>Trial report</title>"
            f"<style>{STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")
    path.write_text(page, encoding="utf-8")
