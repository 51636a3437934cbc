"""Logs the field tests write themselves, of a motion the test knows: ArduPilot DataFlash (binary and text),
the Otter API's CSV (with the quirks real files have) and MAVLink tlogs (pymavlink packs the frames).

The motion is either plain sines (figures a test can compute exactly) or the vessel model riding a sea
(``plant_motion``: the Otter's own roll, pitch, heave and IMU in regular waves, as the estimator expects).
The DataFlash layouts are ArduPilot's (LogStructure.h: ATT, IMU, GPS, MODE, ARM, RCOU, RCIN, CMD, PARM, MSG),
packed with pymavlink's own table of DataFlash types (``DFReader.FORMAT_TO_STRUCT``), so that pymavlink's
DFReader reads them as it reads a boat's log.
"""

from __future__ import annotations

import calendar
import math
import os
import re
import struct
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.DFReader import FORMAT_TO_STRUCT
from pymavlink.dialects.v20 import ardupilotmega as mav

from vessel.geo import latlon_from_ned
from vessel.sensors import rotation_body_to_ned

HOME = (59.9086, 10.7194)  # Oslo harbour
GRAVITY = 9.80665
EPOCH_S = 1_711_107_749.0  # 2024-03-22, when the Otter's harbour runs were logged


@dataclass(frozen=True)
class Motion:
    """A boat's motion sampled at ``t`` (s): η rows (north, east, down m; roll, pitch, yaw rad), NED velocity
    (m/s), body rates (rad/s) and the IMU's body specific force (m/s², FRD)."""

    t: np.ndarray
    eta: np.ndarray
    velocity_ned: np.ndarray
    rates: np.ndarray
    accel: np.ndarray

    def latlon(self, i: int) -> tuple[float, float]:
        """Latitude/longitude (deg) of sample ``i``."""
        return latlon_from_ned(*HOME, float(self.eta[i, 0]), float(self.eta[i, 1]))


def sine_motion(seconds: float, rate_hz: float = 20.0, roll_deg: float = 4.0, period_s: float = 3.0,
                speed_m_s: float = 1.0, heading_deg: float = 30.0, pitch_deg: float = 1.0) -> Motion:
    """A boat going straight at ``speed_m_s`` on ``heading_deg``, rolling ``roll_deg`` (sine) and pitching
    ``pitch_deg`` (cosine) at ``period_s``."""
    t = np.arange(0.0, seconds, 1.0 / rate_hz)
    w = 2 * math.pi / period_s
    psi = math.radians(heading_deg)
    roll = np.radians(roll_deg) * np.sin(w * t)
    pitch = np.radians(pitch_deg) * np.cos(w * t)
    eta = np.column_stack([speed_m_s * t * math.cos(psi), speed_m_s * t * math.sin(psi), np.zeros_like(t), roll,
                           pitch, np.full_like(t, psi)])
    velocity = np.tile([speed_m_s * math.cos(psi), speed_m_s * math.sin(psi), 0.0], (t.size, 1))
    rates = np.column_stack([np.radians(roll_deg) * w * np.cos(w * t), -np.radians(pitch_deg) * w * np.sin(w * t),
                             np.zeros_like(t)])
    accel = np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, -GRAVITY)])
    return Motion(t, eta, velocity, rates, accel)


def plant_motion(waves: Any, seconds: float, shafts: tuple[float, float] = (70.0, 70.0), heading_deg: float = 45.0,
                 rate_hz: float = 20.0) -> Motion:
    """The Otter model (published parameters, riding the sea: surface heave) in ``waves`` with constant shaft
    speeds, sampled at ``rate_hz`` with its ideal IMU."""
    from vessel import Plant, otter_parameters
    from vessel.imu import ImuModel

    x0 = np.zeros(14)
    x0[5] = math.radians(heading_deg)
    plant = Plant(otter_parameters(), waves, dt=0.01, x0=x0, surface_heave=True)
    imu = ImuModel.for_plant(plant)
    steps = round(1.0 / rate_hz / plant.dt)
    rows = []
    while plant.time < seconds:
        x = plant.state
        force, rates = imu.measure(x, plant.time)
        velocity = rotation_body_to_ned(x[3], x[4], x[5]) @ x[6:9]
        rows.append((plant.time, *x[0:6], *velocity, *rates, *force))
        plant.advance(shafts, steps)
    data = np.array(rows)
    return Motion(data[:, 0], data[:, 1:7], data[:, 7:10], data[:, 10:13], data[:, 13:16])


