"""The benchmarks' report: the table of rows, the machine they ran on, and results.md,
written whole by a run of every case or merged by a run of some (``--case N``): their rows
replace those cases' rows, and every other part of the file is kept.

A row of the file's table belongs to the case in its first cell. The header's machine is
the file's; a merged case that ran on another (another CPU, or another version of what
the header names) is noted after it, ``(case 13: Intel Xeon, 2 cores)``, cases that ran
on the same other machine together, ``(cases 7 and 13: ...)``. The notes after the table
are kept (a case's note the run writes is added where the file has none) and the line of
targets missed is recomputed from every row: a kept case keeps the file's words for it."""

from __future__ import annotations

import os
import platform
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from harness import Row, Timing, blas_threading
from pins import DESIGN_BEFORE

TITLE = "# Benchmark results"
MISSED = "**MISSED**"
PREAMBLE = (
    "Each ratio is measured side by side in one run (interleaved, medians of at least five "
    "repetitions after a warm-up; rows noted 'single run' are one sample); absolute times "
    "hold for this machine only. Peak MB is "
    "the largest memory traced (tracemalloc, numpy buffers included) during one call of "
    "each side; RSS is the peak resident size of the process that ran the case (for case "
    "7, of the largest measured process)."
)
CASE_NOTES = {
    8: "Case 8: the reference (benchmarks/design_suite.py) does not use IPOPT or the "
    "design's smooth pieces, but shares with it the generated closed forms (the exact "
    "margins) and the closed problem's distances (STRICT_MARGIN, TABLE_DISTANCE): a "
    "defect of the generated code itself would not show here (the derivation's own "
    "tests cover it). The 'before' side runs vsw/synthesis/design.py of commit "
    f"{DESIGN_BEFORE} on today's generated code, vsw.models.ile.analysis and "
    "vsw.models.ile.simulate.",
}
"""The note a case's rows bring below the table."""


def fmt_time(t: Timing | None) -> str:
    if t is None:
        return "-"

    def one(x: float) -> str:
        if x >= 1:
            return f"{x:.2f} s"
        if x >= 1e-3:
            return f"{x * 1e3:.1f} ms"
        if x >= 1e-6:
            return f"{x * 1e6:.1f} us"
        return f"{x * 1e9:.1f} ns"

    return f"{one(t.median)} [{one(t.low)}, {one(t.high)}]"


def fmt_ratio(r: float | None) -> str:
    if r is None:
        return "-"
    return f"{r:.3g}x" if r >= 0.01 else f"1/{1 / r:,.0f}"


def fmt_memory(row: Row) -> str:
    parts = []
    if row.subject_peak_mb is not None:
        parts.append(f"{row.subject_peak_mb:,.0f}")
    if row.baseline_peak_mb is not None:
        parts.append(f"{row.baseline_peak_mb:,.0f}")
    rss = row.extra.get("case_peak_rss_mb")
    text = " / ".join(parts) if parts else "-"
    return text + (f" (RSS {rss:,.0f})" if rss is not None else "")


def row_line(r: Row) -> str:
    """``r`` as a line of the table."""
    met = {True: "yes", False: MISSED, None: "-"}[r.met]
    note = f" ({r.note})" if r.note else ""
    return (
        f"| {r.case} | {r.subject}{note} | {r.baseline} | {fmt_time(r.subject_time)} "
        f"| {fmt_time(r.baseline_time)} | {fmt_ratio(r.ratio)} | {fmt_memory(r)} "
        f"| {r.target} | {met} |"
    )


TABLE_HEAD = (
    "| case | measured | against | time: median [min, max] | baseline: median [min, max] "
    "| ratio | peak MB: measured / against (case RSS) | target | met |"
)


