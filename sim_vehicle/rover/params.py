"""Rover parameters: names, MAVLink types and defaults, the persistent store and ``.parm`` files.

The parameters this simulator acts on (plus the ones tools commonly read) are built in; values are
kept as floats and cast to the parameter's integer type on write, as ArduPilot's AP_Param does.
Other real ArduPilot names given in a ``.parm`` file (``extra``) are kept as REAL32 parameters after
the built-in ones: stored, readable, settable and listed, but not acted on.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim_vehicle.sensing import WIND_PARAMS, sim_param_defaults
from vessel.config import ConfigError

INT8, INT16, INT32, REAL32 = 2, 4, 6, 9  # MAV_PARAM_TYPE values
_INT_LIMITS = {INT8: (-128, 127), INT16: (-32768, 32767), INT32: (-(2**31), 2**31 - 1)}

STREAM_NAMES = (
    "RAW_SENS",
    "EXT_STAT",
    "RC_CHAN",
    "RAW_CTRL",
    "POSITION",
    "EXTRA1",
    "EXTRA2",
    "EXTRA3",
    "PARAMS",
    "ADSB",
)
_STREAM_DEFAULTS = {"PARAMS": 10, "ADSB": 0}
N_STREAM_CHANNELS = 4


@dataclass(frozen=True)
class ParamDef:
    """One parameter: its name, MAV_PARAM_TYPE and default value."""

    name: str
    ptype: int
    default: float


def _defs() -> list[ParamDef]:
    """The parameter table, in the order PARAM_REQUEST_LIST reports it."""
    r, i8, i16, i32 = REAL32, INT8, INT16, INT32
    table: list[tuple[str, int, float]] = [
        ("FORMAT_VERSION", i16, 16),
        ("SYSID_THISMAV", i16, 1),
        ("SYSID_MYGCS", i16, 255),
        ("SYSID_ENFORCE", i8, 0),
        ("FRAME_CLASS", i8, 2),
        ("FRAME_TYPE", i8, 0),
        ("INITIAL_MODE", i8, 0),
        ("MODE_CH", i8, 8),
        ("PILOT_STEER_TYPE", i8, 0),
        # Which RC inputs steer and throttle (Rover's defaults). The simulator's sticks are channels 1 and 3:
        # other values are reported (a companion reads them) but not simulated; sim-vehicle warns at start.
        ("RCMAP_ROLL", i8, 1),
        ("RCMAP_THROTTLE", i8, 3),
        ("ARMING_CHECK", i32, 1),
        ("ARMING_REQUIRE", i8, 1),
        # The speed feed-forward matched to the Otter (deploy/otter-json-sitl.parm: 80 % shaft speed gives
        # 2.08 m/s in calm water); Rover's 2 m/s at 50 % would leave a third of the throttle to the PI.
        ("CRUISE_SPEED", r, 2.08),
        ("CRUISE_THROTTLE", i8, 80),
        ("WP_SPEED", r, 2.0),
        ("WP_RADIUS", r, 2.0),
        ("RTL_SPEED", r, 0.0),
        ("TURN_RADIUS", r, 0.9),
        ("LOIT_RADIUS", r, 2.0),
        ("LOIT_SPEED_GAIN", r, 0.5),
        ("ACRO_TURN_RATE", r, 180.0),
        ("MIS_DONE_BEHAVE", i8, 0),
        ("MIS_RESTART", i8, 0),
        ("FS_ACTION", i8, 2),
        ("FS_TIMEOUT", r, 1.5),
        ("FS_THR_ENABLE", i8, 1),
        ("FS_THR_VALUE", i16, 910),
        ("FS_GCS_ENABLE", i8, 0),
        ("FS_GCS_TIMEOUT", r, 5.0),
        ("FS_OPTIONS", i32, 0),
        ("RC_OVERRIDE_TIME", r, 3.0),
        ("RC_OPTIONS", i32, 32),
        ("MOT_THST_ASYM", r, 1.0),
        ("MOT_STR_THR_MIX", r, 0.5),
        ("MOT_SAFE_DISARM", i8, 0),
        ("MOT_SLEWRATE", i16, 100),
        ("MOT_THR_MAX", i8, 100),
        # Serial ports: protocol 2 = MAVLink2, baud in ArduPilot's short codes (57 = 57600, 921 = 921600).
        ("SERIAL0_PROTOCOL", i8, 2),
        ("SERIAL0_BAUD", i32, 115),
        ("SERIAL1_PROTOCOL", i8, 2),
        ("SERIAL1_BAUD", i32, 57),
        ("SERIAL2_PROTOCOL", i8, 2),
        ("SERIAL2_BAUD", i32, 57),
        # Steering and speed controllers: names as ArduPilot's, gains tuned for the Otter's thrusters.
        ("ATC_STR_ANG_P", r, 2.0),
        ("ATC_STR_RAT_MAX", r, 20.0),
        ("ATC_STR_RAT_FF", r, 2.85),  # 1 / the hull's turn rate at full steering (0.3503 rad/s)
        ("ATC_STR_RAT_P", r, 1.0),
        ("ATC_STR_RAT_I", r, 0.5),
        ("ATC_STR_RAT_IMAX", r, 1.0),
        ("ATC_SPEED_P", r, 0.3),
        ("ATC_SPEED_I", r, 0.2),
        ("ATC_SPEED_IMAX", r, 1.0),
        ("ATC_ACCEL_MAX", r, 1.0),
    ]
    for n in (1, 3):
        table += [
            (f"RC{n}_MIN", i16, 1100),
            (f"RC{n}_TRIM", i16, 1500),
            (f"RC{n}_MAX", i16, 1900),
            (f"RC{n}_REVERSED", i8, 0),
            (f"RC{n}_DZ", i16, 30),
        ]
    for n, function in ((1, 73), (3, 74)):
        table += [
            (f"SERVO{n}_FUNCTION", i16, function),
            (f"SERVO{n}_MIN", i16, 1100),
            (f"SERVO{n}_TRIM", i16, 1500),
            (f"SERVO{n}_MAX", i16, 1900),
            (f"SERVO{n}_REVERSED", i8, 0),
        ]
    table += [(name, r, default) for name, default in sim_param_defaults()]  # sensor model, see sensing.py
    table += [(name, r, 0.0) for name in WIND_PARAMS]  # the wind, as ArduPilot SITL's (see physics.py)
    for ch in range(N_STREAM_CHANNELS):
        table += [(f"SR{ch}_{s}", i16, _STREAM_DEFAULTS.get(s, 1)) for s in STREAM_NAMES]
    return [ParamDef(name, ptype, float(default)) for name, ptype, default in table]


PARAM_DEFS: tuple[ParamDef, ...] = tuple(_defs())


_BAUD_CODES = {1: 1200, 2: 2400, 4: 4800, 9: 9600, 19: 19200, 38: 38400, 57: 57600, 111: 111100, 115: 115200,
               230: 230400, 256: 256000, 460: 460800, 500: 500000, 921: 921600, 1500: 1500000, 2000: 2000000}


def baud_from_code(code: float) -> int:
    """SERIALn_BAUD as a bit rate: ArduPilot's short codes, else values above 2000 taken as bits/s."""
    value = round(code)
    if value in _BAUD_CODES:
        return _BAUD_CODES[value]
    if value > 2000:
        return value
    raise ValueError(f"{value} is not a SERIALn_BAUD code")


