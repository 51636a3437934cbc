"""The Rover's brain: modes, arming, RC and guided inputs, failsafes and the per-step control demands.

The pieces it composes live beside it: the pilot's sticks (``pilot``), the helm's controllers (``helm``),
the targets of the autopilot modes (``navigator``), the failsafes (``failsafe``), the pre-arm checks
(``arming``) and the motor outputs (``servos``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.rover import modes
from sim_vehicle.rover.arming import prearm_failure
from sim_vehicle.rover.auto import MissionRunner
from sim_vehicle.rover.control import NavState
from sim_vehicle.rover.failsafe import Failsafe, Failsafes, action_mode, gcs_lost, rc_lost
from sim_vehicle.rover.guided import GuidedTarget, from_attitude, to_location
from sim_vehicle.rover.helm import Helm
from sim_vehicle.rover.mission import MissionStore
from sim_vehicle.rover.modes import MODE_INFO, Mode
from sim_vehicle.rover.navigator import Navigator
from sim_vehicle.rover.params import ParamTable, default_speed
from sim_vehicle.rover.pilot import THROTTLE_CHANNEL, pilot_input, reverses_steering, stick_position
from sim_vehicle.rover.rc import RcInput
from sim_vehicle.rover.servos import servo_outputs
from vessel.geo import Home

M = mavlink
RC_OPTIONS_IGNORE_OVERRIDES = 2  # RC_OPTIONS bit: ignore MAVLink overrides


class Vehicle:
    """Everything between MAVLink messages and the two motor outputs; stepped with the plant."""

    def __init__(
        self,
        params: ParamTable,
        home: Home,
        store: MissionStore,
        text: Callable[[int, str], None],
        reached: Callable[[int], None],
        rc_receiver: bool = True,
    ) -> None:
        self.params, self.home, self.store = params, home, store
        self.text, self.reached = text, reached
        self.rc = RcInput(rc_receiver)
        self.nav = NavState()
        self.helm = Helm(params)
        self.runner = MissionRunner(store, params, home, reached, text)
        self.navigator = Navigator(params, self.helm, self.runner, text, reached, self._finish_mission_behaviour)
        self.failsafes = Failsafes()
        self.armed = False
        self.mode = modes.lookup(params["INITIAL_MODE"]) or Mode.MANUAL
        if not MODE_INFO[self.mode].implemented or self.mode in (Mode.AUTO, Mode.RTL, Mode.GUIDED):
            self.mode = Mode.MANUAL
        self.gcs_last_seen: float | None = None
        self.now = 0.0
        self.steering = 0.0  # last normalised demands, for telemetry
        self.throttle = 0.0
        self.servos = servo_outputs(params, False, 0.0, 0.0)

    # ----- modes and arming -------------------------------------------------------------------------------
    def set_mode(self, number: float) -> int:
        """Change mode as Rover does; returns a MAV_RESULT and explains refusals in STATUSTEXT."""
        mode = modes.lookup(number)
        if mode is not None and mode == self.mode:
            return M.MAV_RESULT_ACCEPTED
        if mode is None or not MODE_INFO[mode].implemented:
            self.text(M.MAV_SEVERITY_WARNING, "Flight mode change failed")
            return M.MAV_RESULT_FAILED
        if mode == Mode.AUTO and not self.store.present():
            self.text(M.MAV_SEVERITY_WARNING, "No Mission. Can't set AUTO.")
            self.text(M.MAV_SEVERITY_WARNING, "Flight mode change failed")
            return M.MAV_RESULT_FAILED
        self._enter(mode)
        return M.MAV_RESULT_ACCEPTED

    def _enter(self, mode: Mode) -> None:
        """Switch to ``mode`` (already checked) and initialise what it needs."""
        if self.mode == Mode.AUTO:
            self.runner.pause()
        self.mode = mode
        self.helm.reset(self.nav.forward_speed)
        self.navigator.enter_mode(self.nav)
        if mode == Mode.AUTO:
            self.runner.start_or_resume()

    def arm(self, force: bool) -> int:
        """Arm with Rover's pre-arm checks unless forced (2989); refusals go out as STATUSTEXT."""
        if self.armed:
            return M.MAV_RESULT_ACCEPTED
        if not force:
            reason = self.prearm_failure()
            if reason:
                self.text(M.MAV_SEVERITY_CRITICAL, reason)
                return M.MAV_RESULT_FAILED
        self.armed = True
        self.helm.reset(self.nav.forward_speed)
        self.text(M.MAV_SEVERITY_INFO, "Throttle armed")
        return M.MAV_RESULT_ACCEPTED

    def prearm_failure(self) -> str:
        """The first failing arming check as ArduPilot words it, or '' if all pass."""
        return prearm_failure(self.params, self.mode, stick_position(self.params, self.rc, THROTTLE_CHANNEL, self.now))

    def disarm(self) -> int:
        """Disarm (any mode); outside AUTO the mission goes back to its start."""
        if not self.armed:
            return M.MAV_RESULT_ACCEPTED
        self.armed = False
        if self.mode != Mode.AUTO:
            self.runner.rewind()
        self.text(M.MAV_SEVERITY_INFO, "Throttle disarmed")
        return M.MAV_RESULT_ACCEPTED

    # ----- inputs -------------------------------------------------------------------------------------------
    def override(self, channels: list[int]) -> None:
        """RC overrides (RC_CHANNELS_OVERRIDE or MANUAL_CONTROL) from the GCS sysid; the caller filters senders.

        Like Rover, an override also counts as the GCS being seen for the GCS failsafe.
        """
        if self.params["RC_OVERRIDE_TIME"] == 0 or int(self.params["RC_OPTIONS"]) & RC_OPTIONS_IGNORE_OVERRIDES:
            return
        self.rc.apply_override(channels, self.now)
        self.gcs_last_seen = self.now

    def gcs_heartbeat(self) -> None:
        """A HEARTBEAT from SYSID_MYGCS: the GCS failsafe's "last seen"."""
        self.gcs_last_seen = self.now

    def attitude_target(self, type_mask: int, q: list[float], yaw_rate: float, thrust: float) -> None:
        """SET_ATTITUDE_TARGET as Rover reads it; silently dropped outside GUIDED or when malformed."""
        if self.mode == Mode.GUIDED:
            self.set_guided(from_attitude(type_mask, q, yaw_rate, thrust, self.default_speed(), self.now))

    def set_guided(self, target: GuidedTarget | None) -> bool:
        """Take a GUIDED target (position, velocity, heading or rate); False outside GUIDED or if None."""
        if self.mode != Mode.GUIDED or target is None:
            return False
        self.navigator.guided = target
        return True

    def guided_goto(self, lat_deg: float, lon_deg: float, speed: float | None = None) -> bool:
        """A GUIDED waypoint at lat/lon (DO_REPOSITION, MISSION_ITEM current=2); False outside GUIDED or if invalid.

        ``speed`` (m/s) None drives at the GUIDED waypoint speed (the last DO_CHANGE_SPEED, else the default).
        """
        speed = self.navigator.guided_waypoint_speed() if speed is None else speed
        return self.set_guided(to_location(lat_deg, lon_deg, self.home, self.nav, speed, self.now))

    def default_speed(self) -> float:
        """WP_SPEED if set, else CRUISE_SPEED (Rover's default speed)."""
        return default_speed(self.params)

    def change_speed(self, speed: float) -> bool:
        """DO_CHANGE_SPEED (m/s, >= 0) as Rover's modes take it; False where the mode has no speed to change.

        AUTO: the mission's speed from now on. GUIDED: see ``Navigator.change_guided_speed``.
        """
        if self.mode == Mode.AUTO:
            self.runner.change_speed(speed)
            return True
        return self.mode == Mode.GUIDED and self.navigator.change_guided_speed(speed)

    # ----- failsafes ----------------------------------------------------------------------------------------
    def _check_failsafes(self) -> None:
        """RC (no valid frame for 0.5 s or throttle below FS_THR_VALUE) and GCS heartbeat loss."""
        p, fs = self.params, self.failsafes
        conditions = ((fs.rc, rc_lost(p, self.rc, self.now)), (fs.gcs, gcs_lost(p, self.gcs_last_seen, self.now)))
        for failsafe, lost in conditions:
            if failsafe.update(lost, self.now, p, self.mode, self.text):
                self._failsafe_action(failsafe)

    def _failsafe_action(self, fs: Failsafe) -> None:
        """A failsafe has just triggered: drop the overrides and switch mode as FS_ACTION says (HOLD if refused)."""
        self.rc.clear_overrides()
        target = action_mode(fs, self.params, self.mode)
        if target is not None and self.set_mode(target) != M.MAV_RESULT_ACCEPTED:
            self.set_mode(Mode.HOLD)

    # ----- the control step ---------------------------------------------------------------------------------
    def update(self, nav: NavState, now: float, dt: float) -> tuple[float, float]:
        """One control step: returns the left/right motor outputs in [-1, 1] the ESCs receive."""
        self.nav, self.now = nav, now
        self._check_failsafes()
        steering, throttle = self._mode_demands(dt)
        if not self.armed:
            steering, throttle = 0.0, 0.0
            self.helm.reset(nav.forward_speed)
        self.steering = steering
        self.throttle = self.helm.output_throttle(throttle, dt)
        self.servos = servo_outputs(self.params, self.armed, steering, self.throttle)
        return self.outputs

    @property
    def outputs(self) -> tuple[float, float]:
        """Left/right motor outputs in [-1, 1] after PWM (what the ESCs see)."""
        return self.servos.motors

    def _mode_demands(self, dt: float) -> tuple[float, float]:
        """Steering and throttle demands of the current mode."""
        self.navigator.output = None
        if self.mode == Mode.MANUAL:
            return self._manual_demands(dt)
        if self.mode in (Mode.ACRO, Mode.STEERING):
            return self._acro_demands(dt)
        if self.mode == Mode.HOLD:
            return 0.0, 0.0
        return self.navigator.demands(self.mode, self.nav, self.now, dt)

    def _manual_demands(self, dt: float) -> tuple[float, float]:
        """Mode::get_pilot_desired_steering_and_throttle: while the slewed throttle still has the other sign
        than the stick, the boat moves the way it did, so reversing types un-mirror the steering."""
        steering, throttle = pilot_input(self.params, self.rc, self.now)
        if (throttle < 0) != (self.helm.slew_limited(throttle, dt) < 0) and reverses_steering(self.params):
            steering = -steering
        return steering, throttle

    def _acro_demands(self, dt: float) -> tuple[float, float]:
        """Mode::get_pilot_desired_steering_and_speed, with the same check on the acceleration-limited speed."""
        p = self.params
        steering, throttle = pilot_input(p, self.rc, self.now)
        speed = throttle * p["CRUISE_SPEED"] * 100.0 / max(1.0, p["CRUISE_THROTTLE"])
        if (speed < 0) != (self.helm.accel_limited_speed(speed, dt) < 0) and reverses_steering(p):
            steering = -steering
        return self.helm.rate(steering * math.radians(p["ACRO_TURN_RATE"]), speed, self.nav, dt)

    def _finish_mission_behaviour(self) -> None:
        """MIS_DONE_BEHAVE after the last item: 2 -> ACRO, 3 -> MANUAL; 0/1 stay in AUTO holding station."""
        behave = int(self.params["MIS_DONE_BEHAVE"])
        if self.runner.state == "complete" and behave in (2, 3):
            self._enter(Mode.ACRO if behave == 2 else Mode.MANUAL)
