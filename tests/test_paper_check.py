"""``python -m paper_check``: JSON contract, determinism, verdict table, exit status."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from paper_check.audit import EXPECTED_PATH, VERDICTS, expected_verdicts, verdict_changes
from paper_check.figures import FIGURES

ROOT = Path(__file__).resolve().parents[1]


def _run(out: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "paper_check", "--out", str(out), *extra],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.fixture(scope="module")
def audit_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One audit run without its figures: the report and JSON are the same bytes (the
    figures are drawn from the audit's data after it), for about half the time. The figure
    files, and a second run for byte-identity, are the slow tier's; tests/test_figures.py
    draws every audit figure in the default tier."""
    out = tmp_path_factory.mktemp("audit")
    proc = _run(out, "--no-figures")
    assert proc.returncode == 0, proc.stderr
    return out


def test_writes_report_and_json(audit_run: Path) -> None:
    names = {p.name for p in audit_run.iterdir()}
    assert {"audit.md", "audit.json"} <= names


def test_json_contract(audit_run: Path) -> None:
    doc = json.loads((audit_run / "audit.json").read_text())
    assert set(doc["verdict_vocabulary"]) == set(VERDICTS)
    assert [e["id"] for e in doc["equations"]] == [f"({i})" for i in range(1, 24)]
    for entry in doc["equations"] + doc["claims"]:
        assert {"id", "verdict", "evidence", "note"} <= set(entry)
        assert entry["verdict"] in VERDICTS
        assert entry["note"]
        assert entry["evidence"]
    for entry in doc["equations"]:
        ev = entry["evidence"]
        assert "zero" in ev["symbolic"] and "residual" in ev["symbolic"]
        assert ev["numeric"]["samples"] >= 1000


def test_json_verdicts_match_recorded_table(audit_run: Path) -> None:
    doc = json.loads((audit_run / "audit.json").read_text())
    found = {
        "equations": {e["id"]: e["verdict"] for e in doc["equations"]},
        "claims": {c["id"]: c["verdict"] for c in doc["claims"]},
    }
    assert verdict_changes(found, expected_verdicts()) == []


def test_counterexamples_reported_for_refuted_claims(audit_run: Path) -> None:
    doc = json.loads((audit_run / "audit.json").read_text())
    claims = {c["id"]: c for c in doc["claims"]}
    for cid in ("existence-sufficient", "existence-necessary", "qf-largest-at-theta-II-zero"):
        rows = claims[cid]["counterexamples"]
        assert rows and {"beta", "theta_II_deg", "phi0_deg"} <= set(rows[0])
    sims = claims["existence-sufficient"]["evidence"]["simulation"]
    assert sims["simulated sets whose outcome disagrees with the derived conditions"] == 0
    assert sims["per category"]["printed, lift-off"].get("lift-off", 0) > 0


@pytest.mark.slow  # two audit runs with their figures
def test_writes_the_figures_and_the_report_is_deterministic(
    audit_run: Path, tmp_path: Path
) -> None:
    """Every figure in every format written, and every file of the report, figures
    included, byte-identical from run to run (and the report and JSON those of the run
    without figures)."""
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        proc = _run(out)
        assert proc.returncode == 0, proc.stderr
    names = {p.name for p in a.iterdir()}
    for fig in FIGURES:
        assert {f"{fig}.png", f"{fig}.svg", f"{fig}.pdf"} <= names
    for path in sorted(a.iterdir()):
        assert path.read_bytes() == (b / path.name).read_bytes(), path.name
    for path in sorted(audit_run.iterdir()):
        assert path.read_bytes() == (a / path.name).read_bytes(), path.name


def test_markdown_summary_first_and_figures_linked(audit_run: Path) -> None:
    md = (audit_run / "audit.md").read_text()
    headings = [line for line in md.splitlines() if line.startswith("## ")]
    assert headings[0] == "## Summary"
    for fig in FIGURES:
        assert f"]({fig}.png)" in md and f"({fig}.svg)" in md and f"({fig}.pdf)" in md
    for verdict in VERDICTS:
        assert f"`{verdict}`" in md


def test_expected_table_is_complete_and_uses_the_vocabulary() -> None:
    table = json.loads(EXPECTED_PATH.read_text())
    assert set(table["equations"]) == {f"({i})" for i in range(1, 24)}
    for verdict in list(table["equations"].values()) + list(table["claims"].values()):
        assert verdict in VERDICTS


