"""Benchmarks: every speed claim measured side by side with what a user would write instead.

``python benchmarks/run.py [--quick] [--json FILE] [--results FILE] [--case N ...]`` runs
the cases, prints a table and writes ``benchmarks/results.md`` (the table, the machine, the
versions). Each comparison is a ratio measured within one run: the two sides interleaved,
a warm-up call of each first, then at least five repetitions (two with ``--quick``);
medians are reported with min and max. Absolute times are reported; only ratios are
claimed, except where a case sets an absolute target (cases 4-7).
Case 9 times one passive-walker gait solve per model; cases 10 and 11 the
compiled batch simulator, per step and as a 500 x 500 basin, locally and on Dask.

Every case runs in a fresh Python process, so its peak resident memory (RSS) is its own;
the peak memory of one call of each side is measured with ``tracemalloc`` (numpy reports
its array buffers to it). ``--quick`` uses small sizes so the test suite can run it to keep
this code working; its numbers mean nothing and it writes to a temporary file unless
``--results`` says otherwise.

The cases live in ``benchmarks/cases/`` (by topic), what they share in
``benchmarks/harness.py``, the commits some compare with in ``benchmarks/pins.py`` and the
table and results.md in ``benchmarks/report.py``. ``--case N`` (not ``--quick``) merges
its rows into an existing results file: they replace that case's rows, every other part of
the file is kept.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
import report
from cases.basins import case_basin_grid
from cases.batch import case_batch_before, case_walks_against
from cases.design import (
    case_design,
    case_design_every_model,
    case_design_suite,
    case_powered_shooting,
)
from cases.gaits import (
    _near_gait_starts,
    case_batch_step,
    case_gait_rootfinder,
    case_gait_search,
    case_locate_flip,
)
from cases.ile import (
    case_basin,
    case_fixed_point_vectorised,
    case_fixed_point_vs_simulation,
    case_rootfinders_and_c,
    case_step_metrics,
)
from cases.startup import case_startup
from harness import ROOT, Row, Timing, interleaved, peak_rss_mb
from pins import THREADS_BEFORE

CASES = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18)


def run_case(case: int, quick: bool, against: str | None = None) -> list[Row]:
    reps = 2 if quick else 5
    if case == 1:
        return case_fixed_point_vectorised(2_000 if quick else 10**6, reps)
    if case == 2:
        return case_fixed_point_vs_simulation(2 if quick else 10, 1000 if quick else 10**5, reps)
    if case == 3:
        return case_rootfinders_and_c(reps)
    if case == 4:
        return case_step_metrics(2_000 if quick else 10**6, reps)
    if case == 5:
        return case_basin(50 if quick else 1000, reps)
    if case == 6:
        return case_design(quick)
    if case == 7:
        return case_startup(1 if quick else 5, include_audit=not quick, every_model=not quick)
    if case == 8:
        return case_design_suite(quick)
    if case == 9:
        return case_gait_rootfinder(reps)
    if case == 10:
        return case_batch_step(8 if quick else 200, reps)
    if case == 11:
        return case_basin_grid(20 if quick else 500, 1 if quick else 2)
    if case == 12:
        return case_gait_search(quick)
    if case == 13:
        return case_design_every_model(quick)
    if case == 14:
        return case_locate_flip(quick)
    if case == 15:
        count = 100 if quick else 1000
        rows = case_batch_before(count, reps)
        return rows + (case_walks_against(against, count, reps) if against else [])
    if case == 16:
        return case_powered_shooting(quick)
    if case == 17:  # walks on rough ground: benchmarks/rough_bench.py
        from rough_bench import case_rough

        return case_rough(20 if quick else 2000, reps, Row, interleaved, _near_gait_starts)
    if case == 18:  # HZD gait optimisation against collocation: benchmarks/hzd_bench.py
        from hzd_bench import case_hzd_optimize

        return case_hzd_optimize(quick, Row, Timing)
    raise ValueError(f"no benchmark case {case}; cases are {CASES}")


def _plain(value):
    """numpy scalars as Python numbers for JSON."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _run_isolated(case: int, quick: bool, against: str | None = None) -> list[Row]:
    """One case in a fresh interpreter, so that its peak RSS is its own."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.json"
        command = [sys.executable, str(Path(__file__).resolve()), "--case", str(case)]
        command += ["--rows-out", str(out)] + (["--quick"] if quick else [])
        command += ["--against", against] if against else []
        done = subprocess.run(command, cwd=ROOT, text=True, capture_output=True)
        if done.returncode != 0:
            raise RuntimeError(f"benchmark case {case} failed:\n{done.stdout}\n{done.stderr}")
        payload = json.loads(out.read_text())
    rows = [Row.from_dict(r) for r in payload["rows"]]
    for row in rows:
        row.extra["case_peak_rss_mb"] = payload["peak_rss_mb"]
    return rows


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes; checks the code runs")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    parser.add_argument("--results", type=Path, help="markdown report (default: see module doc)")
    parser.add_argument("--case", type=int, action="append", choices=CASES, help="run only these")
    parser.add_argument("--rows-out", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--against", metavar="REF", nargs="?", const=THREADS_BEFORE,
                        help="case 15: also its walks in a checkout of REF (a commit; default "
                        f"{THREADS_BEFORE}), process by process, alternately with this "
                        "tree's")  # fmt: skip
    return parser


def _child(args: argparse.Namespace) -> int:
    """A child process of :func:`_run_isolated`: exactly one case, its rows and peak RSS
    written to ``--rows-out``."""
    rows = run_case(args.case[0], args.quick, args.against)
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
    # Case 7 measures whole processes: their peak is that of the largest child.
    peak = children if args.case[0] == 7 else peak_rss_mb()
    payload = {"rows": [asdict(r) for r in rows], "peak_rss_mb": peak}
    args.rows_out.write_text(json.dumps(payload, default=_plain))
    return 0


def _results_path(args: argparse.Namespace) -> Path:
    if args.results is not None:
        return args.results
    if args.quick:
        return Path(tempfile.gettempdir()) / "vsw-benchmark-quick.md"
    return ROOT / "benchmarks" / "results.md"


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.rows_out is not None:  # child process of _run_isolated: exactly one case
        return _child(args)
    results = _results_path(args)
    if args.case and not args.quick and results.exists():
        try:  # a file the rows could not be merged into is refused before measuring
            report.parse_results(results.read_text())
        except ValueError as exc:
            parser.error(f"cannot merge into {results}: {exc}")
    rows: list[Row] = []
    for case in args.case or CASES:
        started = time.perf_counter()
        rows += _run_isolated(case, args.quick, args.against)
        print(f"case {case}: {time.perf_counter() - started:.1f} s", file=sys.stderr)
    if args.quick:  # sizes are reduced: the targets do not apply
        for row in rows:
            row.met = None
    print(report.table(rows) + report.case_notes(rows))
    report.write_results(results, rows, quick=args.quick, cases=args.case,
                         machine=report.machine())  # fmt: skip
    print(f"wrote {results}", file=sys.stderr)
    if args.json:
        rows_json = [asdict(r) | {"ratio": r.ratio} for r in rows]
        args.json.write_text(json.dumps(rows_json, indent=1, default=_plain))
    return 0


if __name__ == "__main__":
    sys.exit(main())
