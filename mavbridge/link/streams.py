"""The telemetry the companion asks an ArduPilot Rover for, and how it asks (one place for run and check).

SET_MESSAGE_INTERVAL per message first; where the autopilot does not accept it, the older
REQUEST_DATA_STREAM groups (EXTRA1 carries ATTITUDE, POSITION the two position messages). Heartbeats
are asked for at twice the control rate, so that a pilot's mode change stops the companion within one
period. ``restore_configured`` (interval 0) hands each message back to the port's SRn_* / MAVn_* rates.

The IMU (for the wave estimator) is asked for apart from the rest, so that an autopilot without it does
not send the others down the fallback path: SCALED_IMU at the ATTITUDE rate, else RAW_IMU (on ArduPilot
the same first IMU, scaled alike), else the RAW_SENS group (RAW_IMU, SCALED_IMU2/3). Whether it then
arrives is measured, not assumed: without it the estimator uses the GPS height.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from mavbridge.link.connection import mavlink

STREAMS_HZ = {mavlink.MAVLINK_MSG_ID_ATTITUDE: 20.0, mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 10.0,
              mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 10.0}
FALLBACK_STREAMS_HZ = {mavlink.MAV_DATA_STREAM_EXTRA1: 20, mavlink.MAV_DATA_STREAM_POSITION: 10}
IMU_HZ = 20.0
IMU_REQUESTS = (mavlink.MAVLINK_MSG_ID_SCALED_IMU, mavlink.MAVLINK_MSG_ID_RAW_IMU)
IMU_MEASURED = ("SCALED_IMU", "RAW_IMU", "SCALED_IMU2")
MEASURED = ("ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "HEARTBEAT", *IMU_MEASURED)


def requested_hz(message: str) -> float | None:
    """The rate the companion asks for ``message`` (e.g. 'ATTITUDE'), or None if it asks for none."""
    return STREAMS_HZ.get(getattr(mavlink, f"MAVLINK_MSG_ID_{message}", -1))


def request_streams(link: Any, period_s: float, log: Callable[[str], None]) -> str:
    """Ask for the companion's streams (falling back to REQUEST_DATA_STREAM) and fast heartbeats; returns the IMU
    message asked for (``request_imu``)."""
    refused = [msg_id for msg_id, rate in STREAMS_HZ.items() if not link.request_message_interval(msg_id, rate)]
    if refused:
        log("SET_MESSAGE_INTERVAL not accepted: falling back to REQUEST_DATA_STREAM")
        for stream, rate in FALLBACK_STREAMS_HZ.items():
            link.request_data_stream(stream, rate)
    if not link.request_message_interval(mavlink.MAVLINK_MSG_ID_HEARTBEAT, 2.0 / period_s):
        log("warning: HEARTBEAT rate not raised; a mode change is noticed within 1 s only")
    return request_imu(link)


def request_imu(link: Any) -> str:
    """Ask for the IMU at IMU_HZ: SCALED_IMU, else RAW_IMU, else the RAW_SENS group; returns what was asked."""
    for msg_id in IMU_REQUESTS:
        if link.request_message_interval(msg_id, IMU_HZ):
            return mavlink.mavlink_map[msg_id].msgname
    link.request_data_stream(mavlink.MAV_DATA_STREAM_RAW_SENSORS, round(IMU_HZ))
    return "RAW_SENS"


def imu_rate(rates: dict[str, float]) -> tuple[str | None, float]:
    """The fastest IMU message among measured ``rates`` and its rate (None, 0.0 when none arrives)."""
    best = max(IMU_MEASURED, key=lambda name: rates.get(name, 0.0))
    rate = float(rates.get(best, 0.0))
    return (best, rate) if rate > 0 else (None, 0.0)


def restore_configured(link: Any) -> None:
    """SET_MESSAGE_INTERVAL 0 for every message the companion asks for: back to the port's configured rate."""
    for msg_id in (mavlink.MAVLINK_MSG_ID_HEARTBEAT, *STREAMS_HZ, *IMU_REQUESTS):
        link.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, 0.0))


def measure_rates(link: Any, clock_ms: Callable[[], int | None], seconds: float = 2.0,
                  warn: Callable[[str], None] | None = None) -> dict[str, float]:
    """Messages per autopilot second (``clock_ms``: the newest time_boot_ms) over ``seconds`` of listening.

    Falls back to wall time when the autopilot's clock did not advance (nothing stamped arrived). A known
    clock that advanced less than half the wall time listened (a simulator held still for part of it, or not
    running at all) is said through ``warn``: rates of a held simulator are its repeats, not its streams
    (a lockstep ``--start-at`` reached before the companion's startup ended).
    """
    before = dict(link.rates)
    first_ms = clock_ms()
    start = time.monotonic()
    link.wait_for(lambda m: False, seconds)
    wall = time.monotonic() - start
    span = ((clock_ms() or 0) - (first_ms or 0)) / 1000.0 if first_ms is not None else 0.0
    if first_ms is not None and span < 0.5 * wall and warn is not None:  # a known clock that (nearly) stood still
        warn(f"warning: the autopilot's clock advanced {max(span, 0.0):.2f} s in {wall:.1f} s of measuring stream "
             "rates (time held: in lockstep, --start-at came before this startup ended; raise it): the rates are "
             "not the streams'")
    span = span if span > 0 else wall
    return {name: round((link.rates.get(name, 0) - before.get(name, 0)) / span, 1) for name in MEASURED}
