"""The paper's figures for one run: the x–y path over the wave crests, and stacked time series."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_path(path: Path, north: np.ndarray, east: np.ndarray, waypoint: tuple[float, float], radius: float,
              waves, t_end: float, title: str) -> None:
    """Path as on a chart (east right, north up) over the sea surface at the end of the run."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 6.0))
    lo_e = min(east.min(), waypoint[1]) - 15
    hi_e = max(east.max(), waypoint[1]) + 15
    lo_n = min(north.min(), waypoint[0]) - 15
    hi_n = max(north.max(), waypoint[0]) + 15
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
        fig.colorbar(mesh, ax=ax, label=f"sea surface at t = {t_end:.1f} s (m); lines: {lines}")
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
