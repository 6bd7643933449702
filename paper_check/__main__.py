"""``python -m paper_check [--out DIR]``: write the audit report, JSON and figures.

``python -m paper_check --model NAME [--out DIR]`` writes instead the report of one of the
walkers with massive legs (``simplest-walker``, ``compass-gait``, ``vsw-biped``,
``kneed-walker``) beside its published numbers: :mod:`paper_check.walkers` (default
directory ``reports/walkers``).

Exit status: 0 when every verdict matches ``paper_check/expected_verdicts.json``, 1 when
any verdict changed (the differences are printed on stderr), 2 on a bad output path (one
line on stderr, found before the audit runs: an empty name, a directory that cannot be
created or written, an output file that is a directory or cannot be written).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from paper_check.output import check_output_directory


def main(argv: list[str] | None = None) -> int:
    """Run the audit and write ``DIR/audit.md``, ``DIR/audit.json`` and the figures.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status.
    """
    parser = argparse.ArgumentParser(
        prog="python -m paper_check",
        description="Equation and claim audit of the ILE paper, with its figures reproduced.",
    )
    parser.add_argument(
        "--out", help="output directory (default: reports/; with --model, reports/walkers/)"
    )
    parser.add_argument(
        "--no-figures", action="store_true", help="skip the figures (faster; for tests)"
    )
    from paper_check.walkers import MODELS

    parser.add_argument(
        "--model",
        action="append",
        choices=MODELS,
        metavar="NAME",
        help=f"instead of the audit, the report of a walker: {', '.join(MODELS)} "
        "(python -m paper_check.walkers; repeatable)",
    )
    args = parser.parse_args(argv)
    if args.model:
        from paper_check import walkers

        out = "reports/walkers" if args.out is None else args.out
        return walkers.main([*(a for m in args.model for a in ("--model", m)), "--out", out])
    if args.out is None:
        args.out = "reports"
    problem = check_output_directory(args.out, figures=not args.no_figures)
    if problem is not None:
        print(f"paper_check: error: {problem}", file=sys.stderr)
        return 2
    out = Path(args.out)

    from paper_check.audit import expected_verdicts, run_audit, verdict_changes
    from paper_check.report import write_report

    start = time.perf_counter()
    audit = run_audit()
    try:
        written = write_report(audit, out)
        if not args.no_figures:
            from paper_check.figures import write_figures

            written += write_figures(out, audit.figure_data)
    except OSError as exc:  # e.g. the disk filled up during the audit
        where = f" {exc.filename!r}" if exc.filename else ""
        print(f"paper_check: error: cannot write{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    elapsed = time.perf_counter() - start
    for path in written:
        print(path)
    print(f"paper_check: audit written in {elapsed:.1f} s")
    changes = verdict_changes(audit.verdicts(), expected_verdicts())
    if changes:
        print(
            "paper_check: verdicts differ from paper_check/expected_verdicts.json:", file=sys.stderr
        )
        for line in changes:
            print(f"  {line}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
