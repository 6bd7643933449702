"""Independent work on several cores without threads: :func:`split_map`.

A CasADi solver holds Python's lock while it runs, so threads cannot share its work; a
forked child can, and inherits what the parent built (an NLP whose construction costs more
than a solve) without rebuilding it. :func:`split_map` runs ``function`` over ``items`` in
``workers`` processes (the calling one and ``workers - 1`` forked children), each taking
the next item not yet taken when it is free (the items' indices wait in a pipe; a read of
four bytes takes one), so a long item does not hold the others back. Each child's results
are pickled back through a pipe of its own; the results come in the order of ``items``,
the outcome a loop gives. Where a child fails (a crash, an error, no result), the items it
took are run again in the calling process: a failed child costs the time it ran, never a
result. A child that delivered its results is not waited for (its exit, unmapping a large
process, takes milliseconds): it is reaped by a later call, or as the process ends.

Serial (a plain loop) where there is one worker or one item, inside a child of
``split_map`` (an item that calls it again), where the platform has no ``fork`` (or is
not Linux: forking a process with threads is unsafe on macOS), off the main thread, or for
more items than the pipe holds at once. Ctrl-C and the run-time limit
(:mod:`vsw.runtime.stop`) reach the calling process, which kills its children before the
stop propagates (a child ignores SIGINT, and timers do not survive a fork); a child never
runs the parent's exit handlers (it leaves by ``os._exit``).

Imports: the standard library only.
"""

from __future__ import annotations

import atexit
import os
import pickle
import signal
import struct
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from typing import Any

__all__ = ["split_map"]

_INDEX = struct.Struct("<I")
_STOPS = {signal.SIGINT, signal.SIGALRM}  # Ctrl-C and the run-time limit (vsw.runtime.stop)
_MAX_ITEMS = 1024  # 4 KiB of indices: written before any reader, within a pipe's buffer
_in_child = False  # whether this process is a child of split_map
_exiting: list[int] = []  # children that delivered their results and are exiting: reaped later


def split_map(function: Callable[[Any], Any], items: Sequence[Any], workers: int) -> list[Any]:
    """``[function(item) for item in items]`` on ``workers`` processes (see the module
    docstring)."""
    workers = max(1, min(int(workers), len(items)))
    _reap_exited()
    if workers == 1 or len(items) > _MAX_ITEMS or not _can_fork():
        return [function(item) for item in items]
    tasks, tasks_in = os.pipe()
    os.write(tasks_in, b"".join(_INDEX.pack(i) for i in range(len(items))))
    os.close(tasks_in)
    children: list[tuple[int, int]] = []
    try:
        # A stop between a fork and its record would leave that child to run on.
        held = signal.pthread_sigmask(signal.SIG_BLOCK, _STOPS)
        try:
            for _ in range(workers - 1):
                children.append(_spawn(function, items, tasks))
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, held)
        results = dict(_work(function, items, tasks))
        for pid, results_out in children:
            delivered = _collect(pid, results_out)
            if delivered is not None:
                results.update(delivered)
                _exiting.append(pid)
        for i in range(len(items)):
            if i not in results:  # taken by a child that failed: here
                results[i] = function(items[i])
        return [results[i] for i in range(len(items))]
    finally:
        os.close(tasks)
        for pid, results_out in children:
            _end(pid, results_out)


def _can_fork() -> bool:
    # Not from a child: its own children would outlive a stop (it ignores SIGINT and is
    # killed without cleanup), and the cores are busy already.
    return (not _in_child and sys.platform.startswith("linux") and hasattr(os, "fork")
            and threading.current_thread() is threading.main_thread())  # fmt: skip


def _work(function: Callable, items: Sequence, tasks: int) -> Iterator[tuple[int, Any]]:
    """(index, result) of each item this process takes from the pipe of indices."""
    while len(data := os.read(tasks, _INDEX.size)) == _INDEX.size:
        (i,) = _INDEX.unpack(data)
        yield i, function(items[i])


def _spawn(function: Callable, items: Sequence, tasks: int) -> tuple[int, int]:
    results_in, results_out = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: its items, pickled to its pipe, then out without cleanup
        global _in_child
        _in_child = True
        code = 1
        try:
            os.close(results_in)
            # A Ctrl-C is the parent's to handle: it kills this child.
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOPS)
            payload = pickle.dumps(dict(_work(function, items, tasks)))
            with os.fdopen(results_out, "wb") as pipe:
                pipe.write(payload)
            code = 0
        except BaseException:  # any failure: the parent runs the items this one took
            pass
        finally:
            os._exit(code)
    os.close(results_out)
    return pid, results_in


def _collect(pid: int, results_in: int) -> dict[int, Any] | None:
    """A child's results by index, once its pipe closes; None where it failed or crashed
    (then it is reaped here). A child that delivered is not waited for: it exits on its
    own, and unmapping a large process takes milliseconds (:func:`_reap_exited`)."""
    chunks = []
    while chunk := os.read(results_in, 1 << 20):
        chunks.append(chunk)
    try:
        # Written whole only after the child's last item: a complete payload is a success.
        return pickle.loads(b"".join(chunks)) if chunks else _failed(pid)
    except Exception:  # a truncated payload: the parent runs these items
        return _failed(pid)


def _failed(pid: int) -> None:
    """Reap a child that delivered nothing."""
    try:
        os.waitpid(pid, 0)
    except ChildProcessError:
        pass


def _reap_exited(wait: bool = False) -> None:
    """Reap the children that delivered their results and have exited since (with
    ``wait``: all of them, as the process ends, so that none outlives it). Only the main
    thread of the process that forked them: calls from other threads run as loops and
    leave the list to it (two reapers of one pid would both remove it)."""
    if _in_child or threading.current_thread() is not threading.main_thread():
        return
    for pid in list(_exiting):
        try:
            if os.waitpid(pid, 0 if wait else os.WNOHANG)[0] == 0:
                continue  # still exiting
        except ChildProcessError:
            pass
        _exiting.remove(pid)


atexit.register(_reap_exited, wait=True)  # a child leaves by os._exit: never runs this


def _end(pid: int, results_in: int) -> None:
    """The child killed where it still runs (the parent is stopping), and reaped; one that
    delivered is left to exit."""
    try:
        os.close(results_in)
    except OSError:
        pass
    if pid in _exiting:
        return
    try:
        if os.waitpid(pid, os.WNOHANG) == (0, 0):
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
    except ChildProcessError:
        pass  # reaped by _failed
