"""The boat's state for the NMPC from what an ArduPilot Rover streams: ATTITUDE and positions.

η = [north, east, down, φ, θ, ψ] relative to home (from GLOBAL_POSITION_INT by flat earth, so the
waypoint and the boat share one frame whatever the EKF origin), ν = [u, v, w, p, q, r] in the body frame
(NED velocity from LOCAL_POSITION_NED, else GLOBAL_POSITION_INT, rotated by the attitude; body rates from
ATTITUDE). Everything is stamped with the autopilot's time_boot_ms; ψ is unwrapped across ±π so the
controller's warm start stays continuous.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vessel.dynamics import rotation_body_to_ned
from vessel.geo import ned_from_latlon

from .seasource import MotionSample


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
    rejected: int = 0
    max_distance_m: float = 10_000.0  # positions farther from home are rejected (no fix reports 0, 0)
    _psi_unwrapped: float | None = None

    def set_home(self, lat_deg: float, lon_deg: float) -> None:
        """The origin of η (the autopilot's home)."""
        self.home_lat_deg, self.home_lon_deg = lat_deg, lon_deg

    def on_message(self, msg: Any) -> None:
        """Take ATTITUDE, GLOBAL_POSITION_INT and LOCAL_POSITION_NED; non-finite fields are rejected."""
        kind = msg.get_type()
        stamp = getattr(msg, "time_boot_ms", None)
        if stamp is not None and self.attitude_ms is not None and stamp < self.attitude_ms - 5000:
            self.attitude_ms = self.position_ms = self.velocity_ms = None  # the autopilot rebooted
        if kind == "ATTITUDE":
            values = [msg.roll, msg.pitch, msg.yaw, msg.rollspeed, msg.pitchspeed, msg.yawspeed]
            if not all(math.isfinite(v) for v in values):
                self.rejected += 1
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
            velocity = np.array([msg.vx, msg.vy, msg.vz])
            if not np.all(np.isfinite(velocity)):
                self.rejected += 1
                return
            self.velocity_ned = velocity
            self.velocity_ms = int(msg.time_boot_ms)

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
        phi, theta, psi = self.attitude[0:3]
        lag_s = (self.attitude_ms - self.position_ms) / 1000.0  # type: ignore[operator]
        position = self.position_ned + self.velocity_ned * float(np.clip(lag_s, 0.0, 0.5))
        body_velocity = np.array(rotation_body_to_ned(phi, theta, psi)).T @ self.velocity_ned
        return np.concatenate([position, self.attitude[0:3], body_velocity, self.attitude[3:6]])

    def motion_sample(self) -> MotionSample:
        """What the wave source sees at the attitude's time: attitude, body rates, NED position and velocity
        (relative to home); no accelerations yet (SCALED_IMU is not streamed)."""
        if not self.ready():
            raise ValueError("state: no attitude or position received yet")
        return MotionSample((self.attitude_ms or 0) / 1000.0, self.attitude[0:3].copy(), self.attitude[3:6].copy(),
                            self.position_ned.copy(), self.velocity_ned.copy(), None)
