"""The NLP's unknowns and constraints: each phase's knots, midpoints, inputs, impulses and
positive-work slacks (:class:`Unknowns`), stacked into one vector with its layout and
bounds; the constraints' rows with their bounds (:class:`Constraints`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.orbits.collocation import SAMPLES
from vsw.synthesis.powered.request import Request, limited_bounds, ordered_impulses, prices_work

__all__ = [
    "Constraints",
    "Unknowns",
    "block",
    "phase_unknowns",
    "stacked_unknowns",
    "variable_bounds",
]


@dataclass
class Unknowns:
    """The NLP's unknowns of one phase: states and inputs at the knots and midpoints, the
    impulses of the event that ends it (in :func:`ordered_impulses`' order: before its
    reset, with its impact, after it), and
    the positive-work slacks of inputs and impulses (width 0 unless the cost is the work)."""

    knots: list
    middles: list
    u_knots: list
    u_middles: list
    s_intervals: list
    impulses: list
    splits: list
    s_impulses: list

    KEYS = (
        "knots",
        "middles",
        "u_knots",
        "u_middles",
        "s_intervals",
        "impulses",
        "splits",
        "s_impulses",
    )


@dataclass
class Constraints:
    """The NLP's constraint rows with their lower and upper bounds, in order."""

    rows: list = field(default_factory=list)
    lower: list = field(default_factory=list)
    upper: list = field(default_factory=list)

    def add(self, expr: Any, low: float, high: float) -> None:
        self.rows.append(expr)
        self.lower.extend([low] * expr.shape[0])
        self.upper.extend([high] * expr.shape[0])


def phase_unknowns(k: int, m: int, nu: int, nj: int, nodes: int, slack: bool) -> Unknowns:
    """Phase ``k``'s unknowns (:class:`Unknowns`): ``m`` states and ``nu`` inputs at
    ``nodes + 1`` knots and ``nodes`` midpoints, ``nj`` impulses, and with ``slack`` the
    positive work's slacks and each impulse's split."""
    import casadi as ca

    def symbols(stem: str, count: int, width: int) -> list:
        return [ca.MX.sym(f"{stem}_{k}_{i}", width) for i in range(count)]

    # The positive work's epigraph: on each interval, a quartic slack above 0 and above the
    # power, by its Bernstein coefficients (_collocate). An impulse in two parts (its
    # split), each with two slacks at its power's ends (event_map).
    width, split_width = (nu, nj) if slack else (0, 0)
    return Unknowns(symbols("x", nodes + 1, m), symbols("xc", nodes, m),
                     symbols("u", nodes + 1, nu), symbols("uc", nodes, nu),
                     symbols("s", nodes, len(SAMPLES) * width),
                     symbols("j", 1, nj), symbols("f", 1, split_width),
                     symbols("sj", 1, 4 * split_width))  # fmt: skip


def stacked_unknowns(durations: Any, unknowns: list[Unknowns]) -> tuple[Any, list[dict]]:
    """The unknowns as one vector (durations first, then each phase's blocks) and, per
    phase, each block's (offset, count, width)."""
    import casadi as ca

    parts, layout, offset = [durations], [], durations.shape[0]
    for v in unknowns:
        entry = {}
        for key in Unknowns.KEYS:
            block = getattr(v, key)
            width = block[0].shape[0] if block else 0
            entry[key] = (offset, len(block), width)
            offset += len(block) * width
            parts += block
        layout.append(entry)
    return ca.vertcat(*parts), layout


def variable_bounds(model: HybridModel, sequence: list, layout: list[dict], size: int,
                    request: Request) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Durations >= 1e-3 (a phase of no duration is no step), slacks >= 0, each input and
    impulse within its declared bounds and the request's limits, each impulse's split in
    [0, 1] (0 where it has one part); impulses zero when the cost is the squared inputs'
    integral or the stability (which do not price them: they would be free)."""
    lbx, ubx = np.full(size, -np.inf), np.full(size, np.inf)
    lbx[: len(sequence)] = 1e-3
    for (phase, event), entry in zip(sequence, layout):
        for key in ("s_intervals", "s_impulses"):
            first, parts, width = entry[key]
            lbx[first : first + parts * width] = 0.0
        first, _, width = entry["impulses"]
        split, _, split_width = entry["splits"]
        slacks = entry["s_impulses"][0]
        records = {i["name"]: i for i in event.get("impulses", ())}
        for j, name in enumerate(ordered_impulses(model, event)):
            low, high = limited_bounds(records[name]["bounds"], request, name)
            if not prices_work(request) or (request.use and name not in request.use):
                low, high = 0.0, 0.0
            lbx[first + j] = -np.inf if low is None else low
            ubx[first + j] = np.inf if high is None else high
            if split_width:  # a split and slacks where there are two parts
                whole = records[name]["applied"] == "with" or low == high == 0.0
                lbx[split + j], ubx[split + j] = 0.0, 0.0 if whole else 1.0
                if records[name]["applied"] == "with":
                    ubx[slacks + 4 * j + 2 : slacks + 4 * j + 4] = 0.0
        bounds = [(0.0, 0.0) if request.use and i["name"] not in request.use
                  else limited_bounds(i["bounds"], request, i["name"])
                  for i in model.phases[model.phase_index[phase]].get("inputs", ())]  # fmt: skip
        for key in ("u_knots", "u_middles"):
            first, parts, width = entry[key]
            for j, (low, high) in enumerate(bounds):
                lbx[first + j : first + parts * width : width] = -np.inf if low is None else low
                ubx[first + j : first + parts * width : width] = np.inf if high is None else high
    return lbx, ubx


def block(w: np.ndarray, entry: tuple[int, int, int]) -> np.ndarray:
    """The block ``entry`` = (offset, count, width) of ``w`` as a (count, width) array."""
    first, parts, width = entry
    return w[first : first + parts * width].reshape(parts, width)