@pytest.mark.slow
def test_exit_status_nonzero_on_verdict_change(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A changed verdict makes the CLI fail (simulated by a tampered expected table)."""
    import paper_check.__main__ as cli
    import paper_check.audit as audit

    table = expected_verdicts()
    table["equations"]["(18)"] = "identical"
    tampered = tmp_path / "expected.json"
    tampered.write_text(json.dumps(table))
    monkeypatch.setattr(
        audit, "expected_verdicts", lambda path=tampered: json.loads(tampered.read_text())
    )
    assert cli.main(["--out", str(tmp_path / "out"), "--no-figures"]) == 1


def _caption(md: str, fig: str) -> str:
    (line,) = [ln for ln in md.splitlines() if ln.startswith(f"Fig. {fig[3:]} (reproduced)")]
    return line


def test_figure_captions_say_what_is_drawn(audit_run: Path) -> None:
    md = (audit_run / "audit.md").read_text()
    assert "Dotted parts" not in md
    for fig in ("fig5", "fig6", "fig7"):
        assert "dotted where there is no valid gait" in _caption(md, fig)
    for fig in ("fig8", "fig9"):
        assert "dotted where" not in _caption(md, fig)
    # The curves cut at q^f = 3 are named with how high they go.
    assert "The axis stops at $q^f$ = 3" in _caption(md, "fig5")
    assert "The axis stops at" not in _caption(md, "fig6")
    # Fig. 9 names its edges by what happens beyond them.
    assert "falls backward" in _caption(md, "fig9") and "lifts off" in _caption(md, "fig9")


def test_paper_named_by_title_not_by_a_relative_link(audit_run: Path) -> None:
    from paper_check.report import PAPER_TITLE

    md = (audit_run / "audit.md").read_text()
    assert PAPER_TITLE in md.split("## Summary")[0]
    assert "](../" not in md
    readme = (ROOT / "README.md").read_text()
    assert PAPER_TITLE in readme and "../shared" not in readme
    assert json.loads((audit_run / "audit.json").read_text())["paper"] == PAPER_TITLE


def test_note_on_14_does_not_contradict_itself() -> None:
    from paper_check.audit import SHORT_NOTES

    note = SHORT_NOTES["(14)"]
    # A condition is either required for exactness or missing, not both.
    assert note.count("theta_II > theta_1") == 1
    assert "lift-off" in note


def test_readme_links_into_the_report_resolve(audit_run: Path) -> None:

    md = (audit_run / "audit.md").read_text()
    anchors = set(re.findall(r'<a id="([^"]+)"></a>', md))
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\(reports/audit\.md#([^)]+)\)", readme)
    assert len(links) == len(set(links)) >= 23 + 10
    assert set(links) <= anchors, set(links) - anchors
    # No bare '#anchor' links: they would point into the README itself.
    assert not re.findall(r"\]\(#", readme)
    # The README's summary table is the report's, with the links prefixed.
    start = md.index("| Equation | As printed |")
    table = md[start : md.index("\n\n## Verdicts", start)]
    for row in table.replace("](#", "](reports/audit.md#").splitlines():
        assert row in readme, row


def _bad_out_cases(tmp_path: Path) -> list[tuple[list[str], str]]:
    (tmp_path / "md" / "audit.md").mkdir(parents=True)
    (tmp_path / "fig" / "fig9.png").mkdir(parents=True)
    (tmp_path / "file").write_text("not a directory")
    return [
        (["--out", ""], "--out is empty"),
        (["--out", "/proc/vsw-audit"], "cannot create output directory"),
        # /sys/kernel is read-only even for root (CI runs as root: chmod would not do).
        (["--out", "/sys/kernel"], "cannot write into output directory"),
        (["--out", str(tmp_path / "file")], "cannot create output directory"),
        (["--out", str(tmp_path / "md"), "--no-figures"], "audit.md': it is a directory"),
        (["--out", str(tmp_path / "fig")], "fig9.png': it is a directory"),
    ]


def test_bad_output_directory_fails_before_the_audit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture
) -> None:
    """Exit 2 and one line, found before the audit runs (run_audit must not be called)."""
    import paper_check.__main__ as cli
    import paper_check.audit as audit

    def no_audit():
        raise AssertionError("the audit ran before the output directory was checked")

    monkeypatch.setattr(audit, "run_audit", no_audit)
    for argv, words in _bad_out_cases(tmp_path):
        assert cli.main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err, (argv, err)


def test_output_directory_check_accepts_a_fresh_or_existing_directory(tmp_path: Path) -> None:
    from paper_check.__main__ import check_output_directory

    assert check_output_directory(str(tmp_path / "new" / "deeper")) is None
    assert (tmp_path / "new" / "deeper").is_dir()
    (tmp_path / "new" / "deeper" / "audit.md").write_text("old report")
    assert check_output_directory(str(tmp_path / "new" / "deeper")) is None
    assert (tmp_path / "new" / "deeper" / "audit.md").read_text() == "old report"
