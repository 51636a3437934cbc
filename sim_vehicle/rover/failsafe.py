"""Rover's radio and GCS failsafes: when each condition holds, when its action is due, and which mode it picks."""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.rover.modes import Mode
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.rc import RcInput

RC_FRAME_TIMEOUT_S = 0.5
FS_CONTINUE_IN_AUTO = 2  # FS_THR_ENABLE / FS_GCS_ENABLE value that keeps a mission running
FS_OPTIONS_IN_HOLD = 1  # FS_OPTIONS bit: act on failsafes in HOLD too
FS_ACTION_MODES = {1: Mode.RTL, 3: Mode.RTL, 6: Mode.LOITER}  # FS_ACTION -> mode; 0 nothing, others HOLD


class Failsafe:
    """One failsafe's bookkeeping: when its condition began and whether its action has been taken."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.since: float | None = None
        self.triggered = False

    def update(
        self, condition: bool, now: float, params: ParamTable, mode: Mode, text: Callable[[int, str], None]
    ) -> bool:
        """Advance with this step's condition; True exactly when the failsafe triggers now.

        The action waits until the condition has lasted FS_TIMEOUT; Rover skips the whole failsafe in RTL
        and (unless FS_OPTIONS bit 0) in HOLD, while the timer runs on for when the mode is left.
        """
        if not condition:
            if self.triggered:
                text(mavlink.MAV_SEVERITY_INFO, f"{self.name} Failsafe Cleared")
            self.since, self.triggered = None, False
            return False
        if self.since is None:
            self.since = now
        if self.triggered or now - self.since < params["FS_TIMEOUT"]:
            return False
        if mode == Mode.RTL or (mode == Mode.HOLD and not int(params["FS_OPTIONS"]) & FS_OPTIONS_IN_HOLD):
            return False
        self.triggered = True
        text(mavlink.MAV_SEVERITY_WARNING, f"{self.name} Failsafe")
        return True


class Failsafes:
    """The radio (RC) and ground-station (GCS heartbeat) failsafes of one vehicle."""

    def __init__(self) -> None:
        self.rc = Failsafe("Radio")
        self.gcs = Failsafe("GCS")

    @property
    def active(self) -> bool:
        """True while any failsafe has triggered (HEARTBEAT system_status CRITICAL)."""
        return self.rc.triggered or self.gcs.triggered


def rc_lost(params: ParamTable, rc: RcInput, now: float) -> bool:
    """With FS_THR_ENABLE: no valid RC frame for 0.5 s, or the throttle PWM below FS_THR_VALUE."""
    if params["FS_THR_ENABLE"] == 0:
        return False
    last = rc.last_override_time
    frames = rc.receiver or (last is not None and now - last <= RC_FRAME_TIMEOUT_S)
    throttle_pwm = rc.pwm(3, now, params["RC_OVERRIDE_TIME"])
    return not frames or 0 < throttle_pwm < params["FS_THR_VALUE"]


def gcs_lost(params: ParamTable, gcs_last_seen: float | None, now: float) -> bool:
    """With FS_GCS_ENABLE: a GCS was seen once, and not for FS_GCS_TIMEOUT since."""
    return (
        params["FS_GCS_ENABLE"] != 0 and gcs_last_seen is not None and now - gcs_last_seen > params["FS_GCS_TIMEOUT"]
    )


def action_mode(fs: Failsafe, params: ParamTable, mode: Mode) -> Mode | None:
    """The mode a triggered failsafe switches to, or None when it lets the boat carry on.

    In AUTO the FS_THR_ENABLE / FS_GCS_ENABLE value 2 continues the mission; FS_ACTION 0 does nothing.
    """
    enable = params["FS_THR_ENABLE"] if fs.name == "Radio" else params["FS_GCS_ENABLE"]
    action = int(params["FS_ACTION"])
    if (mode == Mode.AUTO and enable == FS_CONTINUE_IN_AUTO) or action == 0:
        return None
    return FS_ACTION_MODES.get(action, Mode.HOLD)
