"""A tiny progress bar on stderr, shown only when stderr is a terminal, and the progress
of blockwise work reported to whoever listens (:func:`reporting`).

The runtime's long loops over blocks (:func:`vsw.runtime.vectorize.run_blocks`: the gait search's
scan, a basin's walks) call :func:`report` with the blocks done; a command that wants a bar
for work deep inside a library call wraps the call in ``with reporting(bar):``, and no
progress argument has to travel through the calls in between.

One command's work is often many blockwise passes (the gait search's scan, then a batch of
walks per Newton iteration): a bar made with ``passes=True`` draws them all on one line,
numbered (``analyze pass 3 [###---] 5/17 blocks``), and ends the line only when closed.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from typing import TextIO

__all__ = ["ProgressBar", "report", "reporting"]

_listener: ContextVar[Callable[[int, int], None] | None] = ContextVar("vsw_progress", default=None)


@contextlib.contextmanager
def reporting(callback: Callable[[int, int], None]) -> Iterator[None]:
    """Send the blockwise work's progress inside the body to ``callback(done, total)``."""
    token = _listener.set(callback)
    try:
        yield
    finally:
        _listener.reset(token)


def report(done: int, total: int) -> None:
    """``done`` of ``total`` units of the current blockwise work (to :func:`reporting`)."""
    listener = _listener.get()
    if listener is not None:
        listener(done, total)


class ProgressBar:
    """Callable progress reporter ``bar(done, total)``; silent unless the stream is a TTY.

    Parameters
    ----------
    label : str
        Text in front of the bar.
    stream : file-like, optional
        Defaults to ``sys.stderr``.
    enabled : bool, optional
        Force on or off; by default on exactly when ``stream.isatty()``.
    width : int
        Bar width in characters.
    min_interval : float
        Seconds between redraws (the last update is always drawn).
    passes : bool
        Count the passes of blockwise work (a pass begins where ``done`` does not grow or
        ``total`` changes) on one line that ends when the bar closes; else each pass is a
        bar of its own line.
    """

    def __init__(
        self,
        label: str,
        stream: TextIO | None = None,
        enabled: bool | None = None,
        width: int = 30,
        min_interval: float = 0.1,
        passes: bool = False,
    ) -> None:
        self.label = label
        self.passes = passes
        self.pass_number = 0
        self._series = (-1, -1)  # the last (done, total): where a pass begins
        self._shown = 0  # characters of the line drawn last
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.width = width
        self.min_interval = min_interval
        self._last_draw = -float("inf")
        self._drawn = False

    def __call__(self, done: int, total: int) -> None:
        """Report ``done`` of ``total`` units of work."""
        if not self.enabled or total <= 0:
            return
        last_done, last_total = self._series
        started = done <= last_done or total != last_total
        self._series = (done, total)
        if started:
            self.pass_number += 1
        now = time.monotonic()
        finished = done >= total
        if not (finished or started) and now - self._last_draw < self.min_interval:
            return
        self._last_draw = now
        fraction = min(max(done / total, 0.0), 1.0)
        filled = round(fraction * self.width)
        bar = "#" * filled + "-" * (self.width - filled)
        if not self.passes:
            self.stream.write(f"\r{self.label} [{bar}] {done}/{total}")
            self._drawn = True
            if finished:
                self.close()
            else:
                self.stream.flush()
            return
        line = f"{self.label} pass {self.pass_number} [{bar}] {done}/{total} blocks"
        self.stream.write(f"\r{line:<{self._shown}}")  # spaces over a longer line before
        self._shown = len(line)
        self._drawn = True
        self.stream.flush()

    def close(self) -> None:
        """End the bar's line (idempotent)."""
        if self.enabled and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False
            self._shown = 0

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
