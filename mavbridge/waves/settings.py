"""Tuning of the wave estimator: one frozen, validated dataclass (SI units in the field names)."""

from __future__ import annotations

from dataclasses import dataclass, field

from vessel.config import ConfigError, bounded, validate

TRACKERS = ("zero-crossing", "belleter")
METHODS = ("window", "recursive")


@dataclass(frozen=True)
class EstimatorSettings:
    """Tuning of the wave estimator (SI units in the names; defaults tuned on the paper's sea)."""

    method: str = field(default="window", metadata={"choices": METHODS, "doc": "window: one regular wave fitted "
                        "in the earth frame to the last window_s of motion (the default); recursive: the per-sample "
                        "demodulating estimator (with its Doppler line for a hull that does not heave)"})
    window_s: float = bounded(20.0, 5.0, 120.0, "s", "window: seconds of motion each fit uses")
    min_window_s: float = bounded(8.0, 2.0, 60.0, "s", "window: seconds of valid motion before the first fit")
    fit_interval_s: float = bounded(1.0, 0.05, 10.0, "s", "window: a new fit every this long")
    roll_sign: float = bounded(1.0, -1.0, 1.0, "", "+1: roll = +slope across the hull (the paper's plant); "
                               "−1: geometric (a real hull)")
    roll_gain: float = bounded(1.0, 0.1, 10.0, "", "hull roll / slope across the hull near ω_e (calibration)")
    roll_phase_deg: float = bounded(0.0, -90.0, 90.0, "deg", "phase of hull roll against roll_sign × that slope: "
                                    "the hull's lag only, the sign being roll_sign's")
    pitch_gain: float = bounded(1.0, 0.1, 10.0, "", "hull pitch / slope along the hull near ω_e (calibration)")
    pitch_phase_deg: float = bounded(0.0, -90.0, 90.0, "deg", "phase of hull pitch against that slope")
    fit_tau_s: float = bounded(2.0, 0.2, 30.0, "s", "time constant of the sinusoid fits")
    mean_tau_s: float = bounded(10.0, 1.0, 300.0, "s", "running-mean (high-pass) time constant")
    omega_init_rad_s: float = bounded(1.0, 0.2, 5.0, "rad/s", "tracker's first guess of ω_e")
    omega_min_rad_s: float = bounded(0.3, 0.05, 5.0, "rad/s", "lowest encounter frequency tracked")
    omega_max_rad_s: float = bounded(4.0, 0.5, 20.0, "rad/s", "highest encounter frequency tracked")
    tracker: str = field(default="zero-crossing", metadata={"choices": TRACKERS,
                                                            "doc": "coarse ω_e tracker: zero-crossing or belleter"})
    tracker_filter_rad_s: float = bounded(3.0, 0.5, 30.0, "rad/s", "tracker's second-order filter frequency")
    tracker_gain: float = bounded(2.0, 0.01, 100.0, "", "tracker's adaptation gain (normalised input)")
    tracker_pull: float = bounded(0.5, 0.0, 10.0, "1/s", "how fast the unlocked oscillator follows the tracker")
    fll_gain: float = bounded(0.3, 0.0, 10.0, "1/s", "how fast the phasors' rotation corrects the oscillator")
    attitude_lag_s: float = bounded(0.0, 0.0, 2.0, "s", "known lag of ATTITUDE, compensated")
    position_lag_s: float = bounded(0.0, 0.0, 2.0, "s", "known lag of the GPS position/velocity, compensated")
    settle_s: float = bounded(6.0, 0.0, 120.0, "s", "quiet time needed after a start, gap or turn")
    min_confidence: float = bounded(0.5, 0.0, 1.0, "", "below this, estimate() answers None")
    min_height_m: float = bounded(0.1, 0.0, 10.0, "m", "smallest wave height that counts as heave")
    min_slope_rad: float = bounded(0.004, 0.0, 1.0, "rad", "smallest slope amplitude that counts")
    wavelength_min_m: float = bounded(3.0, 0.1, 1e4, "m", "shortest plausible wavelength")
    wavelength_max_m: float = bounded(1000.0, 1.0, 1e5, "m", "longest plausible wavelength")
    turn_rate_rad_s: float = bounded(0.15, 0.0, 10.0, "rad/s", "heading rate that counts as a manoeuvre")
    sharp_turn_rate_rad_s: float = bounded(0.25, 0.0, 10.0, "rad/s", "heading rate over 1 s that counts as a "
                                           "sharp turn (wave-induced yaw stays below it)")
    turn_filter_s: float = bounded(6.0, 0.1, 60.0, "s", "low-pass of that heading rate: longer than a wave "
                                   "period, so wave-induced yaw is no manoeuvre")
    doppler_memory_s: float = bounded(240.0, 5.0, 3600.0, "s", "memory of the Doppler line fit")
    doppler_spread_mps: float = bounded(0.25, 0.01, 10.0, "m/s", "speed spread the Doppler fit needs")
    max_gap_s: float = bounded(1.0, 0.05, 60.0, "s", "a longer silence restarts the settling")

    def __post_init__(self) -> None:
        for axis in ("roll", "pitch"):
            phase = getattr(self, f"{axis}_phase_deg")
            if isinstance(phase, (int, float)) and abs(phase) > 90.0:
                raise ConfigError(f"{axis}_phase_deg: {phase:g} is outside the allowed range [-90, 90] deg; a phase "
                                  "beyond ±90° is a reversed sign, which roll_sign says (wave_roll_sign in the "
                                  "companion's YAML, estimation.roll_sign in a scenario): set that instead")
        validate(self)
        if self.roll_sign not in (-1.0, 1.0):
            raise ConfigError(f"roll_sign: {self.roll_sign!r} is not one of -1, 1")
        if self.method not in METHODS:
            raise ConfigError(f"method: {self.method!r} is not one of {', '.join(METHODS)}")
        if self.tracker not in TRACKERS:
            raise ConfigError(f"tracker: {self.tracker!r} is not one of {', '.join(TRACKERS)}")
