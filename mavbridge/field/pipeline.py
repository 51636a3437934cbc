"""The report's reading on two cores: a child process reads the log and keeps the trial, this one runs the wave
estimator on the motion samples the child sends as it goes.

Reading (framing, decoding, the companion's ``StateEstimate``) and the estimator each take about half of an
hour's report, and neither waits for the other's result until the end: a forked child does the first and
sends the motion samples in batches of compact rows (16 floats: t, attitude, rates, NED position and velocity,
the IMU's specific force or NaN) through a pipe, then the trial. The estimator sees exactly the samples, in
exactly the order, of the one-process reading (``record``), which is what runs where fork is not available.
A ``LogError`` in the child comes back as a ``LogError`` here; any other failure as a RuntimeError naming it.
"""

from __future__ import annotations

import math
import multiprocessing
from collections.abc import Callable
from typing import Any

import numpy as np

from mavbridge.field.logs import LogError, LogReader, Progress
from mavbridge.field.trial import Trial, record
from mavbridge.waves.source import MotionSample

BATCH = 2000
COLUMNS = 16


def _row(sample: MotionSample) -> list[float]:
    accel = sample.accel_body if sample.accel_body is not None else (math.nan, math.nan, math.nan)
    return [sample.t_s, *sample.attitude, *sample.rates, *sample.position_ned, *sample.velocity_ned, *accel]


def _samples(rows: np.ndarray) -> list[MotionSample]:
    """The motion samples of a batch of rows (views into it)."""
    return [MotionSample(float(r[0]), r[1:4], r[4:7], r[7:10], r[10:13], None if math.isnan(r[13]) else r[13:16])
            for r in rows]


def _child(reader: LogReader, progress: Progress | None, send: Any) -> None:
    """Read the log; send ("rows", array) batches as they fill, then ("trial", Trial) or ("error", text)."""
    batch: list[list[float]] = []

    def collect(sample: MotionSample) -> None:
        batch.append(_row(sample))
        if len(batch) >= BATCH:
            send.send(("rows", np.array(batch, float)))
            batch.clear()

    try:
        trial = record(reader.messages(progress), reader.info, collect)
        if batch:
            send.send(("rows", np.array(batch, float)))
        send.send(("trial", trial))
    except LogError as exc:
        send.send(("error", str(exc)))
    except KeyboardInterrupt:  # Ctrl-C reaches the whole process group: the parent says it, once
        pass
    except Exception as exc:  # anything else: said, not lost in a child
        send.send(("failed", f"{type(exc).__name__}: {exc}"))
    finally:
        getattr(progress, "done", lambda: None)()  # a line drawn in place is this process's to end
        send.close()


def record_on_two_cores(reader: LogReader, on_motion: Callable[[MotionSample], None],
                        progress: Progress | None = None) -> Trial:
    """``record(reader.messages(progress), reader.info, on_motion)``, the reading in a forked child (see the
    module docstring); in this process where fork is not available."""
    if "fork" not in multiprocessing.get_all_start_methods():
        return record(reader.messages(progress), reader.info, on_motion)
    context = multiprocessing.get_context("fork")
    receive, send = context.Pipe(duplex=False)
    child = context.Process(target=_child, args=(reader, progress, send), daemon=True)
    child.start()
    send.close()
    try:
        while True:
            try:
                kind, payload = receive.recv()
            except EOFError:
                raise RuntimeError(f"reading {reader.info.path} ended without a trial (exit code "
                                   f"{child.exitcode})") from None
            if kind == "rows":
                for sample in _samples(payload):
                    on_motion(sample)
            elif kind == "trial":
                return payload
            elif kind == "error":
                raise LogError(payload)
            else:
                raise RuntimeError(f"reading {reader.info.path}: {payload}")
    finally:
        receive.close()
        child.join(timeout=5)
        if child.is_alive():
            child.terminate()
            child.join()