# Name prefixes of ArduPilot Rover's parameter groups (libraries and vehicle code), for telling a real
# parameter this simulator does not model from a typo or an invented name.
ARDUPILOT_GROUPS = (
    "ACRO_", "ADSB_", "AHRS_", "AIS_", "ARMING_", "ARSPD", "ATC_", "AUTO_", "AVOID_", "BARO", "BATT", "BCN_", "BRD_",
    "BTN_", "CAM", "CAN_", "CIRC_", "COMPASS_", "CRUISE_", "CUST_ROT", "DOCK_", "EAHRS", "EK2_", "EK3_", "ESC_",
    "FENCE_", "FFT_", "FLOW", "FOLL_", "FORMAT_VERSION", "FRAME_", "FRSKY_", "FS_", "GCS_", "GEN_", "GPS", "GRIP_",
    "GUID_", "ICE_", "INITIAL_MODE", "INS_", "LOG_", "LOIT_", "MAV", "MIS_", "MNT", "MODE", "MOT_", "MSP_",
    "NAVL1_", "NET_", "NTF_", "OA_", "OSD", "PILOT_", "PRX", "PSC_", "RALLY_", "RC", "RELAY", "RNGFND", "RPM", "RSSI_",
    "RTC_", "RTL_", "SAIL_", "SCHED_", "SCR_", "SERIAL", "SERVO", "SIM_", "SPEED_", "SPRAY_", "SR", "STAT_",
    "STEER2SRV_", "SYSID_", "TEMP", "TERRAIN_", "TUNE", "TURN_", "VISO", "VTX_", "WENC", "WNDVN", "WP_", "WRC",
)


def is_param_name(name: str) -> bool:
    """A plausible ArduPilot Rover parameter: at most 16 of A-Z, 0-9 and _, in one of Rover's groups."""
    return (
        1 <= len(name) <= 16
        and all(c.isupper() or c.isdigit() or c == "_" for c in name)
        and name.startswith(ARDUPILOT_GROUPS)
    )


def cast(ptype: int, value: float) -> float:
    """The value a parameter of type ``ptype`` actually holds after being set to ``value``."""
    if ptype == REAL32:
        return float(value)
    lo, hi = _INT_LIMITS[ptype]
    return float(min(hi, max(lo, round(value))))


