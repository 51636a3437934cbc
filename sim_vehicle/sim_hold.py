"""Where the simulator holds simulated time still: at a lockstep tick until the controller's command, and at 0
until a client speaks (``--wait-for-client``).

While time is held the links are still read and answered, so a controller or GCS sees a live autopilot; the
lockstep hold also repeats the tick's HEARTBEAT and ATTITUDE now and then, so one lost datagram cannot stall a run.
"""

from __future__ import annotations

import logging
import select
import time
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.clock import Pacer
from sim_vehicle.lockstep import Lockstep
from sim_vehicle.mavlink.gcs import Gcs
from sim_vehicle.mavlink.link import Channel
from sim_vehicle.mavlink.telemetry import Telemetry
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.vehicle import Vehicle
from vessel.config import ConfigError

log = logging.getLogger("sim_vehicle")
HOLD_POLL_S = 0.01  # wall seconds between link polls while simulated time is held
RESEND_WALL_S = 0.25  # lockstep: a held tick repeats its HEARTBEAT and ATTITUDE this often (lost datagrams)


class LockstepHold:
    """``--lockstep``: the controller is SYSID_MYGCS, as for RC overrides; at each control tick simulated time
    waits for its command. Watches every incoming message (a GCS hook) and remembers the controller's channel."""

    def __init__(self, lockstep: Lockstep, gcs: Gcs, telemetry: Telemetry, vehicle: Vehicle) -> None:
        self.lockstep = lockstep
        self._gcs = gcs
        self._telemetry = telemetry
        self._vehicle = vehicle
        self._controller_channel: int | None = None  # id() of the channel the controller commands on
        gcs.lockstep_order = True
        gcs.message_hooks.append(self._watch_commands)

    def summary(self) -> str:
        """One line of what lockstep did (ticks held, timeouts) for the closing log."""
        return self.lockstep.stats.summary()

    def _watch_commands(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """Feed every incoming message to the lockstep; remember the channel the controller commands on."""
        was = self.lockstep.command_arrived()
        self.lockstep.on_message(msg.get_type(), msg.get_srcSystem())
        if self.lockstep.command_arrived() and not was:
            self._controller_channel = id(channel)

    def _attitude_sent(self) -> bool:
        """Whether the step just made sent ATTITUDE to the controller (before its first command: on any channel)."""
        if self._controller_channel is None:
            sent = [i for ids in self._gcs.last_sent.values() for i in ids]
        else:
            sent = self._gcs.last_sent.get(self._controller_channel, [])
        return mavlink.MAVLINK_MSG_ID_ATTITUDE in sent

    def hold_for_command(self, now: float, pacer: Pacer, running: Callable[[], bool]) -> None:
        """At a lockstep tick (this step sent ATTITUDE to the controller), read the links until its command.

        Messages handled while holding are stamped with the tick's time; nothing is sent, so the order of
        what the controller saw for this tick is fixed. Pacing restarts after the hold (no catching up).
        """
        lock = self.lockstep
        if not lock.is_tick(now, self._attitude_sent()):
            return
        self._vehicle.now = now
        start = resent = time.monotonic()
        while running() and not lock.command_arrived():
            waited = time.monotonic() - start
            if waited > lock.timeout_s:
                lock.timed_out(now, waited)
                break
            if time.monotonic() - resent > RESEND_WALL_S:
                self._repeat_tick()
                resent = time.monotonic()
            self._gcs.poll(now)
            if not lock.command_arrived():
                select.select(self._gcs.fileno_list(), [], [], HOLD_POLL_S)
        if lock.command_arrived():
            lock.released(time.monotonic() - start)
        pacer.restart(now)

    def _repeat_tick(self) -> None:
        """The held tick's HEARTBEAT and ATTITUDE again (same time, same content) to the controller's channel:
        a lost datagram (a lossy link, or a receiver's parser thrown off by noise) must not stall the run, and
        the controller's link watchdog keeps seeing the autopilot while it computes."""
        attitude = self._telemetry.build(mavlink.MAVLINK_MSG_ID_ATTITUDE)
        for channel in self._gcs.channels:  # before the first command (a start hold): every channel
            if channel.closed or self._controller_channel not in (None, id(channel)):
                continue
            channel.send(self._telemetry.heartbeat())
            if attitude is not None:
                channel.send(attitude)


def make_lockstep_hold(period_s: float | None, timeout_s: float, start_s: float | None, params: ParamTable,
                       gcs: Gcs, telemetry: Telemetry, vehicle: Vehicle) -> LockstepHold | None:
    """The lockstep hold for ``--lockstep PERIOD`` (None without it; ``--lockstep-start`` alone is a ConfigError)."""
    if period_s is None:
        if start_s is not None:
            raise ConfigError("--lockstep-start needs --lockstep")
        return None
    lock = Lockstep(period_s, timeout_s, int(params["SYSID_MYGCS"]), start_s)
    return LockstepHold(lock, gcs, telemetry, vehicle)


def wait_for_first_client(gcs: Gcs, running: Callable[[], bool]) -> int:
    """Keep simulated time at 0, reading (and answering) the links, until some client sends a message; returns
    the wall time in Unix µs at which the simulated clock starts.

    ArduPilot's SITL likewise waits for its SERIAL0 TCP client before it starts; here any link counts
    (UDP has no connection), and a client speaks first as every GCS does with its own heartbeat.
    """
    log.info("waiting for a client to speak before simulated time starts")
    while running() and gcs.messages_received == 0:
        gcs.poll(0.0)
        time.sleep(HOLD_POLL_S)
    return int(time.time() * 1e6)
