"""Stopping a run: Ctrl-C and the run-time limit, whatever library is running.

Python raises KeyboardInterrupt from its SIGINT handler, but CasADi calls Python's signal
check inside its solvers and turns that exception into a plain RuntimeError ("rhs
failed: KeyboardInterrupt"), which code that maps solver failures to results takes for a
failed start: an interrupted gait search used to finish with exit 0 and a gait missing.
So a command runs under :func:`supervised`, whose handlers *record* why the run stops
before they raise, and :func:`check` raises the recorded stop again. The runtime calls
:func:`check` in its loops (the gait search, continuation, walks, the batch simulator's
blocks) and wherever it turns a library's error into a result; the CLI calls it once more
before it reports success, so no library can turn a stop into a result.

The run-time limit (``VSW_MAX_SECONDS``, :func:`vsw.runtime.limits.max_seconds`) is checked before
work starts, from estimates, and enforced while it runs: :func:`supervised` arms a timer
(SIGALRM) for the limit, and :func:`check` compares the clock with it, so the run stops
within about one block of work (a batch of walks, one orbit solve) after the limit with
:class:`RunTimeLimitError`. Any positive limit is accepted, up to ``1e308`` and ``inf``: the
system's timer holds at most about 9.2e9 s (2**63 ns), so a limit beyond
:data:`TIMER_MAX_SECONDS` (about 31 years) arms no timer, which for any real run is the
same as no limit (:func:`check` still compares the clock with it).

Compiled code cannot raise: the batch simulator's C library registers hooks
(:func:`register`) that tell its walks in progress to end, called when a stop is
recorded; and under :func:`supervised`, :func:`vsw.runtime.vectorize.run_blocks` runs even one
block on a worker thread, so that the main thread, where Python runs signal handlers,
waits interruptibly instead of sitting inside C.

Outside :func:`supervised` (the library used from Python) nothing is installed: Python's
own Ctrl-C applies, and :func:`check` raises only a stop recorded by a handler.
"""

from __future__ import annotations

import contextlib
import math
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator

from vsw.runtime.errors import VswInputError

__all__ = [
    "RunTimeLimitError",
    "check",
    "interrupt_unless_settled",
    "reason",
    "register",
    "settle",
    "supervised",
    "supervising",
]


class RunTimeLimitError(VswInputError):
    """The run went past the run-time limit (``VSW_MAX_SECONDS``) and was stopped."""


_lock = threading.RLock()  # reentrant: a signal handler may run while it is held
_state: dict[str, float | str | None] = {"stop": None, "deadline": None, "limit": None}
_started = time.monotonic()
_supervising = False
_closing = threading.Event()
_settled = threading.Event()
_hooks: list[tuple[Callable[[], None], Callable[[], None]]] = []


def register(on_stop: Callable[[], None], on_reset: Callable[[], None]) -> None:
    """Call ``on_stop()`` when a stop is recorded (from a signal handler or a thread) and
    ``on_reset()`` when the supervised run ends: compiled code's own stop flag."""
    with _lock:
        _hooks.append((on_stop, on_reset))


def settle() -> None:
    """The command's outcome is decided: its output written, or its error said. A Ctrl-C
    from now on is late: the run's handler ignores it, and so does the ``vsw`` program's
    own (:func:`interrupt_unless_settled`) while the process exits, so that the user gets
    the whole result with its exit status, never a result and then a signal's death."""
    _settled.set()


def interrupt_unless_settled(signum, frame) -> None:
    """The ``vsw`` program's SIGINT handler outside a command's run (parsing before it,
    exiting after it): one line and exit 130 before the outcome is settled, nothing
    after. Installed for good: the process ends with the command."""
    if _settled.is_set():
        return
    _settled.set()  # said once: a second Ctrl-C while this one ends the program is late
    sys.stderr.write("vsw: interrupted\n")
    raise SystemExit(130)


def supervising() -> bool:
    """Whether a command runs under :func:`supervised`."""
    return _supervising


def _limit_error() -> RunTimeLimitError:
    limit = float(_state["limit"] or math.inf)
    return RunTimeLimitError(
        f"stopped after {time.monotonic() - _started:.3g} s, past the run-time limit of "
        f"{limit:g} s (VSW_MAX_SECONDS); ask for less work, or raise the limit with "
        "VSW_MAX_SECONDS (in seconds, inf for none)"
    )


def _stop_error(stop: str) -> BaseException:
    return KeyboardInterrupt() if stop == "interrupt" else _limit_error()


def _raise(stop: str) -> None:
    raise _stop_error(stop)


