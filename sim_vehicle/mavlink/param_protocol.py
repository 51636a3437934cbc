"""The parameter protocol: list download paced per step, read by name or index, set with broadcast echo.

``hidden`` names are served as a real autopilot serves a parameter it does not have (its firmware lacks
it): not listed, not counted, and a read or set of it answered as of any unknown name, with PARAM_ERROR
DOES_NOT_EXIST (recent ArduPilot) or, with ``errors`` off, with nothing at all (older firmware). The
simulation itself still uses its value (``sim-vehicle --hide-params``, ``--no-param-error``).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sim_vehicle.mavlink.link import Channel
from sim_vehicle.rover.params import ParamTable

PARAMS_PER_STEP = 10  # list download pace: 1000 parameters per simulated second
BY_NAME = 65535


def _name(raw: object) -> str:
    """A param_id field as text (pymavlink may give bytes or str, NUL padded)."""
    if isinstance(raw, bytes):
        raw = raw.decode("ascii", errors="replace")
    return str(raw).split("\0", 1)[0].strip()


class ParamServer:
    """Answers PARAM_* messages from the live parameter table."""

    def __init__(
        self,
        params: ParamTable,
        text: Callable[[int, str, Channel | None], None],
        broadcast: Callable[[mavlink.MAVLink_message], None],
        banner: list[str],
        hidden: frozenset[str] = frozenset(),
        errors: bool = True,
    ) -> None:
        self.params, self.text, self.broadcast, self.banner = params, text, broadcast, banner
        self.errors = errors
        self._queues: dict[int, tuple[Channel, deque[int]]] = {}
        # the table indices served, in list order (a hidden parameter has no index on the wire)
        self._served = [i for i in range(len(params)) if params.at(i)[0].name not in hidden]
        self._wire_index = {table: wire for wire, table in enumerate(self._served)}

    def value_message(self, index: int, reported_index: int) -> mavlink.MAVLink_message:
        """PARAM_VALUE for parameter ``index`` (of the table) reporting ``reported_index``."""
        d, value = self.params.at(index)
        return mavlink.MAVLink_param_value_message(
            d.name.encode(), value, d.ptype, len(self._served), reported_index
        )

    def _find(self, name: str, index: int) -> int:
        """The table index of a served parameter by name (``index`` -1) or wire index; KeyError if none."""
        if index == -1:
            found = self.params.index(name)
            if found not in self._wire_index:
                raise KeyError(name)
            return found
        if not 0 <= index < len(self._served):
            raise KeyError(index)
        return self._served[index]

    def handle(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """Dispatch one PARAM_* message addressed to us."""
        kind = msg.get_type()
        if kind == "PARAM_REQUEST_LIST":
            for line in self.banner:
                self.text(6, line, channel)
            self._queues[id(channel)] = (channel, deque(self._served))
        elif kind == "PARAM_REQUEST_READ":
            self._read(channel, msg)
        elif kind == "PARAM_SET":
            self._set(channel, msg)

    def _error(
        self, channel: Channel, msg: mavlink.MAVLink_message, name: str, index: int, code: int
    ) -> None:
        """PARAM_ERROR back to the sender (firmware before PARAM_ERROR, ``errors`` off: nothing)."""
        if not self.errors:
            return
        channel.send(
            mavlink.MAVLink_param_error_message(
                msg.get_srcSystem(), msg.get_srcComponent(), name.encode()[:16], index, code
            )
        )

    def _read(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """PARAM_REQUEST_READ by name (index -1) or by index."""
        index = int(msg.param_index)
        name = _name(msg.param_id)
        try:
            found = self._find(name, index)
        except KeyError:
            self._error(channel, msg, name, index, mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST)
            return
        channel.send(self.value_message(found, BY_NAME if index == -1 else index))

    def _set(self, channel: Channel, msg: mavlink.MAVLink_message) -> None:
        """PARAM_SET: store, persist and echo to every channel; refuse unknown names and NaN."""
        name = _name(msg.param_id)
        if name not in self.params or self.params.index(name) not in self._wire_index:
            self._error(channel, msg, name, -1, mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST)
            return
        if not self.params.set(name, float(msg.param_value)):
            self._error(channel, msg, name, -1, mavlink.MAV_PARAM_ERROR_VALUE_OUT_OF_RANGE)
            return
        self.broadcast(self.value_message(self.params.index(name), BY_NAME))

    def update(self) -> None:
        """Send the next few PARAM_VALUEs of every list download in progress."""
        for key, (channel, queue) in list(self._queues.items()):
            for _ in range(min(PARAMS_PER_STEP, len(queue))):
                index = queue.popleft()
                channel.send(self.value_message(index, self._wire_index[index]))
            if not queue or channel.closed:
                del self._queues[key]
