"""ArduPilot's JSON SITL wire format, both directions, with no I/O: servo packets in, sensor JSON out.

Checked against ArduPilot's ``libraries/SITL/SIM_JSON.{h,cpp}`` and ``libraries/SITL/examples/JSON``:

- The firmware sends little-endian ``uint16 magic, uint16 frame_rate, uint32 frame_count,
  uint16 pwm[N]``: N = 16 with magic 18458 (40 bytes) or N = 32 with magic 29569 (72 bytes, when
  SERVO_32_ENABLE = 1). frame_rate is SIM_RATE_HZ, the step the physics should take is 1/frame_rate;
  frame_count grows by one per frame, repeats when the firmware re-sends after a silent second, and
  starts again from 0 when the firmware restarts. PWM is µs; an output not driven reads 0.
- The reply is one JSON object with a newline before and after it. The firmware's parser is not a
  JSON parser: it finds each key with ``strstr`` and reads the value starting right after ``":``, and
  vectors with ``sscanf("[%f, %f, %f]")``, so there must be no space between a key's colon and its
  value. Fields: ``timestamp`` (s, physics time, absolute), ``imu.gyro`` (rad/s, body FRD),
  ``imu.accel_body`` (m/s², specific force, body FRD), ``position`` (m, NED from the origin),
  ``velocity`` (m/s, NED) and ``quaternion`` [w, x, y, z] (body to NED; wins over ``attitude``).
  Vectors are read as float32 (position as double), so 9 significant digits are exact.
"""

from __future__ import annotations

import struct
from typing import Any, NamedTuple

from vessel.mathops import ops

MAGIC_16 = 18458
MAGIC_32 = 29569
PACKET_16 = struct.Struct("<HHI16H")
PACKET_32 = struct.Struct("<HHI32H")
FRAME_RATE_MIN_HZ = 1
FRAME_RATE_MAX_HZ = 2000

# ThrottleLeft on SERVO1, ThrottleRight on SERVO3 (SERVOn_FUNCTION 73 / 74), channel indices 0 and 2.
LEFT_CHANNEL = 0
RIGHT_CHANNEL = 2
# The ESC pulse range deploy/otter-json-sitl.parm gives SERVO1/SERVO3 (as on the boat): reverse, stop, full.
SERVO_MIN_US = 1100
SERVO_TRIM_US = 1500
SERVO_MAX_US = 1900
# Pulses outside this band are not a servo command (0 = output not driven): read as stopped.
PWM_VALID_MIN_US = 500
PWM_VALID_MAX_US = 2500

_REPLY = (
    '\n{"timestamp":%r,"imu":{"gyro":[%.9g,%.9g,%.9g],"accel_body":[%.9g,%.9g,%.9g]},'
    '"position":[%r,%r,%r],"velocity":[%.9g,%.9g,%.9g],"quaternion":[%.9g,%.9g,%.9g,%.9g]}\n'
)
REPLY_VALUES = 17  # timestamp, gyro 3, accel 3, position 3, velocity 3, quaternion 4


class BadPacketError(ValueError):
    """A datagram that is not a usable servo packet; ``reason`` is a short key for counting."""

    def __init__(self, reason: str, detail: str) -> None:
        super().__init__(detail)
        self.reason = reason


class ServoFrame(NamedTuple):
    """One decoded servo packet (a NamedTuple: built at 400 Hz, so cheap to make)."""

    frame_rate_hz: int
    frame_count: int
    pwm_us: tuple[int, ...]

    @property
    def dt_s(self) -> float:
        """The physics step this frame asks for, s."""
        return 1.0 / self.frame_rate_hz


def parse_servo_packet(data: bytes) -> ServoFrame:
    """Decode a 16- or 32-channel servo packet; BadPacketError for a wrong size, magic or frame rate."""
    if len(data) == PACKET_16.size:
        magic, rate, count, *pwm = PACKET_16.unpack(data)
        expected = MAGIC_16
    elif len(data) == PACKET_32.size:
        magic, rate, count, *pwm = PACKET_32.unpack(data)
        expected = MAGIC_32
    else:
        raise BadPacketError("size", f"{len(data)} bytes, not a servo packet ({PACKET_16.size} or {PACKET_32.size})")
    if magic != expected:
        raise BadPacketError("magic", f"magic {magic} in a {len(data)}-byte packet (expected {expected})")
    if not FRAME_RATE_MIN_HZ <= rate <= FRAME_RATE_MAX_HZ:
        raise BadPacketError("frame_rate", f"frame_rate {rate} Hz is outside the allowed range "
                                      f"[{FRAME_RATE_MIN_HZ}, {FRAME_RATE_MAX_HZ}] Hz (SIM_RATE_HZ)")
    return ServoFrame(rate, count, tuple(pwm))


def pwm_to_motor_output(pwm_us: int) -> float:
    """A ThrottleLeft/Right pulse -> motor output in [-1, 1] about SERVOn_TRIM; 0 µs (not driven) -> 0."""
    if not PWM_VALID_MIN_US <= pwm_us <= PWM_VALID_MAX_US:
        return 0.0
    if pwm_us >= SERVO_TRIM_US:
        out = (pwm_us - SERVO_TRIM_US) / (SERVO_MAX_US - SERVO_TRIM_US)
    else:
        out = (pwm_us - SERVO_TRIM_US) / (SERVO_TRIM_US - SERVO_MIN_US)
    return min(1.0, max(-1.0, out))


def motor_outputs(frame: ServoFrame) -> tuple[float, float]:
    """(left, right) motor outputs in [-1, 1] from SERVO1 and SERVO3."""
    return pwm_to_motor_output(frame.pwm_us[LEFT_CHANNEL]), pwm_to_motor_output(frame.pwm_us[RIGHT_CHANNEL])


def motor_output_to_pwm(out: float) -> int:
    """The inverse, for test doubles and checks: motor output in [-1, 1] -> pulse µs."""
    out = min(1.0, max(-1.0, out))
    span = SERVO_MAX_US - SERVO_TRIM_US if out >= 0 else SERVO_TRIM_US - SERVO_MIN_US
    return round(SERVO_TRIM_US + out * span)


def encode_servo_packet(frame_rate_hz: int, frame_count: int, pwm_us: list[int] | tuple[int, ...],
                        channels: int = 16) -> bytes:
    """A servo packet as the firmware sends it (16 or 32 channels, missing channels 0); for test doubles."""
    padded = list(pwm_us) + [0] * (channels - len(pwm_us))
    if channels == 16:
        return PACKET_16.pack(MAGIC_16, frame_rate_hz, frame_count, *padded)
    if channels == 32:
        return PACKET_32.pack(MAGIC_32, frame_rate_hz, frame_count, *padded)
    raise ValueError(f"channels: {channels} is not 16 or 32")


def quaternion_from_euler(phi: Any, theta: Any, psi: Any) -> tuple[Any, Any, Any, Any]:
    """[w, x, y, z] of the ZYX (yaw, pitch, roll) body-to-NED rotation; floats or CasADi symbols."""
    xp = ops(phi, theta, psi)
    cr, sr = xp.cos(phi / 2), xp.sin(phi / 2)
    cp, sp = xp.cos(theta / 2), xp.sin(theta / 2)
    cy, sy = xp.cos(psi / 2), xp.sin(psi / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy)


def encode_reply(values: tuple[float, ...] | list[float]) -> bytes:
    """The sensor reply: timestamp, gyro[3], accel_body[3], position[3], velocity[3], quaternion[4].

    Python floats expected (timestamp and position are written as their shortest exact repr).
    """
    return (_REPLY % tuple(values)).encode("ascii")
