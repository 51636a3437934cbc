"""The settings of an irregular sea: a frozen, validated dataclass, and the CLI form ``jonswap:HS,TP,DIR,…``.

:class:`IrregularSea` is what a scenario's ``sea:`` section or a simulator flag resolves to; its
:meth:`IrregularSea.wave_field` builds the :class:`vessel.sea.irregular.IrregularWaves` (or calm water for
sea state 0). Degrees only in ``travel_dir_deg``; every other quantity is SI.

A NATO ``sea_state`` (the paper's Table I) fills Hs with the middle of its band and Tp with its most
probable modal period, unless ``hs_m`` / ``tp_s`` are given; sea states 0–1 have no modal period there,
so sea state 1 needs ``tp_s`` and sea state 0 is calm water.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from vessel.config import ConfigError, bounded, check_number, describe_range
from vessel.params import OtterParameters
from vessel.sea.irregular import IrregularWaves, hull_averaging_factor, synthesise
from vessel.sea.spectra import JONSWAP_GAMMA, nato_sea_state
from vessel.sea.waves import BREAKING_STEEPNESS, CalmWater

SPECTRA: tuple[str, ...] = ("jonswap", "pm")
DEFAULT_HS_M = 1.75  # the paper's wave height, used when neither hs_m nor sea_state is given
DEFAULT_TP_S = 6.0  # the paper's wave period
MAX_SEED = 2**32 - 1


def _choice(default: str, choices: tuple[str, ...], doc: str) -> str:
    """A text field restricted to ``choices`` (checked by ``vessel.config.from_mapping`` and here)."""
    return dataclasses.field(default=default, metadata={"choices": choices, "doc": doc})


@dataclass(frozen=True)
class IrregularSea:
    """An irregular sea from a spectrum: JONSWAP or Pierson–Moskowitz, long- or short-crested.

    ``n_components`` defaults to 200: over 10 seeds × 20 min of Hs 1.75 m, Tp 6 s, the Welch energy in
    0.1·ωp bands of 0.7–1.5 ωp stays within 9 % of the target with 200 components (worst band 8.6 %,
    ``tests/vessel/test_irregular_statistics.py``), but strays by up to 13 % with 100 (each Welch bin
    then holds less than one component). The plant compiles either size
    (``vessel.jit``). ``paper_roll_sign`` False (default) is the geometric surface-relative roll; True
    the paper's literal sign, as in ``RegularWaves``. ``travel_dir_deg`` −90 is the paper's West.
    ``start_s`` moves the sea's clock: the run's t = 0 meets the waves of the sea's t = ``start_s``, so an
    in-process run can fly the very stretch of sea a simulator run met later (its engage time over MAVLink).
    """

    spectrum: str = _choice("jonswap", SPECTRA, "jonswap or pm (Pierson–Moskowitz, γ = 1)")
    hs_m: float | None = bounded(None, 0.0, 30.0, "m", "significant wave height Hs (default: sea state "
                                  "mid-band, else 1.75)", lo_open=True)
    tp_s: float | None = bounded(None, 1.0, 30.0, "s", "peak period Tp (default: sea state modal, else 6)")
    gamma: float = bounded(JONSWAP_GAMMA, 1.0, 10.0, "", "JONSWAP peak enhancement γ (ignored for pm)")
    travel_dir_deg: float = bounded(-90.0, -360.0, 360.0, "deg", "mean direction the waves travel to (0 = N)")
    spreading_s: float = bounded(0.0, 0.0, None, "", "cos-2s spreading exponent s; 0 = long-crested")
    sea_state: int | None = bounded(None, 0, 8, "", "NATO sea state number (paper Table I)")
    n_components: int = bounded(200, 10, 5000, "", "number of wave components N")
    seed: int = bounded(7, 0, MAX_SEED, "", "random seed of frequencies, phases and directions")
    depth_m: float | None = bounded(None, 0.5, 1e4, "m", "water depth for dispersion (default: deep water)")
    start_s: float = bounded(0.0, -86400.0, 86400.0, "s", "the sea's own clock at the run's t = 0")
    paper_roll_sign: bool = False

    def __post_init__(self) -> None:
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if "lo" in f.metadata and value is not None:
                if f.type in ("int", "int | None") and (isinstance(value, bool) or not isinstance(value, int)):
                    raise ConfigError(f"{f.name}: expected an integer in [{f.metadata['lo']:d}, "
                                      f"{f.metadata['hi']:d}], got {value!r}")
                check_number(value, f.name, f.metadata)
        if self.spectrum not in SPECTRA:
            raise ConfigError(f"spectrum: {self.spectrum!r} is not one of {', '.join(SPECTRA)}")
        if self.sea_state == 1 and self.tp_s is None:
            raise ConfigError("tp_s: sea state 1 has no modal period in Table I; give tp_s in [1, 30] s")
        hs, tp = self.significant_height_m, self.peak_period_s
        steepness = hs / (9.81 * tp**2 / (2 * math.pi))
        if steepness > BREAKING_STEEPNESS:
            raise ConfigError(f"hs_m: {hs:g} m breaks at Tp {tp:g} s; allowed (0, "
                              f"{BREAKING_STEEPNESS * 9.81 * tp**2 / (2 * math.pi):.3g}] m (Hs/λp <= 1/7)")

    @property
    def significant_height_m(self) -> float:
        """Hs in m: given, else the middle of the sea state's band, else the paper's 1.75 m."""
        if self.hs_m is not None:
            return float(self.hs_m)
        if self.sea_state is not None:
            return nato_sea_state(self.sea_state)[0]
        return DEFAULT_HS_M

    @property
    def peak_period_s(self) -> float:
        """Tp in s: given, else the sea state's most probable modal period, else the paper's 6 s."""
        if self.tp_s is not None:
            return float(self.tp_s)
        if self.sea_state is not None:
            return nato_sea_state(self.sea_state)[1] or DEFAULT_TP_S
        return DEFAULT_TP_S

    @property
    def peak_frequency_rad_s(self) -> float:
        """ωp = 2π/Tp in rad/s."""
        return 2 * math.pi / self.peak_period_s

    @property
    def effective_gamma(self) -> float:
        """γ actually used: 1 for Pierson–Moskowitz."""
        return 1.0 if self.spectrum == "pm" else self.gamma

    def point_waves(self) -> IrregularWaves:
        """The sea at a point (what a wave staff measures), no hull averaging."""
        return synthesise(self.spectrum, self.significant_height_m, self.peak_period_s, self.effective_gamma,
                          math.radians(self.travel_dir_deg), self.spreading_s, self.n_components, self.seed,
                          self.depth_m, roll_sign=1.0 if self.paper_roll_sign else -1.0).advanced(self.start_s)

    def wave_field(self, params: OtterParameters | None = None) -> IrregularWaves | CalmWater:
        """The wave field a hull with ``params`` rides on (averaged over its waterplane); calm for sea state 0.

        Without ``params`` the point sea is returned. See ``vessel.sea.irregular.hull_averaging_factor``.
        """
        if self.sea_state == 0 and self.hs_m is None:
            return CalmWater(roll_sign=1.0 if self.paper_roll_sign else -1.0)
        sea = self.point_waves()
        if params is None:
            return sea
        return sea.attenuated(hull_averaging_factor(sea.wavenumber_rad_m, params.length, params.beam))


def field_range(name: str) -> str:
    """The allowed range of an IrregularSea field as text, e.g. '(0, 30] m'."""
    meta = next(f.metadata for f in dataclasses.fields(IrregularSea) if f.name == name)
    return describe_range(meta)


SPEC_FORMS = "jonswap:HS,TP,DIR[,GAMMA[,SPREADING]] or pm:HS,TP,DIR"
_SPEC_FIELDS = ("hs_m", "tp_s", "travel_dir_deg", "gamma", "spreading_s")
_SPEC_NAMES = ("HS", "TP", "DIR", "GAMMA", "SPREADING")


def parse_sea_spec(text: str, flag: str = "--sea", seed: int = 7, n_components: int = 200,
                   depth_m: float | None = None) -> IrregularSea:
    """Parse ``jonswap:HS,TP,DIR[,GAMMA[,SPREADING]]`` or ``pm:HS,TP,DIR`` (m, s, degrees) into an IrregularSea.

    Errors are one-line ConfigErrors naming ``flag``, the item and its allowed range.
    """
    name, sep, rest = text.partition(":")
    name = name.strip().lower()
    if not sep or name not in SPECTRA:
        raise ConfigError(f"{flag}: {text!r} is not of the form {SPEC_FORMS}")
    items = [item.strip() for item in rest.split(",")]
    allowed = 5 if name == "jonswap" else 3
    if not 3 <= len(items) <= allowed:
        raise ConfigError(f"{flag}: {text!r} is not of the form {SPEC_FORMS}")
    values: dict[str, float] = {}
    for item, field_name, label in zip(items, _SPEC_FIELDS, _SPEC_NAMES, strict=False):
        try:
            number = float(item)
        except ValueError:
            raise ConfigError(f"{flag} {label}: {item!r} is not a number; allowed {field_range(field_name)}") \
                from None
        meta = next(f.metadata for f in dataclasses.fields(IrregularSea) if f.name == field_name)
        check_number(number, f"{flag} {label}", meta)
        values[field_name] = number
    try:
        return IrregularSea(spectrum=name, seed=seed, n_components=n_components, depth_m=depth_m, **values)
    except ConfigError as exc:
        raise ConfigError(f"{flag}: {exc}") from None
