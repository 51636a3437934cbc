"""A trial from a log: the boat's attitude and track as the companion's own ``StateEstimate`` reads them, with
the autopilot's modes, home, mission and parameters; the motion samples the wave estimator sees, as it goes.

Every message of a reader goes through ``StateEstimate.on_message`` (attitude checked and yaw unwrapped,
position by flat earth from an origin, velocity from LOCAL_POSITION_NED else GLOBAL_POSITION_INT, the IMU),
exactly as in `mavbridge run`; each ATTITUDE it takes is one attitude sample, and — once a position is
known — one ``MotionSample`` for the wave estimator, stamped on the log's timeline. The origin of the track
is the autopilot's home when the log says it before the first fix (HOME_POSITION), else the first fix; the
IMU stream used is the fastest one in each window of IMU_CHOICE_S, as the companion takes the fastest stream it
measures and returns to it when it starts late (a ground station's log begins before a companion asks for it).
Only compact arrays are kept (an hour of 20 Hz attitude is a few megabytes), never the messages.
"""

from __future__ import annotations

import math
from array import array
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from mavbridge.companion.state import IMU_MESSAGES, StateEstimate
from mavbridge.field.logs import LogError, LogInfo, TimedMessage
from mavbridge.link.connection import mavlink, mavutil
from mavbridge.waves.source import MotionSample
from vessel.geo import ned_from_latlon

IMU_SWITCH_RATIO = 1.5  # a stream replaces the one in use when this many times as frequent in a window
IMU_CHOICE_S = 5.0  # the IMU stream is (re)chosen over windows of this much log time, as the companion measures rates
NAV_COMMANDS = range(16, 96)  # MAV_CMD_NAV_*: mission items with a position
NO_HEADING = 65535  # GLOBAL_POSITION_INT.hdg when the heading is not known


@dataclass(frozen=True)
class ModeChange:
    """From ``t_s`` on the autopilot is in ``mode``, armed or not."""

    t_s: float
    mode: str
    armed: bool

    @property
    def label(self) -> str:
        """'MANUAL (armed)'."""
        return f"{self.mode} ({'armed' if self.armed else 'disarmed'})"


@dataclass
class Trial:
    """What a log says of one trial, in arrays (SI, rad; NED metres relative to ``origin``)."""

    info: LogInfo
    attitude: np.ndarray  # rows of t_s, roll, pitch, yaw (rad; yaw unwrapped)
    track: np.ndarray  # rows of t_s, north, east (m from origin), speed over ground (m/s)
    origin: tuple[float, float] | None  # lat, lon (deg) of the track's origin
    home: tuple[float, float] | None  # the autopilot's home (HOME_POSITION or mission item 0), if said
    modes: list[ModeChange]
    waypoints: list[tuple[float, float]]  # lat, lon (deg) of the mission's items with a position, in order
    params: dict[str, float]
    start_s: float
    end_s: float
    rejected: int = 0  # messages the state refused (corrupt attitude, wild position)
    imu: str | None = None
    course: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # rows of t_s, course over ground (deg)
    named: dict[str, np.ndarray] = field(default_factory=dict)  # NAMED_VALUE_FLOAT name: rows of t_s, value
    targets: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))  # rows of t_s, north, east (m): the
    # position target the autopilot (or the Otter API's controller) steered for

    def local(self, lat_lon: tuple[float, float] | None) -> tuple[float, float] | None:
        """(north, east) m of a lat/lon from the track's origin."""
        if lat_lon is None or self.origin is None:
            return None
        return ned_from_latlon(*self.origin, *lat_lon)

    @property
    def attitude_rate_hz(self) -> float:
        """Median rate of the attitude samples."""
        gaps = np.diff(self.attitude[:, 0])
        gaps = gaps[gaps > 0]
        return float(1.0 / np.median(gaps)) if gaps.size else 0.0


def on_timeline(sample: MotionSample, t: float) -> MotionSample:
    """The state's motion sample stamped ``t`` on the log's timeline instead of the autopilot's clock."""
    return MotionSample(t, sample.attitude, sample.rates, sample.position_ned, sample.velocity_ned, sample.accel_body)


