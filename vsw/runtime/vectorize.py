"""Cache-friendly, multi-threaded evaluation of generated numpy code over large arrays.

The generated functions are long chains of elementwise numpy operations. On arrays of
10^6 elements every intermediate is an 8 MB temporary that misses the cache and costs
page faults; evaluating in blocks of about 16k elements keeps the temporaries in cache
and is 2-3x faster (benchmarks/run.py, case 4). numpy releases the GIL inside each
operation, so blocks also run in parallel on threads (``VSW_THREADS``, default: every
core). The operations are elementwise and the blocks are fixed, so the results do not
depend on the number of threads: they equal one whole-array call up to SIMD rounding in
the last bit.
"""

from __future__ import annotations

import contextvars
import os
import threading
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

from vsw.runtime import blas, progress, stop
from vsw.runtime.threads import default_threads

CHUNK = 16384


def _raise_glibc_malloc_thresholds() -> None:
    # glibc returns freed memory above 128 KiB at the top of the heap to the OS, and serves
    # requests from 128 KiB up with fresh mmap()s, until the process first frees a large
    # mmap()ed block: then it raises both thresholds to that block's size (mallopt(3),
    # "dynamic mmap threshold"). Until that happens, every temporary of a block is
    # page-faulted in anew: a cold 1000 x 1000 basin took 2.0 s against 0.63 s warm (timed
    # by hand once; benchmarks/run.py case 5 times the first call). Allocating
    # and freeing one untouched 4 MiB array performs that first free up front; elsewhere
    # it is a no-op.
    np.empty(4 * 1024 * 1024 // 8)


_raise_glibc_malloc_thresholds()

_pools: dict[int, ThreadPoolExecutor] = {}
_pools_lock = threading.Lock()
_worker = threading.local()


def _forget_pools_in_child() -> None:
    # A forked child inherits the pools' bookkeeping but not their threads.
    global _pools_lock
    _pools.clear()
    _pools_lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pools_in_child)


def _executor(threads: int) -> ThreadPoolExecutor:
    # One pool per size, never shut down: callers on several threads may share them.
    with _pools_lock:
        pool = _pools.get(threads)
        if pool is None:
            pool = _pools[threads] = ThreadPoolExecutor(threads, thread_name_prefix="vsw-block")
        return pool


def run_blocks(block: Callable[[int], None], starts: Sequence[int], threads: int) -> None:
    """Call ``block(start)`` for every start, on ``threads`` worker threads when > 1.

    Each call runs in a copy of the caller's context, so ``np.errstate`` and other context
    variables apply inside the workers as in the caller. A call made from inside a worker
    (a block function that itself evaluates blockwise) runs serially, so nested use cannot
    exhaust the pool and deadlock. The first exception is raised in the caller once no
    block is running any more: none writes into the caller's arrays after this returns.
    A stop (Ctrl-C, the run-time limit: :mod:`vsw.runtime.stop`) is raised between blocks; the
    blocks not started then are cancelled. Under :func:`vsw.runtime.stop.supervised` the main
    thread never runs a block itself, so that it waits where signals reach it (a block in
    C holds it for as long as the block takes).
    """
    in_worker = getattr(_worker, "active", False)
    offload = stop.supervising() and threading.current_thread() is threading.main_thread()
    if in_worker or (not offload and (threads <= 1 or len(starts) < 2)):
        for done, start in enumerate(starts, 1):
            stop.check()
            block(start)
            if not in_worker and len(starts) > 1:
                progress.report(done, len(starts))
        return

    def task(start: int) -> None:
        _worker.active = True
        try:
            block(start)
        finally:
            _worker.active = False

    pool = _executor(max(1, threads))
    futures = [pool.submit(contextvars.copy_context().run, task, s) for s in starts]
    try:
        for done, future in enumerate(futures, 1):
            future.result()
            stop.check()
            if len(futures) > 1:
                progress.report(done, len(futures))
    finally:
        for future in futures:
            future.cancel()
        wait(futures)


def chunked(
    fn: Callable,
    *args,
    chunk: int = CHUNK,
    threads: int | None = None,
    out: tuple[np.ndarray, ...] | np.ndarray | None = None,
):
    """Evaluate ``fn(*args)`` blockwise over the broadcast shape of ``args``.

    Parameters
    ----------
    fn : callable
        A generated function (or any elementwise function) returning an array or a
        tuple of arrays.
    *args : array_like
        Broadcastable arguments.
    chunk : int
        Block length.
    threads : int, optional
        Blocks evaluated in parallel; default :func:`default_threads`. 1 runs in the
        calling thread.
    out : numpy.ndarray or tuple of numpy.ndarray, optional
        Float arrays of the broadcast shape to write the results into (one per result),
        e.g. reused across calls: fresh result arrays cost page faults, 10-20 ms for
        eleven arrays of 10^6 doubles (benchmarks/run.py, case 1, fresh against reused).

    Returns
    -------
    numpy.ndarray or tuple of numpy.ndarray
        Same as ``fn(*args)``, each of the broadcast shape of ``args``.

    Examples
    --------
    >>> import numpy as np
    >>> from generated import ile
    >>> q = chunked(ile.q_fixed, np.full(40000, 0.8), 0.0, np.pi / 4)
    >>> q.shape, bool(np.all(q == ile.q_fixed(0.8, 0.0, np.pi / 4)))
    ((40000,), True)
    """
    threads = default_threads() if threads is None else threads
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    shape = arrays[0].shape
    size = arrays[0].size
    if size <= chunk and out is None:
        return _broadcast_result(fn(*arrays), shape)
    flat = [np.ascontiguousarray(a).reshape(-1) for a in arrays]
    first = fn(*(a[:chunk] for a in flat))
    is_tuple = isinstance(first, tuple)
    parts = list(first) if is_tuple else [first]
    if out is None:
        outputs = [np.empty(size) for _ in parts]
    else:
        given = out if isinstance(out, tuple) else (out,)
        if len(given) != len(parts) or any(
            o.shape != shape or o.dtype != float or not o.flags.c_contiguous for o in given
        ):
            raise ValueError(f"out must be {len(parts)} C-contiguous float arrays of shape {shape}")
        outputs = [o.reshape(-1) for o in given]
    for target, part in zip(outputs, parts):
        target[:chunk] = part

    def block(start: int) -> None:
        stop = min(start + chunk, size)
        result = fn(*(a[start:stop] for a in flat))
        for target, part in zip(outputs, result if is_tuple else (result,)):
            target[start:stop] = part

    with blas.limited(threads):
        run_blocks(block, range(chunk, size, chunk), threads)
    if out is not None:
        return out
    shaped = tuple(target.reshape(shape) for target in outputs)
    return shaped if is_tuple else shaped[0]


def _broadcast_result(result, shape):
    if isinstance(result, tuple):
        return tuple(np.broadcast_to(np.asarray(r, dtype=float), shape).copy() for r in result)
    return np.broadcast_to(np.asarray(result, dtype=float), shape).copy()
