"""The README, the documentation and the code's prose describe the current state only.

History (issue numbers, dates of measurements, commit hashes, CI runs, working sessions)
belongs in CHANGELOG.md alone: elsewhere it ages into wrong statements. This test reads the
prose of README.md, docs/, vsw/, derive/, paper_check/ and benchmarks/ (whole Markdown and
text files; comments and string literals of Python files; comments of C, JavaScript and
HTML files) and refuses the words of a diary. generated/, tests/ and CHANGELOG.md are not
read: the first is derived, the second may date its fixtures, the third is history.
"""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
TREES = ("docs", "vsw", "derive", "paper_check", "benchmarks")
PROSE_SUFFIXES = {".md", ".txt", ".rst"}
COMMENTED_SUFFIXES = {".c", ".h", ".js", ".html", ".pyx"}

# Each pattern names a kind of history; matching is case-insensitive.
PATTERNS: dict[str, re.Pattern[str]] = {
    "issue number": re.compile(r"\bissues?\s+#?\d+\b|(?<![\w&])#\d{1,4}\b(?!\s*[\w.]*\s*=)"),
    "stop number": re.compile(r"\bstop[- ]\d+\b"),
    "date": re.compile(r"\b20\d\d-(?:0[1-9]|1[0-2])-(?:0[1-9]|[12]\d|3[01])\b"),
    "commit": re.compile(
        r"\b(?:commit|commits|at|before|after|of|against|as of)\s+`?[0-9a-f]{7,40}\b`?"
        r"|\b[0-9a-f]{7,40}\b(?=[^.\n]{0,40}\b(?:commit|before|took|the code of)\b)"
    ),
    "session": re.compile(r"\bthis session\b|\bsession \d+\b|\bround \d+\b"),
    "measured on": re.compile(r"\bmeasured (?:on|at) (?:20\d\d|mon|tue|wed|thu|fri|sat|sun)"),
    "CI history": re.compile(
        r"\b(?:a|the|last|latest|previous|earlier|this|that|one)\s+CI\s+runs?\b"
        r"|\bCI (?:did|didn't|failed|passed|took|timed)\b|\bsubmission's CI\b"
    ),
}
PATTERNS = {kind: re.compile(p.pattern, re.IGNORECASE) for kind, p in PATTERNS.items()}

# Commits that are code, not prose: benchmarks/run.py runs an old commit's checkout side by
# side with the current code (benchmarks/pins.py: `DESIGN_BEFORE = "39d527c"`, ...), so each
# pin is a case's input, and results.md, which run.py writes, names the baseline it
# measured. Only the pinned values, and only in those two files, are allowed.
PIN_FILES = ("benchmarks/pins.py", "benchmarks/results.md")
PIN_ASSIGNMENT = re.compile(r'^([A-Z_]+_BEFORE) = "([0-9a-f]{7,40})"$', re.MULTILINE)


def pinned_commits() -> set[str]:
    """The commit pins that benchmarks/pins.py assigns as code."""
    text = (ROOT / "benchmarks" / "pins.py").read_text()
    return {value for _, value in PIN_ASSIGNMENT.findall(text)}


# A hex run needs a digit and a letter to be taken for a hash (words like "deadbeef",
# numbers like "1000000" are not).
HEXLIKE = re.compile(r"^(?=.*\d)(?=.*[a-f])[0-9a-f]{7,40}$")


def _python_prose(text: str) -> list[tuple[int, str]]:
    """The comments and string literals of a Python source, each with its first line."""
    pieces = []
    try:
        for token in tokenize.generate_tokens(io.StringIO(text).readline):
            if token.type in (tokenize.COMMENT, tokenize.STRING):
                pieces.append((token.start[0], token.string))
            elif token.type == getattr(tokenize, "FSTRING_MIDDLE", -1):
                pieces.append((token.start[0], token.string))
    except (tokenize.TokenError, SyntaxError):
        pieces = list(enumerate(text.splitlines(), 1))
    return pieces


def _c_like_prose(text: str) -> list[tuple[int, str]]:
    """The comments of C, JavaScript or HTML: `//`, `/* */`, `<!-- -->`, `#` lines."""
    pieces = []
    comment = re.compile(
        r"//[^\n]*|/\*.*?\*/|<!--.*?-->"
        r"|^\s*#(?!include|define|if|endif|else|pragma|undef|elif)[^\n]*",
        re.S | re.M,
    )
    for match in comment.finditer(text):
        pieces.append((text.count("\n", 0, match.start()) + 1, match.group(0)))
    return pieces


def _files() -> list[Path]:
    files = [ROOT / "README.md"]
    for tree in TREES:
        files += sorted(p for p in (ROOT / tree).rglob("*") if p.is_file())
    return [
        p
        for p in files
        if p.suffix in PROSE_SUFFIXES | COMMENTED_SUFFIXES | {".py"}
        and "__pycache__" not in p.parts
    ]


