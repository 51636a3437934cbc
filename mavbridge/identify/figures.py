"""The page's pictures: each fit drawn against the data it came from, with the base model's and the identified
model's response beside the log's (PNG bytes, matplotlib's Agg backend). Degrees at this edge."""

from __future__ import annotations

import io
import math
from typing import Any

import numpy as np

from mavbridge.identify.ambient import ArFit, prepared
from mavbridge.identify.analyse import Identification
from mavbridge.identify.decay import DecayFit, decay_curve
from mavbridge.identify.model import linear_mode, plant_speed
from mavbridge.identify.series import Stretch
from mavbridge.identify.yaw import Nomoto
from vessel import OtterParameters

DEG = math.degrees(1.0)


def _png(fig: Any) -> bytes:
    import matplotlib.pyplot as plt

    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=90)
    plt.close(fig)
    return buffer.getvalue()


def _figure(rows: int = 1, cols: int = 1, size: tuple[float, float] = (10, 3.4)) -> tuple[Any, Any]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(rows, cols, figsize=size, constrained_layout=True, squeeze=False)


def decay_figure(axis: str, decays: list[tuple[DecayFit, np.ndarray, np.ndarray]], base: OtterParameters,
                 identified: OtterParameters, signal: str = "") -> bytes:
    """Up to three decays: the log, the fit, and the base and identified models' linear decays from the same start;
    ``signal`` what the decays are of (the axis's angle, or its rate: "roll rate")."""
    shown = decays[:3]
    fig, axes = _figure(1, len(shown), (4 * len(shown) + 2, 3.2))
    for ax, (fit, t, y) in zip(axes[0], shown, strict=True):
        tau = np.linspace(0, t[-1] - t[0], 300)
        ax.plot(t - t[0], y * DEG, ".", ms=3, color="k", label="log")
        ax.plot(tau, fit.curve(tau + t[0]) * DEG, label=f"fit T={fit.period_s:.2f} s ζ={fit.zeta:.2f}")
        for name, p, style in (("base", base, "--"), ("identified", identified, ":")):
            omega, zeta = linear_mode(p, axis)
            ax.plot(tau, decay_curve(np.array([fit.amplitude, zeta, omega, fit.phase, fit.offset]), tau) * DEG,
                    style, label=f"{name} model T={2 * math.pi / omega:.2f} s")
        ax.set_xlabel(f"s from {t[0]:.1f} s")
        ax.set_ylabel(f"{signal or axis} [deg{'/s' if signal.endswith('rate') else ''}]")
        ax.legend(fontsize="small")
    return _png(fig)


def _welch(series: list[np.ndarray], dt: float, n: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Averaged Hann periodogram (one-sided PSD) of the series' segments of ``n`` samples."""
    window = np.hanning(n)
    spectra = [np.abs(np.fft.rfft(window * (y[k:k + n] - y[k:k + n].mean()))) ** 2
               for y in series for k in range(0, y.size - n + 1, n // 2)]
    f = np.fft.rfftfreq(n, dt)
    if not spectra:
        return f, np.full(f.size, np.nan)
    return f, 2 * dt * np.mean(spectra, axis=0) / np.sum(window**2)


def ambient_figure(axis: str, fit: ArFit, items: list[Stretch], base: OtterParameters,
                   identified: OtterParameters) -> bytes:
    """The log's spectrum, the AR fit's, and the base and identified models' responses to broad excitation."""
    f, psd = _welch(prepared(items), fit.dt)
    fig, axes = _figure()
    ax = axes[0][0]
    band = (f > 0.1) & (f < min(3.0, 0.5 / fit.dt))
    ax.semilogy(f[band], psd[band] * DEG**2, color="k", label="log (averaged periodogram)")
    ar = fit.spectrum(f[band])
    ax.semilogy(f[band], ar * DEG**2, label=f"AR({fit.coeffs.size}) fit: T={2 * math.pi / fit.omega_n:.2f} s "
                                            f"ζ={fit.zeta:.2f}")
    w = 2 * math.pi * f[band]
    for name, p, style in (("base", base, "--"), ("identified", identified, ":")):
        omega, zeta = linear_mode(p, axis)
        h = 1 / np.abs(omega**2 - w**2 + 2j * zeta * omega * w) ** 2
        ax.semilogy(f[band], h / h.max() * ar.max() * DEG**2, style,
                    label=f"{name} model (scaled) T={2 * math.pi / omega:.2f} s ζ={zeta:.2f}")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel(f"{axis} PSD [deg²/Hz]")
    ax.legend(fontsize="small")
    return _png(fig)


CURVE_OUTPUTS = (0.2, 0.35, 0.5, 0.65, 0.8, 1.0)  # motor outputs at which each model's steady speed is drawn


def model_speed_curve(p: OtterParameters) -> tuple[np.ndarray, np.ndarray]:
    """(thrust fractions, steady speeds m/s) of the model measured on ``vessel.Plant`` at CURVE_OUTPUTS (the points
    where it diverges left out): the model's own curve, which neither ``max_speed`` alone nor u = U·s gives where a
    payload's weight pushes the hull (``payload_mass`` is identified in place of ``max_speed`` there)."""
    got = [(o * o, v) for o in CURVE_OUTPUTS if (v := plant_speed(p, o)) is not None]
    return np.array([0.0] + [f for f, _ in got]), np.array([0.0] + [v for _, v in got])


def surge_figure(result: Identification, base: OtterParameters, identified: OtterParameters) -> bytes:
    """Steady windows' speed against the command, with the base and identified models' steady speeds."""
    s = result.surge
    points = s["points"]
    fig, axes = _figure()
    ax = axes[0][0]
    ax.plot([p.command for p in points], [p.speed_m_s for p in points], "o", ms=4, color="k", label="steady windows")
    for name, params, style in (("base", base, "--"), ("identified", identified, "-")):
        fractions, speeds = model_speed_curve(params)
        command = fractions * s["full_forward"] if s["kind"] == "tau" else np.sqrt(fractions) * s["full_forward"]
        said = f"{speeds[-1]:.2f} m/s at full" if fractions[-1] == 1.0 else "diverges before full command"
        ax.plot(command, speeds, style, marker=".", label=f"{name} model ({said})")
    ax.set_xlabel(f"{s['label']} [{s['unit']}]")
    ax.set_ylabel("speed [m/s]")
    ax.legend(fontsize="small")
    return _png(fig)


def yaw_figure(model: Nomoto, items: list[Stretch], label: str, base_T: float, base_K: float | None) -> bytes:
    """The longest stretch's yaw rate beside the Nomoto model's from the command (and the base model's T)."""
    s = max(items, key=lambda x: x.duration_s)
    keep = s.t <= s.t[0] + 180.0
    t, delta, r = s.t[keep], s.y[keep, 0], s.y[keep, 1]
    fig, axes = _figure(2, 1, (10, 5))
    ax = axes[0][0]
    ax.plot(t, r * DEG, color="k", lw=1, label="log")
    ax.plot(t, model.simulate(delta, float(r[0])) * DEG, label=f"identified K, T={model.T:.2f} s")
    base = Nomoto(base_K if base_K is not None else model.K, base_T, model.r0 if base_K is None else 0.0, model.dt)
    ax.plot(t, base.simulate(delta, float(r[0])) * DEG, "--",
            label=f"base model T={base_T:.2f} s" + ("" if base_K is not None else " (identified K)"))
    ax.set_ylabel("yaw rate [deg/s]")
    ax.legend(fontsize="small")
    axes[1][0].plot(t, delta)
    axes[1][0].set_ylabel(label)
    axes[1][0].set_xlabel("log time [s]")
    return _png(fig)
