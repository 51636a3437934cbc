"""The paper's figures for one run: the x–y path over the wave crests, and stacked time series."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


WIDE = 0.6  # north span below this fraction of the east span: the chart is drawn wide
MAX_RATIO = 3.0  # a chart is never longer than this many times its width (a straight run is not a sliver)


def _no_sliver(lo_e: float, hi_e: float, lo_n: float, hi_n: float) -> tuple[float, float, float, float]:
    """The chart's limits widened about their middle so that neither side is more than MAX_RATIO times the other."""
    span_e, span_n = hi_e - lo_e, hi_n - lo_n
    if span_e > MAX_RATIO * span_n:
        pad = (span_e / MAX_RATIO - span_n) / 2
        lo_n, hi_n = lo_n - pad, hi_n + pad
    elif span_n > MAX_RATIO * span_e:
        pad = (span_n / MAX_RATIO - span_e) / 2
        lo_e, hi_e = lo_e - pad, hi_e + pad
    return lo_e, hi_e, lo_n, hi_n


def plot_path(path: Path, north: np.ndarray, east: np.ndarray, waypoint: tuple[float, float], radius: float,
              waves, t_end: float, title: str) -> None:
    """Path as on a chart (east right, north up) over the sea surface at the end of the run."""
    plt = _pyplot()
    lo_e = min(east.min(), waypoint[1]) - 15
    hi_e = max(east.max(), waypoint[1]) + 15
    lo_n = min(north.min(), waypoint[0]) - 15
    hi_n = max(north.max(), waypoint[0]) + 15
    lo_e, hi_e, lo_n, hi_n = _no_sliver(lo_e, hi_e, lo_n, hi_n)
    wide = (hi_n - lo_n) < WIDE * (hi_e - lo_e)  # a long run across: a wide chart, the colour bar under it
    fig, ax = plt.subplots(figsize=(7.0, 7.0 * (hi_n - lo_n) / (hi_e - lo_e) + 2.0) if wide else (6.4, 6.0))
    ge, gn = np.meshgrid(np.linspace(lo_e, hi_e, 300), np.linspace(lo_n, hi_n, 300))
    zeta = np.asarray(waves.elevation(gn, ge, t_end), float) * np.ones_like(ge)
    if np.any(zeta != 0):
        mesh = ax.pcolormesh(ge, gn, zeta, cmap="Blues_r", shading="auto", alpha=0.6)
        if hasattr(waves, "slope_along_travel"):  # crests: zero slope where the surface is high
            slope = np.ma.masked_where(zeta < 0, np.asarray(waves.slope_along_travel(gn, ge, t_end), float))
            ax.contour(ge, gn, slope, levels=[0.0], colors="navy", linewidths=0.8)
            lines = "crests"
        else:  # an irregular sea has no single crest line: outline the highest 15 % of the surface
            ax.contour(ge, gn, zeta, levels=[float(np.percentile(zeta, 85))], colors="navy", linewidths=0.8)
            lines = "highest 15 %"
        fig.colorbar(mesh, ax=ax, label=f"sea surface at t = {t_end:.1f} s (m); lines: {lines}",
                     orientation="horizontal" if wide else "vertical")
    ax.plot(east, north, "k-", lw=1.6, label="path")
    ax.plot(east[0], north[0], "go", label="start")
    ax.plot(waypoint[1], waypoint[0], "r*", ms=14, label="waypoint")
    circle = plt.Circle((waypoint[1], waypoint[0]), radius, color="r", fill=False, ls="--")
    ax.add_patch(circle)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_aspect("equal")
    ax.set_xlim(lo_e, hi_e)
    ax.set_ylim(lo_n, hi_n)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_timeseries(path: Path, t: np.ndarray, wave_force: np.ndarray, roll_deg: np.ndarray,
                    pitch_deg: np.ndarray, tau_x: np.ndarray, tau_n: np.ndarray, title: str) -> None:
    """Wave force, roll, pitch and inputs over time, stacked with a shared time axis."""
    plt = _pyplot()
    fig, axes = plt.subplots(4, 1, sharex=True, figsize=(7.0, 8.0))
    axes[0].plot(t, wave_force, "b-", lw=1)
    axes[0].set_ylabel("wave force (N)\nalong travel")
    axes[1].plot(t, roll_deg, "k-", lw=1)
    axes[1].set_ylabel("roll φ (deg)")
    axes[2].plot(t, pitch_deg, "k-", lw=1)
    axes[2].set_ylabel("pitch θ (deg)")
    axes[3].plot(t, tau_x, "g-", lw=1, label="τ_X (N)")
    axes[3].plot(t, tau_n, "m-", lw=1, label="τ_N (N·m)")
    axes[3].set_ylabel("inputs")
    axes[3].legend(loc="best", fontsize=8)
    axes[3].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _estimated_slope(rows: list, north: np.ndarray, east: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Slope along the estimate's own travel direction at the boat (rad), NaN where nothing was estimated."""
    from vessel import RegularWaves

    out = np.full(len(rows), np.nan)
    for i, row in enumerate(rows):
        try:
            wave = RegularWaves(float(row["wave_height_m"]), float(row["wave_length_m"]), float(row["wave_period_s"]),
                                np.radians(float(row["wave_dir_deg"])), phase_rad=float(row["wave_phase_rad"]))
        except (KeyError, TypeError, ValueError):
            continue
        out[i] = float(wave.slope_along_travel(north[i], east[i], t[i]))
    return out


ESTIMATE_PANELS = (("wave_height_m", "height (m)", "height_m", 1.0), ("wave_period_s", "period (s)", "period_s", 1.0),
                   ("wave_length_m", "wavelength (m)", "length_m", 1.0),
                   ("wave_dir_deg", "travel dir (deg)", "travel_dir_rad", 180 / np.pi))


def wave_estimate_series(rows: list) -> dict[str, np.ndarray | float | None]:
    """What ``plot_wave_estimate`` draws, from the run's rows: time, true and estimated slope (deg), the
    estimate's parameters, its confidence, and ``first_estimate_s`` (None if it never gave one).

    Only what the estimator gave: a row without an estimate (empty wave columns) is NaN in the estimate's
    series, so nothing is drawn there, and 0 in the confidence (0: nothing known).
    """
    from mavbridge.lab.runlog import column

    t, north, east = column(rows, "t_s"), column(rows, "north_m"), column(rows, "east_m")
    confidence = column(rows, "wave_confidence")
    given = ~np.isnan(confidence)
    series: dict[str, np.ndarray | float | None] = {
        "t_s": t,
        "true_slope_deg": np.degrees(column(rows, "wave_slope_rad")),
        "estimated_slope_deg": np.degrees(_estimated_slope(rows, north, east, t)),
        "confidence": np.where(given, confidence, 0.0),
        "first_estimate_s": float(t[np.argmax(given)]) if given.any() else None,
    }
    for name, *_ in ESTIMATE_PANELS:
        series[name] = column(rows, name)
    return series


def plot_wave_estimate(path: Path, rows: list, truth, title: str) -> None:
    """Estimated against true slope at the boat, and the estimate's parameters and confidence over time.

    Slopes are along each wave's own travel direction (rad → deg); the truth's parameters are dashed. Before the
    estimator's first fit nothing of the estimate is drawn (shaded: no estimate yet) and the confidence is 0.
    """
    plt = _pyplot()
    data = wave_estimate_series(rows)
    t, first = data["t_s"], data["first_estimate_s"]
    fig, axes = plt.subplots(6, 1, sharex=True, figsize=(7.0, 10.0))
    axes[0].plot(t, data["true_slope_deg"], "k-", lw=1, label="true")
    axes[0].plot(t, data["estimated_slope_deg"], "r-", lw=1, label="estimated")
    axes[0].set_ylabel("slope (deg)")
    for ax, (name, label, attr, scale) in zip(axes[1:5], ESTIMATE_PANELS, strict=True):
        ax.plot(t, data[name], "r-", lw=1)
        if hasattr(truth, attr):
            ax.axhline(getattr(truth, attr) * scale, color="k", ls="--", lw=0.8)
        ax.set_ylabel(label)
    axes[5].plot(t, data["confidence"], "b-", lw=1)
    axes[5].axhline(0.5, color="k", ls=":", lw=0.8)
    axes[5].set_ylim(-0.05, 1.05)
    axes[5].set_ylabel("confidence")
    axes[5].set_xlabel("time (s)")
    if len(t) and (first is None or first > t[0]):
        end = first if first is not None else t[-1]
        for i, ax in enumerate(axes):
            ax.axvspan(t[0], end, color="0.85", zorder=0, label="no estimate yet" if i == 0 else None)
    axes[0].legend(loc="upper right", fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
