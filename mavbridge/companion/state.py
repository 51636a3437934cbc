"""The boat's state for the NMPC from what an ArduPilot Rover streams: ATTITUDE, positions and the IMU.

η = [north, east, down, φ, θ, ψ] relative to home (from GLOBAL_POSITION_INT by flat earth, so the
waypoint and the boat share one frame whatever the EKF origin), ν = [u, v, w, p, q, r] in the body frame
(NED velocity from LOCAL_POSITION_NED, else GLOBAL_POSITION_INT, rotated by the attitude; body rates from
ATTITUDE). Everything is stamped with the autopilot's time_boot_ms; ψ is unwrapped across ±π so the
controller's warm start stays continuous.

The IMU (for the wave estimator only): SCALED_IMU, RAW_IMU (on ArduPilot both carry the first IMU,
scaled: milli-g of specific force in the body frame FRD, so a level boat at rest reads z ≈ −1000 mG) or
SCALED_IMU2 (the second IMU); the first kind that arrives is the one used. Converted to m/s² (ArduPilot
divides by its GRAVITY_MSS = 9.80665) and stamped on the autopilot clock (time_boot_ms, or RAW_IMU's
time_usec since boot).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.waves.source import MotionSample
from vessel.geo import ned_from_latlon
from vessel.sensors import body_velocity_from_ned

GRAVITY_MSS = 9.80665  # ArduPilot's milli-g scale for SCALED_IMU / RAW_IMU
IMU_MESSAGES = ("SCALED_IMU", "RAW_IMU", "SCALED_IMU2")
IMU_FRESH_MS = 60  # an IMU sample farther than this from ATTITUDE's time is not handed to the wave source: it
# would be taken as the attitude's instant (0.1 s is 6° of heave phase at ω_e = 1 rad/s); a 20 Hz stream fits
IMU_SILENT_MS = 1000  # the IMU kind in use silent this long (autopilot time): another kind that arrives is taken
MAX_ANGLE_RAD = math.pi + 0.01  # ArduPilot's ATTITUDE angles are within ±π: a larger one is forged or corrupt
MAX_RATE_RAD_S = 35.0  # a gyro's range (2000 °/s): faster body rates are not a boat's
MAX_SPEED_M_S = 100.0  # NED velocity beyond this is not a boat's


def imu_specific_force(msg: Any) -> tuple[int, np.ndarray] | None:
    """(autopilot ms, body FRD specific force m/s²) of a SCALED_IMU / RAW_IMU / SCALED_IMU2, None if unusable.

    Plain floats until the array is made (each IMU message passes here, 20 times a second): the same products
    as an array times the scale, without numpy's per-call cost on three numbers."""
    stamp = getattr(msg, "time_boot_ms", None)
    if stamp is None:
        usec = getattr(msg, "time_usec", None)
        stamp = None if usec is None else int(usec) // 1000
    scale = GRAVITY_MSS / 1000.0
    try:
        fx, fy, fz = float(msg.xacc) * scale, float(msg.yacc) * scale, float(msg.zacc) * scale
    except (TypeError, ValueError):  # a field that is no number (a hand-made or replayed message): unusable
        return None
    if stamp is None or not (math.isfinite(fx) and math.isfinite(fy) and math.isfinite(fz)) or not (fx or fy or fz):
        return None  # an all-zero reading is an IMU that is not there, never a boat at rest
    return int(stamp), np.array([fx, fy, fz])


def _attitude_plausible(values: list[float]) -> bool:
    """True when (φ, θ, ψ, p, q, r) are finite and a boat's (NaN compares False); plain comparisons, as every
    ATTITUDE passes here."""
    roll, pitch, yaw, p, q, r = values
    return (abs(roll) <= MAX_ANGLE_RAD and abs(pitch) <= MAX_ANGLE_RAD and abs(yaw) <= MAX_ANGLE_RAD
            and abs(p) <= MAX_RATE_RAD_S and abs(q) <= MAX_RATE_RAD_S and abs(r) <= MAX_RATE_RAD_S)


