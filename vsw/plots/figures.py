"""Saving figures: the path checked before any work, the bytes the same on every run.

Every figure of the project (the commands' ``--plot``, the audit's, the walkers' reports)
is a ``matplotlib.figure.Figure`` in the style of :mod:`vsw.plots.plotstyle` and is written by
:func:`save_figure`: PNG (at :data:`vsw.plots.plotstyle.PNG_DPI`), SVG or PDF without dates or
version strings and with a fixed SVG hash salt, so the same figure gives the same bytes.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from vsw.plots import plotstyle
from vsw.runtime.errors import VswInputError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["SAVE_FORMATS", "check_save_path", "save_figure"]

SAVE_FORMATS = ("png", "svg", "pdf")


def check_save_path(path: str | Path) -> Path:
    """Validate a figure's path before any work (:func:`check_output_path` for
    :data:`SAVE_FORMATS`)."""
    return check_output_path(path, tuple("." + s for s in SAVE_FORMATS), "plot file")


def check_output_path(path: str | Path, suffixes: tuple[str, ...], kind: str) -> Path:
    """Validate an output path before any work: it can be written as a ``kind`` file.

    Checks a known suffix, an existing parent directory, that the path is not a
    directory, and that the file can be opened for writing (it is opened without
    truncation and closed; a file that did not exist is removed again), so that a
    read-only or virtual file system (``/proc``, ``/sys``) fails here and not after
    the computation.

    Raises
    ------
    VswInputError
        One line naming the path and what is wrong.
    """
    text = str(path)
    if not text.strip():
        raise VswInputError(f"{kind} name is empty: give a path ending in {', '.join(suffixes)}")
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise VswInputError(f"{kind} {text!r} must end in one of {', '.join(suffixes)}")
    parent = path.parent
    if not parent.is_dir():
        raise VswInputError(f"{kind} {text!r}: directory {str(parent)!r} does not exist")
    if path.is_dir():
        raise VswInputError(f"{kind} {text!r} is a directory")
    existed = os.path.lexists(path)
    try:
        # O_NONBLOCK: a FIFO without a reader fails at once instead of blocking.
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_NONBLOCK, 0o666)
    except OSError as exc:
        raise VswInputError(f"{kind} {text!r} cannot be written: {exc.strerror}") from None
    os.close(fd)
    if not existed:
        path.unlink(missing_ok=True)
    return path


def save_figure(fig: Figure, path: str | Path, dpi: int = plotstyle.PNG_DPI) -> Path:
    """Save deterministically (no dates, no software version, fixed SVG ids).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
        Ending in .png, .svg or .pdf in an existing directory; the format follows.
    dpi : int
        PNG resolution (default :data:`vsw.plots.plotstyle.PNG_DPI`); SVG and PDF are vector.

    Returns
    -------
    Path
    """
    path = check_save_path(path)
    fmt = path.suffix.lower().lstrip(".")
    with plotstyle.context():
        plotstyle.settle_layout(fig, dpi=dpi)
        fig.savefig(path, format=fmt, dpi=dpi, metadata=plotstyle.SAVE_METADATA[fmt])
    return path
