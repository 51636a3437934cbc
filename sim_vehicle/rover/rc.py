"""RC input: a simulated receiver plus MAVLink RC_CHANNELS_OVERRIDE with per-channel expiry."""

from __future__ import annotations

import math

N_CHANNELS = 16
NO_CHANGE = 65535
RELEASE_HIGH = 65534  # release code for channels 9-16


class RcInput:
    """Per-channel PWM from the receiver, replaced by MAVLink overrides until they expire or are released.

    The simulated receiver (present by default, as in ArduPilot SITL) holds every stick at its trim
    (1500 µs); without one, only overrides provide valid RC frames, which matters for the RC failsafe.
    """

    def __init__(self, receiver: bool = True) -> None:
        self.receiver = receiver
        self._radio = [1500] * N_CHANNELS if receiver else [0] * N_CHANNELS
        self._override = [0] * N_CHANNELS
        self._override_time = [0.0] * N_CHANNELS
        self.last_override_time: float | None = None

    def apply_override(self, channels: list[int], now: float) -> None:
        """Apply one RC_CHANNELS_OVERRIDE (channels 1..18 raw values) received at ``now`` (s)."""
        self.last_override_time = now
        for i, raw in enumerate(channels[:N_CHANNELS]):
            if i < 8:
                if raw == NO_CHANGE:
                    continue
                release = raw == 0
            else:
                if raw in (0, NO_CHANGE):
                    continue
                release = raw == RELEASE_HIGH
            self._override[i] = 0 if release else int(raw)
            self._override_time[i] = now

    def clear_overrides(self) -> None:
        """Drop every override (what a failsafe does)."""
        self._override = [0] * N_CHANNELS

    def overridden(self, channel: int, now: float, timeout_s: float) -> bool:
        """True if ``channel`` (1-based) has a live override under RC_OVERRIDE_TIME ``timeout_s``."""
        i = channel - 1
        if self._override[i] == 0 or timeout_s == 0:
            return False
        if timeout_s < 0 or not math.isfinite(timeout_s):
            return True
        return now - self._override_time[i] < timeout_s

    def pwm(self, channel: int, now: float, timeout_s: float) -> int:
        """Effective PWM (µs) of ``channel`` (1-based); 0 means no signal at all."""
        if self.overridden(channel, now, timeout_s):
            return self._override[channel - 1]
        return self._radio[channel - 1]

    def all_pwm(self, now: float, timeout_s: float) -> list[int]:
        """Effective PWM of channels 1..16."""
        return [self.pwm(ch, now, timeout_s) for ch in range(1, N_CHANNELS + 1)]

    def any_override(self, now: float, timeout_s: float) -> bool:
        """True if any channel is currently overridden."""
        return any(self.overridden(ch, now, timeout_s) for ch in range(1, N_CHANNELS + 1))


def stick(pwm: int, pwm_min: float, trim: float, pwm_max: float, dead_zone: float, reversed_: bool) -> float:
    """A centred stick's PWM -> [-1, 1] about trim with a dead zone (angle input); 0 if no signal."""
    if pwm <= 0:
        return 0.0
    if pwm > trim + dead_zone:
        span = pwm_max - trim - dead_zone
        value = (pwm - trim - dead_zone) / span if span > 0 else 0.0
    elif pwm < trim - dead_zone:
        span = trim - dead_zone - pwm_min
        value = (pwm - trim + dead_zone) / span if span > 0 else 0.0
    else:
        value = 0.0
    value = min(1.0, max(-1.0, value))
    return -value if reversed_ else value