# ---------------------------------------------------------------- DataFlash
LAYOUTS = {  # name: (type id, DataFlash format, columns): ArduPilot's layouts
    "PARM": (64, "QNff", "TimeUS,Name,Value,Default"),
    "MSG": (65, "QZ", "TimeUS,Message"),
    "ATT": (66, "QccccCCCCB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF"),
    "IMU": (67, "QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"),
    "GPS": (68, "QBBIHBcLLeffffB", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw,U"),
    "MODE": (69, "QMBB", "TimeUS,Mode,ModeNum,Rsn"),
    "ARM": (70, "QBIBB", "TimeUS,ArmState,ArmChecks,Forced,Method"),
    "RCOU": (71, "Q" + "H" * 14, "TimeUS," + ",".join(f"C{n}" for n in range(1, 15))),
    "RCIN": (72, "Q" + "H" * 14, "TimeUS," + ",".join(f"C{n}" for n in range(1, 15))),
    "CMD": (73, "QHHHffffLLfB", "TimeUS,CTot,CNum,CId,Prm1,Prm2,Prm3,Prm4,Lat,Lng,Alt,Frame"),
}
FMT_STRUCT = struct.Struct("<BBB" + "BB4s16s64s")


def _struct(fmt: str) -> tuple[struct.Struct, list[float | None]]:
    return (struct.Struct("<" + "".join(FORMAT_TO_STRUCT[c][0] for c in fmt)),
            [FORMAT_TO_STRUCT[c][1] for c in fmt])


class DataflashWriter:
    """Writes DataFlash messages, binary (as ArduPilot's .bin) or text (as a .log), each type's FMT first."""

    def __init__(self, path: Path, text: bool = False) -> None:
        self.text = text
        self.handle = path.open("w" if text else "wb")
        self.declared: set[str] = set()
        if text:
            self.handle.write("FMT, 128, 89, FMT, BBnNZ, Type,Length,Name,Format,Columns\n")

    def _declare(self, name: str) -> None:
        kind, fmt, columns = LAYOUTS[name]
        packer, _ = _struct(fmt)
        if self.text:
            self.handle.write(f"FMT, {kind}, {packer.size + 3}, {name}, {fmt}, {columns}\n")
        else:
            self.handle.write(FMT_STRUCT.pack(0xA3, 0x95, 0x80, kind, packer.size + 3, name.encode(), fmt.encode(),
                                              columns.encode()))
        self.declared.add(name)

    def write(self, name: str, *values: Any) -> None:
        """One message: the values in the layout's units (degrees, metres, ...), TimeUS first."""
        if name not in self.declared:
            self._declare(name)
        kind, fmt, _ = LAYOUTS[name]
        if self.text:
            cells = [v if isinstance(v, str) else repr(v) for v in values]
            self.handle.write(f"{name}, " + ", ".join(cells) + "\n")
            return
        packer, mults = _struct(fmt)
        raw = [v.encode() if isinstance(v, str) else round(v / m) if m else v
               for v, m in zip(values, mults, strict=True)]
        self.handle.write(bytes((0xA3, 0x95, kind)) + packer.pack(*raw))

    def close(self) -> None:
        """Done."""
        self.handle.close()


def write_dataflash(path: Path, motion: Motion, modes: Sequence[tuple[float, int]] = ((0.0, 0),),
                    armed_at: float | None = 0.0, waypoints_ne: Sequence[tuple[float, float]] = (),
                    params: dict[str, float] | None = None, text: bool = False, imu: bool = True,
                    outputs: bool = True) -> None:
    """A Rover's DataFlash log of ``motion``: ATT and IMU at every sample, GPS at every second sample, MODE at
    ``modes`` (t, Rover mode number), ARM at ``armed_at``, the mission (home, then ``waypoints_ne`` metres from
    HOME), parameters, and RCOU/RCIN at 5 Hz."""
    log = DataflashWriter(path, text)
    log.write("MSG", 0, "ArduRover V4.5.7 (test)")
    for name, value in (params or {}).items():
        log.write("PARM", 0, name, float(value), float(value))
    log.write("CMD", 0, len(waypoints_ne) + 1, 0, 16, 0.0, 0.0, 0.0, 0.0, HOME[0], HOME[1], 0.0, 0)
    for i, (n, e) in enumerate(waypoints_ne, start=1):
        lat, lon = latlon_from_ned(*HOME, n, e)
        log.write("CMD", 0, len(waypoints_ne) + 1, i, 16, 0.0, 0.0, 0.0, 0.0, lat, lon, 0.0, 3)
    pending_modes, arm = sorted(modes), armed_at
    for i, t in enumerate(motion.t):
        us = round(t * 1e6) + 1_000_000
        while pending_modes and pending_modes[0][0] <= t:
            log.write("MODE", us, pending_modes[0][1], pending_modes[0][1], 1)
            pending_modes.pop(0)
        if arm is not None and arm <= t:
            log.write("ARM", us, 1, 0, 0, 0)
            arm = None
        roll, pitch, yaw = (math.degrees(float(a)) for a in motion.eta[i, 3:6])
        if imu:
            log.write("IMU", us, 0, *(float(v) for v in motion.rates[i]), *(float(v) for v in motion.accel[i]), 0, 0,
                      25.0, 1, 1, 400, 400)
        log.write("ATT", us, 0.0, roll, 0.0, pitch, 0.0, yaw % 360.0, 0.0, 0.0, 0)
        if i % 2 == 0:
            _gps(log, us, motion, i)
        if outputs and i % 4 == 0:
            log.write("RCOU", us, 1700, 0, 1650, *[0] * 11)
            log.write("RCIN", us, 1500, 0, 1800, *[0] * 11)
    log.close()


def _gps(log: DataflashWriter, us: int, motion: Motion, i: int) -> None:
    lat, lon = motion.latlon(i)
    vn, ve, vd = (float(v) for v in motion.velocity_ned[i])
    course = math.degrees(math.atan2(ve, vn)) % 360.0
    log.write("GPS", us, 0, 6, 300_000_000 + us // 1000, 2300, 14, 0.7, lat, lon, 12.0, math.hypot(vn, ve), course,
              -vd, 0.0, 1)


# ---------------------------------------------------------------- Otter API CSV
OTTER_41 = ("current_time;lat;lon;height;previous_lat;previous_lon;previous_height;last_speed_update;"
            "current_course_over_ground;current_speed;current_fuel_capacity;current_orientation_1;"
            "current_orientation_2;current_orientation_3;current_rotational_velocities_1;"
            "current_rotational_velocities_2;current_rotational_velocities_3;observer_lat;observer_lon;"
            "observer_height;north_from_observer;east_from_observer;down_from_observer;previous_time;cycle_time;"
            "speed_n;speed_e;speed_surge;speed_sway;n1;n2;north_error;east_error;distance_to_target;yaw_setpoint;"
            "current_angle;tau_X;tau_N;target_north_from_observer;target_east_from_observer").split(";")
OTTER_30 = [c for c in OTTER_41 if c not in ("current_time", "previous_time", "cycle_time", "speed_n", "speed_e",
                                              "speed_surge", "speed_sway", "n1", "n2", "target_north_from_observer",
                                              "target_east_from_observer")]
MONTHS = ("jan", "feb", "mar", "apr", "mai", "jun", "jul", "aug", "sep", "okt", "nov", "des")


def spreadsheet_date(text: str) -> str | None:
    """How a Norwegian spreadsheet shows a number's text when it takes it for a date: 'd.m' as a day of a month
    ('4.2' and '4.02' both as '04.feb'), else 'm.yy' as a month of a year ('1.45' as 'jan.45'); None for a
    number it leaves alone."""
    found = re.fullmatch(r"(\d{1,2})\.(\d{1,2})", text)
    if not found:
        return None
    whole, fraction = int(found.group(1)), int(found.group(2))
    if 1 <= fraction <= 12 and 1 <= whole <= calendar.monthrange(2023, fraction)[1]:
        return f"{whole:02d}.{MONTHS[fraction - 1]}"
    if 1 <= whole <= 12 and len(found.group(2)) == 2:
        return f"{MONTHS[whole - 1]}.{found.group(2)}"
    return None


def is_month(value: float) -> bool:
    """A spreadsheet takes the number (as the API writes it) for a date."""
    return spreadsheet_date(repr(value)) is not None


@dataclass(frozen=True)
class OtterRow:
    """One row of an Otter API log (degrees, as the API logs them)."""

    t: float
    lat: float
    lon: float
    course_deg: float
    speed: float
    attitude_deg: tuple[float, float, float]
    rates_deg_s: tuple[float, float, float]
    extra: tuple[tuple[str, float], ...] = ()  # other columns' values (n1, tau_X, observer_lat ...)


def otter_rows(motion: Motion, placeholder: bool = True, repeats_every: int = 0,
               no_fix_every: int = 0) -> list[OtterRow]:
    """The rows the Otter API would log of ``motion``: a leading all-zero placeholder and a 3 s gap, an attitude
    repeated (stale) every ``repeats_every`` rows, no fix every ``no_fix_every`` rows. The roll rate has two
    decimals (what a spreadsheet can take for a date)."""
    rows = [OtterRow(0.0, *HOME, 0.0, 6635852.8, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))] if placeholder else []
    start = 3.0 if placeholder else 0.0
    for i, t in enumerate(motion.t):
        lat, lon = motion.latlon(i)
        vn, ve = float(motion.velocity_ned[i, 0]), float(motion.velocity_ned[i, 1])
        attitude = tuple(round(math.degrees(float(a)), 3) for a in motion.eta[i, 3:6])
        rates = tuple(round(math.degrees(float(r)), 3 if n else 2) for n, r in enumerate(motion.rates[i]))
        if repeats_every and i % repeats_every == repeats_every - 1 and rows:
            attitude, rates = rows[-1].attitude_deg, rows[-1].rates_deg_s
        if no_fix_every and i % no_fix_every == no_fix_every - 1:
            lat = lon = 0.0
        rows.append(OtterRow(start + float(t), lat, lon, math.degrees(math.atan2(ve, vn)), math.hypot(vn, ve),
                             attitude, rates))  # type: ignore[arg-type]
    return rows


