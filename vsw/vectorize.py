"""Cache-friendly evaluation of generated numpy code over large parameter arrays.

The generated functions are long chains of elementwise numpy operations. On arrays of
10^6 elements every intermediate is an 8 MB temporary that misses the cache and costs
page faults; evaluating in blocks of about 16k elements keeps the temporaries in cache
and is 2-3x faster (benchmarks/run.py, case 4). The operations are elementwise, so the
results equal one whole-array call up to SIMD rounding in the last bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

CHUNK = 16384


def chunked(fn: Callable, *args, chunk: int = CHUNK):
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

    Returns
    -------
    numpy.ndarray or tuple of numpy.ndarray
        Same as ``fn(*args)``, each of the broadcast shape of ``args``.
    """
    arrays = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in args))
    shape = arrays[0].shape
    size = arrays[0].size
    if size <= chunk:
        return _broadcast_result(fn(*arrays), shape)
    flat = [a.reshape(-1) for a in arrays]
    first = fn(*(a[:chunk] for a in flat))
    is_tuple = isinstance(first, tuple)
    parts = list(first) if is_tuple else [first]
    outputs = [np.empty(size) for _ in parts]
    for out, part in zip(outputs, parts):
        out[:chunk] = part
    for start in range(chunk, size, chunk):
        stop = min(start + chunk, size)
        result = fn(*(a[start:stop] for a in flat))
        for out, part in zip(outputs, result if is_tuple else (result,)):
            out[start:stop] = part
    shaped = tuple(out.reshape(shape) for out in outputs)
    return shaped if is_tuple else shaped[0]


def _broadcast_result(result, shape):
    if isinstance(result, tuple):
        return tuple(np.broadcast_to(np.asarray(r, dtype=float), shape).copy() for r in result)
    return np.broadcast_to(np.asarray(result, dtype=float), shape).copy()