def _pieces(path: Path) -> list[tuple[int, str]]:
    text = path.read_text(errors="replace")
    if path.suffix == ".py":
        return _python_prose(text)
    if path.suffix in COMMENTED_SUFFIXES:
        return _c_like_prose(text)
    return list(enumerate(text.splitlines(), 1))


def find_offenders(
    path: Path, pieces: list[tuple[int, str]], pins: set[str] = frozenset()
) -> list[str]:
    """Every match of a pattern in `pieces` of `path`, as `path:line: kind: text`; `pins`
    are commits allowed in this file."""
    relative = path.relative_to(ROOT).as_posix() if path.is_relative_to(ROOT) else str(path)
    found = []
    for start, piece in pieces:
        for kind, pattern in PATTERNS.items():
            for match in pattern.finditer(piece):
                text = match.group(0)
                if kind == "commit":
                    hexes = [w for w in re.findall(r"[0-9a-f]{7,40}", text) if HEXLIKE.match(w)]
                    if not hexes or set(hexes) <= pins:
                        continue
                if kind == "issue number" and text.startswith("#"):
                    # `#12` counts only in Markdown and comments, and not as a C directive.
                    if path.suffix == ".py" and not piece.lstrip().startswith("#"):
                        continue
                line = start + piece.count("\n", 0, match.start())
                found.append(f"{relative}:{line}: {kind}: {text!r}")
    return found


def all_offenders() -> list[str]:
    offenders = []
    pins = pinned_commits()
    for path in _files():
        allowed = pins if path.relative_to(ROOT).as_posix() in PIN_FILES else set()
        offenders += find_offenders(path, _pieces(path), allowed)
    return offenders


def test_no_process_words_in_prose() -> None:
    offenders = all_offenders()
    assert offenders == [], f"{len(offenders)} process words:\n" + "\n".join(offenders[:80])


@pytest.mark.parametrize(
    "prose",
    [
        "Fixed in issue 27, see below.",
        "The stop-32 submission's CI did not finish.",
        "Measured on 2026-12-03 on this machine.",
        "the same commands at f0a3f35, before the change",
        "(the code of commit b643206, 5.4x)",
        "as done in this session",
        "In the last CI run it took 30 minutes.",
        "measured on Tuesday",
    ],
)
def test_each_kind_of_history_is_refused(tmp_path: Path, prose: str) -> None:
    path = tmp_path / "page.md"
    assert find_offenders(path, [(1, prose)]) != []


@pytest.mark.parametrize(
    "prose",
    [
        "Garcia et al. 1998 found two gaits; Kuo 2002's model.",
        "sympy==1.14.0 and casadi==3.8.2 are pinned.",
        "the SHA-256 of the file, 64 hex digits",
        "a step costs 21.6 us at rtol 1e-12, 1000000 steps",
        "the wheel's eigenvalue cos^2(2 alpha) to 4.6e-10",
        "stop the run after 20 s; stops at once",
        "The CI command is the second one.",
        "install with the test extras, then run the tests (this is what CI runs)",
        "a colour #0072b2 from the Okabe-Ito palette",
    ],
)
def test_current_state_prose_passes(tmp_path: Path, prose: str) -> None:
    path = tmp_path / "page.md"
    assert find_offenders(path, [(1, prose)]) == []


def test_the_benchmark_pins_are_allowed_where_they_are_code() -> None:
    """The pins are found, allowed in pins.py and results.md, and nowhere else; another hash
    in those files is still refused."""
    pins = pinned_commits()
    assert {"39d527c", "5e02f11", "cc98831"} <= pins
    pins_file = ROOT / "benchmarks" / "pins.py"
    results = ROOT / "benchmarks" / "results.md"
    pinned = [(1, "the same at 5e02f11")]
    assert find_offenders(results, pinned, pins) == []
    assert find_offenders(ROOT / "docs" / "page.md", pinned) != []
    assert find_offenders(
        pins_file, [(1, "# the same commands at f0a3f35, before the change")], pins
    )


def test_readme_is_a_short_guide_with_the_two_commands() -> None:
    """The README stays a guide (at most 200 lines) and keeps the two commands verbatim:
    the main job's, and the tests' that .ci/run runs."""
    readme = (ROOT / "README.md").read_text()
    main_job = "python -m pip install -e . && python -m paper_check"
    tests = 'python -m pip install -e ".[test]" && python -m pytest -q'
    lines = readme.splitlines()
    assert len(lines) <= 200, len(lines)
    assert main_job in lines and tests in lines
    assert tests in (ROOT / ".ci" / "run").read_text().splitlines()
