"""The design's NLPs solved: CasADi/IPOPT solvers compiled per problem structure and
region, the constraints' values in numpy, the deterministic scan of the box and its
seeds, a solve from a seed, its numpy verification, and the multistart over regions."""

from __future__ import annotations

import contextlib
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from generated import ile
from vsw.models.ile.design.forms import (
    ACTIVE_TOL,
    CONDITIONS_BY_NAME,
    FEAS_TOL,
    IPOPT_OPTIONS,
    IPOPT_SUCCESS,
    MULTIPLIER_TOL,
    OBJECTIVE_SIGN,
    SCAN_POINTS,
    STRICT_MARGIN,
    TABLE_DISTANCE,
    TABLE_LIMITS,
    TARGET_BAND,
    VARIABLES,
    closed_form_quantities,
    numpy_quantities,
    region_of,
)
from vsw.models.ile.design.problem import Constraint, Problem
from vsw.runtime import blas, stop

# --- compiled solvers, cached per problem structure ---------------------------------------

_SOLVERS: dict[tuple, Any] = {}

_WARM_OPTIONS = {
    # Continuation towards an open limit restarts from the previous solution, which lies
    # on the (moved) bounds: keep it there instead of pushing it 1 % into the interior.
    "ipopt.warm_start_init_point": "yes",
    "ipopt.bound_push": 1e-12,
    "ipopt.bound_frac": 1e-12,
    "ipopt.warm_start_bound_push": 1e-12,
    "ipopt.warm_start_bound_frac": 1e-12,
    "ipopt.warm_start_mult_bound_push": 1e-12,
    "ipopt.mu_init": 1e-9,
    "ipopt.max_iter": 80,
}


_PROBE_OPTIONS = {
    # Conflict analysis asks of each relaxed request only whether it is feasible; most stay
    # infeasible, which IPOPT detects sooner when told to expect it.
    "ipopt.expect_infeasible_problem": "yes",
    "ipopt.max_iter": 60,
}
_VARIANTS = {"cold": {}, "warm": _WARM_OPTIONS, "probe": _PROBE_OPTIONS}


def _solver(problem: Problem, variant: str = "cold") -> Any:
    """The ``nlpsol`` for the problem's structure, built once and cached.

    Parameters of the NLP (p): the objective weights and one scale per row, so bounds,
    targets, weights and the region (rows switched off with infinite bounds) change
    without rebuilding. ``variant``: 'cold' starts, 'warm' starts (continuation) or
    'probe' (feasibility questions of the conflict analysis).
    """
    key = (problem.structure(), variant)
    if key in _SOLVERS:
        return _SOLVERS[key]
    import casadi as ca

    terms, rows, timing = key[0]
    x = ca.SX.sym("x", 3)
    qs = closed_form_quantities(x[0], x[1], x[2], timing)
    w = ca.SX.sym("w", len(terms))
    row_scale = ca.SX.sym("s", len(rows))
    f = sum((OBJECTIVE_SIGN[t] * w[i] * qs[t] for i, t in enumerate(terms)), ca.SX(0))
    g = ca.vertcat(*[qs[r] * row_scale[i] for i, r in enumerate(rows)])
    p = ca.vertcat(w, row_scale)
    options = {**IPOPT_OPTIONS, **_VARIANTS[variant]}
    solver = ca.nlpsol("vsw_design", "ipopt", {"x": x, "f": f, "g": g, "p": p}, options)
    blas.libraries_may_have_loaded()  # IPOPT's plugin brings CasADi's OpenBLAS
    _SOLVERS[key] = solver
    return solver


# --- constraint values, violations, objective (numpy) --------------------------------------


def shifted_bounds(c: Constraint, distance: float) -> tuple[float, float]:
    """Bounds of a constraint as imposed: open lower bounds kept ``distance`` inside."""
    lower = c.lower + STRICT_MARGIN * distance if c.open else c.lower
    return lower, c.upper


def _size(c: Constraint, floor: float = 1.0) -> float:
    """The scale of a constraint's bounds: violations and rows are relative to it."""
    finite = [abs(b) for b in (c.lower, c.upper) if math.isfinite(b)]
    return max([floor, *finite])


def _objective_values(problem: Problem, qs: Mapping[str, np.ndarray]) -> np.ndarray:
    total = np.zeros_like(qs["q_fixed"])
    for term, w in problem.weights.items():
        if w:
            total = total + OBJECTIVE_SIGN[term] * w * qs[term]
    return total


