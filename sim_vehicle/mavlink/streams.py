"""Per-channel telemetry schedule: SRn stream rates, REQUEST_DATA_STREAM and SET_MESSAGE_INTERVAL."""

from __future__ import annotations

import math

from sim_vehicle.rover.params import N_STREAM_CHANNELS, ParamTable

# Message ids in each stream, as Rover groups them (only the ones this simulator produces).
STREAM_MESSAGES: dict[str, tuple[int, ...]] = {
    "RAW_SENS": (27, 116),  # RAW_IMU, SCALED_IMU2 (SCALED_IMU only on request, as in Rover)
    "EXT_STAT": (1, 42, 24, 62),  # SYS_STATUS, MISSION_CURRENT, GPS_RAW_INT, NAV_CONTROLLER_OUTPUT
    "RC_CHAN": (36, 65),  # SERVO_OUTPUT_RAW, RC_CHANNELS
    "RAW_CTRL": (34,),  # RC_CHANNELS_SCALED
    "POSITION": (33, 32),  # GLOBAL_POSITION_INT, LOCAL_POSITION_NED
    "EXTRA1": (30,),  # ATTITUDE
    "EXTRA2": (74,),  # VFR_HUD
    "EXTRA3": (2, 147),  # SYSTEM_TIME, BATTERY_STATUS
}
MAV_DATA_STREAM = {
    1: "RAW_SENS",
    2: "EXT_STAT",
    3: "RC_CHAN",
    4: "RAW_CTRL",
    6: "POSITION",
    10: "EXTRA1",
    11: "EXTRA2",
    12: "EXTRA3",
}
STREAM_OF = {msg_id: name for name, ids in STREAM_MESSAGES.items() for msg_id in ids}
MIN_INTERVAL_S, MAX_INTERVAL_S = 0.001, 60.0


class Schedule:
    """When each streamed message is next due on one channel (simulated time, s)."""

    def __init__(self, params: ParamTable, channel_index: int, aligned: bool = False) -> None:
        self.params = params
        self.aligned = aligned  # lockstep: a new stream's sends fall on multiples of its interval
        self.channel = min(channel_index, N_STREAM_CHANNELS - 1)
        self.stream_rate = {name: params[f"SR{self.channel}_{name}"] for name in STREAM_MESSAGES}
        self.custom: dict[int, float | None] = {}  # msg id -> interval s (None = stopped)
        self.next_due: dict[int, float] = {}

    def interval(self, msg_id: int) -> float | None:
        """Current interval (s) of a message on this channel, or None if it is not sent."""
        if msg_id in self.custom:
            return self.custom[msg_id]
        stream = STREAM_OF.get(msg_id)
        if stream is None:
            return None
        rate = self.stream_rate[stream]
        return 1.0 / rate if rate > 0 else None

    def set_stream(self, stream_id: int, rate_hz: float, start: bool) -> None:
        """REQUEST_DATA_STREAM: set one stream (0 = all but PARAMS) to ``rate_hz`` or stop it."""
        names = list(STREAM_MESSAGES) if stream_id == 0 else [MAV_DATA_STREAM.get(stream_id, "")]
        for name in names:
            if name not in self.stream_rate:
                continue
            self.stream_rate[name] = max(0.0, rate_hz) if start and math.isfinite(rate_hz) else 0.0
            for msg_id in STREAM_MESSAGES[name]:
                self.custom.pop(msg_id, None)
                self.next_due.pop(msg_id, None)

    def set_interval(self, msg_id: int, interval_us: float) -> None:
        """SET_MESSAGE_INTERVAL: 0 restores the stream default, -1 stops, others are clamped to 1 ms..60 s."""
        if interval_us == 0:  # back to its stream's current rate; the other messages keep theirs
            self.custom.pop(msg_id, None)
        elif interval_us < 0:
            self.custom[msg_id] = None
        else:
            self.custom[msg_id] = min(MAX_INTERVAL_S, max(MIN_INTERVAL_S, interval_us * 1e-6))
        self.next_due.pop(msg_id, None)

    def due(self, now: float) -> list[int]:
        """Message ids to send at ``now``; each is then rescheduled one interval later."""
        ready: list[int] = []
        for msg_id in set(STREAM_OF) | set(self.custom):
            interval = self.interval(msg_id)
            if interval is None:
                continue
            when = self.next_due.get(msg_id)
            if when is None or now + 1e-9 >= when:
                ready.append(msg_id)
                # keep the phase, but never queue up a burst after a pause
                self.next_due[msg_id] = self._next(now, when, interval)
        return ready

    def _next(self, now: float, when: float | None, interval: float) -> float:
        """The next send after one at ``now`` that was due at ``when``: keep the phase, never queue a burst."""
        if when is None or now - when > interval:
            if self.aligned:
                return (math.floor(now / interval + 1e-6) + 1) * interval
            return now + interval
        return when + interval
