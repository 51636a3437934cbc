"""The Rover's brain: modes, arming, RC and guided inputs, failsafes, controllers and the skid mixer."""

from __future__ import annotations

import math
from collections.abc import Callable

from vessel.geo import Home

from . import modes
from .auto import MissionRunner
from .control import NavCommand, NavState, NavTarget, SpeedControl, SteeringControl, loiter, navigate
from .guided import GuidedTarget, from_attitude
from .mission import MissionStore
from .mixer import output_to_pwm, pwm_to_output, skid_mix
from .modes import MODE_INFO, Mode
from .params import ParamTable, default_speed
from .rc import RcInput, stick

ACCEPTED, DENIED, UNSUPPORTED, FAILED = 0, 2, 3, 4  # MAV_RESULT
SEV_CRITICAL, SEV_WARNING, SEV_NOTICE, SEV_INFO = 2, 4, 5, 6  # MAV_SEVERITY
GUIDED_TIMEOUT_S = 3.0
RC_FRAME_TIMEOUT_S = 0.5
THROTTLE_LEFT, THROTTLE_RIGHT = 73, 74
# PILOT_STEER_TYPE: how the steering and throttle sticks are read (Rover's pilot_steer_type_t)
STEER_DEFAULT, STEER_TWO_PADDLES, STEER_DIR_REVERSED_WHEN_REVERSING, STEER_DIR_UNCHANGED_WHEN_REVERSING = 0, 1, 2, 3


