"""The simulator: one loop that owns time, stepping MAVLink I/O, the autopilot and the plant at 100 Hz."""

from __future__ import annotations

import logging
import select
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from vessel import World, world_preset
from vessel.config import ConfigError
from vessel.geo import Home

from .battery import Battery
from .clock import Pacer
from .gcs import Gcs
from .json_backend_log import write_sea_record
from .link import Channel
from .lockstep import DEFAULT_TIMEOUT_S, Lockstep
from .logs import StateCsv, TlogWriter
from .mission import MissionStore
from .modes import Mode
from .params import ParamTable, baud_from_code
from .physics import PHYSICS_DT_S, Physics, nav_state
from .telemetry import FIRMWARE_VERSION, Telemetry
from .vehicle import Vehicle

log = logging.getLogger("sim_vehicle")
CSV_FLUSH_S = 1.0
HOLD_POLL_S = 0.01  # wall seconds between link polls while simulated time is held
RESEND_WALL_S = 0.25  # lockstep: a held tick repeats its HEARTBEAT and ATTITUDE this often (lost datagrams)
FRAME_CLASS_BOAT = 2
SERIAL_PORT_CHANNEL = 2  # --serial plays SERIAL2, the Otter companion's port, whose rates are SR2_*
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


class Simulator:
    """Builds the boat, the autopilot and its links, then runs them in simulated time."""

    def __init__(self, opts: Options) -> None:
        self.opts = opts
        self.params = opts.params
        self.home = opts.home
        self.store = MissionStore(opts.mission_store)
        self.boot_unix_us = int(time.time() * 1e6)
        self.tlog = TlogWriter(opts.log_dir / "sim_vehicle.tlog", self.unix_us) if opts.log_dir else None
        self.csv = StateCsv(opts.log_dir / "state.csv") if opts.log_dir else None
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
        self.physics = Physics.create(opts.world, opts.seed, opts.surface_heave)
        self.physics.attach_sensing(self.params.__getitem__, opts.ideal_sensors, opts.noise_seed)
        self.startup_s = time.monotonic() - started  # an irregular plant compiles (vessel.jit) before time starts
        if opts.log_dir is not None and self.boots == 1:
            write_sea_record(opts.log_dir / "sea.json", opts.seed, self.physics.plant.waves,
                             self.physics.plant.current, opts.world.vessel, opts.world.plant_state(),
                             note="known to the simulator only; nothing it sends over MAVLink carries the sea")
        self.battery = Battery()
        self.vehicle = Vehicle(self.params, self.home, self.store, self._text, self._reached, opts.rc_receiver)
        self.telemetry = Telemetry(
            self.physics,
            self.vehicle,
            self.home,
            self.params,
            self.store,
            self.vehicle.runner,
            self.battery,
            self.boot_unix_us,
        )
        self.gcs = Gcs(
            self.params,
            self.vehicle,
            self.telemetry,
            self.store,
            self.home,
            self._banner(),
            self.tlog.write if self.tlog else None,
        )
        if opts.tcp_port is not None:
            self.gcs.add_tcp_server(opts.tcp_host, opts.tcp_port)
        for host, port in opts.outputs:
            self.gcs.add_udp(host, port)
        if opts.serial is not None:
            self._open_serial(*opts.serial)
        self.n_cmd = (0.0, 0.0)
        self.lockstep = self._make_lockstep()
        self._controller_channel: int | None = None  # id() of the channel the controller commands on

    def _reboot(self) -> Pacer:
        """MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (param1 1), as SITL restarts: the links close, nothing is said for
        REBOOT_SILENCE_S of wall time, then everything in ``_boot`` starts again with the clock at 0."""
        log.warning("rebooting (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN)")
        self.gcs.close()
        time.sleep(REBOOT_SILENCE_S)
        self.boot_unix_us = int(time.time() * 1e6)
        self._boot()
        return Pacer(self.opts.speedup)

    def _make_lockstep(self) -> Lockstep | None:
        """--lockstep: the controller is SYSID_MYGCS, as for RC overrides; its commands are watched here."""
        if self.opts.lockstep_period_s is None:
            if self.opts.lockstep_start_s is not None:
                raise ConfigError("--lockstep-start needs --lockstep")
            return None
        lock = Lockstep(self.opts.lockstep_period_s, self.opts.lockstep_timeout_s, int(self.params["SYSID_MYGCS"]),
                        self.opts.lockstep_start_s)
        self.gcs.lockstep_order = True
        self.gcs.message_hooks.append(self._watch_commands)
        return lock

    def _watch_commands(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """Feed every incoming message to the lockstep; remember the channel the controller commands on."""
        assert self.lockstep is not None
        was = self.lockstep.command_arrived()
        self.lockstep.on_message(msg.get_type(), msg.get_srcSystem())
        if self.lockstep.command_arrived() and not was:
            self._controller_channel = id(channel)

    def _open_serial(self, device: str, baud: int | None) -> None:
        """The companion's port, as SERIAL2 of an autopilot: MAVLink only if SERIAL2_PROTOCOL says so, SR2_* rates."""
        protocol = int(self.params["SERIAL2_PROTOCOL"])
        if protocol not in (1, 2):
            raise ConfigError(f"--serial: SERIAL2_PROTOCOL is {protocol}, so that port would not speak MAVLink "
                              "(set it to 2 = MAVLink2)")
        if baud is None:
            try:
                baud = baud_from_code(self.params["SERIAL2_BAUD"])
            except ValueError as exc:
                raise ConfigError(f"SERIAL2_BAUD: {exc}") from None
        self.gcs.add_serial(device, baud, SERIAL_PORT_CHANNEL)
        log.info("serving MAVLink on %s at %d baud (SERIAL2, stream rates SR%d_*)", device, baud, SERIAL_PORT_CHANNEL)

    def unix_us(self) -> int:
        """Simulated Unix time in µs (boot wall time + simulated time)."""
        return self.boot_unix_us + round(self.physics.plant.time * 1e6)

    def _text(self, severity: int, text: str) -> None:
        """STATUSTEXT from the vehicle logic to every channel."""
        self.gcs.text(severity, text)

    def _banner(self) -> list[str]:
        """The STATUSTEXT lines Rover sends when a GCS asks for all parameters (firmware and frame)."""
        major, minor, patch = FIRMWARE_VERSION
        frame = "Frame: BOAT" if self.params["FRAME_CLASS"] == FRAME_CLASS_BOAT else "Frame: ROVER"
        return [f"ArduRover V{major}.{minor}.{patch} (sim_vehicle Otter SITL)", frame]

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
        x = plant.step(self.n_cmd)
        if self.physics.sensing is not None:
            self.physics.sensing.update()
        self._log_state(x)
        self.gcs.send_due(plant.time)

    def _log_state(self, x: np.ndarray) -> None:
        """One CSV row of the true state after a step."""
        if self.csv is None:
            return
        t = self.physics.plant.time
        wave = self.physics.wave_at(float(x[0]), float(x[1]), t)
        self.csv.write(t, x, self.n_cmd, wave, int(self.vehicle.mode), self.vehicle.armed)

    def run(self) -> None:
        """Loop until stopped (signal) or the optional duration has passed."""
        plant = self.physics.plant
        last_flush = time.monotonic()
        if self.csv is not None:
            self.csv.write(
                plant.time,
                plant.state,
                self.n_cmd,
                self.physics.wave_at(0.0, 0.0, 0.0),
                int(self.vehicle.mode),
                self.vehicle.armed,
            )
        log.info("sim_vehicle running: mode %s, speedup %g", Mode(self.vehicle.mode).name, self.opts.speedup)
        try:
            if self.physics.sensing is not None:
                self.physics.sensing.update()  # the first reading, at t = 0
            if self.opts.wait_for_client:
                self._hold_until_a_client_speaks()
            pacer = Pacer(self.opts.speedup)  # simulated time starts now
            while self.running:
                if self.opts.duration_s is not None and plant.time >= self.opts.duration_s:
                    break
                self.step()
                if self.gcs.commands.reboot_requested:
                    pacer, plant = self._reboot(), self.physics.plant
                    continue
                if self.lockstep is not None:
                    self._hold_for_command(self.lockstep, pacer)
                pacer.wait_until(plant.time)
                if self.csv is not None and time.monotonic() - last_flush > CSV_FLUSH_S:
                    self.csv.flush()
                    last_flush = time.monotonic()
        finally:
            self.close()

    def _hold_for_command(self, lock: Lockstep, pacer: Pacer) -> None:
        """At a lockstep tick (this step sent ATTITUDE to the controller), read the links until its command.

        Messages handled while holding are stamped with the tick's time; nothing is sent, so the order of
        what the controller saw for this tick is fixed. Pacing restarts after the hold (no catching up).
        """
        now = self.physics.plant.time
        if self._controller_channel is None:  # before its first command: ATTITUDE on any channel
            sent = [i for ids in self.gcs.last_sent.values() for i in ids]
        else:
            sent = self.gcs.last_sent.get(self._controller_channel, [])
        if not lock.is_tick(now, mavlink.MAVLINK_MSG_ID_ATTITUDE in sent):
            return
        self.vehicle.now = now
        start = resent = time.monotonic()
        while self.running and not lock.command_arrived():
            waited = time.monotonic() - start
            if waited > lock.timeout_s:
                lock.timed_out(now, waited)
                break
            if time.monotonic() - resent > RESEND_WALL_S:
                self._repeat_tick()
                resent = time.monotonic()
            self.gcs.poll(now)
            if not lock.command_arrived():
                select.select(self.gcs.fileno_list(), [], [], HOLD_POLL_S)
        if lock.command_arrived():
            lock.released(time.monotonic() - start)
        pacer.restart(now)

    def _repeat_tick(self) -> None:
        """The held tick's HEARTBEAT and ATTITUDE again (same time, same content) to the controller's channel:
        a lost datagram (a lossy link, or a receiver's parser thrown off by noise) must not stall the run, and
        the controller's link watchdog keeps seeing the autopilot while it computes."""
        attitude = self.telemetry.build(mavlink.MAVLINK_MSG_ID_ATTITUDE)
        for channel in self.gcs.channels:  # before the first command (a start hold): every channel
            if channel.closed or self._controller_channel not in (None, id(channel)):
                continue
            channel.send(self.telemetry.heartbeat())
            if attitude is not None:
                channel.send(attitude)

    def _hold_until_a_client_speaks(self) -> None:
        """Keep simulated time at 0, reading (and answering) the links, until some client sends a message.

        ArduPilot's SITL likewise waits for its SERIAL0 TCP client before it starts; here any link counts
        (UDP has no connection), and a client speaks first as every GCS does with its own heartbeat.
        """
        log.info("waiting for a client to speak before simulated time starts")
        while self.running and self.gcs.messages_received == 0:
            self.gcs.poll(0.0)
            time.sleep(HOLD_POLL_S)
        self.boot_unix_us = self.telemetry.boot_unix_us = int(time.time() * 1e6)  # the clock starts now

    def close(self) -> None:
        """Close sockets and logs (and say what lockstep did)."""
        if self.lockstep is not None:
            log.warning(self.lockstep.stats.summary())
        self.gcs.close()
        if self.csv is not None:
            self.csv.close()
        if self.tlog is not None:
            self.tlog.close()
