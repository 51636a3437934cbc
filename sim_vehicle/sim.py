"""The simulator: one loop that owns time, stepping MAVLink I/O, the autopilot and the plant at 100 Hz.

Its parts: the ports it opens at each boot (``sim_ports``), where simulated time is held still — a lockstep tick,
the wait for a first client (``sim_hold``) — and what it writes to ``--log-dir`` (``sim_logs``).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.clock import Pacer
from sim_vehicle.lockstep import DEFAULT_TIMEOUT_S
from sim_vehicle.mavlink.gcs import Gcs
from sim_vehicle.mavlink.telemetry import Telemetry
from sim_vehicle.physics import PHYSICS_DT_S, Physics, nav_state, seed_wind_parameters, wind_of, wind_setting
from sim_vehicle.rover.battery import Battery
from sim_vehicle.rover.mission import MissionStore
from sim_vehicle.rover.modes import Mode
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.vehicle import Vehicle
from sim_vehicle.sim_hold import make_lockstep_hold, wait_for_first_client
from sim_vehicle.sim_logs import SimLogs
from sim_vehicle.sim_ports import banner, open_ports
from vessel import World, world_preset
from vessel.geo import Home

log = logging.getLogger("sim_vehicle")
REBOOT_SILENCE_S = 2.0  # wall seconds a reboot is silent (an autopilot's boot; SITL's restart)


@dataclass
class Options:
    """Everything the command line decides; the physical world (vessel, sea, start) is one vessel World."""

    home: Home = field(default_factory=Home)
    world: World = field(default_factory=lambda: world_preset("calm"))  # vessel, sea and start pose
    speedup: float = 1.0
    tcp_port: int | None = 5760
    tcp_host: str = "0.0.0.0"
    outputs: list[tuple[str, int]] = field(
        default_factory=lambda: [("127.0.0.1", 14550), ("127.0.0.1", 14551)]
    )
    params: ParamTable = field(default_factory=ParamTable)
    mission_store: Path | None = None
    log_dir: Path | None = None
    rc_receiver: bool = True
    duration_s: float | None = None
    serial: tuple[str, int | None] | None = None  # (device, baud or None = from SERIAL2_BAUD), served as SERIAL2
    wait_for_client: bool = False  # hold simulated time at 0 until the first MAVLink message arrives
    seed: int | None = None  # the sea's hidden phase origin; None: the sea as written (phase 0 at boot)
    noise_seed: int = 0  # the sensor noise's seed
    ideal_sensors: bool = False  # report the true state exactly (no SIM_* sensor model)
    surface_heave: bool = False  # the hull heaves with the sea surface (off: the paper's model)
    lockstep_period_s: float | None = None  # lockstep with the controller at this control period (None: paced)
    lockstep_timeout_s: float = DEFAULT_TIMEOUT_S  # wall seconds a lockstep tick waits for its command
    lockstep_start_s: float | None = None  # lockstep holds from this simulated time even before a command
    hidden_params: frozenset[str] = frozenset()  # served as absent over MAVLink (the simulation still uses them)
    param_errors: bool = True  # PARAM_ERROR for an unknown name (recent ArduPilot); False: no answer (older)


class Simulator:
    """Builds the boat, the autopilot and its links, then runs them in simulated time."""

    def __init__(self, opts: Options) -> None:
        self.opts = opts
        self.params = opts.params
        self.home = opts.home
        self.store = MissionStore(opts.mission_store)
        seed_wind_parameters(opts.world, self.params)  # the world's wind as SIM_WIND_*'s starting values
        self.boot_unix_us = int(time.time() * 1e6)
        self.logs = SimLogs(opts.log_dir, self.unix_us)
        self.running = True
        self.boots = 0
        self._boot()

    def _boot(self) -> None:
        """Everything a reboot starts again: the plant and its clock, the autopilot's state, the links.

        Parameters, the mission store and the logs outlive it (as ArduPilot's storage and SITL's files do).
        """
        opts = self.opts
        self.boots += 1
        started = time.monotonic()
        self.wind = wind_setting(self.params.__getitem__)
        self.physics = Physics.create(opts.world, opts.seed, opts.surface_heave,
                                      wind_of(self.wind, opts.world.sea.wind_seed))
        self.physics.attach_sensing(self.params.__getitem__, opts.ideal_sensors, opts.noise_seed)
        self.startup_s = time.monotonic() - started  # an irregular plant compiles (vessel.jit) before time starts
        if self.boots == 1:
            self.logs.write_sea(self.physics, opts.world, opts.seed)
        self.battery = Battery()
        self.vehicle = Vehicle(self.params, self.home, self.store, self._text, self._reached, opts.rc_receiver)
        self.telemetry = Telemetry(self.physics, self.vehicle, self.home, self.params, self.store,
                                   self.vehicle.runner, self.battery, self.boot_unix_us)
        self.gcs = Gcs(self.params, self.vehicle, self.telemetry, self.store, self.home, banner(self.params),
                       self.logs.tlog.write if self.logs.tlog else None, opts.hidden_params, opts.param_errors)
        open_ports(self.gcs, self.params, (opts.tcp_host, opts.tcp_port), opts.outputs, opts.serial)
        self.n_cmd = (0.0, 0.0)
        self.hold = make_lockstep_hold(opts.lockstep_period_s, opts.lockstep_timeout_s, opts.lockstep_start_s,
                                       self.params, self.gcs, self.telemetry, self.vehicle)  # --lockstep

    def _reboot(self) -> Pacer:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (param1 1), as SITL restarts: the links close, nothing is said for
        REBOOT_SILENCE_S of wall time, then everything in ``_boot`` starts again with the clock at 0."""
        log.warning("rebooting (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN)")
        self.gcs.close()
        time.sleep(REBOOT_SILENCE_S)
        self.boot_unix_us = int(time.time() * 1e6)
        self._boot()
        return Pacer(self.opts.speedup)

    def unix_us(self) -> int:
        """Simulated Unix time in µs (boot wall time + simulated time)."""
        return self.boot_unix_us + round(self.physics.plant.time * 1e6)

    def _text(self, severity: int, text: str) -> None:
        """STATUSTEXT from the vehicle logic to every channel."""
        self.gcs.text(severity, text)

    def _reached(self, seq: int) -> None:
        """MISSION_ITEM_REACHED to every channel when a nav item completes."""
        self.gcs.broadcast(mavlink.MAVLink_mission_item_reached_message(seq))

    def step(self) -> None:
        """One physics step: read links, run the autopilot, advance the plant, send what is due."""
        plant = self.physics.plant
        now = plant.time
        self.vehicle.now = now  # messages handled below are stamped with this step's time
        self.gcs.poll(now)
        outputs = self.vehicle.update(nav_state(plant.state), now, PHYSICS_DT_S)
        self.n_cmd = self.physics.shaft_commands(outputs)
        self.battery.update(outputs, PHYSICS_DT_S)
        if wind_setting(self.params.__getitem__) != self.wind:  # SIM_WIND_* set: the wind changes now
            self.wind = wind_setting(self.params.__getitem__)
            self.physics.set_wind(wind_of(self.wind, self.opts.world.sea.wind_seed))
            plant = self.physics.plant
        x = plant.step(self.n_cmd)
        if self.physics.sensing is not None:
            self.physics.sensing.update()
        self.logs.state(self.physics, x, self.n_cmd, self.vehicle)
        self.gcs.send_due(plant.time)

    def run(self) -> None:
        """Loop until stopped (signal) or the optional duration has passed."""
        self.logs.first_state(self.physics, self.n_cmd, self.vehicle)
        log.info("sim_vehicle running: mode %s, speedup %g", Mode(self.vehicle.mode).name, self.opts.speedup)
        try:
            if self.physics.sensing is not None:
                self.physics.sensing.update()  # the first reading, at t = 0
            if self.opts.wait_for_client:
                self.boot_unix_us = self.telemetry.boot_unix_us = wait_for_first_client(self.gcs, self._running)
            self._loop(Pacer(self.opts.speedup))  # simulated time starts now
        finally:
            self.close()

    def _running(self) -> bool:
        """Whether the loop should go on (a signal handler clears ``running``)."""
        return self.running

    def _loop(self, pacer: Pacer) -> None:
        """Step, reboot when asked, hold at lockstep ticks and pace, until stopped or the duration has passed."""
        while self.running:
            if self.opts.duration_s is not None and self.physics.plant.time >= self.opts.duration_s:
                break
            self.step()
            if self.gcs.commands.reboot_requested:
                pacer = self._reboot()
                continue
            if self.hold is not None:
                self.hold.hold_for_command(self.physics.plant.time, pacer, self._running)
            pacer.wait_until(self.physics.plant.time)
            self.logs.flush_if_due()

    def close(self) -> None:
        """Close sockets and logs (and say what lockstep did)."""
        if self.hold is not None:
            log.warning(self.hold.summary())
        self.gcs.close()
        self.logs.close()
