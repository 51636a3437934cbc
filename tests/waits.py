"""Waits for tests that talk MAVLink to a simulator: each one returns what it waited for or raises WaitTimeoutError.

Deadlines are wall-clock upper bounds only; what a test checks is read from the messages themselves
(``time_boot_ms`` is simulated time), so a slow machine makes a test slower, never wrong. A timeout names
what was awaited, where the condition was written and the last matching-type message seen, instead of
handing a ``None`` to the next line.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.rover import MODE_NAMES

TIMED = ["ATTITUDE", "GLOBAL_POSITION_INT", "SYSTEM_TIME"]  # messages that carry time_boot_ms


class WaitTimeoutError(TimeoutError):
    """Something awaited from the simulator did not come in time; the message says what."""


def _describe(cond: Callable[[Any], bool] | None) -> str:
    """Where a condition was written (file:line), for timeout messages."""
    code = getattr(cond, "__code__", None)
    if code is None:
        return "" if cond is None else f" matching {cond!r}"
    return f" matching the condition at {Path(code.co_filename).name}:{code.co_firstlineno}"


def wait_for(
    conn: Any, kind: str | list[str], timeout: float = 10.0, cond: Callable[[Any], bool] | None = None
) -> Any:
    """The next message of ``kind`` satisfying ``cond`` within ``timeout`` wall seconds; else WaitTimeoutError."""
    deadline = time.monotonic() + timeout
    last = None
    while (left := deadline - time.monotonic()) > 0:
        msg = conn.recv_match(type=kind, blocking=True, timeout=min(left, 0.5))
        if msg is None:
            continue
        if cond is None or cond(msg):
            return msg
        last = msg
    seen = f"; last one seen: {last}" if last is not None else "; none of that type arrived"
    raise WaitTimeoutError(f"no {kind}{_describe(cond)} within {timeout:g} s{seen}")


def list_parameters(conn: Any) -> dict[str, Any]:
    """Every PARAM_VALUE of a PARAM_REQUEST_LIST download from system 1, by name (indices 0..count-1 each once)."""
    conn.mav.param_request_list_send(1, 1)
    seen: dict[int, Any] = {}
    while True:
        msg = wait_for(conn, "PARAM_VALUE", 5)
        seen[msg.param_index] = msg
        if len(seen) == msg.param_count:
            return {m.param_id: m for m in seen.values()}


def drain(conn: Any) -> list[Any]:
    """Every message already waiting on the connection (so that the next one read is fresh)."""
    msgs = []
    while (msg := conn.recv_match(blocking=False)) is not None:
        msgs.append(msg)
    return msgs


def command_texts(conn: Any, cmd: int, *params: float, timeout: float = 5.0) -> tuple[int, list[str]]:
    """COMMAND_LONG to 1/1; the ACK's MAV_RESULT and the STATUSTEXTs before it (WaitTimeoutError if no ACK)."""
    p = list(params) + [0.0] * (7 - len(params))
    conn.mav.command_long_send(1, 1, cmd, 0, *p)
    texts: list[str] = []
    deadline = time.monotonic() + timeout
    while (left := deadline - time.monotonic()) > 0:
        msg = conn.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=min(left, 0.5))
        if msg is None:
            continue
        if msg.get_type() == "STATUSTEXT":
            texts.append(msg.text)
        elif msg.command == cmd:
            return int(msg.result), texts
    name = mavlink.enums["MAV_CMD"][cmd].name if cmd in mavlink.enums["MAV_CMD"] else str(cmd)
    raise WaitTimeoutError(f"no COMMAND_ACK for {name} within {timeout:g} s (STATUSTEXT seen: {texts})")


def command(conn: Any, cmd: int, *params: float, timeout: float = 5.0) -> int:
    """COMMAND_LONG to 1/1; the ACK's MAV_RESULT (WaitTimeoutError if no ACK came)."""
    return command_texts(conn, cmd, *params, timeout=timeout)[0]


def set_mode(conn: Any, mode: int) -> int:
    """MAV_CMD_DO_SET_MODE with custom mode ``mode`` (a Rover mode number); the ACK's MAV_RESULT."""
    return command(conn, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)


def wait_mode(conn: Any, mode: int, timeout: float = 5.0) -> Any:
    """The first HEARTBEAT reporting Rover mode ``mode``."""
    try:
        return wait_for(conn, "HEARTBEAT", timeout, lambda m: m.custom_mode == mode)
    except WaitTimeoutError as exc:
        raise WaitTimeoutError(f"no HEARTBEAT in mode {MODE_NAMES.get(mode, mode)}: {exc}") from None


def sim_seconds(conn: Any, timeout: float = 5.0) -> float:
    """Simulated time (s) from the next ATTITUDE / GLOBAL_POSITION_INT / SYSTEM_TIME."""
    return wait_for(conn, TIMED, timeout).time_boot_ms / 1000.0


