"""The report's figures as PNG bytes (matplotlib, Agg): path (with the target, where logged), roll and pitch
with the modes, spectrum, sea (``figures_log``: heading, speed, shaft speeds, forces over time).

Each function draws one figure of one trial and returns the PNG, to be embedded in the HTML page. Long series
are thinned to at most ``MAX_POINTS`` points for drawing (the figures in report.json are from all samples).
"""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

from mavbridge.field.logs import plural
from mavbridge.field.segments import Segment
from mavbridge.field.spectrum import Spectrum
from mavbridge.field.trial import Trial

MAX_POINTS = 8000
DPI = 90


def pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def png(fig: Any) -> bytes:
    """The figure as PNG bytes; the figure is closed."""
    plt = pyplot()
    buffer = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buffer, format="png", dpi=DPI)
    plt.close(fig)
    return buffer.getvalue()


def thin(*columns: np.ndarray) -> list[np.ndarray]:
    """Every k-th row so that at most MAX_POINTS remain."""
    step = max(1, math.ceil(len(columns[0]) / MAX_POINTS))
    return [c[::step] for c in columns]


def path_figure(trial: Trial) -> bytes:
    """The track in local north/east (m from the origin: home, else the first fix) with the mission's waypoints."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 5.6))
    _, north, east = thin(trial.track[:, 0], trial.track[:, 1], trial.track[:, 2])
    if north.size:
        ax.plot(east, north, "k-", lw=1.2, label="path")
        ax.plot(east[0], north[0], "go", label="start")
        ax.plot(east[-1], north[-1], "rs", ms=5, label="end")
    points = [trial.local(p) for p in trial.waypoints]
    for i, (n, e) in enumerate(p for p in points if p is not None):
        ax.plot(e, n, "r*", ms=12, label="waypoints" if i == 0 else None)
        ax.annotate(str(i + 1), (e, n), textcoords="offset points", xytext=(6, 4), fontsize=8, color="r")
    from mavbridge.field.figures_log import target_on_path

    target_on_path(ax, trial)
    home = trial.local(trial.home)
    if home is not None:
        ax.plot(home[1], home[0], "b^", label="home")
    if not north.size and not points:
        ax.text(0.5, 0.5, "no position in the log", transform=ax.transAxes, ha="center")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(alpha=0.3)
    ax.set_title("path: metres from " + ("home" if trial.origin is not None and trial.origin == trial.home
                                         else "the first position fix"), fontsize=10)
    ax.legend(loc="best", fontsize=8)
    return png(fig)


def _bands(ax: Any, segments: list[Segment], hatch: list[Segment]) -> None:
    """Modes as coloured bands (one colour per label), the companion's engagements hatched."""
    colours = {}
    palette = pyplot().get_cmap("tab10")
    for seg in segments:
        new = seg.label not in colours
        colours.setdefault(seg.label, palette(len(colours) % 10))
        ax.axvspan(seg.start_s, seg.end_s, color=colours[seg.label], alpha=0.15, lw=0, label=seg.label if new else None)
    for i, seg in enumerate(hatch):
        ax.axvspan(seg.start_s, seg.end_s, fill=False, hatch="//", ec="0.3", lw=0,
                   label="companion engaged" if i == 0 else None)


def attitude_figure(trial: Trial, modes: list[Segment], engaged: list[Segment]) -> bytes:
    """Roll and pitch (deg) over the log's time, the modes as bands, the companion's engagements hatched."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(9.0, 5.6))
    t, roll, pitch = thin(trial.attitude[:, 0], np.degrees(trial.attitude[:, 1]), np.degrees(trial.attitude[:, 2]))
    for ax, values, name in ((axes[0], roll, "roll φ (deg)"), (axes[1], pitch, "pitch θ (deg)")):
        _bands(ax, modes if len(modes) > 1 or trial.modes else [], engaged)
        ax.plot(t, values, "k-", lw=0.6)
        ax.set_ylabel(name)
        ax.grid(alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    if labels:
        axes[0].legend(handles, labels, loc="upper right", fontsize=7, ncol=min(len(labels), 4))
    axes[1].set_xlabel("time (s, " + ("autopilot clock" if trial.info.format != "otter-csv" else "since the first row")
                       + ")")
    return png(fig)


def spectrum_figure(spectrum: Spectrum | None) -> bytes:
    """Roll PSD (deg²/Hz, log scale) against frequency, the peak marked with its period."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    if spectrum is None:
        ax.text(0.5, 0.5, "too short for a spectrum", transform=ax.transAxes, ha="center")
    else:
        keep = spectrum.freq_hz > 0
        ax.semilogy(spectrum.freq_hz[keep], np.maximum(spectrum.psd_deg2_hz[keep], 1e-12), "k-", lw=1)
        if spectrum.peak_hz:
            ax.axvline(spectrum.peak_hz, color="r", ls="--", lw=0.8,
                       label=f"peak {spectrum.peak_hz:.3f} Hz (period {1 / spectrum.peak_hz:.2f} s)")
            ax.legend(fontsize=8)
        ax.set_xlim(0, min(float(spectrum.freq_hz[-1]), 3.0))
        ax.set_title(f"roll spectrum (Welch, {plural(spectrum.windows, 'window')} of {spectrum.window_s:.0f} s; "
                     f"{spectrum.used_s:.0f} s of {spectrum.log_s:.0f} s used)", fontsize=10)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("roll PSD (deg²/Hz)")
    ax.grid(alpha=0.3, which="both")
    return png(fig)


