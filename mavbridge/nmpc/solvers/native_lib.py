"""Build, cache and load the native RTI kernels (``native_source``) and call them with preallocated buffers;
call any compiled CasADi library through its C API (``CompiledFunction``, ``compiled_native``: the condensing's
linearisation, the companion's delay prediction) without CasADi's per-call conversions.

The library is compiled once with the system C compiler (``codegen.compiler``: $CC, gcc or cc) into the
same cache as the compiled linearisations (``codegen.cache_dir``), named by a hash of the source and the
flags, and loaded with ctypes. ctypes releases the GIL during each call, so the preparation running in a
background thread never holds up the control loop while it computes. Without a compiler (or when the
build fails) ``native_library`` answers None with the reason, and the ``nrti`` backend says so once and
runs as ``asrti`` (slower).
"""

from __future__ import annotations

import ctypes
import fcntl
import hashlib
import os
import platform
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from mavbridge.nmpc.solvers.codegen import cache_dir, compiled_library, compiler, load
from mavbridge.nmpc.solvers.native_source import C_SOURCE

FLAGS = ("-O3", "-fPIC", "-shared", "-std=c99")
NATIVE_FLAGS = ("-march=native",)  # this CPU's vector units (≈ 1.5× on condensing); the cache key names the CPU
_P = ctypes.c_void_p
_I = ctypes.c_int
_D = ctypes.c_double
SIGNATURES = {
    "nrti_condense": (_I, _I, _I, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P),
    "nrti_box_qp": (_I, _P, _P, _P, _P, _P, _P, _P, _P, _I, _D),
    "nrti_feedback": (_I, _I, _I, _I, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _I, _D, _P, _P, _P, _P, _P),
    "nrti_converge": (_I, _I, _I, _I, _I, _D, _D, *(_P,) * 21, _I, _D, *(_P,) * 5),
}


def cpu_identity() -> str:
    """What the machine's CPU is (model and feature flags where Linux says so), for the cache key: a
    library built with ``-march=native`` must never be loaded on a different CPU sharing the cache."""
    try:
        lines = Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        lines = []
    wanted = [line for line in lines if line.startswith(("model name", "flags", "Features", "CPU part"))]
    return "\n".join(sorted(set(wanted))) or f"{platform.machine()} {platform.processor()}"


def source_hash() -> str:
    """A hash of the C source, the compiler flags and the CPU (the library's cache key)."""
    digest = hashlib.sha256(C_SOURCE.encode())
    digest.update(" ".join(FLAGS + NATIVE_FLAGS).encode())
    digest.update(cpu_identity().encode())
    return digest.hexdigest()[:20]


def _build(cc: str, library: Path) -> None:
    """Compile with this CPU's instruction set, or portably when the compiler refuses ``-march=native``."""
    with tempfile.TemporaryDirectory(dir=library.parent) as tmp:
        source = Path(tmp) / "nrti_kernels.c"
        source.write_text(C_SOURCE, encoding="utf-8")
        target = Path(tmp) / library.name
        command = [cc, *FLAGS, "-o", str(target), str(source), "-lm"]
        try:
            subprocess.run([*command[:1], *NATIVE_FLAGS, *command[1:]], check=True, capture_output=True, timeout=300)
        except subprocess.CalledProcessError:
            subprocess.run(command, check=True, capture_output=True, timeout=300)
        os.replace(target, library)


def native_library() -> tuple[ctypes.CDLL | None, str]:
    """(the loaded kernels, how) — built into the cache when missing; (None, why) without a compiler."""
    cc = compiler()
    if cc is None:
        return None, "no C compiler ($CC, gcc or cc)"
    directory = cache_dir()
    library = directory / f"nrti_kernels_{source_hash()}.so"
    try:
        directory.mkdir(parents=True, exist_ok=True)
        if not library.exists():
            with open(directory / f".{library.name}.lock", "w") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX)  # another process may be building it
                if not library.exists():
                    _build(cc, library)
        lib = ctypes.CDLL(str(library))
    except (OSError, subprocess.SubprocessError) as exc:
        return None, f"building the native kernels failed ({str(exc).splitlines()[0] if str(exc) else exc})"
    for name, argtypes in SIGNATURES.items():
        fn = getattr(lib, name)
        fn.argtypes = argtypes
        fn.restype = _I
    return lib, f"native ({library.name})"


def ptr(a: np.ndarray) -> int:
    """The address of a C-contiguous array's data (kept alive by the caller)."""
    if not a.flags.c_contiguous:
        raise ValueError("native kernels need C-contiguous arrays")
    return a.ctypes.data


