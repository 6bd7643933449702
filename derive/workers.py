"""Forked worker processes bound to the process that starts them.

``python -m derive`` derives models in workers, and one model's printed functions are
printed in workers where it is derived alone (:func:`derive.render.render`). A killed
parent leaves no worker behind.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import threading
import time

__all__ = ["exit_with_parent", "map_in_workers", "spare_cores"]

_PR_SET_PDEATHSIG = 1  # linux/prctl.h


def exit_with_parent(parent: int) -> None:
    """Worker initializer: end this worker when the process that started it ends.

    A killed ``python -m derive`` (SIGKILL, or SIGTERM as ``timeout`` sends) must not
    leave workers deriving on, holding the caller's stdout and stderr. On Linux the kernel
    sends SIGKILL when the parent dies (prctl PR_SET_PDEATHSIG); everywhere, a daemon
    thread also checks the parent every 0.2 s (and catches a parent that died before the
    prctl). Interrupts are the parent's to handle: it terminates the workers.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.2)
        os._exit(1)

    threading.Thread(target=watch, name="derive-parent-watch", daemon=True).start()


def map_in_workers(function, items: list, workers: int) -> list:
    """``[function(item) for item in items]`` in ``workers`` forked processes.

    The workers are terminated at once when the parent is interrupted or terminated (a
    pool's ``shutdown`` would wait for their derivations), and end by themselves when the
    parent is killed (:func:`exit_with_parent`).
    """
    context = multiprocessing.get_context("fork" if os.name == "posix" else "spawn")
    pool = context.Pool(workers, initializer=exit_with_parent, initargs=(os.getpid(),))
    try:
        results = pool.map(function, items, chunksize=1)
    except BaseException:
        pool.terminate()
        pool.join()
        raise
    pool.close()
    pool.join()
    return results


def spare_cores() -> int:
    """The processes this one may fork to share its work: the cores it may run on that the
    machine's other work leaves idle (the one-minute load average, this process counted
    in it), at least 1; 1 inside a worker (a daemonic process has no children) and where
    there is no ``fork``. Work split over processes costs CPU time
    (:func:`derive.render.print_ahead`): it pays only on an idle core."""
    if os.name != "posix" or multiprocessing.current_process().daemon:
        return 1
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cores = cores or 1
    try:
        busy = os.getloadavg()[0]
    except OSError:
        return cores
    return max(1, min(cores, int(cores - busy + 1)))
