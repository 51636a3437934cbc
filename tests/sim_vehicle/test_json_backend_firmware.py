"""The JSON backend as a real process, driven over UDP loopback by a double of ArduPilot's SIM_JSON side.

The double sends servo packets exactly as the firmware lays them out (16 or 32 channels), counts frames
the way the firmware does (+1 after each reply it could parse), and parses the reply the way the
firmware's key-search parser does, so a format the firmware would reject fails here too.
"""

from __future__ import annotations

import json
import math
import os
import queue
import re
import socket
import subprocess
import sys
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from sim_vehicle.json_backend.protocol import encode_servo_packet, motor_output_to_pwm

REPO = Path(__file__).resolve().parents[2]
REPLY_TIMEOUT_S = 10.0
STARTUP_TIMEOUT_S = 60.0
_FLOAT = r"\s*([-+0-9.eEinfa]+)"


class BackendTimeoutError(AssertionError):
    """The backend did not answer what the double was waiting for."""


@dataclass(frozen=True)
class Reply:
    """The fields the firmware reads from a reply (float32 where it uses float32)."""

    timestamp: float
    gyro: np.ndarray
    accel_body: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    quaternion: np.ndarray
    raw: bytes


def _after_key(text: str, key: str, section: str = "") -> str:
    """What SIM_JSON's parser sees: strstr(section), then strstr(key), then skip the key and '":'."""
    start = text.find(section) + len(section) + 1 if section else 1
    at = text.find(key, start)
    if at < 0:
        raise AssertionError(f"reply has no {section + '.' if section else ''}{key}: {text!r}")
    return text[at + len(key) + 2:]


def _vector(text: str, key: str, n: int, section: str = "") -> np.ndarray:
    """sscanf("[%f, %f, ...]") semantics: the value must start with '[' right after the colon."""
    rest = _after_key(text, key, section)
    match = re.match(r"\[" + ",".join([_FLOAT] * n) + r"\s*\]", rest)
    if match is None:
        raise AssertionError(f"firmware could not read {key} (needs '[' right after the colon): {rest[:60]!r}")
    return np.array([float(v) for v in match.groups()])


def parse_reply(data: bytes) -> Reply:
    """Parse as the firmware does, and insist on the framing newlines and on valid JSON."""
    if not (data.startswith(b"\n") and data.endswith(b"\n")):
        raise AssertionError(f"reply must have a newline before and after the object: {data[:40]!r}")
    text = data.decode("ascii").strip("\n")
    json.loads(text)
    timestamp = float(re.match(_FLOAT, _after_key(text, "timestamp")).group(1))  # type: ignore[union-attr]
    return Reply(
        timestamp,
        _vector(text, "gyro", 3, "imu").astype(np.float32).astype(float),
        _vector(text, "accel_body", 3, "imu").astype(np.float32).astype(float),
        _vector(text, "position", 3),
        _vector(text, "velocity", 3).astype(np.float32).astype(float),
        _vector(text, "quaternion", 4).astype(np.float32).astype(float),
        data,
    )