class BoxQp:
    """``nrti_box_qp`` with its own work buffers: min ½xᵀHx + gᵀx, lo ≤ x ≤ hi (H SPD, n × n)."""

    def __init__(self, lib: ctypes.CDLL, n: int, max_iter: int, tol: float) -> None:
        self.lib, self.n, self.max_iter, self.tol = lib, n, max_iter, tol
        self.work = np.zeros(n * n + n)
        self.iwork = np.zeros(2 * n, np.intc)

    def solve(self, H: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray,
              state: np.ndarray) -> tuple[np.ndarray, int]:
        """(x, status): status > 0 pivoting iterations, 0 iteration cap (x clipped), −1 H not SPD.
        ``state`` (intc, −1 at lo / 0 free / +1 at hi) is the starting guess and is overwritten."""
        x = np.zeros(self.n)
        H, g = np.ascontiguousarray(H, float), np.ascontiguousarray(g, float)
        lo, hi = np.ascontiguousarray(lo, float), np.ascontiguousarray(hi, float)
        status = self.lib.nrti_box_qp(self.n, ptr(H), ptr(g), ptr(lo), ptr(hi), ptr(state), ptr(x), ptr(self.work),
                                      ptr(self.iwork), self.max_iter, self.tol)
        return x, int(status)


class CompiledFunction:
    """A CasADi-generated library called through its C API into caller-owned numpy buffers.

    The generated ``name(arg, res, iw, w, mem)`` writes each output's nonzeros (for dense outputs: the
    matrix, column-major) straight into ``outputs``; no DM is created and, as with every ctypes call, the
    GIL is released while it runs. One instance per thread (it owns its work vectors).
    """

    def __init__(self, library: Path, fn_name: str, n_out: list[int], n_in: list[int] | None = None) -> None:
        """``n_out``: each output's nonzeros (the buffers' sizes); ``n_in``: each input's, checked by ``bind``."""
        self.n_in = n_in
        self.lib = ctypes.CDLL(str(library))
        self.fn = getattr(self.lib, fn_name)
        self.fn.argtypes = (_P, _P, _P, _P, _I)
        self.fn.restype = _I
        work = getattr(self.lib, f"{fn_name}_work")
        sizes = [ctypes.c_longlong() for _ in range(4)]
        work(*(ctypes.byref(s) for s in sizes))
        sz_arg, sz_res, sz_iw, sz_w = (int(s.value) for s in sizes)
        self.arg = (ctypes.c_void_p * max(sz_arg, 1))()
        self.res = (ctypes.c_void_p * max(sz_res, 1))()
        self.iw = np.zeros(max(sz_iw, 1), np.int64)
        self.w = np.zeros(max(sz_w, 1))
        self.outputs = [np.zeros(n) for n in n_out]
        for i, out in enumerate(self.outputs):
            self.res[i] = out.ctypes.data
        self._work = (ptr(self.iw), ptr(self.w))

    def __call__(self, *inputs: np.ndarray) -> list[np.ndarray]:
        """Evaluate at the (C-contiguous float) ``inputs``; answers this instance's output buffers."""
        self.bind(*inputs)
        return self.call()

    def bind(self, *inputs: np.ndarray) -> None:
        """Point the inputs at these (C-contiguous float) arrays, which the caller keeps alive and refills between
        ``call``s: taking an array's address costs microseconds, as much as a small function's evaluation."""
        if self.n_in is not None and len(inputs) != len(self.n_in):
            raise ValueError(f"{len(inputs)} inputs bound, the function takes {len(self.n_in)}")
        for i, x in enumerate(inputs):
            if x.dtype != np.float64 or (self.n_in is not None and x.size != self.n_in[i]):
                raise ValueError(f"input {i}: {x.dtype} of size {x.size}, the function reads float64 "
                                 f"of size {self.n_in[i] if self.n_in is not None else '?'}")
            self.arg[i] = ptr(x)

    def call(self) -> list[np.ndarray]:
        """Evaluate at the inputs last bound (their current contents); answers this instance's output buffers."""
        if self.fn(self.arg, self.res, *self._work, 0) != 0:
            raise RuntimeError("compiled function failed")
        return self.outputs

    def status_call(self) -> int:
        """Evaluate at the inputs last bound, the outputs into ``res``'s first pointers (which the caller sets):
        the function's return code (0: success; a generated conic answers −1 when its solver did not converge)."""
        return int(self.fn(self.arg, self.res, *self._work, 0))


def compiled_native(fn: ca.Function) -> tuple[ca.Function, CompiledFunction | None, str]:
    """(Function, the same library called through its C API or None, how): ``codegen.compiled`` plus a direct
    caller for per-step use (CasADi's Python call converts each argument to a DM and back), its buffer sizes
    taken from ``fn`` and every bound input checked against them. None, and the Function in CasADi's virtual
    machine, without a C compiler."""
    library, how = compiled_library(fn)
    if library is None:
        return load(fn, library), None, how
    n_out = [fn.nnz_out(i) for i in range(fn.n_out())]
    n_in = [fn.nnz_in(i) for i in range(fn.n_in())]
    return load(fn, library), CompiledFunction(library, fn.name(), n_out, n_in), how
