"""A command's progress on a terminal: one line whose passes of blockwise work are
numbered in order, not a bar of its own line per pass, each restarting at 0."""

from __future__ import annotations

import contextlib
import io
import itertools
import re

from vsw.cli import main
from vsw.runtime.progress import ProgressBar

DRAWN = re.compile(r"^(\w+) pass (\d+) \[[#-]+\] (\d+)/(\d+) blocks *$")


class Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def _drawn(text: str) -> list[tuple[str, int, int, int]]:
    """Every drawing of the bar: its label, pass, done and total."""
    out = []
    for piece in text.rstrip("\n").split("\r")[1:]:
        match = DRAWN.match(piece)
        assert match, repr(piece)
        out.append((match[1], int(match[2]), int(match[3]), int(match[4])))
    return out


def test_passes_are_numbered_on_one_line():
    stream = Tty()
    with ProgressBar("work", stream=stream, min_interval=0, passes=True) as bar:
        for total in (3, 3, 5):
            for done in range(1, total + 1):
                bar(done, total)
    text = stream.getvalue()
    assert text.count("\n") == 1 and text.endswith("\n")
    drawn = _drawn(text)
    assert [p for _, p, _, _ in drawn] == [1, 1, 1, 2, 2, 2, 3, 3, 3, 3, 3]
    assert drawn[-1] == ("work", 3, 5, 5)
    # a shorter drawing covers the longer one before it with spaces
    pieces = text.rstrip("\n").split("\r")[1:]
    assert all(len(b) >= len(a.rstrip()) for a, b in itertools.pairwise(pieces))


def test_analyze_shows_one_line_of_numbered_passes(monkeypatch):
    """`vsw analyze` of an engine model (a scan, then batches of Newton's walks): every
    drawing on one line, the pass numbers never going back, each pass's count growing."""
    # A search of its own: none kept on disk, and a slope no other test searches at (a
    # model keeps its searches in the process).
    monkeypatch.setenv("VSW_SEARCH_CACHE", "0")
    err, out = Tty(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        assert main(["analyze", "--model", "rimless-wheel", "--param", "gamma=0.0812"]) == 0
    text = err.getvalue()
    assert text.count("\n") == 1, text
    drawn = _drawn(text)
    assert {label for label, *_ in drawn} == {"analyze"}
    passes = [p for _, p, _, _ in drawn]
    assert passes == sorted(passes) and passes[-1] > 1 and passes[0] == 1
    for (_, p0, d0, t0), (_, p1, d1, t1) in itertools.pairwise(drawn):
        assert p1 == p0 + 1 or (p1 == p0 and d1 > d0 and t1 == t0)
