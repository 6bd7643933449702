"""BLAS threads within what a command or call was told: :func:`limited`.

numpy and SciPy hand matrix products, solves and eigenvalues to a BLAS (OpenBLAS in their
wheels), which runs a large enough call on a pool of worker threads, one per core by
default; after such a call its idle workers spin for a while before they sleep. A process
told to use N threads (``VSW_THREADS``, the ``threads`` argument of the batch simulator and
the basins) would then bill more than N cores while it walks. Inside :func:`limited` every
BLAS and OpenMP runtime loaded in the process (found by threadpoolctl) runs on at most N
threads, so none wakes more workers than that, and none spins beside the walks; on leaving,
each gets back the setting it had.

The setting is the process's (OpenBLAS has one pool), so nested and concurrent blocks
share it: the smallest N among the blocks in force applies while any of them runs. A BLAS
library loaded after a block began (SciPy's, on its first import) is bounded from the next
block entered, as every entry point that runs walks enters one. Workers that a BLAS call
made before the block woke are not stopped by it: they spin on until their timeout, then
sleep. A fork inside a block (:mod:`vsw.runtime.forked`) shuts OpenBLAS's pool down;
giving it back more than one thread on leaving starts a new worker, which spins about
0.1 s before it sleeps (measured: 0.1 s of CPU per library, none without the fork).

The walks themselves make no BLAS call (vsw/dynamics/csrc, elementwise numpy): the limit bounds the
gait search, the solves and eigenvalues around them, and whatever else the command runs.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["libraries_may_have_loaded", "limited"]

_lock = threading.Lock()
_requests: list[int] = []  # the thread counts of the blocks in force
_libraries: list[Any] = []  # threadpoolctl's controllers of the loaded BLAS and OpenMP
_originals: dict[str, int] = {}  # each library's setting before the first block (by path)
_applied: dict[str, int] = {}  # what this module last set (by path)
_modules_seen = -1  # len(sys.modules) when the libraries were last looked up
_registered = False  # whether threadpoolctl knows RENAMED_OPENBLAS


def _forget_in_child() -> None:
    # A forked child keeps the libraries' settings; a lock held at the fork would stay held.
    global _lock
    _lock = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_in_child)


RENAMED_OPENBLAS = ("libcasadi-tp-openblas",)
"""OpenBLAS builds that wheels ship under names of their own, which threadpoolctl does not
know: CasADi's, which IPOPT's MUMPS calls (its idle workers spinning beside a design of the
compass gait cost the command 0.7 s of system time, against 0.2 s with one thread)."""


def _discover() -> None:
    """Look the loaded BLAS and OpenMP libraries up again when modules were imported since
    (a new extension module may have brought one: SciPy's OpenBLAS with scipy.linalg), or
    when told one may have loaded otherwise (:func:`libraries_may_have_loaded`)."""
    global _libraries, _modules_seen
    if len(sys.modules) == _modules_seen:
        return
    _modules_seen = len(sys.modules)
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:  # not installed: nothing to bound (the runs are the same)
        _libraries = []
        return
    _register_renamed()
    _libraries = list(ThreadpoolController().lib_controllers)


def libraries_may_have_loaded() -> None:
    """The next block looks the loaded libraries up again (about 0.8 ms): call it where one
    may have been loaded without an import (a CasADi plugin, with the solver that needs
    it), so that the blocks after it need not look each time."""
    global _modules_seen
    with _lock:
        _modules_seen = -1


def _register_renamed() -> None:
    """threadpoolctl's OpenBLAS controller for :data:`RENAMED_OPENBLAS`, registered once."""
    global _registered
    if _registered:
        return
    try:
        from threadpoolctl import OpenBLASController, register
    except ImportError:  # a threadpoolctl without custom controllers: numpy's and SciPy's only
        return

    class RenamedOpenBLAS(OpenBLASController):
        internal_api = "openblas_renamed"
        filename_prefixes = RENAMED_OPENBLAS

    register(RenamedOpenBLAS)
    _registered = True


def _settle() -> None:
    """Set every library to the smallest count in force (never above its own setting), or
    give each back its setting when no block is in force. Under ``_lock``."""
    if not _requests:
        for library in _libraries:
            path = library.filepath
            if path in _originals and _applied.get(path) != _originals[path]:
                library.set_num_threads(_originals[path])
        _originals.clear()
        _applied.clear()
        return
    _discover()
    target = min(_requests)
    for library in _libraries:
        path = library.filepath
        if path not in _originals:
            _originals[path] = _applied[path] = library.get_num_threads()
        wanted = min(target, _originals[path])
        if _applied[path] != wanted:
            library.set_num_threads(wanted)
            _applied[path] = wanted


@contextlib.contextmanager
def limited(threads: int) -> Iterator[int]:
    """Every BLAS and OpenMP runtime of the process on at most ``threads`` threads while
    the block runs; yields the count. A library loaded without an import (a CasADi
    plugin) is bounded from the block after :func:`libraries_may_have_loaded`.

    Examples
    --------
    >>> import numpy as np
    >>> with limited(1):
    ...     product = np.ones((500, 500)) @ np.ones((500, 500))  # on the calling thread
    """
    threads = max(1, int(threads))
    try:
        with _lock:
            _requests.append(threads)
            _settle()
        yield threads
    finally:
        with _lock:
            if threads in _requests:  # not when a Ctrl-C came before it was added
                _requests.remove(threads)
            _settle()