def _record(stop: str) -> None:
    with _lock:
        if _state["stop"] is not None:  # the first reason wins: an interrupt after the
            return  # limit still reports the limit it stopped for
        _state["stop"] = stop
        hooks = list(_hooks)
    for on_stop, _ in hooks:
        on_stop()


def reason() -> str | None:
    """Why the run is stopping: ``"interrupt"``, ``"limit"`` or None (it is not)."""
    return _state["stop"]  # type: ignore[return-value]


def check() -> None:
    """Raise the recorded stop (KeyboardInterrupt, or :class:`RunTimeLimitError`), if any,
    or the limit's error when the deadline has passed; else return at once (~0.2 us)."""
    stop = _state["stop"]
    if stop is None:
        deadline = _state["deadline"]
        if deadline is None or time.monotonic() <= deadline:  # type: ignore[operator]
            return
        _record("limit")
        stop = _state["stop"]
    _raise(stop)  # type: ignore[arg-type]


def _on_interrupt(signum, frame) -> None:
    if _settled.is_set():  # late: the result is out (settle)
        return
    _record("interrupt")
    raise KeyboardInterrupt


def _on_alarm(signum, frame) -> None:
    if _closing.is_set():  # the run is over: its limit no longer applies
        return
    _record("limit")
    _raise(_state["stop"])  # type: ignore[arg-type]


@contextlib.contextmanager
def supervised(seconds: float = math.inf) -> Iterator[None]:
    """Run the body with Ctrl-C and a run-time limit of ``seconds`` that no library can
    swallow (module docstring). Installed only in the main thread (where Python runs
    signal handlers); the previous handlers and timer are restored on exit.
    """
    global _started, _supervising
    _settled.clear()
    with _lock:
        _state.update(stop=None, limit=seconds)
        _started = time.monotonic()
        _state["deadline"] = _started + seconds if math.isfinite(seconds) else None
    if threading.current_thread() is not threading.main_thread():
        try:
            with _stops_kept():
                yield
        finally:
            _reset()
        return
    _supervising = True
    _closing.clear()
    previous_int = signal.signal(signal.SIGINT, _on_interrupt)
    previous_alarm = signal.signal(signal.SIGALRM, _on_alarm)
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _quiet_stops(previous_hook)
    try:
        # Armed inside the try: a tiny limit fires at once, and the handlers are still
        # restored below.
        if seconds <= TIMER_MAX_SECONDS:
            # Then again every _REPEAT s: a stop raised where Python cannot propagate it
            # (a finalizer, a weakref callback) is raised again at the next tick.
            signal.setitimer(signal.ITIMER_REAL, seconds, _REPEAT)
        with _stops_kept():
            yield
    finally:
        _closing.set()  # a timer's signal still pending now is ignored (_on_alarm)
        try:
            signal.setitimer(signal.ITIMER_REAL, 0)
        finally:
            signal.signal(signal.SIGALRM, previous_alarm)
            signal.signal(signal.SIGINT, previous_int)
            sys.unraisablehook = previous_hook
            _supervising = False
            _reset()


@contextlib.contextmanager
def _stops_kept() -> Iterator[None]:
    """Raise the recorded stop in place of whatever error the body ends with.

    A library that catches the stop on its way out and raises an error of its own ends
    the body with that error: matplotlib's mathtext turns any ValueError raised while it
    looks a glyph up (RunTimeLimitError is one) into "Unknown symbol", which would reach
    the user as a traceback instead of the limit's one line."""
    try:
        yield
    except BaseException as exc:
        stopped = _state["stop"]
        if stopped is None:
            raise
        recorded = _stop_error(stopped)  # type: ignore[arg-type]
        if isinstance(exc, type(recorded)):
            raise
        raise recorded from exc


TIMER_MAX_SECONDS = 1e9
"""The longest limit the timer is armed for: beyond it (the timer itself overflows past
about 9.2e9 s) no run lasts that long, and no timer is armed (module docstring)."""

_REPEAT = 0.25
"""Seconds between the limit's signals once it has passed (see :func:`supervised`)."""


def _quiet_stops(previous: Callable) -> Callable:
    """``sys.unraisablehook`` while supervised: a recorded stop that surfaced where Python
    can only print it (\"Exception ignored in ...\") is not printed; :func:`check` and the
    repeating timer raise it again where it propagates."""

    def hook(unraisable) -> None:
        stopping = isinstance(unraisable.exc_value, (KeyboardInterrupt, RunTimeLimitError))
        if stopping and _state["stop"] is not None:
            return
        previous(unraisable)

    return hook


def _reset() -> None:
    with _lock:
        _state.update(stop=None, deadline=None, limit=None)
        hooks = list(_hooks)
    for _, on_reset in hooks:
        on_reset()