class FirmwareDouble:
    """ArduPilot's side of the JSON link: send a frame, wait for the reply, count frames on success."""

    def __init__(self, port: int, frame_rate: int = 400, channels: int = 16) -> None:
        self.address = ("127.0.0.1", port)
        self.frame_rate = frame_rate
        self.channels = channels
        self.frame_count = 0
        self.first: Reply | None = None
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))

    def close(self) -> None:
        """Close the socket."""
        self.sock.close()

    def pwm(self, left: float, right: float) -> list[int]:
        """SERVO1 = ThrottleLeft, SERVO3 = ThrottleRight pulses for motor outputs in [-1, 1]."""
        return [motor_output_to_pwm(left), 0, motor_output_to_pwm(right)]

    def send(self, pwm: list[int], frame_count: int | None = None) -> None:
        """One servo packet (current frame count unless given)."""
        count = self.frame_count if frame_count is None else frame_count
        self.sock.sendto(encode_servo_packet(self.frame_rate, count, pwm, self.channels), self.address)

    def receive(self, what: str) -> Reply:
        """The next reply, or a typed timeout naming what was awaited."""
        self.sock.settimeout(REPLY_TIMEOUT_S)
        try:
            data, _ = self.sock.recvfrom(65536)
        except TimeoutError:
                raise BackendTimeoutError(f"no reply within {REPLY_TIMEOUT_S} s to {what}") from None
        return parse_reply(data)

    def frame(self, left: float = 0.0, right: float = 0.0) -> Reply:
        """A full firmware frame: send, wait for the reply, advance the frame count."""
        self.send(self.pwm(left, right))
        reply = self.receive(f"frame {self.frame_count} at {self.frame_rate} Hz")
        self.frame_count += 1
        return reply



def free_udp_port() -> int:
    """A UDP port nothing is bound to right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Backend:
    """A running ``sim-vehicle --json-backend -v`` process and its stderr lines, read as they come."""

    def __init__(self, cmd: list[str], port: int, log_dir: Path) -> None:
        env = {**os.environ, "OMP_NUM_THREADS": "1"}
        self.proc = subprocess.Popen(cmd, cwd=REPO, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                                     text=True, env=env)
        self.port = port
        self.log_dir = log_dir
        self.lines: queue.Queue[str | None] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.stderr: list[str] = []

    def _read(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            self.lines.put(line)
        self.lines.put(None)

    def wait_listening(self) -> None:
        """Block until the backend says it is bound (its -v line), or fail naming what was awaited."""
        while True:
            try:
                line = self.lines.get(timeout=STARTUP_TIMEOUT_S)
            except queue.Empty:
                raise BackendTimeoutError(f"backend did not report listening within {STARTUP_TIMEOUT_S} s") from None
            if line is None:
                raise BackendTimeoutError(f"backend exited before listening: {''.join(self.stderr)}")
            self.stderr.append(line)
            if "listening on UDP" in line:
                return

    def stop(self) -> str:
        """SIGTERM, wait, and return all its stderr (which ends with the summary line)."""
        if self.proc.poll() is None:
            self.proc.terminate()
        self.proc.wait(timeout=20)
        self._reader.join(timeout=20)
        while (line := self.lines.get_nowait() if not self.lines.empty() else None) is not None:
            self.stderr.append(line)
        return "".join(self.stderr)


def start_backend(tmp_path: Path, *extra: str) -> Backend:
    """Start the backend in the paper's waves with a fixed seed, logging to tmp_path/run; wait until bound."""
    port = free_udp_port()
    log_dir = tmp_path / "run"
    cmd = [sys.executable, "-m", "sim_vehicle.cli", "--json-backend", f"127.0.0.1:{port}", "--sea", "paper",
           "--seed", "7", "--log-dir", str(log_dir), "-v", *extra]
    backend = Backend(cmd, port, log_dir)
    backend.wait_listening()
    return backend


@pytest.fixture
def backend(tmp_path: Path) -> Iterator[tuple[Backend, FirmwareDouble]]:
    """A listening backend process and a firmware double that has had frame 0 answered."""
    proc = start_backend(tmp_path)
    firmware = FirmwareDouble(proc.port)
    try:
        firmware.first = firmware.frame()
        yield proc, firmware
    finally:
        firmware.close()
        proc.stop()


def test_thousand_frames_at_400_hz_step_exactly_once_each(backend: tuple[Backend, FirmwareDouble]) -> None:
    """1,000 frames at 400 Hz: the timestamp is k/400 after frame k, none skipped, none doubled."""
    proc, firmware = backend
    stamps = [firmware.frame(0.7, 0.3).timestamp for _ in range(1000)]
    expected = np.arange(2, 1002) / 400.0  # frame 0 (the fixture's) was the first step
    np.testing.assert_allclose(stamps, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.diff(stamps), 1 / 400, rtol=0, atol=1e-12)
    summary = proc.stop().strip().splitlines()[-1]
    assert "1001 frames stepped (t = 2.502500 s)" in summary
    assert "0 skipped" in summary


