"""The phase-resolved wave bank as a wave source: the estimator and a ``PhasePredictor`` watching the same motion.

``PredictedSource`` is the estimator the loop already has (a regular wave when confident, and the sea's slope
statistics) with a ``PhasePredictor`` fed every motion sample it is fed. ``BankFeed`` runs once per control step:
when the predictor is confident ``lead_s`` ahead (1 s by default) the NMPC gets K components with absolute
phases on the autopilot clock and plans on them instead of the regular wave (both at once would count the
dominant wave twice); otherwise a zero bank and, exactly as on the estimate alone, the regular wave or nothing.
The K are, by ``select``, the fit compressed over the NMPC's horizon (``bank_compress``, default) or its K
components of most slope energy (``bank_arrays(K)``): in the JONSWAP scenario those hold a small share of the
slope (the strongest 12 of the true sea 14 %; along a 4 s path their skill is about 0), the compressed 12 nearly
all of it. The statistics term (``roll_spread``) stays on in both cases:
with the bank in use it carries the part of the sea the bank does not explain, ``spread_mode``:

* ``full``: the sea's whole slope covariance (as if nothing were explained: the bank then plans on the crests
  it sees, the statistics term keeps the heading preference of the whole sea);
* ``residual``: the covariance times 1 − the predictor's measured skill at ``lead_s`` (the unexplained share);
* ``none``: no statistics term while the bank is in use.

The bank fades out of the model's horizon where the predictor's measured skill falls to a half (``fade``,
``nmpc.wave_bank``): beyond that its crests are guesses. Every change of state is said (``notes``) and counted
(``bank_fraction`` in the run's metrics).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from mavbridge.waves.phase.bank_compress import compress
from mavbridge.waves.phase.predictor import PhasePredictor, PredictorSettings
from mavbridge.waves.source import MotionSample, WaveEstimate, sea_spread
from mavbridge.waves.window_buffer import GAP_S, TRACK_PULL_S
from vessel.sea.irregular import IrregularWaves

NO_FADE_S = 1e12  # nmpc.wave_bank.NO_FADE_S (waves may not import nmpc)

SPREAD_MODES = ("full", "residual", "none")
SELECTIONS = ("compressed", "strongest")
FADE_SKILL = 0.5  # the bank's weight in the NMPC's model halves where the predictor's skill falls to this
GPS_LAG_S = 0.2  # the default sensors' fix lag (0.1 s) plus half their fix interval (5 Hz)


def strongest(waves: IrregularWaves, components: int) -> dict[str, np.ndarray]:
    """The ``components`` components of ``waves`` with most slope energy (a k)², as ``bank_arrays`` gives them."""
    order = np.argsort(-(waves.amplitude_m * waves.wavenumber_rad_m) ** 2)[:components]
    return {name: np.asarray(getattr(waves, name))[order] for name in
            ("amplitude_m", "frequency_rad_s", "wavenumber_rad_m", "direction_rad", "phase_rad")}


class DeadReckonedTrack:
    """The boat's NED track for the predictor's phases: the GPS velocity integrated, pulled to the GPS position
    (moved on by its lag) with ``TRACK_PULL_S``, re-anchored after a gap — the window estimator's track. Raw
    fixes (0.3 m white noise) cost the predictor all its skill: at k = 2 rad/m that is half a radian of phase."""

    def __init__(self, lag_s: float = GPS_LAG_S) -> None:
        self.lag_s = lag_s
        self._track: tuple[float, float] | None = None
        self._t = -math.inf

    def update(self, t: float, pos: np.ndarray, vel: np.ndarray) -> tuple[float, float]:
        """The track (north, east, m) at ``t`` from the latest fix ``pos`` and velocity ``vel`` (NED)."""
        dt, self._t = t - self._t, t
        gps = (float(pos[0] + vel[0] * self.lag_s), float(pos[1] + vel[1] * self.lag_s))
        if self._track is None or not 0 < dt <= GAP_S:
            self._track = gps
        else:
            g = min(1.0, dt / TRACK_PULL_S)
            self._track = (self._track[0] + vel[0] * dt + g * (gps[0] - self._track[0] - vel[0] * dt),
                           self._track[1] + vel[1] * dt + g * (gps[1] - self._track[1] - vel[1] * dt))
        return self._track


class PredictedSource:
    """The estimator's answers, and the predictor's bank when it is confident (see the module docstring)."""

    name = "estimated+phase-bank"

    def __init__(self, estimator: Any, components: int, roll_sign: float, lead_s: float = 1.0,
                 settings: PredictorSettings | None = None, oracle: IrregularWaves | None = None,
                 select: str = "compressed", horizon_s: float = 4.0, true_slope: IrregularWaves | None = None) -> None:
        if select not in SELECTIONS:
            raise ValueError(f"bank selection {select!r} is not one of {', '.join(SELECTIONS)}")
        self.estimator = estimator
        self.components, self.roll_sign, self.lead_s = components, roll_sign, lead_s
        self.select, self.horizon_s = select, horizon_s
        self.predictor = PhasePredictor(settings or PredictorSettings(roll_sign=roll_sign))
        self.track = DeadReckonedTrack()
        self._where = (0.0, 0.0, 0.0, 0.0)  # the last sample's time, track north/east and speed
        self._fit = (0, -math.inf)  # the predictor's fit count and the time of its last fit
        self.explained: list[float] = []  # compressed: the share of the horizon's predicted slope the K hold
        self.oracle = oracle  # simulation only: the true sea replaces the prediction
        self.true_slope = true_slope  # simulation only: the predictor is fed the true slope, not the attitude
        if oracle is not None:
            self.name = "truth-bank (simulation)"
        elif true_slope is not None:
            self.name = "estimated+phase-bank on the true slope (simulation)"

    def observe(self, sample: MotionSample) -> None:
        """Both watch the sample; the predictor's position is the dead-reckoned track, not the raw fix."""
        self.estimator.observe(sample)
        att, pos, vel = (np.asarray(v, float) for v in (sample.attitude, sample.position_ned, sample.velocity_ned))
        if att.shape != (3,) or not (np.all(np.isfinite(att)) and np.all(np.isfinite(pos[:2]))
                                     and np.all(np.isfinite(vel[:2]))):
            return
        north, east = self.track.update(sample.t_s, pos, vel)
        self._where = (sample.t_s, north, east, float(np.hypot(vel[0], vel[1])))
        # no heave channel: the IMU's heave is the hull's response, not the surface (it cost the fit its skill)
        if self.true_slope is None:
            self.predictor.observe_attitude(sample.t_s, north, east, att[0], att[1], att[2])
        else:
            slope_n, slope_e = self.true_slope.gradient(north, east, sample.t_s)
            self.predictor.observe(sample.t_s, north, east, float(slope_n), float(slope_e))
        if self.predictor.fits != self._fit[0]:  # a fit ends on the sample that started it
            self._fit = (self.predictor.fits, sample.t_s)

    def estimate(self, t_s: float) -> WaveEstimate | None:
        """The estimator's regular wave (None while not confident)."""
        return self.estimator.estimate(t_s)

    def latest(self, t_s: float) -> WaveEstimate | None:
        """The estimator's latest answer, confident or not (for the log)."""
        latest = getattr(self.estimator, "latest", None)
        return latest(t_s) if latest is not None else self.estimator.estimate(t_s)

    def spread(self, explained: bool) -> np.ndarray | None:
        """The estimator's unexplained slope covariance (see ``source.sea_spread``)."""
        return sea_spread(self.estimator, explained)

    def bank(self) -> dict[str, np.ndarray] | None:
        """K components while the predictor is confident ``lead_s`` ahead (an oracle: always), else None: the fit
        compressed over the horizon (``bank_compress``) or its K strongest components (``select``)."""
        waves = self.oracle
        if waves is None:
            if not self.predictor.confident(self.lead_s):
                return None
            waves = IrregularWaves(**self.predictor.bank_arrays())
        if self.select == "strongest":
            return strongest(waves, self.components)
        t, north, east, speed = self._where
        squeezed = compress(waves, self.components, t, north, east, speed, self.horizon_s,
                            self.predictor.s.band_rad_s)
        if squeezed is None:
            return None
        self.explained.append(squeezed[1])
        return squeezed[0]

    def skill(self) -> float:
        """The predictor's measured skill at ``lead_s`` (1 perfect, ≤ 0 none; 0 before any is scored; an oracle's
        is the share of the true slope variance its K components hold: over the horizon when compressed)."""
        if self.oracle is not None and self.select == "compressed":
            return self.explained[-1] if self.explained else 1.0
        if self.oracle is not None:
            energy = (self.oracle.amplitude_m * self.oracle.wavenumber_rad_m) ** 2
            return float(np.sort(energy)[::-1][:self.components].sum() / max(energy.sum(), 1e-30))
        value = float(self.predictor.skill(self.lead_s))
        return value if math.isfinite(value) else 0.0

    def fade(self) -> tuple[float, float]:
        """(t_f, τ_f) for the NMPC's bank (``nmpc.wave_bank``): from the last fit's time, half weight at the lead
        where the measured skill (per 1 s bin, at the bins' centres, interpolated) falls to ``FADE_SKILL``; the
        scored horizon when it never does, half a second at least."""
        horizon = self.predictor.s.horizon_s
        if self.oracle is not None:
            return 0.0, NO_FADE_S  # the truth does not age
        leads = np.arange(0.5, horizon, 1.0)
        skill = np.nan_to_num(self.predictor.skill(leads), neginf=-1.0)
        below = np.flatnonzero(skill < FADE_SKILL)
        if below.size == 0:
            return self._fit[1], horizon
        i = int(below[0])
        if i == 0:
            return self._fit[1], 0.5
        share = (skill[i - 1] - FADE_SKILL) / max(skill[i - 1] - skill[i], 1e-9)
        return self._fit[1], max(0.5, float(leads[i - 1] + share))


