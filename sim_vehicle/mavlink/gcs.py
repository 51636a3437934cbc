"""The MAVLink side of the autopilot: channels, routing of incoming messages, heartbeats and streams."""

from __future__ import annotations

import logging
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.commands import CommandHandler
from sim_vehicle.mavlink.link import Channel, SerialChannel, TcpServer, TlogHook, UdpChannel
from sim_vehicle.mavlink.mission_protocol import MissionServer
from sim_vehicle.mavlink.param_protocol import ParamServer
from sim_vehicle.mavlink.signing import Signing
from sim_vehicle.mavlink.streams import Schedule
from sim_vehicle.mavlink.telemetry import Telemetry
from sim_vehicle.rover.control_inputs import ControlInputs
from sim_vehicle.rover.mission import MissionStore
from sim_vehicle.rover.params import ParamTable
from sim_vehicle.rover.vehicle import Vehicle
from vessel.geo import Home

log = logging.getLogger("sim_vehicle")
HEARTBEAT_INTERVAL_S = 1.0
STATUSTEXT_CHUNK = 50
AUTOPILOT_VERSION_REQUEST = 183


class Gcs:
    """All MAVLink channels of the vehicle, the protocol servers behind them, and what it says on them.

    Built complete: the parameter, mission and command servers are made here from the parts they serve.
    """

    def __init__(
        self,
        params: ParamTable,
        vehicle: Vehicle,
        telemetry: Telemetry,
        store: MissionStore,
        home: Home,
        banner: list[str],
        tlog: TlogHook | None,
        hidden_params: frozenset[str] = frozenset(),
        param_errors: bool = True,
    ) -> None:
        self.params, self.vehicle, self.telemetry = params, vehicle, telemetry
        self.sysid = int(params["SYSID_THISMAV"])
        self.compid = 1
        self.tlog = tlog
        self.channels: list[Channel] = []
        self.servers: list[TcpServer] = []
        self._schedules: dict[int, Schedule] = {}
        self._next_heartbeat: dict[int, float] = {}
        self._text_id = 0
        self.missions = MissionServer(store, vehicle.runner, home, self.text, self.broadcast, vehicle.guided_goto)
        self.param_server = ParamServer(params, self.text, self.broadcast, banner, hidden_params, param_errors)
        self.commands = CommandHandler(vehicle, telemetry, self.missions, self.schedule, self.text)
        self.inputs = ControlInputs(params, vehicle, self.sysid, self.text)
        self.signing = Signing(params, lambda: vehicle.armed, self.text,
                               lambda: telemetry.boot_unix_us + round(self.now * 1e6))
        self._handlers: dict[str, Callable[[Channel, mavlink.MAVLink_message], None]] = {
            "COMMAND_LONG": self.commands.handle_command,
            "COMMAND_INT": self.commands.handle_command,
            "SET_MODE": self.commands.handle_set_mode,
            "REQUEST_DATA_STREAM": self._data_stream,
            "TIMESYNC": self._timesync,
            "SETUP_SIGNING": self.signing.handle_setup,
            **self.inputs.handlers(),
        }
        self.now = 0.0
        self.messages_received = 0  # from any client, since start
        self.message_hooks: list[Callable[[Channel, mavlink.MAVLink_message], None]] = []  # see every message
        self.lockstep_order = False  # lockstep: streams on a fixed time grid, ATTITUDE last in each step
        self.last_sent: dict[int, list[int]] = {}  # id(channel) -> message ids sent by the last send_due

    # channels
    def add_udp(self, host: str, port: int) -> None:
        """An output to host:port that also answers whoever writes to it."""
        self.channels.append(
            UdpChannel(host, port, len(self.servers) + len(self.channels), self.sysid, self.compid, self.tlog)
        )

    def add_serial(self, device: str, baud: int, index: int) -> None:
        """A serial MAVLink port on stream-rate channel ``index`` (SRn_*); it stays open for the whole run."""
        self.channels.append(SerialChannel(device, baud, index, self.sysid, self.compid, self.tlog))

    def add_tcp_server(self, host: str, port: int) -> None:
        """A listening TCP port; its clients share stream-rate channel 0 (SR0_*)."""
        self.servers.append(TcpServer(host, port, 0))

    def fileno_list(self) -> list[int]:
        """Descriptors worth waiting on."""
        return [s.fileno() for s in self.servers] + [c.fileno() for c in self.channels if not c.closed]

    def schedule(self, channel: Channel) -> Schedule:
        """The stream schedule of a channel (created on first use)."""
        key = id(channel)
        if key not in self._schedules:
            self._schedules[key] = Schedule(self.params, channel.index, aligned=self.lockstep_order)
        return self._schedules[key]

    def close(self) -> None:
        """Close every socket."""
        for c in self.channels:
            c.close()
        for s in self.servers:
            s.close()

    # output
    def broadcast(self, msg: mavlink.MAVLink_message) -> None:
        """Send to every open channel."""
        for c in self.channels:
            if not c.closed:
                c.send(msg)

    def text(self, severity: int, text: str, channel: Channel | None = None) -> None:
        """STATUSTEXT (chunked when long) to one channel or to all; also logged."""
        log.info("STATUSTEXT %d: %s", severity, text)
        data = text.encode("utf-8", errors="replace")
        chunks = [data[i : i + STATUSTEXT_CHUNK] for i in range(0, max(1, len(data)), STATUSTEXT_CHUNK)]
        msg_id = 0
        if len(chunks) > 1:
            self._text_id = self._text_id % 65535 + 1
            msg_id = self._text_id
        for seq, chunk in enumerate(chunks):
            msg = mavlink.MAVLink_statustext_message(severity=severity, text=chunk, id=msg_id, chunk_seq=seq)
            if channel is not None:
                channel.send(msg)
            else:
                self.broadcast(msg)

    # input
    def poll(self, now: float) -> None:
        """Accept clients, read every channel and act on each message."""
        self.now = now
        for server in self.servers:
            for client in server.accept(self.sysid, self.compid, self.tlog):
                log.info("client connected on %s", client.name)
                self.channels.append(client)
        self.signing.update(self.channels, now)
        for channel in list(self.channels):
            for msg in channel.receive():
                self.messages_received += 1
                for hook in self.message_hooks:
                    hook(channel, msg)
                try:
                    self.dispatch(channel, msg)
                except Exception:
                    log.exception("ignored %s that could not be handled", msg.get_type())
            if channel.closed and not isinstance(channel, (UdpChannel, SerialChannel)):
                log.info("client disconnected from %s", channel.name)
                self.channels.remove(channel)
                self._schedules.pop(id(channel), None)
                self._next_heartbeat.pop(id(channel), None)

    def _for_us(self, msg: mavlink.MAVLink_message) -> bool:
        """Only messages for our system/component (or broadcast) are processed."""
        target = getattr(msg, "target_system", 0)
        component = getattr(msg, "target_component", 0)
        return target in (0, self.sysid) and component in (0, self.compid)

    def dispatch(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """Route one decoded message to its handler."""
        kind = msg.get_type()
        if not self._for_us(msg):
            return
        src = msg.get_srcSystem()
        if kind == "HEARTBEAT":
            if src == int(self.params["SYSID_MYGCS"]):
                self.vehicle.gcs_heartbeat()
            return
        handler = self._handlers.get(kind)
        if handler is not None:
            handler(channel, msg)
        elif kind.startswith("PARAM_"):
            self.param_server.handle(channel, msg)
        elif kind.startswith("MISSION_"):
            self.missions.handle(channel, msg, self.now)
        elif msg.get_msgId() == AUTOPILOT_VERSION_REQUEST:
            channel.send(self.telemetry.autopilot_version())

    def _timesync(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """Answer a TIMESYNC request (tc1 = 0) with our simulated clock in ns."""
        if msg.tc1 == 0:
            channel.send(mavlink.MAVLink_timesync_message(tc1=round(self.now * 1e9), ts1=msg.ts1))

    def _data_stream(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """REQUEST_DATA_STREAM for the channel it arrived on."""
        self.schedule(channel).set_stream(msg.req_stream_id, float(msg.req_message_rate), msg.start_stop == 1)

    # periodic output
    def send_due(self, now: float) -> None:
        """Heartbeats at 1 Hz and every streamed message that is due, on every channel."""
        self.now = now
        self.param_server.update()
        self.missions.update(now)
        built: dict[int, mavlink.MAVLink_message | None] = {}
        self.last_sent = {}
        for channel in self.channels:
            if channel.closed:
                continue
            key = id(channel)
            schedule = self.schedule(channel)
            ids = schedule.due(now)
            if 0 not in schedule.custom and now >= self._next_heartbeat.get(key, 0.0):
                self._next_heartbeat[key] = now + HEARTBEAT_INTERVAL_S
                ids.insert(0, 0)
            if self.lockstep_order:  # what the controller reads for a tick is in before that tick's ATTITUDE
                ids.sort(key=lambda i: (i == mavlink.MAVLINK_MSG_ID_ATTITUDE, i))
            self.last_sent[key] = ids
            for msg_id in ids:
                if msg_id not in built:
                    try:
                        built[msg_id] = self.telemetry.build(msg_id)
                    except Exception:  # e.g. a diverged plant state: drop that message, keep the link alive
                        log.exception("building message %d failed", msg_id)
                        built[msg_id] = None
                msg = built[msg_id]
                if msg is not None:
                    channel.send(msg)