def sea_figure(series: dict[str, np.ndarray]) -> bytes:
    """The estimator's fit over time: period, direction, height and confidence; confident seconds shaded."""
    plt = pyplot()
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(9.0, 7.0))
    t = series["t_s"]
    confident = series["confident"] > 0.5
    panels = (("period_s", "period (s)"), ("dir_deg", "towards (deg)"), ("height_m", "height (m)"),
              ("confidence", "confidence"))
    for ax, (key, label) in zip(axes, panels, strict=True):
        if t.size:
            ax.fill_between(t, 0, 1, where=confident, step="mid", color="tab:green", alpha=0.15, lw=0,
                            transform=ax.get_xaxis_transform(), label="confident" if key == "period_s" else None)
            ax.plot(t, series[key], ".", ms=2, color="tab:blue")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    if t.size and np.isfinite(series["encounter_period_s"]).any():
        axes[0].plot(t, series["encounter_period_s"], "-", lw=0.6, color="0.5", label="encounter period (tracker)")
    if t.size and np.isfinite(series["lock"]).any():
        axes[3].plot(t, series["lock"], "-", lw=0.6, color="0.5", label="lock (oscillator)")
        axes[3].legend(loc="upper right", fontsize=7)
    if t.size and not np.isfinite(series["period_s"]).any():
        axes[1].text(0.5, 0.5, "no wave solved: nothing to estimate from (no heave, no Doppler line)",
                     transform=axes[1].transAxes, ha="center", fontsize=9)
    axes[0].legend(loc="upper right", fontsize=7)
    axes[3].set_ylim(-0.02, 1.02)
    axes[3].set_xlabel("time (s)")
    if not t.size:
        axes[0].text(0.5, 0.5, "no motion sample with a position", transform=axes[0].transAxes, ha="center")
    return png(fig)


def replay_figure(rows: list[dict[str, Any]], output: str) -> bytes:
    """Replay: throttle and steering the companion would have commanded against the boat's motors, roll, and the
    wave's confidence; shaded where the boat was armed in the companion's mode (where it would have commanded)."""
    plt = pyplot()
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(9.0, 8.0))

    def col(key: str) -> np.ndarray:
        return np.array([float(r[key]) if r.get(key) not in (None, "") else math.nan for r in rows], float)

    t = col("t_s")
    would = col("would_command") > 0.5
    for ax, what in zip(axes[:2], ("throttle", "steering"), strict=True):
        ax.plot(t, col(f"cmd_{what}"), "r-", lw=0.9, label=f"companion ({output})")
        ax.plot(t, col(f"boat_{what}"), "k-", lw=0.9, label="the boat's motors")
        ax.set_ylabel(f"{what} (-1..1)")
        ax.set_ylim(-1.05, 1.05)
    axes[2].plot(t, np.degrees(col("roll_rad")), "k-", lw=0.7)
    axes[2].set_ylabel("roll φ (deg)")
    axes[3].plot(t, col("wave_confidence"), "b.", ms=2, label="wave confidence")
    axes[3].plot(t, col("roll_term"), "g-", lw=0.8, label="roll term on")
    axes[3].set_ylim(-0.05, 1.05)
    axes[3].set_xlabel("time (s of the log)")
    for ax in axes:
        if t.size:
            ax.fill_between(t, 0, 1, where=would, step="mid", color="tab:orange", alpha=0.15, lw=0,
                            transform=ax.get_xaxis_transform(), label="would command" if ax is axes[0] else None)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=7, ncol=3)
    axes[3].legend(loc="upper right", fontsize=7)
    if not t.size:
        axes[0].text(0.5, 0.5, "no control step", transform=axes[0].transAxes, ha="center")
    return png(fig)
