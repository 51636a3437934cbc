"""identify.html: one self-contained page (figures embedded as base64 PNG, as `mavbridge report`'s page): the
figures with their intervals, what could not be identified, the vessel fields, the model check, and each fit
drawn against the data it came from with the base and identified models beside the log."""

from __future__ import annotations

import html
import json
import time
from pathlib import Path
from typing import Any

from mavbridge.field.page import STYLE, image, table
from mavbridge.identify.analyse import Identification
from mavbridge.identify.figures import ambient_figure, decay_figure, surge_figure, yaw_figure
from vessel import OtterParameters


def _number(value: float | tuple[float, ...] | list[float]) -> str:
    """A field's value for the page: a number to four figures, a pair as two."""
    if isinstance(value, (tuple, list)):
        return ", ".join(f"{v:.4g}" for v in value)
    return f"{value:.4g}"


def _figures(result: Identification, base: OtterParameters, identified: OtterParameters) -> list[str]:
    parts = []
    for axis in ("roll", "pitch"):
        if axis in result.decays:
            figure = decay_figure(axis, result.decays[axis], base, identified, result.decay_signal.get(axis, axis))
            parts += [f"<h3>{axis}: free decays</h3>", image(figure, f"{axis} decays")]
        elif axis in result.ambient:
            fit, items = result.ambient[axis]
            parts += [f"<h3>{axis}: spectrum of the motion</h3>",
                      image(ambient_figure(axis, fit, items, base, identified), f"{axis} spectrum")]
    if result.surge and result.surge["points"]:
        parts += ["<h3>surge: steady speed</h3>",
                  image(surge_figure(result, base, identified), "surge")]
    if result.yaw is not None:
        model, items, label = result.yaw
        base_K = 1 / float(base.matrices().D[5, 5]) if label.startswith("tau_N") else None
        parts += ["<h3>yaw: Nomoto model</h3>",
                  image(yaw_figure(model, items, label, base.yaw_time_constant, base_K), "yaw")]
    return parts


def write_page(path: Path, result: Identification, data: dict[str, Any], base: OtterParameters,
               identified: OtterParameters) -> None:
    """Write the page."""
    e = html.escape
    rows = [(name, f"{est.value:.4g}", f"{est.low:.4g}", f"{est.high:.4g}", est.unit, f"{est.fit:.2f}", est.source)
            for name, est in result.estimates.items()]
    body = [f"<h1>Identification: {len(data['logs'])} log{'s' if len(data['logs']) != 1 else ''}</h1>",
            f'<p class="note">made by <code>{e(data["command"])}</code> on {time.strftime("%Y-%m-%d %H:%M")}; '
            f"base model {e(data['base'])}</p>",
            table(("quantity", "value", "low", "high", "unit", "fit R²", "from"), rows)]
    if result.missing:
        body.append("<h2>Not identified</h2><ul>" + "".join(f"<li>{e(m)}</li>" for m in result.missing) + "</ul>")
    body += ["<h2>vessel.yaml fields</h2>", table(("field", "base", "identified"),
                                                  [(k, _number(getattr(base, k)), _number(v))
                                                   for k, v in data["vessel_fields"].items()]),
             "<h2>Model check (free decay measured on the plant)</h2>",
             f"<pre>{e(json.dumps(data['model_check'], indent=1))}</pre>",
             "<h2>Fits against the logs</h2>", '<div class="figures">', *_figures(result, base, identified), "</div>",
             "<h2>Logs</h2>", table(("log", "format", "day", "duration (s)", "notes"),
                                     [(Path(x["path"]).name, x["format"], x["day"], f"{x['duration_s']:.0f}",
                                       "; ".join(x["notes"])) for x in data["logs"]])]
    page = (f"<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>Identification</title>"
            f"<style>{STYLE}</style></head><body>\n" + "\n".join(body) + "\n</body></html>\n")
    path.write_text(page, encoding="utf-8")
