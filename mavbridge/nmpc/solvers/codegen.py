"""Compile a CasADi Function to a shared library once and cache it on disk, keyed by its content hash.

The key is a hash of the serialised Function and the compiler flags, so any change of model, parameters,
waves, horizon or optimisation level builds a new library; the same structure reuses it across runs and
processes. Without a C compiler (or
when compilation fails) the Function is returned as it is and runs in CasADi's SX virtual machine.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import os
import shutil
import subprocess
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import casadi as ca

CACHE_ENV = "MAVBRIDGE_CACHE_DIR"
# For functions called several times every step: GCC's -O3 without -march (so no FMA instructions exist to contract
# into) and with contraction off all the same, no -ffast-math: the same IEEE operations in the same order as -O1,
# so the same bits (the closed loop's recorded figures hold), ~10 % less time on the block linearisation
HOT_FLAGS = ("-O3", "-ffp-contract=off")


def cache_dir() -> Path:
    """$MAVBRIDGE_CACHE_DIR, else $XDG_CACHE_HOME/mavbridge, else ~/.cache/mavbridge."""
    if os.environ.get(CACHE_ENV):
        return Path(os.environ[CACHE_ENV])
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "mavbridge"


def compiler() -> str | None:
    """The C compiler to use (``$CC``, gcc or cc), or None."""
    for name in (os.environ.get("CC"), "gcc", "cc"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


def function_hash(fn: ca.Function, flags: tuple[str, ...] = ()) -> str:
    """A content hash of the Function (its serialised form), the CasADi version and the compiler ``flags``
    (a library built with other flags is another library: the cache must never hand out the wrong one)."""
    digest = hashlib.sha256(fn.serialize().encode())
    digest.update(ca.__version__.encode())
    digest.update(" ".join(flags).encode())
    return digest.hexdigest()[:20]


def compiled_library(fn: ca.Function, flags: tuple[str, ...] = ("-O1",)) -> tuple[Path | None, str]:
    """(path of the shared library for ``fn``, how), built into the cache if missing; (None, why) if none."""
    cc = compiler()
    if cc is None:
        return None, "sx-vm (no C compiler)"
    library = cache_dir() / f"{fn.name()}_{function_hash(fn, flags)}.so"
    try:
        build_once(library, lambda: _build(fn, library, cc, flags))
        return library, f"compiled ({library.name})"
    except (OSError, RuntimeError, subprocess.SubprocessError) as exc:
        warnings.warn(f"compiling {fn.name()} failed ({str(exc).splitlines()[0]}); using the SX virtual machine",
                      RuntimeWarning, stacklevel=2)
        return None, "sx-vm (compilation failed)"


def build_once(library: Path, build: Callable[[], None]) -> None:
    """Run ``build`` (which writes ``library``) unless the library is in the cache already, under a file lock: two
    processes that need the same library build it once, the second waiting for the first."""
    library.parent.mkdir(parents=True, exist_ok=True)
    if library.exists():
        return
    with open(library.parent / f".{library.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not library.exists():
            build()


def load(fn: ca.Function, library: Path | None) -> ca.Function:
    """A new instance of ``fn``: loaded from ``library`` when there is one, else ``fn`` itself (SX VM)."""
    return fn if library is None else ca.external(fn.name(), str(library))


def compiled(fn: ca.Function, flags: tuple[str, ...] = ("-O1",)) -> tuple[ca.Function, str]:
    """(Function, how): a compiled equivalent of ``fn`` from the cache (built if missing), or ``fn``."""
    library, how = compiled_library(fn, flags)
    return load(fn, library), how


def _build(fn: ca.Function, library: Path, cc: str, flags: tuple[str, ...]) -> None:
    with tempfile.TemporaryDirectory(dir=library.parent) as tmp:
        source = Path(tmp) / f"{fn.name()}.c"
        with contextlib.chdir(tmp):
            fn.generate(source.name, {"with_header": False})
        target = Path(tmp) / library.name
        subprocess.run([cc, *flags, "-shared", "-fPIC", "-o", str(target), str(source), "-lm"], check=True,
                       capture_output=True, timeout=1800)
        os.replace(target, library)
