"""The limit of a not-attained optimum: the design re-solved ever closer to the open
limits it presses against (distances scaled by
:data:`~vsw.models.ile.design.forms.CONTINUATION`) and the limiting value extrapolated."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.models.ile.design.forms import CONTINUATION, TABLE_LIMITS, VARIABLES, numpy_quantities
from vsw.models.ile.design.nlp import Solve, limit_text, solve_from, verified_solve
from vsw.models.ile.design.problem import Problem


@dataclass(frozen=True)
class Limit:
    """The supremum or infimum of a request whose optimum is not attained.

    Attributes
    ----------
    objective : float or None
        Extrapolated limiting value of the objective (None when the path does not settle;
        ``inf``/``-inf`` when it runs away).
    uncertainty : float or None
        Size of the extrapolation step: the limit is within about this of ``objective``.
    approached_as : tuple of str
        The open limits pressed against: strict conditions by name, parameter limits as
        ``beta < 1``.
    path : tuple of dict
        The design at each distance scale of :data:`CONTINUATION`: ``distance_scale``,
        ``objective``, ``beta``, ``theta_II``, ``phi0``, ``step_length``.
    """

    objective: float | None
    uncertainty: float | None
    approached_as: tuple[str, ...]
    path: tuple[dict[str, float], ...]

    def to_dict(self) -> dict[str, Any]:
        return {
            "objective": _json_float(self.objective),
            "uncertainty": _json_float(self.uncertainty),
            "approached_as": list(self.approached_as),
            "path": [dict(p) for p in self.path],
        }


def _json_float(v: float | None) -> Any:
    if v is None:
        return None
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return v


def continue_to_limit(problem: Problem, best: Solve) -> Limit:
    """Re-solve ever closer to the open limits; extrapolate the objective's limit."""
    path = [best]
    for scale in CONTINUATION[1:]:
        s = verified_solve(problem, solve_from(problem, best.region, path[-1].x, scale, path[-1]))
        # Close to a degenerate limit IPOPT may stop on its iteration limit: a verified
        # point that improves on the previous one still traces the path (marked).
        if not (s.verified and s.objective <= path[-1].objective + 1e-12):
            break
        path.append(s)
    # Only converged points estimate the limit (a verified point IPOPT did not finish is
    # a bound on the optimum at its distance, not the optimum).
    converged = list(itertools.takewhile(lambda s: s.converged, path))
    limit, uncertainty = _extrapolate([s.objective for s in converged])
    approached = list(best.open_active)
    for s in path[1:]:
        approached += [n for n in s.open_active if n not in approached]
    records = []
    for s in path:
        qs = numpy_quantities(s.x[None, :], timing=False)
        records.append(
            {
                "distance_scale": s.distance,
                "objective": s.objective,
                "converged": s.success,
                "beta": float(s.x[0]),
                "theta_II": float(s.x[1]),
                "phi0": float(s.x[2]),
                "step_length": float(qs["step_length"][0]),
            }
        )
    approached += [n for n in _running_to_limits(records) if n not in approached]
    return Limit(limit, uncertainty, tuple(approached), tuple(records))


_STEP = CONTINUATION[1] / CONTINUATION[0]  # distance ratio of successive path points


def _running_to_limits(records: Sequence[Mapping[str, float]]) -> list[str]:
    """Variables (and the step length) that close in on a limit along the path: their gap
    to it shrinks at every step at least like distance**(1/4) and ends below 0.05."""
    if len(records) < 3:
        return []
    out = []
    candidates = [(name, limit) for name in VARIABLES for limit in TABLE_LIMITS[name]]
    candidates.append(("step_length", 0.0))
    for name, limit in candidates:
        gaps = [abs(r[name] - limit) for r in records]
        shrinking = all(b < _STEP**0.25 * a for a, b in itertools.pairwise(gaps))
        if shrinking and gaps[-1] < 0.05:
            out.append(f"{name} -> {limit_text(limit)}")
    return out


def _extrapolate(values: Sequence[float]) -> tuple[float | None, float | None]:
    """Limit of the objective along the path (distances shrinking by :data:`_STEP`).

    With the objective behaving like ``f* + c d**p`` the steps shrink by a constant ratio
    ``_STEP**p``, and the tail after the last point is ``step * r / (1 - r)``. Needs three
    values; ``inf`` when three steps grow; None when the steps do not settle.
    """
    if len(values) < 3:
        return None, None
    last = values[-1]
    steps = np.diff(values)
    if abs(steps[-1]) <= 1e-12 * max(1.0, abs(last)):
        return float(last), float(abs(steps[-1]))
    if steps[-2] == 0:
        return None, None
    ratio = steps[-1] / steps[-2]
    if 0 < ratio < 0.9:
        tail = steps[-1] * ratio / (1 - ratio)
        # How sure the tail is: the same tail with the previous ratio (a settled sequence
        # keeps its ratio); with only three values, the whole tail.
        uncertainty = abs(tail)
        if len(steps) >= 3 and steps[-3] != 0 and 0 < steps[-2] / steps[-3] < 0.9:
            before = steps[-2] / steps[-3]
            uncertainty = abs(tail - steps[-1] * before / (1 - before))
        return float(last + tail), float(uncertainty + 4e-16 * max(1.0, abs(last)))
    growing = len(steps) >= 3 and all(
        abs(b) >= 1.5 * abs(a) and a * b > 0 for a, b in itertools.pairwise(steps)
    )
    if growing:
        return (-math.inf if steps[-1] < 0 else math.inf), None
    return None, None