class ParamTable:
    """The live parameter values, with index order, defaults and an optional JSON store on disk."""

    def __init__(
        self,
        store: Path | None = None,
        defaults: dict[str, float] | None = None,
        extra: dict[str, float] | None = None,
    ) -> None:
        known = {d.name for d in PARAM_DEFS}
        added = [ParamDef(n, REAL32, float(v)) for n, v in (extra or {}).items() if n not in known]
        self.defs = PARAM_DEFS + tuple(added)
        self.extra_names = tuple(d.name for d in added)
        self._by_name = {d.name: i for i, d in enumerate(self.defs)}
        self._values = [d.default for d in self.defs]
        for name, value in (defaults or {}).items():
            self._values[self._by_name[name]] = cast(self.defs[self._by_name[name]].ptype, value)
        self.store = store
        self.storage: dict[str, Any] = {}  # non-parameter records kept in the same store (``_name`` keys), e.g.
        if store is not None:  # the MAVLink signing key, which like ArduPilot's lives with the parameters
            self._load_store(store)

    def __len__(self) -> int:
        return len(self.defs)

    def __contains__(self, name: str) -> bool:
        return name in self._by_name

    def __getitem__(self, name: str) -> float:
        return self._values[self._by_name[name]]

    def index(self, name: str) -> int:
        """The parameter's index in PARAM_REQUEST_LIST order; KeyError if unknown."""
        return self._by_name[name]

    def at(self, index: int) -> tuple[ParamDef, float]:
        """Definition and value at ``index``; IndexError if out of range."""
        if not 0 <= index < len(self.defs):
            raise IndexError(index)
        return self.defs[index], self._values[index]

    def set(self, name: str, value: float, save: bool = True) -> bool:
        """Set a known parameter to a finite value (cast to its type) and persist it; False if refused."""
        if name not in self._by_name or not math.isfinite(value):
            return False
        i = self._by_name[name]
        self._values[i] = cast(self.defs[i].ptype, value)
        if save and self.store is not None:
            self._save_store(self.store)
        return True

    def save_storage(self, name: str, record: dict[str, Any] | None) -> None:
        """Keep (or, with None, forget) a non-parameter record in the store, persisted at once."""
        if record is None:
            self.storage.pop(name, None)
        else:
            self.storage[name] = record
        if self.store is not None:
            self._save_store(self.store)

    def _load_store(self, path: Path) -> None:
        """Apply saved values; a missing store is an empty one, a corrupt store is a ConfigError."""
        if not path.exists():
            return
        try:
            saved = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ConfigError(
                f"{path}: unreadable parameter store ({exc}); use --wipe to start afresh"
            ) from None
        if not isinstance(saved, dict):
            raise ConfigError(f"{path}: parameter store is not a mapping; use --wipe to start afresh")
        for name, value in saved.items():
            if str(name).startswith("_") and isinstance(value, dict):
                self.storage[str(name)[1:]] = value
            elif isinstance(value, (int, float)) and not isinstance(value, bool):
                self.set(str(name), float(value), save=False)

    def _save_store(self, path: Path) -> None:
        """Write every value that differs from its default, atomically."""
        changed: dict[str, Any] = {d.name: v for d, v in zip(self.defs, self._values, strict=True) if v != d.default}
        changed.update({f"_{name}": record for name, record in self.storage.items()})
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(path.suffix + ".tmp")
            tmp.write_text(json.dumps(changed, indent=1, sort_keys=True), encoding="utf-8")
            os.replace(tmp, path)
        except OSError:
            pass  # like a failing EEPROM write: the value still applies for this run


def parse_parm(lines: Iterable[str], where: str) -> dict[str, float]:
    """Parse ``NAME VALUE`` or ``NAME,VALUE`` lines with ``#`` comments into a mapping."""
    values: dict[str, float] = {}
    for number, raw in enumerate(lines, 1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.replace(",", " ").split()
        try:
            if len(parts) != 2:
                raise ValueError
            value = float(parts[1])
            if not math.isfinite(value):
                raise ValueError
        except ValueError:
            raise ConfigError(f"{where}:{number}: expected 'NAME VALUE', got {raw.strip()!r}") from None
        values[parts[0].upper()] = value
    return values


def read_parm(path: Path) -> dict[str, float]:
    """Read a ``.parm`` file; unreadable files and bad lines raise a one-line ConfigError."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read parameter file ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: cannot read parameter file ({exc})") from None
    return parse_parm(text.splitlines(), str(path))


def default_speed(params: ParamTable) -> float:
    """Rover's default speed in m/s: WP_SPEED if set, else CRUISE_SPEED (older firmware's fallback)."""
    wp = params["WP_SPEED"]
    return wp if wp > 0 else params["CRUISE_SPEED"]