@dataclass
class StateEstimate:
    """Latest attitude and position from the autopilot, combined on request into the NMPC state."""

    home_lat_deg: float | None = None
    home_lon_deg: float | None = None
    attitude_ms: int | None = None
    position_ms: int | None = None
    velocity_ms: int | None = None
    attitude: np.ndarray = field(default_factory=lambda: np.zeros(6))  # φ θ ψ p q r
    position_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    velocity_ned: np.ndarray = field(default_factory=lambda: np.zeros(3))
    accel_body: np.ndarray | None = None  # specific force, body FRD, m/s² (IMU)
    imu_ms: int | None = None
    imu_kind: str | None = None  # the IMU message taken (the first that arrived, until ``use_imu`` names one)
    imu_preferred: str | None = None  # the kind ``use_imu`` named: taken back whenever it streams again
    rejected: int = 0
    max_distance_m: float = 10_000.0  # positions farther from home are rejected (no fix reports 0, 0)
    _psi_unwrapped: float | None = None
    _imu_wait_from_ms: int | None = None  # when the kind in use was last heard of (or awaited from), if never

    def set_home(self, lat_deg: float, lon_deg: float) -> None:
        """The origin of η (the autopilot's home)."""
        self.home_lat_deg, self.home_lon_deg = lat_deg, lon_deg

    def on_message(self, msg: Any) -> None:
        """Take ATTITUDE, GLOBAL_POSITION_INT, LOCAL_POSITION_NED and the IMU; non-finite fields are rejected."""
        kind = msg.get_type()
        if kind in IMU_MESSAGES:
            self._on_imu(kind, msg)
            return
        stamp = getattr(msg, "time_boot_ms", None)
        if stamp is not None and self.attitude_ms is not None and stamp < self.attitude_ms - 5000:
            self.attitude_ms = self.position_ms = self.velocity_ms = self.imu_ms = None  # the autopilot rebooted
            self._imu_wait_from_ms = None
        if kind == "ATTITUDE":
            values = [msg.roll, msg.pitch, msg.yaw, msg.rollspeed, msg.pitchspeed, msg.yawspeed]
            if not _attitude_plausible(values):
                self.rejected += 1  # not finite, or not a boat's attitude (a corrupt or forged message)
                return
            psi = values[2]
            if self._psi_unwrapped is not None:
                psi = self._psi_unwrapped + math.remainder(psi - self._psi_unwrapped, 2 * math.pi)
            self._psi_unwrapped = psi
            values[2] = psi
            self.attitude = np.array(values)
            self.attitude_ms = int(msg.time_boot_ms)
        elif kind == "GLOBAL_POSITION_INT" and self.home_lat_deg is not None:
            north, east = ned_from_latlon(self.home_lat_deg, self.home_lon_deg, msg.lat / 1e7, msg.lon / 1e7)
            if (msg.lat == 0 and msg.lon == 0) or math.hypot(north, east) > self.max_distance_m:
                self.rejected += 1  # no position estimate yet (ArduPilot then sends 0, 0) or a wild one
                return
            self.position_ned = np.array([north, east, -msg.relative_alt / 1000.0])
            self.position_ms = int(msg.time_boot_ms)
            if self.velocity_ms is None or self.position_ms - self.velocity_ms > 500:
                self.velocity_ned = np.array([msg.vx, msg.vy, msg.vz]) / 100.0
        elif kind == "LOCAL_POSITION_NED":
            vx, vy, vz = msg.vx, msg.vy, msg.vz
            if not (abs(vx) <= MAX_SPEED_M_S and abs(vy) <= MAX_SPEED_M_S and abs(vz) <= MAX_SPEED_M_S):
                self.rejected += 1  # NaN compares False: rejected too
                return
            self.velocity_ned = np.array([vx, vy, vz])
            self.velocity_ms = int(msg.time_boot_ms)

    def use_imu(self, kind: str | None) -> None:
        """Take the IMU from ``kind`` only (the fastest stream measured); None: the first kind that arrives.

        The first IMU message to arrive is often a slow default stream (Rover sends RAW_IMU at SRx_RAW_SENS,
        1-2 Hz, before SCALED_IMU is requested): the wave estimator fed from it sees one heave sample a second.
        """
        self.imu_preferred = kind
        if kind != self.imu_kind:
            self.imu_kind, self.imu_ms, self.accel_body = kind, None, None
            self._imu_wait_from_ms = self.attitude_ms

    def _imu_in_use_silent(self) -> bool:
        """True once the IMU kind in use has not been heard for IMU_SILENT_MS of autopilot (ATTITUDE) time."""
        if self.attitude_ms is None:
            return False
        if self.imu_ms is None and self._imu_wait_from_ms is None:
            self._imu_wait_from_ms = self.attitude_ms  # start waiting now
        last = self.imu_ms if self.imu_ms is not None else self._imu_wait_from_ms
        return last is not None and self.attitude_ms - last > IMU_SILENT_MS

    def _on_imu(self, kind: str, msg: Any) -> None:
        """One IMU message of the kind in use (the first kind that arrived, or the one ``use_imu`` named); another
        kind only once that one has been silent for IMU_SILENT_MS (it stopped, e.g. not requested again after a
        reboot, or started late): a slower IMU beats none. The kind ``use_imu`` named is taken back as soon as it
        streams again, so a late start of the fast stream never leaves the estimator on Rover's 1 Hz RAW_IMU."""
        if self.imu_kind not in (None, kind) and kind != self.imu_preferred and not self._imu_in_use_silent():
            return
        reading = imu_specific_force(msg)
        if reading is None:
            self.rejected += 1
            return
        self.imu_kind = kind
        self.imu_ms, self.accel_body = reading

    def imu_fresh(self) -> bool:
        """True when an IMU sample within IMU_FRESH_MS of the attitude's time is there."""
        return (self.imu_ms is not None and self.attitude_ms is not None
                and abs(self.attitude_ms - self.imu_ms) <= IMU_FRESH_MS)

    def ready(self) -> bool:
        """True once attitude and position have both arrived."""
        return self.attitude_ms is not None and self.position_ms is not None

    def age_ms(self, now_ms: int) -> int:
        """Age of the older of attitude and position at autopilot time ``now_ms``."""
        if not self.ready():
            return 1 << 30
        return now_ms - min(self.attitude_ms, self.position_ms)  # type: ignore[type-var]

    def vector(self) -> np.ndarray:
        """x = [η, ν] (12) at the attitude's time, position extrapolated with the NED velocity."""
        if not self.ready():
            raise ValueError("state: no attitude or position received yet")
        phi, theta, psi, p, q, r = self.attitude.tolist()
        lag_s = min(max((self.attitude_ms - self.position_ms) / 1000.0, 0.0), 0.5)  # type: ignore[operator]
        (north, east, down), (vn, ve, vd) = self.position_ned.tolist(), self.velocity_ned.tolist()
        u, v, w = body_velocity_from_ned(phi, theta, psi, vn, ve, vd)
        return np.array([north + vn * lag_s, east + ve * lag_s, down + vd * lag_s, phi, theta, psi, u, v, w, p, q, r])

    def motion_sample(self) -> MotionSample:
        """What the wave source sees at the attitude's time: attitude, body rates, NED position and velocity
        (relative to home), and the IMU's body specific force when a fresh one is there (else None)."""
        if not self.ready():
            raise ValueError("state: no attitude or position received yet")
        accel = self.accel_body.copy() if self.imu_fresh() and self.accel_body is not None else None
        return MotionSample((self.attitude_ms or 0) / 1000.0, self.attitude[0:3].copy(), self.attitude[3:6].copy(),
                            self.position_ned.copy(), self.velocity_ned.copy(), accel)
