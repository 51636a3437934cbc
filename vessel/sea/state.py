"""The ``sea`` and ``start`` sections of a world (see ``vessel.world``), as scenario YAML spells them.

``SeaState`` (waves and current) and ``Start`` (initial pose and velocity) are read by the one world
loader for both ``sim-vehicle --scenario`` and ``mavbridge``; degrees only in fields whose names end in
``_deg``, radians inside. ``SeaState``'s defaults are the paper's sea (the ``paper`` preset), so a partial
``sea:`` section means "the paper's sea, except ...".

The wave field is built in one place only, :meth:`SeaState.waves`; everything else (simulator plant,
in-process plants, NMPC truth, plots) calls it. An irregular sea is the optional ``spectrum`` field (an
``IrregularSea``: JONSWAP/PM, Hs, Tp, γ, direction, spreading, N, seed, or a NATO sea state); when it is
set the regular-wave fields are ignored and ``waves()`` returns the irregular field averaged over the
hull's waterplane. Without it the regular fields (and their defaults, the paper's sea) are used exactly
as before, so the paper's runs stay bit-identical. :meth:`SeaState.with_waves_of` copies either kind of
waves, and the current is unaffected.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from vessel.config import bounded
from vessel.dynamics import OceanCurrent
from vessel.params import PARAMETER_SETS, OtterParameters, otter_parameters
from vessel.sea.irregular import IrregularWaves
from vessel.sea.irregular_sea import IrregularSea
from vessel.sea.waves import CalmWater, RegularWaves
from vessel.sea.wind import Wind, check_not_blocked, doppler_frequency


@dataclass(frozen=True)
class SeaState:
    """Regular waves (height 0 is calm water) or an irregular ``spectrum``, a uniform current and a wind.

    The defaults are the paper's sea (regular waves, no current). ``spectrum`` set: an irregular sea,
    and the regular-wave fields are not used.
    """

    height_m: float = bounded(1.75, 0.0, 30.0, "m", "crest-to-trough height H")
    length_m: float = bounded(35.0, 1.0, 2000.0, "m", "wavelength λ")
    period_s: float = bounded(6.0, 0.5, 60.0, "s", "wave period T")
    travel_dir_deg: float = bounded(-90.0, -360.0, 360.0, "deg", "direction the waves travel to (0 = North)")
    current_speed_mps: float = bounded(0.0, 0.0, 5.0, "m/s", "uniform current speed")
    current_dir_deg: float = bounded(0.0, -360.0, 360.0, "deg", "direction the current flows to")
    wind_speed_mps: float = bounded(0.0, 0.0, 40.0, "m/s", "mean wind speed (ArduPilot SITL's SIM_WIND_SPD)")
    wind_from_deg: float = bounded(0.0, -360.0, 360.0, "deg", "direction the wind blows from, 0 = from North "
                                   "(ArduPilot SITL's SIM_WIND_DIR)")
    wind_gust_mps: float = bounded(0.0, 0.0, 20.0, "m/s", "gust standard deviation (first order, 5 s)")
    wind_seed: int = bounded(0, 0, 2**31 - 1, "", "seed of the gusts")
    spectrum: IrregularSea | None = None

    def waves(self, params: OtterParameters | None = None) -> RegularWaves | IrregularWaves | CalmWater:
        """The wave field (radians inside): the only place a SeaState becomes one.

        An irregular sea is averaged over the waterplane of ``params`` (default: the published Otter);
        regular waves do not depend on the hull.
        """
        if self.spectrum is not None:
            field = self.spectrum.wave_field(params or otter_parameters(PARAMETER_SETS[0]))
            return field if isinstance(field, CalmWater) else self._on_current(field)
        if self.height_m == 0:
            return CalmWater()
        chi = math.radians(self.travel_dir_deg)
        period = self.period_s
        if self.current_speed_mps > 0:  # the waves ride on the current: a fixed observer sees ω + k·U_c
            k, beta = 2 * math.pi / self.length_m, math.radians(self.current_dir_deg)
            check_not_blocked(2 * math.pi / period, k, chi, self.current_speed_mps, beta, "sea.current_speed_mps")
            omega = doppler_frequency(2 * math.pi / period, k, chi, self.current_speed_mps, beta)
            period = 2 * math.pi / float(omega)
        return RegularWaves(self.height_m, self.length_m, period, chi)

    def _on_current(self, field: IrregularWaves) -> IrregularWaves:
        """An irregular sea's components each shifted by k·U_c (unchanged without a current)."""
        if self.current_speed_mps == 0:
            return field
        beta = math.radians(self.current_dir_deg)
        check_not_blocked(field.frequency_rad_s, field.wavenumber_rad_m, field.direction_rad, self.current_speed_mps,
                          beta, "sea.current_speed_mps")
        omega = doppler_frequency(field.frequency_rad_s, field.wavenumber_rad_m, field.direction_rad,
                                  self.current_speed_mps, beta)
        start_s = self.spectrum.start_s if self.spectrum is not None else 0.0  # the field was advanced to it at ω:
        phase = np.mod(field.phase_rad + (omega - field.frequency_rad_s) * start_s, 2 * math.pi)  # now at ω + k·U
        return IrregularWaves(field.amplitude_m, omega, field.wavenumber_rad_m, field.direction_rad, phase,
                              field.roll_sign)

    def current(self) -> OceanCurrent:
        """The ocean current."""
        return OceanCurrent(self.current_speed_mps, math.radians(self.current_dir_deg))

    def wind(self) -> Wind | None:
        """The wind (None in still air: the plant then has no wind terms)."""
        wind = Wind(self.wind_speed_mps, math.radians(self.wind_from_deg), self.wind_gust_mps, seed=self.wind_seed)
        return None if wind.calm else wind

    def with_waves_of(self, other: SeaState) -> SeaState:
        """This sea's current with ``other``'s waves (``sim-vehicle --sea NAME`` over a scenario's sea)."""
        current = {name: getattr(self, name) for name in CURRENT_FIELDS}
        return dataclasses.replace(other, **current)

    def describe(self) -> str:
        """One line for logs and start-up messages, e.g. 'regular waves H 1.75 m, λ 35 m, T 6 s to -90°'."""
        if self.spectrum is not None:
            waves = describe_irregular(self.spectrum)
        else:
            waves = "calm water" if self.height_m == 0 else (
                f"regular waves H {self.height_m:g} m, λ {self.length_m:g} m, T {self.period_s:g} s "
                f"travelling to {self.travel_dir_deg:g}°")
        if self.current_speed_mps > 0:
            waves += f"; current {self.current_speed_mps:g} m/s to {self.current_dir_deg:g}°"
        if self.wind_speed_mps > 0 or self.wind_gust_mps > 0:
            waves += f"; wind {self.wind_speed_mps:g} m/s from {self.wind_from_deg:g}°"
            waves += f", gusts σ {self.wind_gust_mps:g} m/s" if self.wind_gust_mps > 0 else ""
        return waves


