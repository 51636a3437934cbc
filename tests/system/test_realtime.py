"""`mavbridge run --realtime` (issue 32): real-time scheduling, locked memory and an isolated CPU as far as the
system allows, one line saying what it got and what it fell back to, and never fatal.

The fall-back is made real, not mocked: the run's process starts without CAP_SYS_NICE and CAP_IPC_LOCK (dropped
from its capability bounding set before exec, so even root lacks them) and with RLIMIT_RTPRIO 0 and
RLIMIT_MEMLOCK 64 KiB, as an unprivileged service without LimitRTPRIO=/LimitMEMLOCK= would be.
"""

from __future__ import annotations

import ctypes
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from mavbridge.cli.realtime import Outcome, cpu_list, fmt_cpus, own_cpu
from sim_vehicle.harness import SimProcess
from tests.system.processes import collecting, wait_for_line
from tests.system.test_companion_sitl import HOME

pytestmark = pytest.mark.integration
PR_CAPBSET_DROP = 24
CAP_IPC_LOCK, CAP_SYS_NICE = 14, 23
SCHED_FIFO = 1


def unprivileged() -> None:
    """preexec_fn: drop CAP_SYS_NICE and CAP_IPC_LOCK for good, RLIMIT_RTPRIO 0, RLIMIT_MEMLOCK 64 KiB."""
    libc = ctypes.CDLL(None, use_errno=True)
    for cap in (CAP_IPC_LOCK, CAP_SYS_NICE):
        if libc.prctl(PR_CAPBSET_DROP, cap, 0, 0, 0) != 0 and ctypes.get_errno() != 1:  # EPERM: not ours to drop
            raise OSError(ctypes.get_errno(), "prctl(PR_CAPBSET_DROP)")
    resource.setrlimit(resource.RLIMIT_RTPRIO, (0, 0))
    resource.setrlimit(resource.RLIMIT_MEMLOCK, (65536, 65536))


def fifo_allowed() -> bool:
    """Whether a child of this test may take SCHED_FIFO 10 (root or CAP_SYS_NICE or RLIMIT_RTPRIO here)."""
    probe = "import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))"
    return subprocess.run([sys.executable, "-c", probe], capture_output=True, timeout=30).returncode == 0


def policy_and_locked_kb(pid: int) -> tuple[int, int]:
    """(scheduling policy, VmLck in kB) of a running process, from /proc."""
    stat = Path(f"/proc/{pid}/stat").read_text()
    policy = int(stat.rsplit(")", 1)[1].split()[38])  # field 41: policy (fields after the comm, from 3)
    locked = next(int(line.split()[1]) for line in Path(f"/proc/{pid}/status").read_text().splitlines()
                  if line.startswith("VmLck:"))
    return policy, locked


def realtime_run(sim: SimProcess, out: Path, preexec=None) -> tuple[int, list[str], tuple[int, int]]:
    """`mavbridge run --realtime` in shadow mode for 3 s of autopilot time: (exit code, lines, (policy, VmLck kB)
    read while it flew)."""
    argv = [sys.executable, "-m", "mavbridge.cli", "run", "--connect", f"udpin:127.0.0.1:{sim.udp_ports[0]}",
            "--realtime", "--dry-run", "--waypoint", "20,15", "--max-time", "3", "--out", str(out)]
    with collecting(argv, preexec_fn=preexec) as (proc, lines):
        wait_for_line(proc, lines, "phase: shadow", timeout_s=120)
        seen = policy_and_locked_kb(proc.pid)
        code = proc.wait(timeout=120)
    return code, [line.rstrip() for line in lines], seen


def test_without_the_privileges_it_says_what_it_fell_back_to_and_still_flies(tmp_path: Path) -> None:
    with SimProcess(tmp_path / "sim", speedup=5, waves="paper", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        code, lines, (policy, locked_kb) = realtime_run(sim, tmp_path / "run", unprivileged)
    assert code == 0, "\n".join(lines[-20:])
    said = [line for line in lines if line.startswith("realtime:")]
    assert len(said) == 1, lines
    assert "fell back: SCHED_OTHER (SCHED_FIFO priority 10: not permitted" in said[0], said[0]
    assert "no CAP_SYS_NICE, RLIMIT_RTPRIO 0; systemd: LimitRTPRIO=10" in said[0], said[0]
    assert "memory not locked (mlockall: " in said[0] and "LimitMEMLOCK=infinity" in said[0], said[0]
    assert (policy, locked_kb) == (0, 0)  # SCHED_OTHER, nothing locked: what it said
    planned = (tmp_path / "run" / "companion.csv").read_text().splitlines()
    assert len(planned) > 5, "the shadow run planned nothing"  # it still ran
    assert any("run ended: stopped (max_time_s reached)" in line for line in lines), lines[-5:]


def test_with_the_privileges_it_gets_fifo_and_locked_memory(tmp_path: Path) -> None:
    """Where this test may grant them (here: root), the run gets SCHED_FIFO 10 and locks its memory, and /proc
    shows both while it flies; elsewhere it says it fell back, and still flies."""
    allowed = fifo_allowed()
    with SimProcess(tmp_path / "sim", speedup=5, waves="paper", extra=[HOME, "--wipe"], udp_outs=1) as sim:
        code, lines, (policy, locked_kb) = realtime_run(sim, tmp_path / "run")
    assert code == 0, "\n".join(lines[-20:])
    said = next(line for line in lines if line.startswith("realtime:"))
    if allowed:
        assert said.startswith("realtime: got SCHED_FIFO priority 10, memory locked"), said
        assert policy == SCHED_FIFO and locked_kb > 50_000, (policy, locked_kb)  # the whole process, tens of MB
    else:
        assert "fell back: SCHED_OTHER" in said and policy == 0, said


def test_an_isolated_cpu_is_taken_when_the_kernel_lists_one(tmp_path: Path) -> None:
    """The isolated list as the kernel writes it ('1' here, a file standing in for sysfs): every thread moves
    there (a real sched_setaffinity, in a child process); none listed: the affinity is left as it was."""
    isolated = tmp_path / "isolated"
    cpu = max(os.sched_getaffinity(0))
    isolated.write_text(f"{cpu}\n")
    script = (f"import os; from pathlib import Path; from mavbridge.cli.realtime import own_cpu, Outcome; "
              f"o = Outcome(); own_cpu(o, Path({str(isolated)!r})); print(o.line()); print(os.sched_getaffinity(0))")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    line, affinity = done.stdout.splitlines()
    assert line == f"realtime: got CPU {cpu} of its own (isolated)" and affinity == f"{{{cpu}}}", done.stdout
    isolated.write_text("\n")
    before = os.sched_getaffinity(0)
    outcome = Outcome()
    own_cpu(outcome, isolated)
    assert outcome.fell_back == [f"CPUs {fmt_cpus(before)} as they were (no isolated CPU: {isolated} lists none; "
                                 "boot with isolcpus=)"] and os.sched_getaffinity(0) == before


def test_cpu_lists_read_as_the_kernel_writes_them() -> None:
    assert cpu_list("2-3,5\n") == [2, 3, 5] and cpu_list("\n") == [] and cpu_list("0") == [0]
    assert fmt_cpus({0, 1}) == "0-1" and fmt_cpus({0, 2}) == "0,2" and fmt_cpus({3}) == "3"
