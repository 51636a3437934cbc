"""`mavbridge run --realtime` (YAML ``realtime: true``): ask the operating system to keep the control step on time
on a busy companion computer, and say in one line what it got and what it fell back to. Never fatal.

* Scheduling: SCHED_FIFO at ``realtime_priority`` (default 10: above every normal process, such as a camera's
  or a logger's, below the kernel's interrupt threads at 50) for every thread of the process; threads started
  later inherit it (asrti/nrti's background solve, whose result the step waits for); a child process started
  before (the wave estimator's, ``mavbridge.companion.wave_process``) is given its own settings (`mavbridge
  run`: one priority lower, applied by the child itself, as locked memory is a process's own). Needs root,
  CAP_SYS_NICE or RLIMIT_RTPRIO at least the priority (systemd: ``LimitRTPRIO=``); else the process stays
  SCHED_OTHER.
* Memory: ``mlockall`` through ctypes, so no page the loop touches is swapped out or faulted in late:
  MCL_CURRENT | MCL_FUTURE where RLIMIT_MEMLOCK is unlimited or the process has CAP_IPC_LOCK (systemd:
  ``LimitMEMLOCK=infinity``); with a finite limit only MCL_CURRENT is tried (a later allocation past the limit
  would fail with MCL_FUTURE), and that fails once the process is larger than the limit.
* A CPU of its own: if ``/sys/devices/system/cpu/isolated`` lists CPUs (the kernel's ``isolcpus=``), every
  thread moves to the first one the process may use; otherwise the affinity is left as it is.
"""

from __future__ import annotations

import ctypes
import errno
import os
import resource
from dataclasses import dataclass, field
from pathlib import Path

DEFAULT_PRIORITY = 10
MCL_CURRENT, MCL_FUTURE = 1, 2
CAP_IPC_LOCK, CAP_SYS_NICE = 14, 23
ISOLATED = Path("/sys/devices/system/cpu/isolated")


@dataclass
class Outcome:
    """What the process got and what it fell back to, each as short phrases."""

    got: list[str] = field(default_factory=list)
    fell_back: list[str] = field(default_factory=list)

    def line(self) -> str:
        """'realtime: got ...; fell back: ...' (either part left out when empty)."""
        parts = ([f"got {', '.join(self.got)}"] if self.got else []) + \
            ([f"fell back: {'; '.join(self.fell_back)}"] if self.fell_back else [])
        return "realtime: " + "; ".join(parts)


def cpu_list(text: str) -> list[int]:
    """The CPUs of a kernel cpulist such as '2-3,5' (empty text: none)."""
    cpus: list[int] = []
    for part in text.strip().split(","):
        if part:
            first, _, last = part.partition("-")
            cpus += range(int(first), int(last or first) + 1)
    return cpus


def fmt_cpus(cpus: set[int] | list[int]) -> str:
    """'0-1' or '0,2' for a set of CPUs."""
    ordered = sorted(cpus)
    if ordered and ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 1:
        return f"{ordered[0]}-{ordered[-1]}"
    return ",".join(str(c) for c in ordered)


def _has_capability(bit: int) -> bool:
    """True if the process's effective capabilities include ``bit`` (from /proc/self/status)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("CapEff:"):
                return bool(int(line.split()[1], 16) >> bit & 1)
    except (OSError, ValueError):
        pass
    return False


def _threads() -> list[int]:
    """The ids of the process's threads (the calling one first, then the others)."""
    try:
        others = [int(t) for t in os.listdir("/proc/self/task") if int(t) != _own_tid()]
    except OSError:
        others = []
    return [0, *others]  # 0: the calling thread


def _own_tid() -> int:
    return int(getattr(os, "gettid", os.getpid)())


def _limit(value: int, unit: str = "") -> str:
    return "unlimited" if value == resource.RLIM_INFINITY else f"{value}{unit}"


def _each_thread(apply: object) -> None:
    """``apply(tid)`` for the calling thread (its error propagates), then the others (a thread that ended
    meanwhile is skipped)."""
    first, *others = _threads()
    apply(first)  # type: ignore[operator]
    for tid in others:
        try:
            apply(tid)  # type: ignore[operator]
        except (ProcessLookupError, PermissionError, OSError):
            pass


def schedule(priority: int, outcome: Outcome) -> None:
    """SCHED_FIFO at ``priority`` for every thread, or the reason it stays SCHED_OTHER."""
    try:
        _each_thread(lambda tid: os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(priority)))
    except OSError as exc:
        soft = resource.getrlimit(resource.RLIMIT_RTPRIO)[0]
        why = (f"not permitted: {'root' if os.geteuid() == 0 else 'not root'}, "
               f"{'with' if _has_capability(CAP_SYS_NICE) else 'no'} CAP_SYS_NICE, RLIMIT_RTPRIO {_limit(soft)}; "
               f"systemd: LimitRTPRIO={priority}" if exc.errno == errno.EPERM else exc.strerror or str(exc))
        outcome.fell_back.append(f"SCHED_OTHER (SCHED_FIFO priority {priority}: {why})")
        return
    outcome.got.append(f"SCHED_FIFO priority {priority}")


def lock_memory(outcome: Outcome) -> None:
    """mlockall: current and future pages where allowed without limit, else the current ones; or why not."""
    soft = resource.getrlimit(resource.RLIMIT_MEMLOCK)[0]
    unlimited = soft == resource.RLIM_INFINITY or _has_capability(CAP_IPC_LOCK)
    flags = MCL_CURRENT | (MCL_FUTURE if unlimited else 0)
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.mlockall(flags) == 0:
        outcome.got.append("memory locked" + (" (current and future)" if unlimited else
                                              f" (current pages only: RLIMIT_MEMLOCK {_limit(soft, ' B')})"))
        return
    code = ctypes.get_errno()
    outcome.fell_back.append(f"memory not locked (mlockall: {os.strerror(code)}; RLIMIT_MEMLOCK "
                             f"{_limit(soft, ' B')}, no CAP_IPC_LOCK; systemd: LimitMEMLOCK=infinity)")


def own_cpu(outcome: Outcome, isolated_file: Path = ISOLATED) -> None:
    """Every thread onto the first isolated CPU the process may use, or the affinity left as it is (and why)."""
    allowed = os.sched_getaffinity(0)
    try:
        isolated = cpu_list(isolated_file.read_text())
    except (OSError, ValueError):
        isolated = []
    if not isolated:
        outcome.fell_back.append(f"CPUs {fmt_cpus(allowed)} as they were (no isolated CPU: {isolated_file} "
                                 "lists none; boot with isolcpus=)")
        return
    cpu = isolated[0]
    try:
        _each_thread(lambda tid: os.sched_setaffinity(tid, {cpu}))
    except OSError as exc:
        outcome.fell_back.append(f"CPUs {fmt_cpus(allowed)} as they were (isolated CPU {cpu}: {exc.strerror})")
        return
    outcome.got.append(f"CPU {cpu} of its own (isolated)")


def apply_realtime(priority: int = DEFAULT_PRIORITY, isolated_file: Path = ISOLATED) -> Outcome:
    """Scheduling, locked memory and an isolated CPU, each as far as the system allows; never raises."""
    outcome = Outcome()
    for name, step in (("scheduling", lambda: schedule(priority, outcome)), ("memory", lambda: lock_memory(outcome)),
                       ("CPU", lambda: own_cpu(outcome, isolated_file))):
        try:
            step()
        except (OSError, AttributeError) as exc:  # an OS without the call (not Linux): nothing changed
            outcome.fell_back.append(f"{name} as it was ({exc})")
    return outcome