def test_repeated_frame_is_answered_without_stepping(backend: tuple[Backend, FirmwareDouble]) -> None:
    """The same frame_count again gets the same bytes back; the next new frame steps once."""
    _, firmware = backend
    for _ in range(10):
        firmware.frame(0.7, 0.7)
    last = firmware.frame_count - 1
    firmware.send(firmware.pwm(1.0, -1.0), frame_count=last)  # different sticks, same frame: still a repeat
    again = firmware.receive(f"repeat of frame {last}")
    firmware.send(firmware.pwm(0.7, 0.7), frame_count=last)
    third = firmware.receive(f"second repeat of frame {last}")
    assert again.raw == third.raw
    assert again.timestamp == pytest.approx(11 / 400, abs=1e-12)
    assert firmware.frame(0.7, 0.7).timestamp == pytest.approx(12 / 400, abs=1e-12)


def test_lower_frame_count_restarts_the_run(backend: tuple[Backend, FirmwareDouble]) -> None:
    """A firmware restart (count back to 0) starts from the initial state: the first run's replies repeat."""
    proc, firmware = backend
    first_run = [firmware.frame(0.8, 0.2) for _ in range(200)]
    firmware.frame_count = 0
    restart = firmware.frame(0.0, 0.0)
    second_run = [firmware.frame(0.8, 0.2) for _ in range(199)]
    assert firmware.first is not None and restart.raw == firmware.first.raw
    assert restart.timestamp == pytest.approx(1 / 400, abs=1e-12)
    assert [r.raw for r in second_run] == [r.raw for r in first_run[:199]]
    assert "1 resets" in proc.stop()


def test_garbage_is_counted_and_never_answered(backend: tuple[Backend, FirmwareDouble]) -> None:
    """Wrong size, wrong magic for the size, and frame rates 0 and 2001 Hz: no reply, each counted."""
    proc, firmware = backend
    count, pwm = firmware.frame_count, firmware.pwm(0.5, 0.5)
    good16 = encode_servo_packet(400, count, pwm, 16)
    good32 = encode_servo_packet(400, count, pwm, 32)
    bad = [
        b"garbage",
        good16[:-1],
        b"\x00" * 100,
        (29569).to_bytes(2, "little") + good16[2:],  # the 32-channel magic on a 16-channel packet
        (18458).to_bytes(2, "little") + good32[2:],  # and the other way round
        encode_servo_packet(0, count, pwm),
        encode_servo_packet(2001, count, pwm),
    ]
    before = firmware.frame(0.5, 0.5).timestamp
    for packet in bad:
        firmware.sock.sendto(packet, firmware.address)
    after = firmware.frame(0.5, 0.5)  # loopback keeps order: this must be the very next datagram back
    assert after.timestamp == pytest.approx(before + 1 / 400, abs=1e-12)
    summary = proc.stop().strip().splitlines()[-1]
    assert "bad packets: frame_rate 2, magic 2, size 3" in summary


def test_frame_rate_changes_step_by_each_frames_own_period(backend: tuple[Backend, FirmwareDouble]) -> None:
    """400 → 100 → 1000 → 50 Hz: every step is 1/frame_rate of the frame that asked for it."""
    proc, firmware = backend
    t = firmware.frame(0.6, 0.4).timestamp
    for rate, frames in ((100, 30), (1000, 50), (50, 10), (400, 20)):
        firmware.frame_rate = rate
        for _ in range(frames):
            stamp = firmware.frame(0.6, 0.4).timestamp
            assert stamp - t == pytest.approx(1 / rate, abs=1e-12)
            t = stamp
    assert "4 rate changes" in proc.stop()


