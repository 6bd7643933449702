"""Every path of the repository that the documentation or paper_check's reports cite
exists: the pages under docs/ and the text paper_check writes into its reports (its
sources' strings: the reports are written, not committed)."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# A placeholder stands for a family of paths: generated/<model>/, reports/walkers/NAME.md.
PLACEHOLDER = re.compile(r"[<>*{}@]|NAME")


def _top_directories() -> list[str]:
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()  # fmt: skip
    return sorted({f.split("/")[0] for f in files if "/" in f and not f.startswith(".")})


def cited_paths(text: str, tops: list[str]) -> list[str]:
    """Paths under a tracked top-level directory in ``text`` (not part of a longer path or
    a URL), without trailing punctuation, placeholders left out."""
    tops_alternatives = "|".join(map(re.escape, tops))
    pattern = re.compile(rf"(?<![\w./~-])((?:{tops_alternatives})/[\w./{{}}<>*@-]*)")
    paths = (m.group(1).rstrip(".,:;)") for m in pattern.finditer(text))
    return [p for p in paths if not PLACEHOLDER.search(p)]


SOURCES = sorted((ROOT / "docs").rglob("*.md")) + sorted((ROOT / "paper_check").glob("*.py"))


def test_the_scan_finds_a_missing_path():
    tops = _top_directories()
    text = "the simulation (`vsw/simulate.py`), the derivation (derive/models/ile/)."
    assert cited_paths(text, tops) == ["vsw/simulate.py", "derive/models/ile/"]
    assert not (ROOT / "vsw" / "simulate.py").exists()
    assert cited_paths("generated/<model>/js and https://x.org/vsw/a.py", tops) == []


@pytest.mark.parametrize("source", SOURCES, ids=[str(s.relative_to(ROOT)) for s in SOURCES])
def test_every_cited_path_exists(source: Path):
    missing = [p for p in cited_paths(source.read_text(), _top_directories())
               if not (ROOT / p).exists()]  # fmt: skip
    assert missing == [], f"{source.relative_to(ROOT)} cites missing paths: {missing}"