def _user_violation(
    problem: Problem, qs: Mapping[str, np.ndarray], floor: float = 1.0
) -> np.ndarray:
    """Sum of the user constraints' violations, each relative to ``max(floor, |bound|)``
    (inf where a value is NaN)."""
    total = np.zeros_like(qs["q_fixed"])
    with np.errstate(invalid="ignore"):
        for c in problem.constraints:
            if not c.user:
                continue
            v = qs[c.quantity]
            excess = np.maximum(c.lower - v, 0.0) + np.maximum(v - c.upper, 0.0)
            total = total + np.where(np.isfinite(v), excess / _size(c, floor), np.inf)
    return total


def _physical_violation(problem: Problem, qs: Mapping[str, np.ndarray]) -> np.ndarray:
    """Violation of the exact conditions: 0 where every physical (and with
    ``conditions='paper'``, every paper) condition holds in its exact strict form."""
    total = np.zeros_like(qs["q_fixed"])
    names = [c[0] for c in ile.CONDITIONS if c[4] and c[0] != "phi0_below_right_angle"]
    if problem.conditions == "paper":
        names += ["theta_I_negative", "extension_before_symmetric_contact"]
    with np.errstate(invalid="ignore"):
        for name in names:
            v = qs[name]
            holds = v > 0 if CONDITIONS_BY_NAME[name][2] else v >= 0
            total = total + np.where(holds, 0.0, np.where(np.isfinite(v), np.abs(v) + 1e-12,
                                                          np.inf))  # fmt: skip
    return total


# --- starts --------------------------------------------------------------------------------


def _halton(n: int, dims: int = 3) -> np.ndarray:
    """The first ``n`` points of the Halton sequence (bases 2, 3, 5), skipping 0."""
    out = np.empty((n, dims))
    index = np.arange(1, n + 1)
    for d, base in enumerate((2, 3, 5)[:dims]):
        value = np.zeros(n)
        f = 1.0 / base
        i = index.copy()
        while np.any(i):
            value += f * (i % base)
            i //= base
            f /= base
        out[:, d] = value
    return out


@dataclass
class _Scan:
    x: np.ndarray
    qs: dict[str, np.ndarray]
    region: np.ndarray
    physical: np.ndarray  # violation of the exact conditions
    user: np.ndarray  # violation of the user constraints (relative to max(1, |bound|))
    band: np.ndarray  # the same relative to |bound|: the distance from a target in %
    objective: np.ndarray
    defined: np.ndarray  # the objective and every NLP row are numbers: IPOPT can start here

    def feasible(self, tol: float = FEAS_TOL) -> np.ndarray:
        return (self.physical == 0) & (self.user <= tol) & self.defined


def scan_box(problem: Problem, n: int = SCAN_POINTS) -> _Scan:
    """The closed forms at ``n`` Halton points of the box (open limits kept away)."""
    lbx, ubx = problem.bounds(2, 1.0)  # region 2 has no theta_II restriction
    x = lbx + (ubx - lbx) * _halton(n)
    qs = numpy_quantities(x, timing=problem.timing)
    objective = _objective_values(problem, qs)
    defined = np.isfinite(objective)
    for row in problem.rows():
        defined &= np.isfinite(qs[row])
    return _Scan(x, qs, region_of(x, qs), _physical_violation(problem, qs),
                 _user_violation(problem, qs), _user_violation(problem, qs, 1e-300),
                 objective, defined)  # fmt: skip


def _seeds(problem: Problem, scan: _Scan, per_region: int) -> list[tuple[int, np.ndarray]]:
    """(region, start) pairs, most promising first.

    In each region: the points that satisfy every condition and come within
    :data:`TARGET_BAND` of the user constraints, best objective first, spread apart; or,
    when there is none, the least-violating point. Regions ordered by their best seed.
    """
    span = np.maximum(problem.ubx - problem.lbx, 1e-12)
    span = np.where(np.isfinite(span), span, 1.0)
    ranked: list[tuple[tuple[float, float], int, np.ndarray]] = []
    objective = np.nan_to_num(scan.objective, nan=np.inf)
    for region in problem.regions:
        inside = scan.region == region
        if not inside.any():
            continue
        inside &= scan.defined
        near = inside & (scan.physical == 0) & (scan.band <= TARGET_BAND)
        chosen: list[np.ndarray] = []
        keys: list[tuple[float, float]] = []
        for idx in np.flatnonzero(near)[np.argsort(objective[near], kind="stable")]:
            point = scan.x[idx]
            if all(np.max(np.abs(point - c) / span) > 0.15 for c in chosen):
                chosen.append(point)
                keys.append((0.0, float(objective[idx])))
            if len(chosen) == per_region:
                break
        merit = scan.physical + scan.user
        merit = np.where(inside & np.isfinite(merit), merit, np.inf)
        best = int(np.argmin(merit))
        if not chosen and np.isfinite(merit[best]):
            chosen.append(scan.x[best])
            keys.append((1.0 + float(merit[best]), float(objective[best])))
        ranked += [(k, region, point) for k, point in zip(keys, chosen)]
    ranked.sort(key=lambda item: item[0])
    return [(region, point) for _, region, point in ranked]


