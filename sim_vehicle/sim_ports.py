"""The simulator's MAVLink ports at each boot (TCP server, UDP outputs, the companion's serial port as SERIAL2)
and the banner Rover sends on them.

A port that cannot be opened raises OSError (the CLI names the port); a serial port whose parameters say it
would not speak MAVLink, or whose SERIAL2_BAUD is not a baud code, raises ConfigError naming the parameter.
"""

from __future__ import annotations

import logging

from sim_vehicle.mavlink.gcs import Gcs
from sim_vehicle.mavlink.telemetry import FIRMWARE_VERSION
from sim_vehicle.rover.params import ParamTable, baud_from_code
from vessel.config import ConfigError

log = logging.getLogger("sim_vehicle")
FRAME_CLASS_BOAT = 2
SERIAL_PORT_CHANNEL = 2  # --serial plays SERIAL2, the Otter companion's port, whose rates are SR2_*


def banner(params: ParamTable) -> list[str]:
    """The STATUSTEXT lines Rover sends when a GCS asks for all parameters (firmware and frame)."""
    major, minor, patch = FIRMWARE_VERSION
    frame = "Frame: BOAT" if params["FRAME_CLASS"] == FRAME_CLASS_BOAT else "Frame: ROVER"
    return [f"ArduRover V{major}.{minor}.{patch} (sim_vehicle Otter SITL)", frame]


def open_ports(gcs: Gcs, params: ParamTable, tcp: tuple[str, int | None], outputs: list[tuple[str, int]],
               serial: tuple[str, int | None] | None) -> None:
    """Open the TCP server (``tcp`` = (host, port), port None: none), the UDP outputs and the serial port."""
    host, port = tcp
    if port is not None:
        gcs.add_tcp_server(host, port)
    for out_host, out_port in outputs:
        gcs.add_udp(out_host, out_port)
    if serial is not None:
        open_serial(gcs, params, *serial)


def open_serial(gcs: Gcs, params: ParamTable, device: str, baud: int | None) -> None:
    """The companion's port, as SERIAL2 of an autopilot: MAVLink only if SERIAL2_PROTOCOL says so, SR2_* rates."""
    protocol = int(params["SERIAL2_PROTOCOL"])
    if protocol not in (1, 2):
        raise ConfigError(f"--serial: SERIAL2_PROTOCOL is {protocol}, so that port would not speak MAVLink "
                          "(set it to 2 = MAVLink2)")
    if baud is None:
        try:
            baud = baud_from_code(params["SERIAL2_BAUD"])
        except ValueError as exc:
            raise ConfigError(f"SERIAL2_BAUD: {exc}") from None
    gcs.add_serial(device, baud, SERIAL_PORT_CHANNEL)
    log.info("serving MAVLink on %s at %d baud (SERIAL2, stream rates SR%d_*)", device, baud, SERIAL_PORT_CHANNEL)
