"""The companion's settings (`mavbridge run`, `mavbridge check`, the service's YAML): one frozen dataclass,
validated on load, with the command-line flags applied on top."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mavbridge.companion.choices import OUTPUTS, WAVE_SOURCES
from mavbridge.companion.outputs import ATTITUDE_FORMS
from mavbridge.link.connection import MAV_COMP_ID_ONBOARD_COMPUTER
from mavbridge.link.signing import LinkSettings
from mavbridge.nmpc.config import choice
from vessel.config import ConfigError, bounded, from_mapping, in_file, read_yaml
from vessel.geo import DEFAULT_MAX_RANGE_M
from vessel.vessel_spec import VesselSpec, relative_to

ARRIVAL_ACTIONS = ("hold", "release")


@dataclass(frozen=True)
class CompanionConfig(LinkSettings):
    """How the companion reaches the autopilot and what it commands. Defaults suit the simulator."""

    connect: str = "udpin:0.0.0.0:14551"
    baud: int = bounded(921600, 1200, 4_000_000, "baud", "serial speed (serial connections only)")
    system_id: int = bounded(255, 1, 255, "", "our MAVLink system id; must equal SYSID_MYGCS for RC override")
    component_id: int = bounded(MAV_COMP_ID_ONBOARD_COMPUTER, 1, 255, "", "our component id (191: onboard)")
    output: str = choice("rc_override", OUTPUTS, "rc_override (MANUAL) or attitude_target (GUIDED)")
    link_timeout_s: float = bounded(2.0, 0.2, 60.0, "s", "no heartbeat this long = link lost")
    max_link_outage_s: float = bounded(10.0, 0.5, 600.0, "s", "a link lost longer than this ends the run "
                                       "(the pilot has had the sticks back for a while; no silent resume)")
    max_distance_m: float = bounded(10_000.0, 10.0, 1e6, "m", "a position farther than this from home is rejected")
    max_range_m: float = bounded(DEFAULT_MAX_RANGE_M, 0.0, None, "m", "never engage on a waypoint farther than "
                                 "this from home or from the boat", lo_open=True)
    connect_timeout_s: float = bounded(30.0, 0.5, 600.0, "s", "wait this long for the autopilot at start")
    stale_state_s: float = bounded(0.5, 0.05, 10.0, "s", "state older than this (autopilot time) is not used")
    lookahead_steps: int = bounded(8, 1, 400, "steps", "attitude_target: plan step whose heading or yaw rate "
                                   "and speed are sent (8 measured best for the rate form; the heading form was "
                                   "measured at 5; tau uses the first step)")
    attitude_form: str = choice("tau", ATTITUDE_FORMS, "attitude_target: tau (the default: the rate and speed "
                                "targets for which Rover's loops give the plan's steering and throttle, closed on "
                                "SERVO_OUTPUT_RAW so that Rover's integrators may stay on), the plan's body yaw rate "
                                "(rate: Rover's rate loop only) or its heading")
    on_arrival: str = choice("hold", ARRIVAL_ACTIONS, "hold: switch to HOLD at the waypoint; release: only stop")
    max_time_s: float | None = bounded(None, 0.1, 1e6, "s", "end the run after this much autopilot time engaged")
    waves: str = choice("estimated", WAVE_SOURCES, "estimated (from the boat's motion) or scenario (simulation "
                        "truth: the scenario's sea; never on a real boat)")
    wave_roll_sign: float = bounded(1.0, -1.0, 1.0, "", "estimator: +1 roll = slope (the paper's plant, the "
                                    "simulator), -1 a real hull")
    wave_position_lag_s: float = bounded(0.0, 0.0, 2.0, "s", "estimator: lag of the GPS position it "
                                         "compensates (0 on ArduPilot)")
    estimator_process: bool = bounded(True, doc="estimator: run the wave estimator in a process of its own, so that "
                                      "its per-sample work and its fit are not the control step's (the estimator's "
                                      "answers, one sample later, or a period paced: a paced step never waits for "
                                      "it); false: in the companion's process")
    lockstep: bool = bounded(False, doc="simulation only, against `sim-vehicle --lockstep`: the simulator waits "
                             "for each command, so a step waits for asrti's background solve fully, has no "
                             "wall-clock deadline and no wall-clock stand-down (a real boat never waits: leave "
                             "false there)")
    start_at_s: float | None = bounded(None, 0.0, 1e6, "s", "command from this autopilot time on, not before "
                                       "(simulation comparisons: every run starts from the same world state)")
    engage_after_s: float = bounded(0.0, 0.0, 3600.0, "s", "with --set-mode/--arm: switch the mode and arm this "
                                    "long (autopilot time) after the first attitude the companion sees, as a pilot "
                                    "would once the boat is ready; the wave estimator watches the sea meanwhile "
                                    "(0: as soon as the start is done)")
    delay_compensation: bool = bounded(True, doc="plan from the state predicted to when the command acts (the "
                                       "link's delay measured with TIMESYNC); false: act on the state as received")
    max_prediction_s: float = bounded(2.0, 0.0, 5.0, "s", "delay compensation predicts at most this far ahead "
                                      "(the state's age plus the uplink's one-way delay)")
    realtime: bool = bounded(False, doc="real-time scheduling (SCHED_FIFO at realtime_priority), locked memory and an "
                             "isolated CPU where the system allows; one line says what it got and what it fell back "
                             "to; never fatal (see deploy/README.md for the service's limits)")
    realtime_priority: int = bounded(10, 1, 98, "", "SCHED_FIFO priority with realtime (above normal processes, "
                                     "below the kernel's interrupt threads at 50 by default)")
    disturbance: str = choice("estimated", ("estimated", "none"), "estimated: the current and steady loads the boat "
                              "meets, learnt from its own motion against the model's prediction (from connection on, "
                              "while disarmed or commanding) and predicted with; none: the model alone")
    model: VesselSpec | None = dataclasses.field(default=None, metadata={"doc": "the hull the NMPC predicts with: a "
                                                 "named set (published, corrected), a mapping {base, <OtterParameters "
                                                 "field>: value} or a vessel YAML file (relative to this file; what "
                                                 "`mavbridge identify` writes); null: the scenario's controller.model "
                                                 "(default published). Never the boat's true hull: nobody knows it"})

    def __post_init__(self) -> None:
        if self.wave_roll_sign not in (-1.0, 1.0):
            raise ConfigError(f"wave_roll_sign: {self.wave_roll_sign!r} is not one of -1, 1")
        for name, choices in (("output", OUTPUTS), ("on_arrival", ARRIVAL_ACTIONS), ("waves", WAVE_SOURCES),
                              ("disturbance", ("estimated", "none")),
                              ("attitude_form", ATTITUDE_FORMS)):
            if getattr(self, name) not in choices:
                raise ConfigError(f"{name}: {getattr(self, name)!r} is not one of {', '.join(choices)}")


def load_companion_config(path: str | Path | None, **overrides: Any) -> CompanionConfig:
    """The YAML configuration (or the defaults), with command-line overrides applied on top."""
    data = read_yaml(path) if path else {}
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a mapping of settings")
    data.update({k: v for k, v in overrides.items() if v is not None})
    if not path:
        return from_mapping(CompanionConfig, data, "configuration")
    try:
        with relative_to(path):  # a vessel file named by model: is found beside this file
            return from_mapping(CompanionConfig, data, "")
    except ConfigError as exc:
        raise in_file(path, exc) from None
