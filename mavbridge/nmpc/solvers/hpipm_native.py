"""The Gauss–Newton SQP's HPIPM conic as compiled C, called through ctypes on preallocated numpy buffers.

CasADi's Python call of the ``hpipm`` conic plugin costs a few tenths of a millisecond per QP beyond HPIPM's own
time (every argument becomes a DM and every output a numpy array), and the sweep's asrti runs solve ~3,600 QPs
each. ``ca.conic(...).generate()`` emits C that runs the same CasADi runtime (``casadi_hpipm_solve``) on the same
HPIPM and BLASFEO libraries the plugin uses — the CasADi wheel ships both, with their headers — so the compiled
conic gives the plugin's bits. Two things the generated code of CasADi 3.8.2 leaves out are put in before it is
compiled (``SOURCE_FIXES``): the HPIPM options it does not write (duality-gap limit, hot-start minima, ...) take
HPIPM's defaults of the plugin's mode, as the plugin's do, instead of whatever the stack held; and its local
structs start zeroed. The generated function also uses its result-pointer array as scratch space, so the output
pointers are set again before every call (``NativeQp.solve``). Each ``NativeQp`` owns its work and output buffers;
what instances of one library share (its static block tables) is rewritten with the same constants every call.

Without a C compiler, without HPIPM's headers and libraries in the CasADi package, or when the generated source
is not the one these fixes are for (another CasADi version), ``native_qp`` answers None with the reason and the
SQP calls the plugin as before.
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from mavbridge.nmpc.solvers.codegen import HOT_FLAGS, build_once, cache_dir, compiler
from mavbridge.nmpc.solvers.native_lib import CompiledFunction

MODE = "speed_abs"  # the conic's HPIPM mode (``gauss_newton.make_qp``); the fix sets the defaults of this one
SOURCE_FIXES = (  # (anchor met exactly once in the generated source, text put before it)
    ("  p.hpipm_options.mu0 = ", f"  d_ocp_qp_ipm_arg_set_default({MODE.upper()}, &p.hpipm_options);\n"),
    ("  d_qp.prob = &p_qp;\n",
     "  memset(&d, 0, sizeof d); memset(&p, 0, sizeof p);\n"
     "  memset(&d_qp, 0, sizeof d_qp); memset(&p_qp, 0, sizeof p_qp);\n"),
)


def hpipm_location() -> tuple[Path | None, str]:
    """(the CasADi package directory holding HPIPM's and BLASFEO's headers and libraries, "") or (None, why)."""
    root = Path(ca.__file__).resolve().parent
    wanted = [root / "include" / "hpipm_d_ocp_qp_ipm.h", root / "include" / "blasfeo_d_aux_ext_dep.h",
              root / "libhpipm.so", root / "libblasfeo.so"]
    missing = [path.name for path in wanted if not path.exists()]
    return (None, f"the CasADi package has no {', '.join(missing)}") if missing else (root, "")


def fixed_source(qp: ca.Function) -> str:
    """The conic's generated C with ``SOURCE_FIXES`` applied; RuntimeError when an anchor is not met exactly once."""
    generator = ca.CodeGenerator(f"{qp.name()}.c", {"with_header": False})  # (in memory: no file, no chdir)
    generator.add(qp)
    source = generator.dump()
    for anchor, insert in SOURCE_FIXES:
        if source.count(anchor) != 1:
            raise RuntimeError(f"the generated conic is not the one known (CasADi {ca.__version__}): {anchor!r}")
        source = source.replace(anchor, insert + anchor)
    return source


def qp_library(qp: ca.Function) -> tuple[Path | None, str]:
    """(the compiled conic, how), built into the cache (``codegen.cache_dir``) when missing; (None, why) if none.

    The key hashes the fixed source, the flags, the CasADi version and where its HPIPM lives (the library is
    linked to that file)."""
    cc = compiler()
    if cc is None:
        return None, "no C compiler ($CC, gcc or cc)"
    root, why = hpipm_location()
    if root is None:
        return None, why
    try:
        source = fixed_source(qp)
    except RuntimeError as exc:
        return None, str(exc)
    flags = (*HOT_FLAGS, "-fPIC", "-shared", f"-I{root / 'include'}")
    links = (f"-L{root}", "-lhpipm", "-lblasfeo", f"-Wl,-rpath,{root}", "-lm")
    digest = hashlib.sha256(source.encode())
    digest.update(" ".join((*flags, *links, ca.__version__)).encode())
    library = cache_dir() / f"{qp.name()}_hpipm_{digest.hexdigest()[:20]}.so"
    try:
        build_once(library, lambda: _build(source, library, [cc, *flags], list(links)))
    except (OSError, subprocess.SubprocessError) as exc:
        return None, f"compiling the conic failed ({str(exc).splitlines()[0] if str(exc) else exc})"
    return library, f"compiled ({library.name})"


def _build(source: str, library: Path, compile_command: list[str], links: list[str]) -> None:
    with tempfile.TemporaryDirectory(dir=library.parent) as tmp:
        path = Path(tmp) / "qp.c"
        path.write_text(source, encoding="utf-8")
        target = Path(tmp) / library.name
        subprocess.run([*compile_command, "-o", str(target), str(path), *links], check=True, capture_output=True,
                       timeout=600)
        os.replace(target, library)


class NativeQp:
    """The compiled conic with its own buffers: (h, g, a, lba, uba, lbx, ubx) in, x out (one instance per thread).

    ``inputs`` are the arrays the conic reads (the nonzeros of each input's sparsity; x0 and the multipliers' guesses
    stay zero, as the plugin's defaults are): the caller fills them and calls ``solve``."""

    def __init__(self, library: Path, qp: ca.Function) -> None:
        self.fn = CompiledFunction(library, qp.name(), [qp.nnz_out(i) for i in range(qp.n_out())],
                                   [qp.nnz_in(i) for i in range(qp.n_in())])
        self.inputs = {name: np.zeros(qp.nnz_in(i)) for i, name in enumerate(qp.name_in())}
        self.fn.bind(*self.inputs.values())
        self.x = self.fn.outputs[qp.name_out().index("x")]
        self._outputs = [out.ctypes.data for out in self.fn.outputs]

    def solve(self) -> bool:
        """Solve for the inputs' current contents into ``x``; True when HPIPM converged (the plugin's "success")."""
        fn = self.fn
        for i, address in enumerate(self._outputs):  # (the generated code used the pointer array as scratch)
            fn.res[i] = address
        return fn.status_call() == 0


def native_qp(qp: ca.Function) -> tuple[NativeQp | None, str]:
    """(a compiled instance of the conic ``qp``, how) or (None, why it runs as CasADi's plugin)."""
    library, how = qp_library(qp)
    return solve_natively(library, how, qp)


def solve_natively(library: Path | None, how: str, qp: ca.Function) -> tuple[NativeQp | None, str]:
    """(a new instance of ``library``, the conic ``qp`` compiled by ``qp_library``, with buffers of its own; how) or
    (None, why it runs as CasADi's plugin: ``how`` when there is no library)."""
    if library is None:
        return None, how
    try:
        return NativeQp(library, qp), how
    except (OSError, AttributeError) as exc:  # a library that does not load, or lacks the conic's entry points
        return None, f"loading the compiled conic failed ({exc})"