# --- solve ---------------------------------------------------------------------------------


@dataclass
class Solve:
    """One IPOPT solve in one region; ``check`` fills the verification fields."""

    x: np.ndarray
    region: int
    distance: float
    objective: float  # IPOPT's; replaced by the numpy value when checked
    ipopt_status: str
    iterations: int
    lam_x: np.ndarray
    lam_g: np.ndarray
    checked: bool = False
    verified: bool = False  # every constraint confirmed by the closed forms in numpy
    violation: float = math.inf  # user constraints (relative) + exact conditions
    open_active: tuple[str, ...] = ()  # open limits the optimum presses against

    @property
    def converged(self) -> bool:
        return self.ipopt_status in IPOPT_SUCCESS

    @property
    def success(self) -> bool:
        return self.converged and self.verified


def _row_bounds(
    problem: Problem, region: int, distance: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(lbg, ubg, scales) of the NLP rows in a region: every constraint on a quantity
    intersected into its row, rows a region does not use left free."""
    _, rows, _ = problem.structure()
    lower = dict.fromkeys(rows, -math.inf)
    upper = dict.fromkeys(rows, math.inf)
    size = dict.fromkeys(rows, 1.0)
    for c in problem.region_constraints(region):
        lo, hi = shifted_bounds(c, distance)
        lower[c.quantity] = max(lower[c.quantity], lo)
        upper[c.quantity] = min(upper[c.quantity], hi)
        size[c.quantity] = max(size[c.quantity], _size(c))
    scales = np.array([1.0 / size[r] for r in rows])
    lbg = np.array([lower[r] for r in rows]) * scales
    ubg = np.array([upper[r] for r in rows]) * scales
    return lbg, ubg, scales


def solve_from(
    problem: Problem,
    region: int,
    x0: np.ndarray,
    distance: float = 1.0,
    warm: Solve | None = None,
    probe: bool = False,
) -> Solve:
    """IPOPT from ``x0`` in ``region`` at ``distance`` from the open limits (the compiled
    solver of :func:`_solver`), its result checked in numpy (:func:`verified_solve`)."""
    terms, _rows, _ = problem.structure()
    lbx, ubx = problem.bounds(region, distance)
    lbg, ubg, scales = _row_bounds(problem, region, distance)
    if np.any(lbx > ubx) or np.any(lbg > ubg):
        empty = np.zeros(0)
        return Solve(np.clip(x0, problem.lbx, problem.ubx), region, distance, math.inf,
                      "Empty_Region", 0, empty, empty, checked=True)  # fmt: skip
    solver = _solver(problem, "warm" if warm is not None else "probe" if probe else "cold")
    p = np.concatenate([[problem.weights[t] for t in terms], scales])
    start: dict[str, Any] = {"x0": np.clip(x0, lbx, ubx)}
    if warm is not None and len(warm.lam_x):
        start.update(lam_x0=warm.lam_x, lam_g0=warm.lam_g)
    # CasADi writes some diagnostics (over-constrained NLP, multipliers not computed) to
    # Python's stderr; the result object carries what matters, so they are swallowed.
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        sol = solver(p=p, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, **start)
    stop.check()  # IPOPT ends an interrupted solve with a status, not an exception
    stats = solver.stats()
    x = np.clip(np.array(sol["x"], dtype=float).reshape(-1), lbx, ubx)
    return Solve(
        x, region, distance, float(sol["f"]), str(stats.get("return_status", "unknown")),
        int(stats.get("iter_count", -1)), np.array(sol["lam_x"], dtype=float).reshape(-1),
        np.array(sol["lam_g"], dtype=float).reshape(-1),
    )  # fmt: skip


def verified_solve(problem: Problem, s: Solve) -> Solve:
    """Verify a solve with the closed forms in numpy (IPOPT's word is not enough): every
    user constraint to FEAS_TOL, every physical condition in its exact strict form."""
    if s.checked:
        return s
    qs = numpy_quantities(s.x[None, :], timing=True)
    s.objective = float(_objective_values(problem, qs)[0])
    user = float(_user_violation(problem, qs)[0])
    physical = float(_physical_violation(problem, qs)[0])
    s.violation = user + physical
    s.verified = (
        user <= FEAS_TOL
        and physical == 0
        and math.isfinite(s.objective)
        and math.isfinite(float(qs["speed"][0]))
    )
    if s.verified:
        _, rows, _ = problem.structure()
        _, _, scales = _row_bounds(problem, s.region, s.distance)
        lam_g = dict(zip(rows, s.lam_g * scales))  # multipliers of the unscaled rows
        s.open_active = _open_active(problem, s, qs, lam_g)
    s.checked = True
    return s


def _open_active(
    problem: Problem, s: Solve, qs: Mapping[str, np.ndarray], lam_g: Mapping[str, float]
) -> tuple[str, ...]:
    """Open limits at their kept distance whose multiplier pulls the optimum onto them."""
    pull = MULTIPLIER_TOL * max(1.0, abs(s.objective))
    names: list[str] = []
    for i, side in sorted(problem.table_open):
        # The kept bound itself, not the region's (theta_II = 0 bounds two regions).
        bound = _kept_table_bound(i, side, s.distance)
        near = abs(s.x[i] - bound) <= ACTIVE_TOL * max(1.0, abs(bound))
        if near and abs(s.lam_x[i]) > pull:
            names.append(_limit_name(i, side))
    for c in problem.region_constraints(s.region):
        if not c.open:
            continue
        lower, _ = shifted_bounds(c, s.distance)
        value = float(qs[c.quantity][0])
        near = abs(value - lower) <= ACTIVE_TOL * max(1.0, abs(lower)) + 1e-12
        if near and abs(lam_g.get(c.quantity, 0.0)) > pull and c.name not in names:
            names.append(c.name)
    return tuple(names)


def _kept_table_bound(i: int, side: int, distance: float) -> float:
    limit = TABLE_LIMITS[VARIABLES[i]][side]
    return limit + (1 if side == 0 else -1) * TABLE_DISTANCE * distance


def limit_text(limit: float) -> str:
    """A table limit as people write it: 1, 0, pi/2, -pi/2."""
    if abs(abs(limit) - math.pi / 2) < 1e-12:
        return "-pi/2" if limit < 0 else "pi/2"
    return f"{limit:g}"


def _limit_name(i: int, side: int) -> str:
    name = VARIABLES[i]
    if name == "phi0" and side == 1:
        return "phi0_below_right_angle"
    return f"{name} {'>' if side == 0 else '<'} {limit_text(TABLE_LIMITS[name][side])}"


def _better(a: Solve, b: Solve | None) -> bool:
    return b is None or a.objective < b.objective - 1e-12 * max(1.0, abs(b.objective))


def multistart(
    problem: Problem, per_region: int, scan: _Scan | None = None, probe: bool = False
) -> tuple[Solve | None, list[Solve], _Scan]:
    """Best verified converged solve (or None), every solve, and the scan.

    Only a converged solve that beats the best so far is verified (a numpy evaluation
    costs about as much as a short solve).
    """
    scan = scan_box(problem) if scan is None else scan
    solves: list[Solve] = []
    best: Solve | None = None

    def consider(s: Solve) -> None:
        nonlocal best
        solves.append(s)
        # IPOPT's objective first (cheap); the checked, numpy one decides.
        if s.converged and _better(s, best) and verified_solve(problem, s).verified:
            if _better(s, best):
                best = s

    for region, x0 in _seeds(problem, scan, per_region):
        consider(solve_from(problem, region, x0, probe=probe))
        if probe and best is not None:
            break
    # An optimum on the boundary between two regions may continue into the neighbour.
    if best is not None:
        tried = {s.region for s in solves}
        for other in _neighbours(problem, best):
            if other not in tried:
                consider(solve_from(problem, other, best.x))
    return best, solves, scan


def _neighbours(problem: Problem, s: Solve) -> list[int]:
    """Regions that share the boundary the solution lies on."""
    out = []
    if abs(s.x[1]) <= 1e-9 and s.region in (0, 1):
        out.append(1 - s.region)
    qs = numpy_quantities(s.x[None, :], timing=False)
    if abs(float(qs["theta_I_negative"][0])) <= 1e-9 and s.region in (1, 2):
        out.append(3 - s.region)
    return [r for r in out if r in problem.regions]