def write_otter_csv(path: Path, rows: Iterable[OtterRow], columns: Sequence[str] = OTTER_41,
                    spreadsheet: bool = False) -> None:
    """The rows in the Otter API's semicolon CSV (an unnamed local-time first column); ``spreadsheet``: the file
    went through a spreadsheet, which turned the attitude and rates it took for dates into dates
    (``spreadsheet_date``)."""
    lines = [";" + ";".join(columns)]
    for row in rows:
        stamp = datetime.fromtimestamp(EPOCH_S + row.t)
        values: dict[str, str] = {name: "0.0" for name in columns}
        values.update(current_time=f"{EPOCH_S + row.t:.7f}", lat=repr(row.lat), lon=repr(row.lon),
                      current_course_over_ground=f"{row.course_deg:.3f}", current_speed=repr(row.speed),
                      current_fuel_capacity="0.74")
        values.update((name, repr(value)) for name, value in row.extra if name in values)
        cells = {**{f"current_orientation_{n}": v for n, v in enumerate(row.attitude_deg, start=1)},
                 **{f"current_rotational_velocities_{n}": v for n, v in enumerate(row.rates_deg_s, start=1)}}
        for name, value in cells.items():
            values[name] = (spreadsheet_date(repr(value)) or repr(value)) if spreadsheet else repr(value)
        lines.append(stamp.strftime("%Y-%m-%d_%H:%M:%S:%f") + ";" + ";".join(values[c] for c in columns))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


