"""Compiled batch kernels: the generated C loops of ``generated/ile/c/ile_batch.c`` via ctypes.

``python -m derive`` writes vectorisable C loops for a few quantities from the same
derivation as the numpy and CasADi code. At first use they are compiled for this machine
(``-O3 -march=native -fopenmp-simd``, glibc's vector libm when present) into the verified
cache of :mod:`vsw.dynamics.compiled`. Without a compiler, or with ``VSW_KERNELS=0``, every
function here falls back to the generated numpy code, so results never depend on a
compiler being present, only their last bits do (tests/test_kernels.py bounds the
difference to 1e-12 relative on walking sets, 1e-11 over the domain).

Each block of the loop is one ctypes call, which releases the GIL: blocks run in parallel
on :func:`vsw.runtime.vectorize.run_blocks`. benchmarks/run.py, case 1, measures it.

Examples
--------
>>> import numpy as np
>>> q_f, eigenvalue, *margins = fixed_point_conditions(np.full(3, 0.8), 0.0, np.pi / 4)
>>> [round(float(v), 9) for v in q_f]
[0.465196423, 0.465196423, 0.465196423]
"""

from __future__ import annotations

import ctypes
import os
import threading
from pathlib import Path

import numpy as np

import generated
from generated import ile
from vsw.dynamics.compiled import build_library
from vsw.runtime.threads import default_threads
from vsw.runtime.vectorize import CHUNK, chunked, run_blocks

SOURCE = Path(generated.__file__).resolve().parent / "ile" / "c" / "ile_batch.c"
N_OUTPUTS = 2 + len(ile.CONDITIONS)

# Tried in order: vectorised with glibc's libmvec, then plain optimised C.
_FLAG_SETS = (
    ["-O3", "-march=native", "-fno-math-errno", "-fopenmp-simd", "-lmvec", "-lm"],
    ["-O3", "-fno-math-errno", "-lm"],
)

_lock = threading.Lock()
_library: ctypes.CDLL | None = None
_tried = False
build_error: str | None = None
"""Why the kernels are not available (None while they are, or before the first use)."""
library_path: Path | None = None
"""The cached library in use (None while the kernels are unavailable or not yet built)."""


def _build() -> tuple[ctypes.CDLL, Path]:
    return build_library(SOURCE.read_bytes(), "ile_batch", _FLAG_SETS)


def library() -> ctypes.CDLL | None:
    """The compiled kernels, built on first call; None when unavailable (see build_error)."""
    global _library, _tried, build_error, library_path
    if os.environ.get("VSW_KERNELS", "1").strip() == "0":
        return None
    with _lock:
        if not _tried:
            _tried = True
            try:
                lib, path = _build()
                fn = lib.vsw_ile_fixed_point_conditions_batch
                fn.restype = None
                pointer = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
                fn.argtypes = [ctypes.c_longlong, pointer, pointer, pointer, pointer]
                _library, library_path = lib, path
            except (OSError, AttributeError) as exc:
                build_error = f"compiled kernels unavailable, using numpy: {exc}"
        return _library


def fixed_point_conditions(
    beta, theta_II, phi0, *, threads: int | None = None
) -> tuple[np.ndarray, ...]:
    """q^f, eigenvalue and every condition margin, as ``generated.ile.fixed_point_conditions``.

    Eq. (10), (19), (12)-(17). Compiled C when available, else the generated numpy code.

    Parameters
    ----------
    beta, theta_II, phi0 : float or array_like
        Broadcastable parameters (radians), shape ``S`` after broadcasting.
    threads : int, optional
        Blocks in parallel; default :func:`vsw.runtime.threads.default_threads`.

    Returns
    -------
    tuple of numpy.ndarray
        ``(q_f, eigenvalue, *margins)`` in the order of ``ile.CONDITIONS``, each of shape
        ``S``.
    """
    # VSW_THREADS is checked whatever the size, as by every blockwise entry point.
    threads = default_threads() if threads is None else threads
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (beta, theta_II, phi0)))
    shape = arrays[0].shape
    lib = library()
    if lib is None:
        with np.errstate(all="ignore"):
            return chunked(ile.fixed_point_conditions, *arrays, threads=threads)
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrays]
    n = flat[0].size
    out = np.empty((N_OUTPUTS, n))
    fn = lib.vsw_ile_fixed_point_conditions_batch

    def block(start: int) -> None:
        stop = min(start + CHUNK, n)
        part = np.empty((N_OUTPUTS, stop - start))
        fn(stop - start, *(a[start:stop] for a in flat), part)
        out[:, start:stop] = part

    if n > 0:
        if n <= CHUNK:
            fn(n, *flat, out)
        else:
            run_blocks(block, range(0, n, CHUNK), threads)
    return tuple(row.reshape(shape) for row in out)
