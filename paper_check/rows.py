"""A published (or independently derived) number beside ours, and their Markdown table:
the rows of the walkers' reports (:mod:`paper_check.walkers`, :mod:`paper_check.powered`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Row:
    """One published number beside ours."""

    quantity: str
    source: str
    published: float
    ours: float
    tolerance: float
    note: str = ""

    @property
    def difference(self) -> float:
        return self.ours - self.published

    @property
    def verdict(self) -> str:
        return "agrees" if abs(self.difference) <= self.tolerance else "differs"


def table(rows: Sequence[Row]) -> str:
    lines = [
        "| quantity | source | published | ours | difference | tolerance | verdict | note |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append(
            f"| {r.quantity} | {r.source} | {r.published:.10g} | {r.ours:.10g} | "
            f"{r.difference:.2g} | {r.tolerance:.2g} | {r.verdict} | {r.note} |"
        )
    return "\n".join(lines) + "\n"