class Failsafe:
    """One failsafe's bookkeeping: when its condition began and whether its action has been taken."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.since: float | None = None
        self.triggered = False


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
        self.text = text
        self.rc = RcInput(rc_receiver)
        self.nav = NavState()
        self.steer = SteeringControl(params)
        self.speed = SpeedControl(params)
        self.runner = MissionRunner(store, params, home, reached, text)
        self.reached = reached
        self.armed = False
        self.mode = modes.lookup(params["INITIAL_MODE"]) or Mode.MANUAL
        if not MODE_INFO[self.mode].implemented or self.mode in (Mode.AUTO, Mode.RTL, Mode.GUIDED):
            self.mode = Mode.MANUAL
        self.guided: GuidedTarget | None = None
        self.loiter_at = (0.0, 0.0)
        self.rtl_done = False
        self.nav_output: NavCommand | None = None
        self.gcs_last_seen: float | None = None
        self.failsafes = {"rc": Failsafe("Radio"), "gcs": Failsafe("GCS")}
        self.now = 0.0
        self.steering = 0.0  # last normalised demands, for telemetry
        self.throttle = 0.0
        self._slewed_throttle = 0.0
        self.outputs = (0.0, 0.0)  # motor outputs in [-1, 1] after PWM (what the ESCs see)
        self.servo_pwm = [0] * 16
        self._update_servos(0.0, 0.0)

    # ----- modes and arming -------------------------------------------------------------------------------
    def set_mode(self, number: float) -> int:
        """Change mode as Rover does; returns a MAV_RESULT and explains refusals in STATUSTEXT."""
        mode = modes.lookup(number)
        if mode is not None and mode == self.mode:
            return ACCEPTED
        if mode is None or not MODE_INFO[mode].implemented:
            self.text(SEV_WARNING, "Flight mode change failed")
            return FAILED
        if mode == Mode.AUTO and not self.store.present():
            self.text(SEV_WARNING, "No Mission. Can't set AUTO.")
            self.text(SEV_WARNING, "Flight mode change failed")
            return FAILED
        self._enter(mode)
        return ACCEPTED

    def _enter(self, mode: Mode) -> None:
        """Switch to ``mode`` (already checked) and initialise what it needs."""
        if self.mode == Mode.AUTO:
            self.runner.pause()
        self.mode = mode
        self.steer.reset()
        self.speed.reset(self.nav.forward_speed)
        self.loiter_at = self._stopping_point()
        self.guided = None
        self.rtl_done = False
        if mode == Mode.AUTO:
            self.runner.start_or_resume()

    def arm(self, force: bool) -> int:
        """Arm with Rover's pre-arm checks unless forced (2989); refusals go out as STATUSTEXT."""
        if self.armed:
            return ACCEPTED
        if not force:
            reason = self.prearm_failure()
            if reason:
                self.text(SEV_CRITICAL, reason)
                return FAILED
        self.armed = True
        self.steer.reset()
        self.speed.reset(self.nav.forward_speed)
        self.text(SEV_INFO, "Throttle armed")
        return ACCEPTED

    def prearm_failure(self) -> str:
        """The first failing arming check as ArduPilot words it, or '' if all pass."""
        p = self.params
        if not MODE_INFO[self.mode].armable:
            return "PreArm: Mode not armable"
        if not self.skid_config_ok():
            return "PreArm: check skid steering config"
        if p["ARMING_CHECK"] == 0:
            return ""
        if p["WP_SPEED"] <= 0:
            return "PreArm: WP_SPEED too low"
        if int(p["RC_OPTIONS"]) & 32 and MODE_INFO[self.mode].manual_input and self._stick(3) != 0.0:
            return "Arm: Throttle (RC3) is not neutral"
        return ""

    def skid_config_ok(self) -> bool:
        """Both or neither of ThrottleLeft/ThrottleRight must be assigned to outputs."""
        functions = {self.params["SERVO1_FUNCTION"], self.params["SERVO3_FUNCTION"]}
        return (THROTTLE_LEFT in functions) == (THROTTLE_RIGHT in functions)

    def disarm(self) -> int:
        """Disarm (any mode); outside AUTO the mission goes back to its start."""
        if not self.armed:
            return ACCEPTED
        self.armed = False
        if self.mode != Mode.AUTO:
            self.runner.rewind()
        self.text(SEV_INFO, "Throttle disarmed")
        return ACCEPTED

    # ----- inputs -------------------------------------------------------------------------------------------
    def override(self, channels: list[int]) -> None:
        """An RC_CHANNELS_OVERRIDE from the GCS sysid (the caller filters senders)."""
        if self.params["RC_OVERRIDE_TIME"] == 0 or int(self.params["RC_OPTIONS"]) & 2:
            return
        self.rc.apply_override(channels, self.now)
        self.gcs_last_seen = self.now

    def attitude_target(self, type_mask: int, q: list[float], yaw_rate: float, thrust: float) -> None:
        """SET_ATTITUDE_TARGET as Rover reads it; silently dropped outside GUIDED or when malformed."""
        if self.mode == Mode.GUIDED:
            self.set_guided(from_attitude(type_mask, q, yaw_rate, thrust, self.default_speed(), self.now))

    def set_guided(self, target: GuidedTarget | None) -> bool:
        """Take a GUIDED target (position, velocity, heading or rate); False outside GUIDED or if None."""
        if self.mode != Mode.GUIDED or target is None:
            return False
        self.guided = target
        return True

    def default_speed(self) -> float:
        """WP_SPEED if set, else CRUISE_SPEED (Rover's default speed)."""
        return default_speed(self.params)

    def _stick(self, channel: int, dead_zone: bool = True) -> float:
        """Pilot stick of ``channel`` (1 steering, 3 throttle) in [-1, 1] after dead zone (or without it,
        as RC_Channel::norm_input reads a channel)."""
        p = self.params
        pwm = self.rc.pwm(channel, self.now, p["RC_OVERRIDE_TIME"])
        return stick(
            pwm,
            p[f"RC{channel}_MIN"],
            p[f"RC{channel}_TRIM"],
            p[f"RC{channel}_MAX"],
            p[f"RC{channel}_DZ"] if dead_zone else 0.0,
            p[f"RC{channel}_REVERSED"] != 0,
        )

    def _reverses_steering(self) -> bool:
        """True if PILOT_STEER_TYPE flips the steering stick while going backwards (types 0 and 2)."""
        return int(self.params["PILOT_STEER_TYPE"]) not in (STEER_TWO_PADDLES, STEER_DIR_UNCHANGED_WHEN_REVERSING)

    def pilot_input(self) -> tuple[float, float]:
        """The pilot's steering and throttle in [-1, 1] as Rover's Mode::get_pilot_input reads them.

        PILOT_STEER_TYPE 0/2 (and unknown values) mirror the steering while the throttle stick is below
        trim, so the boat turns like a car reversing; 3 leaves it alone; 1 reads ch1 as the left and ch3
        as the right paddle (each -1..1, no dead zone), which the skid mixer turns back into exactly those
        two motor outputs. (Rover also zeroes both while the radio-failsafe condition holds; not modelled.)
        """
        steer_type = int(self.params["PILOT_STEER_TYPE"])
        if steer_type == STEER_TWO_PADDLES:
            left, right = self._stick(1, dead_zone=False), self._stick(3, dead_zone=False)
            return 0.5 * (left - right), 0.5 * (left + right)
        steering, throttle = self._stick(1), self._stick(3)
        if throttle < 0 and self._reverses_steering():
            steering = -steering
        return steering, throttle

    def _slew_limited(self, throttle: float, dt: float) -> float:
        """``throttle`` after MOT_SLEWRATE (percent of full range per second) from the last output."""
        slew = self.params["MOT_SLEWRATE"] / 100.0 * dt
        if slew <= 0:
            return throttle
        return self._slewed_throttle + max(-slew, min(slew, throttle - self._slewed_throttle))

    # ----- failsafes ----------------------------------------------------------------------------------------
    def _check_failsafes(self) -> None:
        """RC (no valid frame for 0.5 s or throttle below FS_THR_VALUE) and GCS heartbeat loss."""
        p = self.params
        rc_lost = False
        if p["FS_THR_ENABLE"] != 0:
            last = self.rc.last_override_time
            frames = self.rc.receiver or (last is not None and self.now - last <= RC_FRAME_TIMEOUT_S)
            throttle_pwm = self.rc.pwm(3, self.now, p["RC_OVERRIDE_TIME"])
            rc_lost = not frames or 0 < throttle_pwm < p["FS_THR_VALUE"]
        gcs_lost = (
            p["FS_GCS_ENABLE"] != 0
            and self.gcs_last_seen is not None
            and self.now - self.gcs_last_seen > p["FS_GCS_TIMEOUT"]
        )
        self._failsafe(self.failsafes["rc"], rc_lost)
        self._failsafe(self.failsafes["gcs"], gcs_lost)

    def _failsafe(self, fs: Failsafe, condition: bool) -> None:
        """Trigger the FS_ACTION once the condition has lasted FS_TIMEOUT; report when it clears."""
        if not condition:
            if fs.triggered:
                self.text(SEV_INFO, f"{fs.name} Failsafe Cleared")
            fs.since, fs.triggered = None, False
            return
        if fs.since is None:
            fs.since = self.now
        if fs.triggered or self.now - fs.since < self.params["FS_TIMEOUT"]:
            return
        if self.mode == Mode.RTL or (self.mode == Mode.HOLD and not int(self.params["FS_OPTIONS"]) & 1):
            return  # Rover skips the whole failsafe in RTL and HOLD; the timer runs on for when it leaves
        fs.triggered = True
        self.text(SEV_WARNING, f"{fs.name} Failsafe")
        self.rc.clear_overrides()
        continue_auto = self.mode == Mode.AUTO and (
            (fs.name == "Radio" and self.params["FS_THR_ENABLE"] == 2)
            or (fs.name == "GCS" and self.params["FS_GCS_ENABLE"] == 2)
        )
        action = int(self.params["FS_ACTION"])
        if continue_auto or action == 0:
            return
        target = {1: Mode.RTL, 3: Mode.RTL, 6: Mode.LOITER}.get(action, Mode.HOLD)
        if self.set_mode(target) != ACCEPTED:
            self.set_mode(Mode.HOLD)

    @property
    def failsafe_active(self) -> bool:
        """True while any failsafe has triggered (HEARTBEAT system_status CRITICAL)."""
        return any(fs.triggered for fs in self.failsafes.values())

    # ----- the control step ---------------------------------------------------------------------------------
    def update(self, nav: NavState, now: float, dt: float) -> tuple[float, float]:
        """One control step: returns the left/right motor outputs in [-1, 1] the ESCs receive."""
        self.nav, self.now = nav, now
        self._check_failsafes()
        steering, throttle = self._mode_demands(dt)
        if not self.armed:
            steering, throttle = 0.0, 0.0
            self.steer.reset()
            self.speed.reset(nav.forward_speed)
        self.steering = steering
        throttle = self._slew_limited(throttle, dt)
        self._slewed_throttle = throttle
        limit = max(0.0, min(100.0, self.params["MOT_THR_MAX"])) / 100.0
        self.throttle = max(-limit, min(limit, throttle))
        self._update_servos(steering, self.throttle)
        return self.outputs

    def _mode_demands(self, dt: float) -> tuple[float, float]:
        """Steering and throttle demands of the current mode."""
        self.nav_output = None
        mode, nav, p = self.mode, self.nav, self.params
        if mode == Mode.MANUAL:
            # Mode::get_pilot_desired_steering_and_throttle: while the slewed throttle still has the other
            # sign than the stick, the boat moves the way it did, so reversing types un-mirror the steering.
            steering, throttle = self.pilot_input()
            if (throttle < 0) != (self._slew_limited(throttle, dt) < 0) and self._reverses_steering():
                steering = -steering
            return steering, throttle
        if mode in (Mode.ACRO, Mode.STEERING):
            # Mode::get_pilot_desired_steering_and_speed, with the same check on the acceleration-limited speed.
            steering, throttle = self.pilot_input()
            max_speed = p["CRUISE_SPEED"] * 100.0 / max(1.0, p["CRUISE_THROTTLE"])
            speed = throttle * max_speed
            if (speed < 0) != (self._accel_limited_speed(speed, dt) < 0) and self._reverses_steering():
                steering = -steering
            return self._drive_rate(steering * math.radians(p["ACRO_TURN_RATE"]), speed, dt)
        if mode == Mode.HOLD:
            return 0.0, 0.0
        target: NavTarget | None = None
        if mode == Mode.GUIDED and self.guided is not None:
            g = self.guided
            if g.waypoint is not None:
                if math.hypot(g.waypoint.north - nav.north, g.waypoint.east - nav.east) <= max(
                    0.1, p["WP_RADIUS"]
                ):
                    self.reached(0)
                    self.guided = None
                else:
                    target = g.waypoint
            elif self.now - g.time > GUIDED_TIMEOUT_S:
                self.text(SEV_NOTICE, "target not received last 3secs, stopping")
                self.loiter_at = self._stopping_point()
                self.guided = None
            elif g.heading is not None:
                return self._drive_heading(g.heading, g.speed, dt)
            else:
                return self._drive_rate(g.rate or 0.0, g.speed, dt)
        if mode == Mode.AUTO:
            target = self.runner.update(nav, self.now)
            if target is None:
                self._finish_mission_behaviour()
        elif mode == Mode.RTL and not self.rtl_done:
            if math.hypot(nav.north, nav.east) <= max(0.1, p["WP_RADIUS"]):
                self.text(SEV_INFO, "Reached destination")
                self.rtl_done, self.loiter_at = True, (0.0, 0.0)
            else:
                speed = p["RTL_SPEED"] if p["RTL_SPEED"] > 0 else self.default_speed()
                target = NavTarget(0.0, 0.0, nav.north, nav.east, speed)
        if target is not None:
            self.nav_output = navigate(
                target, nav, lookahead_m=max(3.0, 2.0 * p["TURN_RADIUS"]), accel=p["ATC_ACCEL_MAX"]
            )
            self.loiter_at = self._stopping_point()
        else:
            self.nav_output = loiter(
                *self.loiter_at, nav, p["LOIT_RADIUS"], p["LOIT_SPEED_GAIN"], self.default_speed()
            )
        return self._drive_heading(self.nav_output.heading, self.nav_output.speed, dt)

    def _stopping_point(self) -> tuple[float, float]:
        """Where the boat would come to rest braking at ATC_ACCEL_MAX: the point a boat loiters around."""
        nav, decel = self.nav, max(0.1, self.params["ATC_ACCEL_MAX"])
        speed = nav.ground_speed
        return nav.north + nav.vn * speed / (2 * decel), nav.east + nav.ve * speed / (2 * decel)

    def _finish_mission_behaviour(self) -> None:
        """MIS_DONE_BEHAVE after the last item: 2 -> ACRO, 3 -> MANUAL; 0/1 stay in AUTO holding station."""
        behave = int(self.params["MIS_DONE_BEHAVE"])
        if self.runner.state == "complete" and behave in (2, 3):
            self._enter(Mode.ACRO if behave == 2 else Mode.MANUAL)

    def _accel_limited_speed(self, speed: float, dt: float) -> float:
        """The speed target SpeedControl will ramp to this step under ATC_ACCEL_MAX (its ramp is not stepped)."""
        ramp = self.speed._target
        step = max(0.1, self.params["ATC_ACCEL_MAX"]) * dt
        return ramp + max(-step, min(step, speed - ramp))

    def _drive_heading(self, heading: float, speed: float, dt: float) -> tuple[float, float]:
        """Heading and speed targets -> steering and throttle."""
        return self._drive_rate(self.steer.rate_for_heading(heading, self.nav), speed, dt)

    def _drive_rate(self, rate: float, speed: float, dt: float) -> tuple[float, float]:
        """Turn-rate and speed targets -> steering and throttle."""
        throttle = self.speed.throttle_for_speed(speed, self.nav, dt)
        if speed == 0.0 and throttle == 0.0 and abs(rate) < 1e-3 and abs(self.nav.yaw_rate) < 0.02:
            self.steer.reset()
            return 0.0, 0.0
        return self.steer.steering_for_rate(rate, self.nav, dt), throttle

    # ----- outputs ------------------------------------------------------------------------------------------
    def _update_servos(self, steering: float, throttle: float) -> None:
        """Mix, write PWM to the SERVOn outputs holding ThrottleLeft/Right, and decode them as the ESCs do."""
        p = self.params
        pwm = [0] * 16
        if self.armed and self.skid_config_ok():
            left, right = skid_mix(steering, throttle, p["MOT_STR_THR_MIX"], p["MOT_THST_ASYM"])
        else:
            left = right = 0.0
        outs = {THROTTLE_LEFT: 0.0, THROTTLE_RIGHT: 0.0}
        for n in (1, 3):
            function = int(p[f"SERVO{n}_FUNCTION"])
            lo, trim, hi, rev = (
                p[f"SERVO{n}_MIN"],
                p[f"SERVO{n}_TRIM"],
                p[f"SERVO{n}_MAX"],
                p[f"SERVO{n}_REVERSED"] != 0,
            )
            if function not in outs:
                continue
            demand = left if function == THROTTLE_LEFT else right
            if not self.armed and p["MOT_SAFE_DISARM"] == 1:
                pwm[n - 1] = 0
            else:
                pwm[n - 1] = output_to_pwm(demand, lo, trim, hi, rev)
            outs[function] = pwm_to_output(pwm[n - 1], lo, trim, hi, rev)
        self.servo_pwm = pwm
        self.outputs = (outs[THROTTLE_LEFT], outs[THROTTLE_RIGHT]) if self.armed else (0.0, 0.0)
