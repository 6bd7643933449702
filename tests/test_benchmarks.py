"""benchmarks/run.py --quick keeps working: every case runs and reports its measurements;
and a run of single cases (`--case N`) merges its rows into results.md, keeping the rest.

Nothing here is about speed (the quick sizes are too small to mean anything); the figures
live in benchmarks/results.md, written by a full run.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_quick_benchmark_runs_every_case(tmp_path):
    results, rows_json = tmp_path / "results.md", tmp_path / "rows.json"
    command = [sys.executable, "benchmarks/run.py", "--quick", "--results", str(results)]
    done = subprocess.run(
        [*command, "--json", str(rows_json)], cwd=ROOT, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    rows = json.loads(rows_json.read_text())
    assert sorted({int(r["case"]) for r in rows}) == list(range(1, 19))
    for r in rows:
        if r["subject_time"] is not None:
            assert 0 < r["subject_time"]["low"] <= r["subject_time"]["median"]
            assert r["subject_time"]["median"] <= r["subject_time"]["high"]
        if r["ratio"] is not None:
            assert r["ratio"] > 0
        assert r["met"] is None  # quick mode claims no target
        assert r["extra"]["case_peak_rss_mb"] > 0
    text = results.read_text()
    assert text.startswith("# Benchmark results") and "Mode: quick" in text
    # The closed form and the simulation agree on the sampled fixed points (case 2 note).
    case2 = next(r for r in rows if r["case"] == "2")
    disagreement = float(case2["note"].rsplit(" ", 1)[1])
    assert disagreement <= 1e-8


RESULTS = """# Benchmark results

Written by `python benchmarks/run.py`; rerun it to measure your machine.

Mode: full. Machine: AMD EPYC, 2 cores, Linux 6.1, Python 3.11.7, numpy 2.4.6; vsw threads 2.

## Method

Kept as the file has it: rows of one table may come from separate runs of single cases.

## Results

Each ratio is measured side by side in one run.

{table}

Case 1: a note of the file's own, kept as it is.

Targets missed: 1 (case one's second row, in the file's words); 2 (case two, old).
"""


def test_a_single_case_run_replaces_only_that_cases_rows(tmp_path, monkeypatch):
    """`--case 2` into a results.md with rows of cases 1 and 2: case 1's rows stay as they
    were, case 2's are the new ones, in case order; the Method section and the notes are
    kept, the header notes the case's other machine, the targets missed are recomputed."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import report
    from harness import Row, Timing

    def row(case, subject, met, note=""):
        return Row(case, subject, "numpy", Timing(2.0, 1.5, 3.0), Timing(1.0, 0.9, 1.2),
                   "<= 1.5x", met, note=note)  # fmt: skip

    ones = [row("1", "case one, first", True), row("1", "case one, second", False, "a note")]
    old = [row("2", "case two, old", False)]
    new = [row("2", "case two, new", True), row("2", "case two, newer", False, "noted")]
    path = tmp_path / "results.md"
    path.write_text(RESULTS.format(table=report.table(old + ones)))
    before = path.read_text()
    machine = "Intel Xeon, 2 cores, Linux 6.1, Python 3.11.7, numpy 2.4.6; vsw threads 2; BLAS: -"
    report.write_results(path, new, quick=False, cases=[2], machine=machine)
    after = path.read_text()

    def rows_of(text, case):
        return [line for line in text.splitlines() if line.startswith(f"| {case} |")]

    assert len(rows_of(before, 1)) == 2 and rows_of(after, 1) == rows_of(before, 1)
    assert rows_of(after, 2) == [report.row_line(r) for r in new]
    table = [line for line in after.splitlines() if line[:4] in ("| 1 ", "| 2 ")]
    assert table == rows_of(before, 1) + rows_of(after, 2)  # in case order
    for kept in ("## Method\n\nKept as the file has it", "Case 1: a note of the file's own"):
        assert kept in after
    assert "Machine: AMD EPYC, 2 cores (case 2: Intel Xeon, 2 cores), Linux 6.1," in after
    assert after.endswith(
        "Targets missed: 1 (case one's second row, in the file's words); 2 (case two, newer).\n"
    )


def test_run_case_merges_into_the_results_file_it_is_given(tmp_path, monkeypatch, capsys):
    """`run.py --case 2 --results FILE` (FILE there, not --quick) merges; the case's process
    is stood in for, so nothing is measured."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import report
    import run
    from harness import Row, Timing

    def isolated(case, quick, against=None):
        assert (case, quick, against) == (2, False, None)
        return [Row("2", "case two, again", "-", Timing(1.0, 1.0, 1.0), None, "-", None)]

    monkeypatch.setattr(run, "_run_isolated", isolated)
    machine = "AMD EPYC, 2 cores, Linux 6.1, Python 3.11.7; vsw threads 2; BLAS: -"
    monkeypatch.setattr(report, "machine", lambda: machine)
    first = Row("1", "case one", "-", Timing(2.0, 2.0, 2.0), None, "-", None)
    path = tmp_path / "results.md"
    path.write_text(RESULTS.format(table=report.table([first])))
    assert run.main(["--case", "2", "--results", str(path)]) == 0
    text = path.read_text()
    assert report.row_line(first) in text and "| 2 | case two, again |" in text
    assert "Machine: AMD EPYC, 2 cores, Linux 6.1," in text and "Every target met." in text
    assert "| 2 | case two, again |" in capsys.readouterr().out


def test_a_results_file_it_cannot_cut_is_refused(tmp_path, monkeypatch):
    """A table row whose first cell is not a case number is not guessed at."""
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks"))
    import report

    text = RESULTS.format(table=report.table([]) + "\n| one | a row | - | - |")
    with pytest.raises(ValueError, match="without a case number"):
        report.parse_results(text)