CURRENT_FIELDS = ("current_speed_mps", "current_dir_deg", "wind_speed_mps", "wind_from_deg", "wind_gust_mps",
                  "wind_seed")  # what --sea NAME keeps of a scenario's sea: all but the waves


def describe_irregular(sea: IrregularSea) -> str:
    """One line for an irregular sea, e.g. 'jonswap Hs 1.75 m, Tp 6 s, γ 3.3, long-crested to -90°, N 200, seed 7'."""
    if sea.sea_state == 0 and sea.hs_m is None:
        return "calm water (sea state 0)"
    gamma = f", γ {sea.effective_gamma:g}" if sea.spectrum == "jonswap" else ""
    crests = "long-crested" if sea.spreading_s == 0 else f"short-crested (s {sea.spreading_s:g})"
    state = f"sea state {sea.sea_state}: " if sea.sea_state is not None else ""
    return (f"{state}{sea.spectrum} Hs {sea.significant_height_m:g} m, Tp {sea.peak_period_s:g} s{gamma}, "
            f"{crests} to {sea.travel_dir_deg:g}°, N {sea.n_components}, seed {sea.seed}"
            + (f", from the sea's t = {sea.start_s:g} s" if sea.start_s else ""))


@dataclass(frozen=True)
class Start:
    """Initial pose and body velocity."""

    north_m: float = bounded(0.0, -1e5, 1e5, "m")
    east_m: float = bounded(0.0, -1e5, 1e5, "m")
    heading_deg: float = bounded(90.0, -360.0, 360.0, "deg", "ψ, 0 = North, 90 = East")
    surge_mps: float = bounded(0.0, -5.0, 10.0, "m/s", "u")
    sway_mps: float = bounded(0.0, -5.0, 5.0, "m/s", "v")
    yaw_rate_deg_s: float = bounded(0.0, -180.0, 180.0, "deg/s", "r")

    def state(self) -> np.ndarray:
        """The 12 rigid-body states η = [N, E, D, φ, θ, ψ] (NED, rad), ν = [u, v, w, p, q, r] (body)."""
        x = np.zeros(12)
        x[0], x[1], x[5] = self.north_m, self.east_m, math.radians(self.heading_deg)
        x[6], x[7], x[11] = self.surge_mps, self.sway_mps, math.radians(self.yaw_rate_deg_s)
        return x