# ---------------------------------------------------------------- MAVLink tlog
def write_tlog(path: Path, frames: Iterable[tuple[float, Any, int, int]]) -> None:
    """A tlog of (t s, message, sysid, compid): each frame packed by pymavlink, stamped EPOCH_S + t."""
    packers: dict[tuple[int, int], Any] = {}
    with path.open("wb") as handle:
        for t, msg, sysid, compid in frames:
            packer = packers.setdefault((sysid, compid), mav.MAVLink(None, srcSystem=sysid, srcComponent=compid))
            handle.write(struct.pack(">Q", round((EPOCH_S + t) * 1e6)) + msg.pack(packer))


def motion_frames(motion: Motion, sysid: int = 1, compid: int = 1, mode: int = 0,
                  armed: bool = False) -> list[tuple[float, Any, int, int]]:
    """What an ArduPilot boat streams of ``motion``: HEARTBEAT at 1 Hz, ATTITUDE at every sample,
    GLOBAL_POSITION_INT at every second one."""
    frames = []
    base = mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (mav.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0)
    next_beat = 0.0
    for i, t in enumerate(motion.t):
        ms = round(float(t) * 1000) + 5000
        if t >= next_beat:
            frames.append((float(t), mav.MAVLink_heartbeat_message(mav.MAV_TYPE_SURFACE_BOAT,
                                                                   mav.MAV_AUTOPILOT_ARDUPILOTMEGA, base, mode, 4, 3),
                           sysid, compid))
            next_beat += 1.0
        roll, pitch, yaw = (float(a) for a in motion.eta[i, 3:6])
        frames.append((float(t), mav.MAVLink_attitude_message(ms, roll, pitch, math.remainder(yaw, 2 * math.pi),
                                                              *(float(r) for r in motion.rates[i])), sysid, compid))
        if i % 2 == 0:
            lat, lon = motion.latlon(i)
            vn, ve, vd = (round(float(v) * 100) for v in motion.velocity_ned[i])
            frames.append((float(t), mav.MAVLink_global_position_int_message(ms, round(lat * 1e7), round(lon * 1e7),
                                                                            0, 0, vn, ve, vd, 0), sysid, compid))
    return frames
