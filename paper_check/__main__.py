"""``python -m paper_check [--out DIR]``: write the audit report, JSON and figures.

Exit status: 0 when every verdict matches ``paper_check/expected_verdicts.json``, 1 when
any verdict changed (the differences are printed on stderr), 2 on a bad output path.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


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
    parser.add_argument("--out", default="reports", help="output directory (default: reports/)")
    parser.add_argument(
        "--no-figures", action="store_true", help="skip the figures (faster; for tests)"
    )
    args = parser.parse_args(argv)
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"paper_check: cannot create output directory {str(out)!r}: {exc}", file=sys.stderr)
        return 2

    from paper_check.audit import expected_verdicts, run_audit, verdict_changes
    from paper_check.report import write_report

    start = time.perf_counter()
    audit = run_audit()
    written = write_report(audit, out)
    if not args.no_figures:
        from paper_check.figures import write_figures

        written += write_figures(out, audit.figure_data)
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