def test_sixteen_and_thirty_two_channel_packets_drive_the_same(tmp_path: Path) -> None:
    """The same sticks as 16- and as 32-channel packets give byte-identical replies (same seed)."""
    runs = []
    for channels in (16, 32):
        proc = start_backend(tmp_path / str(channels))
        firmware = FirmwareDouble(proc.port, channels=channels)
        try:
            firmware.frame()
            runs.append([firmware.frame(0.9, -0.4).raw for _ in range(100)])
        finally:
            firmware.close()
            proc.stop()
    assert runs[0] == runs[1]
    assert parse_reply(runs[0][-1]).velocity[0] != 0.0


def test_run_folder_has_state_csv_and_sea_seed(backend: tuple[Backend, FirmwareDouble]) -> None:
    """state.csv (the simulator's state columns, ≤ 100 rows per s) and sea.json with the seed and phase."""
    proc, firmware = backend
    for _ in range(399):
        firmware.frame(0.7, 0.7)
    proc.stop()
    sea = json.loads((proc.log_dir / "sea.json").read_text())
    assert sea["seed"] == 7
    assert sea["waves"]["type"] == "RegularWaves" and 0 < sea["waves"]["phase_rad"] < 2 * math.pi
    lines = (proc.log_dir / "state.csv").read_text().splitlines()
    assert lines[0].startswith("t_s,north_m,east_m,down_m,roll_rad")
    assert ",wave_elevation_m,wave_slope_rad,wave_slope_n_rad,wave_slope_e_rad,run," in lines[0]
    slope_e = [float(row.split(",")[20]) for row in lines[1:]]
    assert max(map(abs, slope_e)) > 0.05  # the paper's waves travel West: the true slope is towards East
    assert 100 <= len(lines) - 1 <= 101  # 1 s at 400 Hz, one row per 10 ms


def test_port_in_use_is_one_line_and_exit_2(tmp_path: Path) -> None:
    """A second backend on the same port: one clear line, status 2, no traceback."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as holder:
        holder.bind(("127.0.0.1", 0))
        port = holder.getsockname()[1]
        done = subprocess.run([sys.executable, "-m", "sim_vehicle.cli", "--json-backend", str(port)],
                              cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "cannot bind UDP 127.0.0.1:" in done.stderr
    assert "Traceback" not in done.stderr


@pytest.mark.parametrize("args, field", [
    (["--json-backend", "70000"], "port must be in [1, 65535]"),
    (["--json-backend", "host:"], "expected [HOST:]PORT"),
    (["--json-backend", "9002", "--seed", "-1"], "seed must be an integer in [0, 4294967295]"),
    (["--json-backend", "9002", "--seed", str(2**32)], "seed must be an integer in [0, 4294967295]"),
    (["--json-backend", "9002", "--duration", "0"], "duration must be > 0"),
    (["--json-backend", "9002", "--sea", "9,10,6,0"], "--sea"),
    (["--json-backend", "9002", "--tcp", "5760"], "unrecognized arguments"),
])
def test_bad_flags_are_one_line_and_exit_2(args: list[str], field: str) -> None:
    """Each bad flag names itself or its range in one line, exit status 2."""
    done = subprocess.run([sys.executable, "-m", "sim_vehicle.cli", *args], cwd=REPO, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and field in done.stderr, done.stderr


def test_a_used_run_folder_is_refused(tmp_path: Path) -> None:
    """A folder that already holds a run is never overwritten: one line naming --log-dir, exit 2."""
    (tmp_path / "state.csv").write_text("t_s\n")
    done = subprocess.run([sys.executable, "-m", "sim_vehicle.cli", "--json-backend", str(free_udp_port()),
                           "--log-dir", str(tmp_path)], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and "--log-dir" in done.stderr and "already holds a run" in done.stderr
    assert (tmp_path / "state.csv").read_text() == "t_s\n"
