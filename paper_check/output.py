"""Where the audit and the walkers' reports are written: checked before the work."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from paper_check.figures import FIGURES
from vsw.plots.figures import SAVE_FORMATS

__all__ = ["REPORT_FILES", "check_output_directory"]

REPORT_FILES = ("audit.md", "audit.json")
"""What ``paper_check.report.write_report`` writes; the figures are ``FIGURES`` x formats."""


def check_output_directory(out: str, figures: bool = True) -> str | None:
    """Why the audit cannot be written into ``out``, or None when it can.

    Creates the directory (with parents), writes and removes a temporary file in it, and
    checks every file the audit will write: not a directory, and, where it exists,
    openable for writing (it is opened without truncation and closed). Run before the
    audit so that a bad ``--out`` fails in a moment, not after the whole audit.

    Parameters
    ----------
    out : str
        The ``--out`` argument.
    figures : bool
        Whether the figures will be written too.

    Returns
    -------
    str or None
        A one-line reason.
    """
    if not out.strip():
        return "--out is empty: give a directory (default: reports)"
    path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return f"cannot create output directory {out!r}: {exc.strerror or exc}"
    try:
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        return f"cannot write into output directory {out!r}: {exc.strerror or exc}"
    names = list(REPORT_FILES)
    if figures:
        # Every format save_figure knows, not only those written today: a directory in
        # the way of any of them is worth a message.
        names += [f"{name}.{ext}" for name in FIGURES for ext in SAVE_FORMATS]
    for name in names:
        target = path / name
        if target.is_dir():
            return f"cannot write {str(target)!r}: it is a directory"
        if target.exists():
            try:
                os.close(os.open(target, os.O_WRONLY | os.O_APPEND | os.O_NONBLOCK))
            except OSError as exc:
                return f"cannot write {str(target)!r}: {exc.strerror or exc}"
    return None
