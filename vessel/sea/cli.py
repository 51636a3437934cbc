"""`vessel sea`: record an irregular sea at a fixed point, and compare the record with what was asked for.

Writes ``t_s,elevation_m,slope_n_rad,slope_e_rad`` (the point sea a wave staff would see, not averaged
over a hull; slopes are the NED slope-angle vector of ``vessel.sea.waves.WaveField``) and prints Hm0
(4·√m0 of the record) and Tp (peak of a Welch-averaged periodogram) beside the requested Hs and Tp.
``--plot`` draws the record and its spectrum over the target spectrum. Bad input: one line naming the
flag and its allowed range, exit code 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vessel.argtypes import check_output_file, plot_formats
from vessel.config import ConfigError, bounded, check_number, describe_range
from vessel.sea.analysis import default_segment, hm0, peak_period, welch
from vessel.sea.irregular_sea import SPECTRA, IrregularSea
from vessel.sea.spectra import spectrum as target_spectrum

EXIT_USAGE = 2
MAX_SAMPLES = 5_000_000  # keeps one record (and its CSV) within a few hundred MB

# flag -> (IrregularSea field, type); degrees only in --dir (travel_dir_deg)
SEA_FLAGS: dict[str, tuple[str, type]] = {
    "--hs": ("hs_m", float), "--tp": ("tp_s", float), "--gamma": ("gamma", float),
    "--dir": ("travel_dir_deg", float), "--spreading": ("spreading_s", float),
    "--sea-state": ("sea_state", int), "--seed": ("seed", int), "--components": ("n_components", int),
    "--depth": ("depth_m", float),
}


@dataclass(frozen=True)
class RecordSettings:
    """Where and how long the sea is sampled."""

    duration_s: float = bounded(1200.0, 0.0, 86400.0, "s", "record length", lo_open=True)
    dt_s: float = bounded(0.1, 0.0, 10.0, "s", "sample interval", lo_open=True)
    north_m: float = bounded(0.0, -1e5, 1e5, "m", "NED north of the sampling point")
    east_m: float = bounded(0.0, -1e5, 1e5, "m", "NED east of the sampling point")


RECORD_FLAGS = {"--duration": "duration_s", "--dt": "dt_s", "--north": "north_m", "--east": "east_m"}


def add_parser(sub: Any) -> None:
    """Register the `sea` subcommand on the `vessel` subparsers."""
    p = sub.add_parser("sea", help="record an irregular sea at a fixed point (CSV, Hm0/Tp, plot)",
                       description=__doc__.splitlines()[0])
    p.add_argument("--spectrum", choices=SPECTRA, default="jonswap", help="jonswap (default) or pm (Pierson–Moskowitz)")
    helps = {"--hs": "significant height Hs in m, (0, 30] (default: sea state mid-band, else 1.75)",
             "--tp": "peak period Tp in s, [1, 30] (default: sea state modal period, else 6)",
             "--gamma": "JONSWAP peak enhancement, [1, 10] (default 3.3)",
             "--dir": "direction the waves travel to, deg, 0 = North, [-360, 360] (default -90: West)",
             "--spreading": "cos-2s spreading exponent s >= 0; 0 = long-crested (default)",
             "--sea-state": "NATO sea state of the paper's Table I, [0, 8] (default: none: --hs and --tp, else 1.75 m "
                            "and 6 s)",
             "--seed": "integer seed of frequencies, phases and directions (default 7)",
             "--components": "number of wave components, [10, 5000] (default 200)",
             "--depth": "water depth in m for dispersion, [0.5, 10000] (default deep water)",
             "--duration": "record length in s, (0, 86400] (default 1200)",
             "--dt": "sample interval in s, (0, 10] (default 0.1)",
             "--north": "NED north of the sampling point in m (default 0)",
             "--east": "NED east of the sampling point in m (default 0)"}
    for flag, text in helps.items():
        p.add_argument(flag, metavar=flag.lstrip("-").replace("-", "_").upper(), help=text)
    p.add_argument("--csv", metavar="FILE", required=True, help="write t_s,elevation_m,slope_n_rad,slope_e_rad")
    p.add_argument("--plot", metavar="FILE.png", help="draw the record and its spectrum against the target, the "
                   "format by the extension (.png, .pdf, .svg, ...; default: none)")


def _parse(text: str, flag: str, meta: Any, kind: type) -> float | int:
    """A flag's text as a number of ``kind`` within the field's range, or a one-line ConfigError."""
    if kind is int:
        try:
            value: float | int = int(text)
        except ValueError:
            raise ConfigError(f"{flag}: expected an integer in [{meta['lo']:d}, {meta['hi']:d}], got {text!r}") \
                from None
        if not meta["lo"] <= value <= meta["hi"]:
            raise ConfigError(f"{flag}: {value} is outside the allowed range [{meta['lo']:d}, {meta['hi']:d}]")
        return value
    try:
        value = float(text)
    except ValueError:
        raise ConfigError(f"{flag}: {text!r} is not a number; allowed {describe_range(meta)}") from None
    if not math.isfinite(value):
        raise ConfigError(f"{flag}: {text} is not finite; allowed {describe_range(meta)}")
    return check_number(value, flag, meta)


def _metadata(cls: type) -> dict[str, Any]:
    """Field name -> range metadata of a settings dataclass (for messages in terms of the flags)."""
    return {f.name: f.metadata for f in dataclasses.fields(cls)}


def settings_from_args(args: argparse.Namespace) -> tuple[IrregularSea, RecordSettings]:
    """Validated sea and record settings from the flags; errors name the flag and its range."""
    sea_meta, record_meta = _metadata(IrregularSea), _metadata(RecordSettings)
    values: dict[str, Any] = {"spectrum": args.spectrum}
    for flag, (name, kind) in SEA_FLAGS.items():
        text = getattr(args, flag.lstrip("-").replace("-", "_"))
        if text is not None:
            values[name] = _parse(text, flag, sea_meta[name], kind)
    record: dict[str, float] = {}
    for flag, name in RECORD_FLAGS.items():
        text = getattr(args, flag.lstrip("-"))
        if text is not None:
            record[name] = float(_parse(text, flag, record_meta[name], float))
    try:
        sea = IrregularSea(**values)
    except ConfigError as exc:
        message = str(exc)
        for flag, (name, _) in SEA_FLAGS.items():
            message = message.replace(name, flag)
        raise ConfigError(message) from None
    settings = RecordSettings(**record)
    samples = math.floor(settings.duration_s / settings.dt_s + 1e-9) + 1
    if samples < 64 or samples > MAX_SAMPLES:
        raise ConfigError(f"--duration/--dt: {samples} samples; allowed [64, {MAX_SAMPLES}] "
                          f"(duration / dt + 1)")
    return sea, settings


def record_sea(sea: IrregularSea, settings: RecordSettings) -> dict[str, np.ndarray]:
    """t (s), elevation (m) and NED slope angles (rad) of the point sea at the sampling point."""
    samples = math.floor(settings.duration_s / settings.dt_s + 1e-9) + 1
    t = np.arange(samples) * settings.dt_s
    waves = sea.wave_field()
    north = np.full_like(t, settings.north_m)
    east = np.full_like(t, settings.east_m)
    zeta = np.broadcast_to(waves.elevation(north, east, t), t.shape)
    a_n, a_e = (np.broadcast_to(a, t.shape) for a in waves.slope_angles(north, east, t))
    return {"t_s": t, "elevation_m": zeta, "slope_n_rad": a_n, "slope_e_rad": a_e}


def write_csv(record: dict[str, np.ndarray], path: str | Path) -> None:
    """The record as CSV with a header line."""
    data = np.column_stack(list(record.values()))
    np.savetxt(path, data, delimiter=",", header=",".join(record), comments="", fmt="%.9g")


def _describe(sea: IrregularSea, settings: RecordSettings, segment: int) -> list[str]:
    """Two lines saying which sea was drawn and how it was sampled."""
    crest = "long-crested" if sea.spreading_s == 0 else f"cos-2s spreading s {sea.spreading_s:g}"
    depth = "deep water" if sea.depth_m is None else f"depth {sea.depth_m:g} m"
    gamma = f", gamma {sea.effective_gamma:g}" if sea.spectrum == "jonswap" else ""
    state = f", sea state {sea.sea_state}" if sea.sea_state is not None else ""
    return [f"sea: {sea.spectrum}{state}, Hs {sea.significant_height_m:g} m, Tp {sea.peak_period_s:g} s{gamma}, "
            f"travelling towards {sea.travel_dir_deg:g} deg, {crest}, {sea.n_components} components, "
            f"seed {sea.seed}, {depth}",
            f"record: {settings.duration_s:g} s at dt {settings.dt_s:g} s at N {settings.north_m:g} m, "
            f"E {settings.east_m:g} m; Welch segments of {segment * settings.dt_s:g} s "
            f"(bin {2 * math.pi / (segment * settings.dt_s):.4g} rad/s)"]


def run(args: argparse.Namespace) -> int:
    """The `vessel sea` command; returns the exit code."""
    try:
        sea, settings = settings_from_args(args)
        check_output_file(args.csv, "--csv")  # before the record is drawn: never compute, then fail on the name
        if args.plot:
            check_output_file(args.plot, "--plot", plot_formats())
    except ConfigError as exc:
        print(f"vessel sea: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    record = record_sea(sea, settings)
    zeta = record["elevation_m"]
    segment = default_segment(zeta.size)
    omega, density = welch(zeta, settings.dt_s, segment)
    calm = not np.any(zeta)
    for line in _describe(sea, settings, segment):
        print(line)
    tp_record = f"{peak_period(omega, density):10.3f}" if not calm else f"{'-':>10}"
    print(f"  {'':<10} {'requested':>10} {'record':>10}")
    hs_requested = 0.0 if calm and sea.hs_m is None else sea.significant_height_m
    print(f"  {'Hm0 (m)':<10} {hs_requested:10.3f} {hm0(zeta):10.3f}")
    print(f"  {'Tp (s)':<10} {sea.peak_period_s:10.3f} {tp_record}")
    try:
        write_csv(record, args.csv)
        print(f"csv:  {args.csv}")
        if args.plot:
            plot_record(record, omega, density, sea, args.plot)
            print(f"plot: {args.plot}")
    except OSError as exc:
        print(f"vessel sea: error: cannot write {exc.filename}: {exc.strerror}", file=sys.stderr)
        return 1
    return 0


def plot_record(record: dict[str, np.ndarray], omega: np.ndarray, density: np.ndarray, sea: IrregularSea,
                path: str | Path) -> None:
    """PNG: the elevation record over time, and its Welch spectrum against the target S(ω)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 7))
    top.plot(record["t_s"], record["elevation_m"], lw=0.6)
    top.set(xlabel="t (s)", ylabel="elevation ζ (m)", title="irregular sea at a fixed point")
    wp = sea.peak_frequency_rad_s
    shown = omega <= 4 * wp
    bottom.plot(omega[shown], density[shown], label="record (Welch)")
    fine = np.linspace(0.3 * wp, 4 * wp, 800)
    if np.any(record["elevation_m"]):
        bottom.plot(fine, target_spectrum(sea.spectrum, fine, sea.significant_height_m, sea.peak_period_s,
                                          sea.effective_gamma), "--", label="target")
    bottom.set(xlabel="ω (rad/s)", ylabel="S(ω) (m²·s/rad)")
    bottom.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
