"""benchmarks/run.py --quick keeps working: every case runs and reports its measurements.

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
