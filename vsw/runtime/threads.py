"""The threads a process may use: ``VSW_THREADS``, read in one place
(:func:`default_threads`), and the BLAS pools sized by it from their start
(:func:`size_blas_pools`).

Imports no numpy: the command line sizes the pools before numpy loads.
"""

from __future__ import annotations

import os

from vsw.runtime.errors import VswInputError

__all__ = ["BLAS_VARIABLES", "MAX_THREADS", "default_threads", "size_blas_pools"]

MAX_THREADS = 256
"""Largest accepted ``VSW_THREADS`` (more threads than blocks or cores only cost memory)."""

BLAS_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
"""The variables that size the BLAS and OpenMP runtimes' pools when they load."""


def default_threads() -> int:
    """Worker threads for block evaluation: ``VSW_THREADS`` if set, else the usable cores.

    The one reading of ``VSW_THREADS``: every entry point that evaluates blockwise
    (``vsw.runtime.vectorize.chunked``, ``vsw.models.ile.analysis.analyze``,
    ``vsw.models.ile.basin.basin``, the CLI) calls it before any work, whatever the size
    of its input, so an invalid setting is rejected the same way everywhere, not only by
    calls large enough to use threads.

    Raises
    ------
    VswInputError
        ``VSW_THREADS`` is set but not an integer from 1 to :data:`MAX_THREADS`.
    """
    setting = os.environ.get("VSW_THREADS", "")
    if setting.strip():
        try:
            threads = int(setting)
        except ValueError:
            threads = 0
        if not 1 <= threads <= MAX_THREADS:
            raise VswInputError(
                f"VSW_THREADS must be a positive integer (at most {MAX_THREADS}), got {setting!r}"
            )
        return threads
    try:
        cores = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        cores = os.cpu_count() or 1
    return max(1, min(cores, 16))


def size_blas_pools() -> None:
    """Where ``VSW_THREADS`` is set and none of :data:`BLAS_VARIABLES` is, each of them is
    set to it, so the pools start at that size. A bound set once a BLAS has loaded
    (:func:`vsw.runtime.blas.limited`) keeps later calls to it, but the workers the pool
    made when it loaded have already run: numpy's OpenBLAS keeps one a core busy while it
    starts, a second core's worth of time billed by every command told ``VSW_THREADS=1``.
    Call before numpy is imported. An invalid setting is left to :func:`default_threads`,
    which each command calls first and which rejects it in one line."""
    if not os.environ.get("VSW_THREADS", "").strip():
        return
    if any(name in os.environ for name in BLAS_VARIABLES):
        return  # the user's: OpenBLAS reads its own variable before OMP_NUM_THREADS
    try:
        threads = default_threads()
    except VswInputError:
        return
    for name in BLAS_VARIABLES:
        os.environ[name] = str(threads)
