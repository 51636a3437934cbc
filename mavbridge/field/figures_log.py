"""What a log holds over time, drawn where it holds it: heading, speed, shaft speeds, the controller's forces
and the distance to its target (PNG bytes, matplotlib's Agg).

A panel is drawn only for what the trial has samples of (no empty boxes): heading from the attitude's yaw with
the course over ground and the yaw setpoint where logged; speed over ground from the track; the shaft speeds
``n1``/``n2`` (rpm), ``tau_X`` (N) and ``tau_N`` (N·m), and the distance to the target (m), as the Otter API logs
them (NAMED_VALUE_FLOAT in the trial). Headings are drawn as points in 0..360° (no line jumps at north).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mavbridge.field.figures import png, pyplot, thin
from mavbridge.field.trial import Trial


def _heading(ax: Any, trial: Trial) -> None:
    t, yaw = thin(trial.attitude[:, 0], np.degrees(trial.attitude[:, 3]) % 360.0)
    ax.plot(t, yaw, ".", ms=1.5, color="k", label="heading (yaw)")
    if trial.course.size:
        tc, course = thin(trial.course[:, 0], trial.course[:, 1] % 360.0)
        ax.plot(tc, course, ".", ms=1.5, color="tab:blue", label="course over ground")
    if "yaw_sp" in trial.named:
        ts, setpoint = thin(trial.named["yaw_sp"][:, 0], np.degrees(trial.named["yaw_sp"][:, 1]) % 360.0)
        ax.plot(ts, setpoint, ".", ms=1.5, color="tab:red", label="yaw setpoint")
    ax.set_ylim(0, 360)
    ax.set_yticks([0, 90, 180, 270, 360])
    ax.set_ylabel("heading (deg)")


def _series(ax: Any, trial: Trial, names: tuple[tuple[str, str], ...], label: str) -> None:
    for name, legend in names:
        if name in trial.named:
            t, v = thin(trial.named[name][:, 0], trial.named[name][:, 1])
            ax.plot(t, v, "-", lw=0.7, label=legend)
    ax.set_ylabel(label)


def panels(trial: Trial) -> list[tuple[str, Any]]:
    """(what, how to draw it) of the panels the trial has data for, in order."""
    out: list[tuple[str, Any]] = [("heading", lambda ax: _heading(ax, trial))]
    if trial.track.size:
        def speed(ax: Any) -> None:
            t, v = thin(trial.track[:, 0], trial.track[:, 3])
            ax.plot(t, v, "-", lw=0.7, color="k", label="speed over ground")
            ax.set_ylabel("speed (m/s)")
        out.append(("speed", speed))
    groups = ((("n1", "n1"), ("n2", "n2")), "shaft speed (rpm)"), ((("tau_X", "τ_X (N)"),), "surge force (N)"), \
        ((("tau_N", "τ_N (N·m)"),), "yaw moment (N·m)"), ((("tgt_dist", "distance to target"),), "to target (m)")
    for names, label in groups:
        if any(name in trial.named for name, _ in names):
            out.append((label, lambda ax, names=names, label=label: _series(ax, trial, names, label)))
    return out


def log_figure(trial: Trial) -> bytes:
    """The panels of ``panels`` stacked over the log's time."""
    plt = pyplot()
    drawn = panels(trial)
    fig, axes = plt.subplots(len(drawn), 1, sharex=True, figsize=(9.0, 1.9 * len(drawn) + 0.6), squeeze=False)
    for ax, (_, draw) in zip(axes[:, 0], drawn, strict=True):
        draw(ax)
        ax.grid(alpha=0.3)
        if len(ax.get_legend_handles_labels()[1]) > 1:
            ax.legend(loc="upper right", fontsize=7, markerscale=4)
    axes[-1, 0].set_xlabel("time (s, " + ("autopilot clock" if trial.info.format != "otter-csv"
                                           else "since the first row") + ")")
    return png(fig)


def target_on_path(ax: Any, trial: Trial) -> None:
    """The target's path (dashed) and where it was last, with the boat's distance to it then, on a path plot."""
    if not trial.targets.size:
        return
    _, north, east = thin(trial.targets[:, 0], trial.targets[:, 1], trial.targets[:, 2])
    ax.plot(east, north, "--", color="tab:orange", lw=1.0, label="target")
    ax.plot(east[-1], north[-1], "D", color="tab:orange", ms=5)
    if trial.track.size:
        i = int(np.argmin(np.abs(trial.track[:, 0] - trial.targets[-1, 0])))
        d = math.hypot(trial.track[i, 1] - trial.targets[-1, 1], trial.track[i, 2] - trial.targets[-1, 2])
        ax.plot([trial.track[i, 2], east[-1]], [trial.track[i, 1], north[-1]], ":", color="tab:orange", lw=0.8)
        ax.annotate(f"{d:.1f} m to target at t = {trial.targets[-1, 0]:.0f} s", (east[-1], north[-1]),
                    textcoords="offset points", xytext=(6, -10), fontsize=8, color="tab:orange")