def latest_sim_seconds(conn: Any) -> float:
    """Simulated time of the newest timed message, after draining whatever is queued (s)."""
    latest = None
    while (msg := conn.recv_match(type=TIMED, blocking=False)) is not None:
        latest = msg.time_boot_ms / 1000.0
    return latest if latest is not None else sim_seconds(conn)


def run_for(
    conn: Any,
    sim_s: float,
    each: Callable[[], None] | None = None,
    period_s: float = 0.5,
    wall_timeout: float = 60.0,
) -> float:
    """Let ``sim_s`` simulated seconds pass, calling ``each`` every ``period_s`` of them; returns the end time (s).

    Raises WaitTimeoutError if the simulator does not get that far within ``wall_timeout`` wall seconds.
    """
    start = now = sim_seconds(conn)
    next_call = start
    deadline = time.monotonic() + wall_timeout
    while now - start < sim_s:
        if time.monotonic() > deadline:
            raise WaitTimeoutError(f"only {now - start:.1f} of {sim_s:g} simulated s passed in {wall_timeout:g} wall s")
        if each is not None and now >= next_call:
            each()
            next_call = now + period_s
        now = wait_for(conn, ["ATTITUDE", "GLOBAL_POSITION_INT"], 5.0).time_boot_ms / 1000.0
    return now


def wait_sim_time(conn: Any, t_s: float, kind: str | list[str] = "ATTITUDE", timeout: float = 30.0) -> Any:
    """The first ``kind`` message stamped at or after simulated time ``t_s`` (s)."""
    return wait_for(conn, kind, timeout, lambda m: m.time_boot_ms >= t_s * 1000.0)


def taken_by(conn: Any, timeout: float = 5.0) -> float:
    """Simulated time (s) by which the simulator has taken every message this link sent before the call.

    A TIMESYNC request goes out behind them; the simulator reads its links in order and answers with its
    clock (as ArduPilot answers tc1 = 0 with its own time), so the reply's tc1 bounds their receipt.
    """
    stamp = time.monotonic_ns()
    conn.mav.timesync_send(0, stamp)
    reply = wait_for(conn, "TIMESYNC", timeout, lambda m: m.ts1 == stamp and m.tc1 != 0)
    return reply.tc1 / 1e9


def _stamp_s(msg: Any) -> float | None:
    """The simulated time a message carries (s), or None."""
    if getattr(msg, "time_boot_ms", None) is not None:
        return msg.time_boot_ms / 1000.0
    if getattr(msg, "time_usec", None) is not None:
        return msg.time_usec / 1e6
    return None


def await_message(conn: Any, kind: str, what: str, sim_s: float, cond: Callable[[Any], bool] | None = None,
                  wall_s: float = 180.0) -> Any:
    """The next ``kind`` message satisfying ``cond`` within ``sim_s`` of *simulated* time (its own stamps).

    The wall-clock bound only catches a simulator that stopped; under load simulated time just runs slower.
    Raises ``WaitTimeoutError`` naming ``what`` instead of returning None.
    """
    start: float | None = None
    now: float | None = None
    deadline = time.monotonic() + wall_s
    while time.monotonic() < deadline:
        msg = conn.recv_match(type=kind, blocking=True, timeout=0.5)
        if msg is None:
            continue
        now = _stamp_s(msg)
        start = now if start is None else start
        if cond is None or cond(msg):
            return msg
        if now is not None and start is not None and now - start > sim_s:
            break
    waited = f"{now - start:.1f} s simulated" if now is not None and start is not None else "no stamped message"
    raise WaitTimeoutError(f"timed out waiting for {what} ({kind}): {waited}, limit {sim_s:g} s simulated / "
                      f"{wall_s:g} s wall")


HOME_LAT, HOME_LON = -35.363261, 149.165230  # the simulator's default home (ArduPilot's CMAC)


def upload_waypoint(conn: Any, north: float, east: float, home: tuple[float, float] = (HOME_LAT, HOME_LON)) -> None:
    """Home placeholder + one NAV_WAYPOINT ``north``/``east`` metres from ``home``, with the mission protocol
    (as MAVSDK's MissionRaw or a ground station would); raises unless the autopilot accepts it."""
    from vessel.geo import latlon_from_ned

    lat, lon = latlon_from_ned(*home, north, east)
    conn.mav.mission_count_send(1, 1, 2, 0)
    for seq, (x, y) in enumerate([home, (lat, lon)]):
        request = wait_for(conn, ["MISSION_REQUEST", "MISSION_REQUEST_INT"], 5)
        assert request.seq == seq, f"the autopilot asked for item {request.seq}, expected {seq}"
        conn.mav.mission_item_int_send(1, 1, seq, 3, 16, 0, 1, 0, 0, 0, 0, round(x * 1e7), round(y * 1e7), 0, 0)
    ack = wait_for(conn, "MISSION_ACK", 5)
    assert ack.type == 0, f"mission refused: {ack}"