def table(rows: list[Row]) -> str:
    lines = [TABLE_HEAD, "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    lines += [row_line(r) for r in rows]
    return "\n".join(lines)


def case_notes(rows: list[Row]) -> str:
    """The notes of the cases of ``rows`` that bring one, each after a blank line."""
    cases = {r.case for r in rows}
    return "".join(f"\n\n{note}" for case, note in CASE_NOTES.items() if str(case) in cases)


def machine_fields() -> list[str]:
    """The machine as results.md's header states it: the CPU and its cores, the system, the
    versions of Python and the libraries, vsw's threads and the BLAS threading."""
    import casadi
    import numpy as np
    import scipy
    import sympy

    from vsw.runtime.threads import default_threads

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return [
        f"{cpu}, {os.cpu_count()} cores", f"{platform.system()} {platform.release()}",
        f"Python {platform.python_version()}", f"numpy {np.__version__}",
        f"scipy {scipy.__version__}", f"casadi {casadi.__version__}",
        f"sympy {sympy.__version__}", f"vsw threads {default_threads()}", blas_threading(),
    ]  # fmt: skip


def machine(fields: Sequence[str] | None = None) -> str:
    host, system, *versions, threads, blas = fields or machine_fields()
    return f"{', '.join([host, system, *versions])}; {threads}; {blas}"


def _missed_line(entries: list[str]) -> str:
    return "Targets missed: " + "; ".join(entries) + "." if entries else "Every target met."


def full_report(rows: list[Row], quick: bool, machine: str) -> str:
    """results.md of ``rows`` alone, run on ``machine``."""
    mode = "quick (sizes reduced; numbers not meaningful)" if quick else "full"
    missed = [f"{r.case} ({r.subject})" for r in rows if r.met is False]
    return (
        f"{TITLE}\n\n"
        "Written by `python benchmarks/run.py`; rerun it to measure your machine.\n\n"
        f"Mode: {mode}. Machine: {machine}.\n\n"
        f"{PREAMBLE}\n\n{table(rows)}{case_notes(rows)}\n\n{_missed_line(missed)}\n"
    )


def write_results(
    path: Path, rows: list[Row], *, quick: bool, cases: Sequence[int] | None, machine: str
) -> str:
    """Write results.md at ``path``: merged, if only ``cases`` ran (not quick) and the file
    exists; whole otherwise. Returns the text written."""
    if cases and not quick and path.exists():
        text = merge_report(path.read_text(), rows, cases, machine)
    else:
        text = full_report(rows, quick, machine)
    path.write_text(text)
    return text


# ---------------------------------------------------------------------------- merging


@dataclass
class _Parsed:
    """results.md cut where a merge changes it: line indices of the header's machine line,
    the table's rows (each with its case) and the line of targets missed."""

    lines: list[str]
    header: int
    mode: str
    host: str
    elsewhere: dict[int, str]
    rest: str
    first_row: int
    end_row: int
    rows: list[tuple[int, str]]
    targets: tuple[int, int]


HEADER = re.compile(r"^Mode: (?P<mode>.*?)\. Machine: (?P<desc>.*)\.$")
HOST = re.compile(
    r"^(?P<host>.+?, \d+ cores)(?: \((?P<notes>(?:[^()]|\([^()]*\))*)\))?(?P<rest>.*)$"
)
ELSEWHERE = re.compile(r"^cases? (?P<cases>\d+(?:(?:, | and )\d+)*): (?P<desc>.+)$")


def _elsewhere(notes: str | None) -> dict[int, str]:
    """The header's cases run on another machine: ``case 13: X; cases 7 and 9: Y``."""
    found: dict[int, str] = {}
    for group in re.split(r"; (?=cases? \d)", notes) if notes else []:
        match = ELSEWHERE.match(group)
        if match is None:
            raise ValueError(f"the machine line's note {group!r} names no case")
        for case in re.findall(r"\d+", match["cases"]):
            found[int(case)] = match["desc"]
    return found


def _row_case(line: str) -> int:
    cell = line.split("|")[1].strip()
    if not cell.isdigit():
        raise ValueError(f"a row of the results table without a case number: {line[:80]!r}")
    return int(cell)


def parse_results(text: str) -> _Parsed:
    """Cut results.md for a merge; ValueError where it is not as run.py writes it."""
    lines = text.splitlines()
    headers = [k for k, line in enumerate(lines) if HEADER.match(line)]
    heads = [k for k, line in enumerate(lines) if line == TABLE_HEAD]
    if len(headers) != 1 or len(heads) != 1:
        raise ValueError("not one 'Mode: ... Machine: ...' line and one results table")
    header = HEADER.match(lines[headers[0]])
    host = HOST.match(header["desc"])
    if host is None:
        raise ValueError("the machine line names no 'CPU, N cores'")
    first = heads[0] + 2
    if first > len(lines) or not lines[first - 1].startswith("| --- |"):
        raise ValueError("the results table has no separator line")
    end = first
    while end < len(lines) and lines[end].startswith("|"):
        end += 1
    rows = [(_row_case(line), line) for line in lines[first:end]]
    starts = [k for k in range(end, len(lines))
              if lines[k].startswith(("Targets missed: ", "Every target met."))]  # fmt: skip
    start = starts[-1] if starts else len(lines)
    stop = start
    while stop < len(lines) and lines[stop].strip():
        stop += 1
    return _Parsed(lines, headers[0], header["mode"], host["host"], _elsewhere(host["notes"]),
                   host["rest"], first, end, rows, (start, stop))  # fmt: skip


def _label(field: str) -> str:
    """What a machine field is about: ``numpy`` of ``numpy 2.4.6``."""
    return "BLAS:" if field.startswith("BLAS:") else field.rsplit(" ", 1)[0] + " "


def _differences(fields: Sequence[str], host: str, rest: str) -> str:
    """The fields of ``fields`` (the run's machine) that differ from the file's: its CPU
    and cores, and each field the file states with another value; '' if none does."""
    differ = [fields[0]] if fields[0] != host else []
    for field in fields[1:]:
        stated = re.search(r"(?:^|[,;] )" + re.escape(field) + r"(?=[,;]|$)", rest)
        if not stated and re.search(r"(?:^|[,;] )" + re.escape(_label(field)), rest):
            differ.append(field)
    return ", ".join(differ)


def _cases_phrase(cases: list[int]) -> str:
    if len(cases) == 1:
        return f"case {cases[0]}"
    return f"cases {', '.join(map(str, cases[:-1]))} and {cases[-1]}"


def _machine_line(parsed: _Parsed, ran: set[int], fields: Sequence[str]) -> str:
    elsewhere = {c: d for c, d in parsed.elsewhere.items() if c not in ran}
    differ = _differences(fields, parsed.host, parsed.rest)
    if differ:
        elsewhere.update(dict.fromkeys(ran, differ))
    groups: dict[str, list[int]] = {}
    for case in sorted(elsewhere):
        groups.setdefault(elsewhere[case], []).append(case)
    notes = "; ".join(f"{_cases_phrase(cases)}: {desc}" for desc, cases in groups.items())
    host = parsed.host + (f" ({notes})" if notes else "")
    return f"Mode: {parsed.mode}. Machine: {host}{parsed.rest}."


def _old_missed(paragraph: str) -> dict[int, list[str]] | None:
    """The file's entries of targets missed by case, ``N (words)`` each; None where the
    line cannot be cut into them."""
    prefix = "Targets missed: "
    if not paragraph.startswith(prefix):
        return {}
    body = paragraph[len(prefix) :].removesuffix(".")
    entries: dict[int, list[str]] = {}
    at = 0
    while at < len(body):
        match = re.compile(r"(\d+) \(").match(body, at)
        if match is None:
            return None
        depth, end = 0, match.end() - 1
        for end in range(match.end() - 1, len(body)):
            depth += {"(": 1, ")": -1}.get(body[end], 0)
            if depth == 0:
                break
        if depth:
            return None
        entries.setdefault(int(match[1]), []).append(body[match.start() : end + 1])
        at = end + 1 + (2 if body.startswith("; ", end + 1) else 0)
        if at == end + 1 and at != len(body):
            return None
    return entries


def _met(line: str) -> str:
    return line.rstrip().removesuffix("|").rsplit("|", 1)[-1].strip()


def _missed(merged: list[tuple[int, str]], rows: list[Row], ran: set[int], old) -> list[str]:
    """The entries of targets missed over ``merged`` (case, line): a case that ran names
    each row that missed, a kept case keeps the file's entries (or names its rows)."""
    entries = []
    for case in dict.fromkeys(c for c, line in merged if _met(line) == MISSED):
        if case in ran:
            entries += [f"{r.case} ({r.subject})" for r in rows
                        if int(r.case) == case and r.met is False]  # fmt: skip
        elif old and case in old:
            entries += old[case]
        else:
            entries += [f"{case} ({line.split(' | ')[1]})" for c, line in merged
                        if c == case and _met(line) == MISSED]  # fmt: skip
    return entries


def _with_notes(notes: list[str], ran: set[int]) -> list[str]:
    """The lines between the table and the targets, with the note of each case that ran
    and brings one where the file has none (before the first note of a later case)."""
    for case, note in CASE_NOTES.items():
        if case not in ran or any(line.startswith(f"Case {case}:") for line in notes):
            continue
        later = [k for k, line in enumerate(notes)
                 if (m := re.match(r"Case (\d+)\b", line)) and int(m[1]) > case]  # fmt: skip
        at = later[0] if later else len(notes)
        while at > 0 and not notes[at - 1].strip():
            at -= 1
        notes[at:at] = ["", note]
    return notes


def merge_report(text: str, rows: list[Row], cases: Sequence[int], machine: str) -> str:
    """results.md ``text`` with the rows of ``cases`` replaced by ``rows`` (run on
    ``machine``, as :func:`machine` states it), every other part kept."""
    parsed = parse_results(text)
    lines = parsed.lines
    ran = {int(c) for c in cases} | {int(r.case) for r in rows}
    kept = [(case, line) for case, line in parsed.rows if case not in ran]
    merged = sorted(kept + [(int(r.case), row_line(r)) for r in rows], key=lambda cl: cl[0])
    start, stop = parsed.targets
    old = _old_missed(" ".join(lines[start:stop]))
    fields = _machine_fields_of(machine)
    out = [*lines[: parsed.header], _machine_line(parsed, ran, fields)]
    out += lines[parsed.header + 1 : parsed.first_row] + [line for _, line in merged]
    out += _with_notes(lines[parsed.end_row : start], ran)
    if start == len(lines):
        out.append("")
    out += [_missed_line(_missed(merged, rows, ran, old)), *lines[stop:]]
    return "\n".join(out) + "\n"


def _machine_fields_of(machine: str) -> list[str]:
    """The fields of a :func:`machine` string (its CPU and cores one field)."""
    head, *tail = machine.split("; ")
    host = HOST.match(head)
    if host is None:
        raise ValueError(f"a machine without 'CPU, N cores': {machine!r}")
    return [host["host"], *(f for f in host["rest"].split(", ") if f), *tail]