class BankFeed:
    """Per control step: the bank (or none) to the NMPC, the wave and spread that go with it; notes, counts."""

    def __init__(self, source: PredictedSource, spread_mode: str = "full",
                 note: Callable[[str], None] | None = None, fade: bool = True) -> None:
        if spread_mode not in SPREAD_MODES:
            raise ValueError(f"bank spread mode {spread_mode!r} is not one of {', '.join(SPREAD_MODES)}")
        self.source, self.spread_mode, self.note, self.fade = source, spread_mode, note, fade
        self.steps = self.bank_steps = 0
        self._on: bool | None = None
        self.skills: list[float] = []
        self.fades: list[float] = []

    def step(self, t: float, nmpc: Any, est: WaveEstimate | None) -> tuple[WaveEstimate | None, np.ndarray | None]:
        """Hand ``nmpc`` the bank or none; (the regular wave to plan with, the spread covariance to hand it)."""
        arrays = self.source.bank()
        on = arrays is not None
        nmpc.set_wave_bank(arrays, 1.0, self.source.roll_sign, self.source.fade() if on and self.fade else None)
        self.steps += 1
        self.bank_steps += int(on)
        self._say(t, on)
        if not on:
            return est, self.source.spread(est is not None)
        skill = self.source.skill()
        self.skills.append(skill)
        self.fades.append(self.source.fade()[1] if self.fade else math.inf)
        full = self.source.spread(False)
        if full is None or self.spread_mode == "none":
            return None, None
        share = 1.0 if self.spread_mode == "full" else min(max(1.0 - skill, 0.0), 1.0)
        return None, full * share

    def _say(self, t: float, on: bool) -> None:
        if on == self._on:
            return
        if on:
            line = (f"t = {t:.1f} s: phase bank confident {self.source.lead_s:g} s ahead (skill "
                    f"{self.source.skill():.2f}): planning on its {self.source.components} components")
        elif self._on is None:
            why = self.source.predictor.not_confident_because(self.source.lead_s)
            line = f"t = {t:.1f} s: phase bank not confident yet: {why}"
        else:
            line = f"t = {t:.1f} s: phase bank no longer confident: back to the estimate and the sea's statistics"
        self._on = on
        if self.note is not None:
            self.note(line)

    def metrics(self) -> dict[str, Any]:
        """Share of steps planned on the bank, the predictor's median skill then, its fits and spread mode."""
        return {"bank_fraction": self.bank_steps / max(self.steps, 1),
                "bank_skill_median": float(np.median(self.skills)) if self.skills else None,
                "bank_fade_s_median": float(np.median(self.fades)) if self.fades else None,
                "bank_components": self.source.components, "bank_spread": self.spread_mode,
                "bank_select": self.source.select,
                "bank_compressed_share_median": (float(np.median(self.source.explained)) if self.source.explained
                                                 else None),
                "predictor_fits": self.source.predictor.fits}
