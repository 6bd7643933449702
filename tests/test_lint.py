"""The code base stays ruff-clean (lint and format); generated/ is excluded in pyproject.toml."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize("command", [["check"], ["format", "--check"]])
def test_ruff(command):
    ruff = shutil.which("ruff")
    base = [ruff] if ruff else [sys.executable, "-m", "ruff"]
    done = subprocess.run([*base, *command, "."], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


def test_no_named_unicode_escapes_in_the_runtime():
    """No ``\\N{...}`` escape in vsw/ or paper_check/: compiling one imports unicodedata, and
    a Ctrl-C landing in that import while `vsw` starts (bytecode not cached) turns into a
    SyntaxError with a traceback instead of "vsw: interrupted" (seen in CI: "\\N escapes not
    supported (can't load unicodedata module)"). ``\\uXXXX`` escapes need no module."""
    offenders = [
        f"{path.relative_to(ROOT)}:{number}"
        for folder in ("vsw", "paper_check")
        for path in sorted((ROOT / folder).rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if "\\N{" in line
    ]
    assert offenders == []
