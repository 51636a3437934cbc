"""Where a sweep's cases run, all behind ``concurrent.futures.Executor``.

* ``local`` — a process pool (spawn), one process per job, one thread each;
* ``dask-local:N`` — a Dask ``LocalCluster`` of N single-threaded worker processes on this machine;
* ``tcp://HOST:PORT`` — an existing Dask scheduler (``dask scheduler`` + ``dask worker`` started by the user).

Dask is the optional ``cluster`` extra. Its executor is made with ``pure=False`` so two cases with equal
arguments are both run (Dask's default would deduplicate them). Solvers are built inside each worker
process and cached there by the NMPC's own build cache; only scenarios and metrics cross the wire.
"""

from __future__ import annotations

import contextlib
import os
import re
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from multiprocessing import get_context

from vessel import ConfigError

DASK_LOCAL = re.compile(r"^dask-local:(\d+)$")
DASK_ADDRESS = re.compile(r"^tcp://[A-Za-z0-9_.\-\[\]:]+:\d+$")
CONNECT_TIMEOUT_S = 10.0
# What a Dask worker does besides the task takes the GIL from the closed loop (a one-thread worker runs its
# task beside the event loop): a stack sample every 10 ms for the dashboard's profile, an event-loop tick
# every 20 ms, a memory check every 100 ms, a system monitor every 500 ms. On the clusters we start these
# are off or slowed, and glibc's default malloc trimming is kept (Dask's 64 KiB threshold returns memory to
# the OS on every few frees); a user's own workers keep their own configuration.
LOCAL_WORKER_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
}


def parse_executor(text: str) -> tuple[str, int | None, str | None]:
    """('local', None, None) | ('dask-local', N, None) | ('dask', None, address); ConfigError otherwise."""
    if text == "local":
        return "local", None, None
    match = DASK_LOCAL.match(text)
    if match:
        n = int(match.group(1))
        if not 1 <= n <= 256:
            raise ConfigError(f"--executor: dask-local:N needs N in 1..256, got {n}")
        return "dask-local", n, None
    if DASK_ADDRESS.match(text):
        return "dask", None, text
    raise ConfigError(f"--executor: expected local, dask-local:N or tcp://HOST:PORT, got {text!r}")


def _single_thread() -> None:
    """Worker initialiser: one BLAS/OpenMP thread per process (the pool supplies the parallelism)."""
    os.environ["OMP_NUM_THREADS"] = "1"


def _import_distributed():
    try:
        import distributed
    except ImportError:
        raise ConfigError("--executor: Dask is not installed; pip install '.[cluster]'") from None
    return distributed


def _stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel queued cases and end the worker processes: a case still running after an interrupt is stopped,
    not left to finish (or be orphaned) after the sweep has said what remains. The pool keeps its processes
    in a private map; there is no public way to end a running task."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        proc.terminate()
    for proc in processes:
        proc.join(timeout=30)


@contextlib.contextmanager
def open_executor(text: str, jobs: int | None = None) -> Iterator[Executor]:
    """The executor named by ``text``, shut down (cluster and client closed) on leaving the block."""
    kind, n, address = parse_executor(text)
    if kind == "local":
        workers = max(1, jobs or os.cpu_count() or 1)
        pool = ProcessPoolExecutor(max_workers=workers, mp_context=get_context("spawn"), initializer=_single_thread)
        try:
            yield pool
        finally:
            _stop_pool(pool)
        return
    distributed = _import_distributed()
    if kind == "dask-local":
        import dask  # installed with distributed

        with dask.config.set(LOCAL_WORKER_CONFIG):  # a Nanny hands its worker the config of now
            cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                               dashboard_address=":0", silence_logs=40)  # no fixed 8787
        with cluster, distributed.Client(cluster) as client:
            yield client.get_executor(pure=False)
        return
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as exc:
        raise ConfigError(f"--executor: no Dask scheduler answers at {address} ({type(exc).__name__})") from None
    with client:
        yield client.get_executor(pure=False)


def worker_count(executor: Executor) -> int:
    """How many cases can run at once (for the progress line)."""
    pool_size = getattr(executor, "_max_workers", None)
    if pool_size:
        return int(pool_size)
    client = getattr(executor, "_client", None)
    if client is not None:
        return max(1, len(client.scheduler_info().get("workers", {})))
    return 1