def mode_of(heartbeat: Any) -> str:
    """The autopilot's mode by name (pymavlink's tables: ArduPilot's by vehicle type, PX4's)."""
    try:
        return str(mavutil.mode_string_v10(heartbeat))
    except Exception:  # an autopilot pymavlink has no table for
        return f"mode {heartbeat.custom_mode}"


@dataclass
class TrialRecorder:
    """Takes a reader's messages in order; ``trial()`` at the end. ``on_motion`` gets each motion sample."""

    info: LogInfo
    on_motion: Callable[[MotionSample], None] | None = None
    state: StateEstimate = field(default_factory=StateEstimate)
    _att: array = field(default_factory=lambda: array("d"))
    _track: array = field(default_factory=lambda: array("d"))
    _modes: list[ModeChange] = field(default_factory=list)
    _items: dict[int, tuple[int, float, float]] = field(default_factory=dict)
    _count: int | None = None
    _params: dict[str, float] = field(default_factory=dict)
    _home: tuple[float, float] | None = None
    _imu_counts: Counter[str] = field(default_factory=Counter)
    _imu_window_end: float | None = None
    _last_t: float = 0.0
    _course: array = field(default_factory=lambda: array("d"))
    _named: dict[str, array] = field(default_factory=dict)
    _targets: array = field(default_factory=lambda: array("d"))  # t_s, lat, lon (deg)
    _handlers: dict[str, Callable[[float, Any], None]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self._handlers = {kind.upper(): getattr(self, f"_on_{kind}") for kind in (
            "attitude", "global_position_int", "home_position", "heartbeat", "mission_item_int", "mission_item",
            "mission_count", "param_value", "named_value_float", "position_target_global_int")}
        self._handlers.update({kind: self._on_imu for kind in IMU_MESSAGES})
        self._handlers["LOCAL_POSITION_NED"] = lambda t, msg: self.state.on_message(msg)

    def take(self, t: float, msg: Any) -> None:
        """One message of the log at ``t`` (s on the log's timeline)."""
        if t > self._last_t:
            self._last_t = t
        handler = self._handlers.get(msg.get_type())
        if handler is not None:
            handler(t, msg)

    def _on_imu(self, t: float, msg: Any) -> None:
        self._imu_counts[msg.get_type()] += 1
        self.state.on_message(msg)

    def _choose_imu(self, t: float) -> None:
        """At the end of each IMU_CHOICE_S window, use the IMU kind heard most often in it when clearly faster
        than the one in use (IMU_SWITCH_RATIO: two streams at one rate do not take turns)."""
        if self._imu_window_end is None:
            self._imu_window_end = t + IMU_CHOICE_S
        if t < self._imu_window_end:
            return
        self._imu_window_end = t + IMU_CHOICE_S
        if self._imu_counts:
            kind, count = self._imu_counts.most_common(1)[0]
            if count > IMU_SWITCH_RATIO * self._imu_counts.get(self.state.imu_preferred or "", 0):
                self.state.use_imu(kind)
            self._imu_counts.clear()

    def _accepted(self, msg: Any) -> bool:
        """The state took ``msg`` (its refusal count did not move)."""
        before = self.state.rejected
        self.state.on_message(msg)
        return self.state.rejected == before

    def _on_attitude(self, t: float, msg: Any) -> None:
        if not self._accepted(msg):
            return
        self._att.append(t)
        self._att.extend(self.state.attitude[0:3].tolist())
        self._choose_imu(t)
        if self.on_motion is not None and self.state.ready():
            self.on_motion(on_timeline(self.state.motion_sample(), t))

    def _on_global_position_int(self, t: float, msg: Any) -> None:
        if self.state.home_lat_deg is None and (msg.lat or msg.lon):
            self.state.set_home(msg.lat / 1e7, msg.lon / 1e7)  # the track's origin: the first fix
        if self.state.home_lat_deg is not None and self._accepted(msg):
            v = self.state.velocity_ned
            self._track.extend((t, float(self.state.position_ned[0]), float(self.state.position_ned[1]),
                                math.hypot(float(v[0]), float(v[1]))))
            if msg.hdg != NO_HEADING:
                self._course.extend((t, msg.hdg / 100.0))

    def _on_named_value_float(self, t: float, msg: Any) -> None:
        name = msg.name.decode() if isinstance(msg.name, bytes) else str(msg.name)
        if math.isfinite(msg.value):
            self._named.setdefault(name.rstrip("\x00"), array("d")).extend((t, float(msg.value)))

    def _on_position_target_global_int(self, t: float, msg: Any) -> None:
        if msg.lat_int or msg.lon_int:
            self._targets.extend((t, msg.lat_int / 1e7, msg.lon_int / 1e7))

    def _on_home_position(self, t: float, msg: Any) -> None:
        if msg.latitude or msg.longitude:
            self._home = (msg.latitude / 1e7, msg.longitude / 1e7)
            if self.state.home_lat_deg is None:
                self.state.set_home(*self._home)

    def _on_heartbeat(self, t: float, msg: Any) -> None:
        change = ModeChange(t, mode_of(msg), bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED))
        if not self._modes or (self._modes[-1].mode, self._modes[-1].armed) != (change.mode, change.armed):
            self._modes.append(change)

    def _on_mission_item_int(self, t: float, msg: Any) -> None:
        self._items[int(msg.seq)] = (int(msg.command), msg.x / 1e7, msg.y / 1e7)

    def _on_mission_item(self, t: float, msg: Any) -> None:
        self._items[int(msg.seq)] = (int(msg.command), float(msg.x), float(msg.y))

    def _on_mission_count(self, t: float, msg: Any) -> None:
        self._count = int(msg.count)

    def _on_param_value(self, t: float, msg: Any) -> None:
        name = msg.param_id.decode() if isinstance(msg.param_id, bytes) else str(msg.param_id)
        self._params[name.rstrip("\x00")] = float(msg.param_value)

    def _mission(self) -> tuple[list[tuple[float, float]], tuple[float, float] | None]:
        """(waypoints lat/lon with a position, in order; home from item 0) of the last mission seen."""
        items = {s: v for s, v in self._items.items() if self._count is None or s < self._count}
        home = (items[0][1], items[0][2]) if 0 in items and (items[0][1] or items[0][2]) else None
        points = [(lat, lon) for s, (cmd, lat, lon) in sorted(items.items())
                  if s >= 1 and cmd in NAV_COMMANDS and (lat or lon)]
        return points, home

    def trial(self) -> Trial:
        """The trial; LogError when the log held no attitude of the autopilot."""
        attitude = np.frombuffer(self._att, dtype=float).reshape(-1, 4).copy()
        if not attitude.size:
            what = "no attitude" if not self.state.rejected else "no usable attitude (every sample was refused)"
            raise LogError(f"LOG: {self.info.path}: {what} in this {self.info.format} log: nothing to report")
        waypoints, mission_home = self._mission()
        origin = None if self.state.home_lat_deg is None else (self.state.home_lat_deg, self.state.home_lon_deg)
        track = np.frombuffer(self._track, dtype=float).reshape(-1, 4).copy()
        start = min(float(attitude[0, 0]), float(track[0, 0]) if track.size else math.inf)
        targets = np.frombuffer(self._targets, dtype=float).reshape(-1, 3).copy()
        if origin is not None and targets.size:
            targets[:, 1:] = [ned_from_latlon(*origin, lat, lon) for lat, lon in targets[:, 1:].tolist()]
        named = {k: np.frombuffer(v, dtype=float).reshape(-1, 2).copy() for k, v in self._named.items()}
        return Trial(self.info, attitude, track, origin, self._home or mission_home, list(self._modes), waypoints,
                     dict(self._params), start, self._last_t, self.state.rejected, self.state.imu_kind,
                     np.frombuffer(self._course, dtype=float).reshape(-1, 2).copy(), named,
                     targets if origin is not None else np.zeros((0, 3)))


def record(messages: Iterable[TimedMessage], info: LogInfo,
           on_motion: Callable[[MotionSample], None] | None = None) -> Trial:
    """The trial of a reader's messages (``on_motion``: each motion sample, for the wave estimator)."""
    recorder = TrialRecorder(info, on_motion)
    for t, msg in messages:
        recorder.take(t, msg)
    return recorder.trial()
