"""Constrained design of ILE gait parameters with CasADi and IPOPT.

The inverse question of :mod:`vsw.analysis`: which (beta, theta_II, phi0) give the gait a
user wants within what the robot can do. The NLP is built from the generated closed forms
(``generated.ile`` accepts CasADi SX), so every function and derivative is exact:

* objective: a weighted sum of ``-speed``, ``eigenvalue`` (eq. 19) and the cost of
  transport ``E_c(q^f) / (m g L)`` (eq. 20 per unit step length);
* equality targets: speed, q^f, step length, step frequency;
* inequalities: every *physical* existence condition of ``ile.CONDITIONS`` in its exact
  form (strict ones as ``margin >= STRICT_MARGIN``), the stance contact margin
  ``>= max(0, min_contact_margin)``, an eigenvalue upper bound, step length and step
  frequency bounds, and bounds / fixed values of the decision variables.

The step period inside the NLP is the generated closed form (Carlson R_F by duplication),
which CasADi differentiates exactly; ``tests/test_design.py`` checks it against the SciPy
Legendre form and the time-domain simulation.

Each request is solved from several deterministic starts (the best points of a coarse grid
over the bounds) and the best verified solution is kept. A solution counts only when IPOPT
reports success *and* a numpy re-evaluation of the closed forms confirms every constraint;
the design is then re-checked by the independent time-domain simulation
(:mod:`vsw.simulate`). When no start reaches a feasible point the request is reported
infeasible and each user constraint is relaxed in turn to name the conflicting ones.

``import vsw.design`` is cheap: casadi and scipy are imported inside functions.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from generated import ile
from generated.ile_params import PARAMETERS
from vsw.errors import VswInputError
from vsw.params import RobotScale

__all__ = [
    "OBJECTIVES",
    "STRICT_MARGIN",
    "DesignResult",
    "design",
    "register_cli",
]

STRICT_MARGIN = 1e-6
"""A strict condition ``margin > 0`` is imposed as ``margin >= STRICT_MARGIN``; a solution
that sits on this margin is an open-boundary supremum and is reported as such."""

CLOSED_MARGIN = 1e-9
"""A non-strict condition ``margin >= 0`` (stance contact) is imposed as
``margin >= CLOSED_MARGIN``: exactly at 0 the verifying simulation would see a lift-off
from round-off alone."""

OBJECTIVES = ("speed", "eigenvalue", "cost_of_transport")
"""Objective terms. The weighted sum minimised is
``-w_speed speed + w_eigenvalue eigenvalue + w_cot cost_of_transport``."""

_OBJECTIVE_ALIASES = {
    "speed": {"speed": 1.0},
    "maximize_speed": {"speed": 1.0},
    "max_speed": {"speed": 1.0},
    "eigenvalue": {"eigenvalue": 1.0},
    "minimize_eigenvalue": {"eigenvalue": 1.0},
    "cost_of_transport": {"cost_of_transport": 1.0},
    "minimize_cost_of_transport": {"cost_of_transport": 1.0},
    "cot": {"cost_of_transport": 1.0},
}

VARIABLES = ("beta", "theta_II", "phi0")

# Physical conditions imposed as NLP rows. phi0_below_right_angle (pi/2 - phi0 > 0) is a
# pure variable bound and is imposed through the bounds on phi0 instead: a duplicate
# linear row would make the active set degenerate.
_PHYSICAL = tuple(c for c in ile.CONDITIONS if c[4])
_CONDITION_ROWS = tuple(c[0] for c in _PHYSICAL if c[0] != "phi0_below_right_angle")
_STRICT = {c[0]: c[2] for c in ile.CONDITIONS}
_MARGIN_INDEX = {c[0]: i for i, c in enumerate(ile.CONDITIONS)}
_METRIC_ROWS = ("eigenvalue", "step_length", "step_frequency", "speed", "q_fixed")

# Distance kept from the open intervals of the parameter table (beta in (0, 1), ...).
_TABLE_EPS = 1e-3
_TABLE = {p.name: (p.lower, p.upper) for p in PARAMETERS}

# Tolerances of the verification of a returned design (closed forms re-evaluated in numpy).
_FEAS_TOL = 1e-8  # constraint rows, relative to max(1, |bound|)
_ACTIVE_TOL = 1e-6  # a row within this (relative) of a bound is reported active

_IPOPT_OPTIONS = {
    "ipopt.print_level": 0,
    "print_time": False,
    "ipopt.sb": "yes",
    "ipopt.tol": 1e-10,
    "ipopt.constr_viol_tol": 1e-11,
    "ipopt.acceptable_tol": 1e-7,
    "ipopt.acceptable_constr_viol_tol": 1e-10,
    "ipopt.max_iter": 150,
    "ipopt.mu_strategy": "adaptive",
    # Trial points outside the walking region evaluate to NaN by design; IPOPT cuts the
    # step back, and CasADi must not print a warning for each of them.
    "show_eval_warnings": False,
}
_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


# --- closed-form quantities (numpy or CasADi) ---------------------------------------------


def _quantities(beta: Any, theta_II: Any, phi0: Any, timing: bool = True) -> dict[str, Any]:
    """Every quantity the NLP uses, from the generated code (numpy arrays or CasADi SX)."""
    q_fixed = ile.q_fixed(beta, theta_II, phi0)
    step_length = ile.step_length(beta, phi0)
    margins = ile.condition_margins(beta, theta_II, phi0)
    out: dict[str, Any] = {
        "q_fixed": q_fixed,
        "eigenvalue": ile.eigenvalue(beta, phi0),
        "step_length": step_length,
        # E_c at the fixed point per unit distance, in units of m g: E_c / (m g L).
        "cost_of_transport": ile.energy_complement(beta, theta_II, phi0, q_fixed, 1.0, 1.0, 1.0)
        / step_length,
    }
    for name in _CONDITION_ROWS:
        out[name] = margins[_MARGIN_INDEX[name]]
    if timing:
        tau_I_II, tau_III_IV = ile.phase_durations(beta, theta_II, phi0, q_fixed)
        period = tau_I_II + tau_III_IV
        out["step_period"] = period
        out["step_frequency"] = 1.0 / period
        out["speed"] = step_length / period
    return out


def _numpy_quantities(x: np.ndarray, timing: bool = True) -> dict[str, np.ndarray]:
    """:func:`_quantities` on an ``(n, 3)`` array of designs; NaN where undefined."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    with np.errstate(all="ignore"):
        return {
            k: np.broadcast_to(v, x.shape[:1]).astype(float)
            for k, v in _quantities(x[:, 0], x[:, 1], x[:, 2], timing).items()
        }


# --- the problem ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Row:
    """One inequality/equality constraint row: ``lower <= quantity <= upper``."""

    name: str  # name reported to the user (active / conflicting constraints)
    quantity: str  # key of _quantities
    lower: float
    upper: float
    user: bool  # a user constraint (relaxed in the conflict analysis); else physical
    relax_key: str  # user constraints with the same key are relaxed together


@dataclass
class _Problem:
    weights: dict[str, float]
    lbx: np.ndarray
    ubx: np.ndarray
    rows: list[_Row]
    bound_names: dict[tuple[int, int], str]  # (variable, 0 lower / 1 upper) -> name
    table_clipped: set[tuple[int, int]]  # bounds that are the open table limits
    fixed: dict[str, float]

    def structure(self) -> tuple:
        """Cache key of the compiled solver: the objective terms and the row quantities."""
        return (
            tuple(sorted(k for k, w in self.weights.items() if w != 0)),
            tuple(r.quantity for r in self.rows),
        )

    def without(self, relax_key: str) -> _Problem:
        """The same problem with one user constraint (group) removed."""
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        fixed = dict(self.fixed)
        for (i, side), name in self.bound_names.items():
            if name == relax_key or (relax_key == f"fix_{VARIABLES[i]}" and VARIABLES[i] in fixed):
                lo, hi = _TABLE[VARIABLES[i]]
                if side == 0:
                    lbx[i] = lo + _TABLE_EPS
                else:
                    ubx[i] = hi - _TABLE_EPS
        if relax_key.startswith("fix_"):
            fixed.pop(relax_key[4:], None)
        rows = [r for r in self.rows if not (r.user and r.relax_key == relax_key)]
        # Relaxing the user contact margin keeps the physical one (N >= 0).
        if relax_key == "min_contact_margin":
            rows.append(
                _Row("stance_contact", "stance_contact", CLOSED_MARGIN, math.inf, False, "")
            )
        return _Problem(self.weights, lbx, ubx, rows, self.bound_names, self.table_clipped, fixed)

    def user_constraints(self) -> list[str]:
        """Relax keys of every user constraint, in a stable order."""
        keys: list[str] = []
        for name in self.bound_names.values():
            if name not in keys and not name.startswith("_table"):
                keys.append(name)
        for r in self.rows:
            if r.user and r.relax_key not in keys:
                keys.append(r.relax_key)
        return keys


def _normalise_objective(objective: Any, has_targets: bool) -> dict[str, float]:
    if objective is None:
        if not has_targets:
            raise VswInputError(
                "design needs an objective (speed, eigenvalue, cost_of_transport) or a target"
            )
        return {"eigenvalue": 1.0}  # a target alone: the most stable gait that meets it
    if isinstance(objective, str):
        key = objective.strip().lower().replace("-", "_").replace(" ", "_")
        if key not in _OBJECTIVE_ALIASES:
            raise VswInputError(
                f"objective = {objective!r} is not one of speed, eigenvalue, cost_of_transport"
            )
        return dict(_OBJECTIVE_ALIASES[key])
    if isinstance(objective, Mapping):
        weights: dict[str, float] = {}
        for name, weight in objective.items():
            key = str(name).replace("-", "_")
            if key == "cot":
                key = "cost_of_transport"
            if key not in OBJECTIVES:
                raise VswInputError(f"objective weight {name!r} is not one of {OBJECTIVES}")
            w = float(weight)
            if not math.isfinite(w) or w < 0:
                raise VswInputError(f"objective weight {name} = {weight!r} must be finite, >= 0")
            weights[key] = w
        if not any(weights.values()):
            raise VswInputError("objective weights are all zero")
        return weights
    raise VswInputError(f"objective = {objective!r} must be a name or a mapping of weights")


def _finite(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise VswInputError(f"{name} = {value!r} is not a real number") from None
    if not math.isfinite(v):
        raise VswInputError(f"{name} = {value!r} must be finite")
    return v


def _si_factors(scale: RobotScale | None) -> dict[str, tuple[str, float]]:
    """SI names -> (dimensionless quantity, factor: dimensionless = SI / factor)."""
    if scale is None:
        return {}
    return {
        "speed_m_s": ("speed", math.sqrt(scale.gravity * scale.leg_length)),
        "step_length_m": ("step_length", scale.leg_length),
        "step_frequency_hz": ("step_frequency", 1.0 / scale.time_unit_s),
    }


_SI_NAMES = ("speed_m_s", "step_length_m", "step_frequency_hz")
_TARGETS = ("speed", "q_fixed", "step_length", "step_frequency")
_METRIC_BOUNDS = ("step_length", "step_frequency")


def _to_dimensionless(name: str, value: float, scale: RobotScale | None) -> tuple[str, float]:
    if name in _SI_NAMES:
        if scale is None:
            raise VswInputError(f"{name} is in SI units and needs a robot scale (leg length)")
        quantity, factor = _si_factors(scale)[name]
        return quantity, value / factor
    return name, value


def _build_problem(
    weights: dict[str, float],
    targets: Mapping[str, float] | None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None,
    fixed: Mapping[str, float] | None,
    min_contact_margin: float,
    max_eigenvalue: float | None,
    scale: RobotScale | None,
) -> _Problem:
    lbx = np.empty(3)
    ubx = np.empty(3)
    bound_names: dict[tuple[int, int], str] = {}
    table_clipped: set[tuple[int, int]] = set()
    fixed_v: dict[str, float] = {}
    bounds = dict(bounds or {})
    for name in bounds:
        if name not in VARIABLES and name not in _METRIC_BOUNDS and name not in _SI_NAMES:
            raise VswInputError(
                f"bound on {name!r}: bounds exist for {VARIABLES + _METRIC_BOUNDS + _SI_NAMES}"
            )
    for name in fixed or {}:
        if name not in VARIABLES:
            raise VswInputError(f"fix {name!r}: only {', '.join(VARIABLES)} can be fixed")
    for i, name in enumerate(VARIABLES):
        lo_t, hi_t = _TABLE[name]
        lo, hi = lo_t + _TABLE_EPS, hi_t - _TABLE_EPS
        user_lo, user_hi = bounds.get(name, (None, None))
        if user_lo is not None:
            user_lo = _finite(f"{name} lower bound", user_lo)
            if user_lo >= hi_t:
                raise VswInputError(f"{name} lower bound {user_lo:.6g} >= {hi_t:.6g}, the "
                                    f"table limit of {name}")  # fmt: skip
            if user_lo > lo:
                lo = user_lo
                bound_names[(i, 0)] = f"{name}_min"
        if user_hi is not None:
            user_hi = _finite(f"{name} upper bound", user_hi)
            if user_hi <= lo_t:
                raise VswInputError(f"{name} upper bound {user_hi:.6g} <= {lo_t:.6g}, the "
                                    f"table limit of {name}")  # fmt: skip
            if user_hi < hi:
                hi = user_hi
                bound_names[(i, 1)] = f"{name}_max"
        if (i, 0) not in bound_names:
            table_clipped.add((i, 0))
        if (i, 1) not in bound_names:
            table_clipped.add((i, 1))
        if lo > hi:
            raise VswInputError(f"{name} bounds are empty: lower {lo:.6g} > upper {hi:.6g}")
        if fixed and name in fixed:
            from vsw.params import check_parameter

            value = float(check_parameter(name, _finite(name, fixed[name])))
            if not lo - 1e-12 <= value <= hi + 1e-12:
                raise VswInputError(f"fixed {name} = {value:.6g} is outside its bounds "
                                    f"[{lo:.6g}, {hi:.6g}]")  # fmt: skip
            lo = hi = value
            fixed_v[name] = value
            bound_names[(i, 0)] = bound_names[(i, 1)] = f"fix_{name}"
            table_clipped.discard((i, 0))
            table_clipped.discard((i, 1))
        lbx[i], ubx[i] = lo, hi

    rows: list[_Row] = []
    margin = _finite("min_contact_margin", min_contact_margin)
    for name in _CONDITION_ROWS:
        lower = STRICT_MARGIN if _STRICT[name] else CLOSED_MARGIN
        if name == "stance_contact" and margin > CLOSED_MARGIN:
            rows.append(_Row("min_contact_margin", name, margin, math.inf, True,
                             "min_contact_margin"))  # fmt: skip
            continue
        rows.append(_Row(name, name, lower, math.inf, False, ""))
    if max_eigenvalue is not None:
        v = _finite("max_eigenvalue", max_eigenvalue)
        rows.append(_Row("max_eigenvalue", "eigenvalue", -math.inf, v, True, "max_eigenvalue"))
    metric: dict[str, list[float]] = {}
    for name, (lo, hi) in bounds.items():
        if name in VARIABLES:
            continue
        for side, value in enumerate((lo, hi)):
            if value is None:
                continue
            quantity, v = _to_dimensionless(name, _finite(f"{name} bound", value), scale)
            metric.setdefault(quantity, [-math.inf, math.inf])
            if side == 0:
                metric[quantity][0] = max(metric[quantity][0], v)
            else:
                metric[quantity][1] = min(metric[quantity][1], v)
    for quantity, (lo, hi) in metric.items():
        if lo > hi:
            raise VswInputError(f"{quantity} bounds are empty: lower {lo:.6g} > upper {hi:.6g}")
        if lo > -math.inf:
            rows.append(_Row(f"min_{quantity}", quantity, lo, math.inf, True, f"min_{quantity}"))
        if hi < math.inf:
            rows.append(_Row(f"max_{quantity}", quantity, -math.inf, hi, True, f"max_{quantity}"))
    seen: dict[str, float] = {}
    for name, value in (targets or {}).items():
        if name not in _TARGETS and name not in _SI_NAMES:
            raise VswInputError(f"target {name!r} is not one of {_TARGETS + _SI_NAMES}")
        quantity, v = _to_dimensionless(name, _finite(f"target {name}", value), scale)
        if v <= 0:
            raise VswInputError(f"target {name} = {value!r} must be > 0")
        if quantity in seen and not math.isclose(seen[quantity], v, rel_tol=1e-12):
            raise VswInputError(f"two different targets for {quantity}")
        seen[quantity] = v
        rows.append(_Row(f"target_{quantity}", quantity, v, v, True, f"target_{quantity}"))
    return _Problem(weights, lbx, ubx, rows, bound_names, table_clipped, fixed_v)


# --- compiled solvers, cached per problem structure ---------------------------------------

_SOLVERS: dict[tuple, Any] = {}


def _solver(problem: _Problem) -> tuple[Any, Any]:
    """``(nlpsol, evaluator)`` for the problem's structure, built once and cached.

    Parameters of the NLP (p): the objective weights and one scale per row, so bounds,
    targets and weights change without rebuilding.
    """
    key = problem.structure()
    if key in _SOLVERS:
        return _SOLVERS[key]
    import casadi as ca

    terms, quantities = key
    x = ca.SX.sym("x", 3)
    timing = "speed" in terms or any(
        q in ("speed", "step_frequency", "step_period") for q in quantities
    )
    qs = _quantities(x[0], x[1], x[2], timing)
    w = ca.SX.sym("w", len(terms))
    row_scale = ca.SX.sym("s", len(quantities))
    sign = {"speed": -1.0, "eigenvalue": 1.0, "cost_of_transport": 1.0}
    f = sum((sign[t] * w[i] * qs[t] for i, t in enumerate(terms)), ca.SX(0))
    g = ca.vertcat(*[qs[q] * row_scale[i] for i, q in enumerate(quantities)]) if quantities \
        else ca.SX(0, 1)  # fmt: skip
    p = ca.vertcat(w, row_scale)
    solver = ca.nlpsol("vsw_design", "ipopt", {"x": x, "f": f, "g": g, "p": p}, _IPOPT_OPTIONS)
    evaluator = ca.Function("vsw_design_eval", [x, p], [f, g])
    _SOLVERS[key] = (solver, evaluator)
    return solver, evaluator


# --- starts --------------------------------------------------------------------------------


def _grid(problem: _Problem, n: int) -> np.ndarray:
    axes = []
    for i in range(3):
        lo, hi = problem.lbx[i], problem.ubx[i]
        if lo == hi:
            axes.append(np.array([lo]))
        else:
            # Interior points only: the ends are open table limits or user bounds.
            axes.append(lo + (hi - lo) * (np.arange(n) + 0.5) / n)
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.reshape(-1) for m in mesh], axis=1)


def _objective_values(problem: _Problem, qs: dict[str, np.ndarray]) -> np.ndarray:
    sign = {"speed": -1.0, "eigenvalue": 1.0, "cost_of_transport": 1.0}
    total = np.zeros_like(qs["q_fixed"])
    for term, w in problem.weights.items():
        if w:
            total = total + sign[term] * w * qs[term]
    return total


def _violations(problem: _Problem, qs: dict[str, np.ndarray]) -> np.ndarray:
    """Sum of relative constraint violations per design (inf where a quantity is NaN)."""
    total = np.zeros_like(qs["q_fixed"])
    with np.errstate(invalid="ignore"):
        for r in problem.rows:
            v = qs[r.quantity]
            size = max(1.0, abs(r.lower) if math.isfinite(r.lower) else abs(r.upper))
            excess = np.maximum(r.lower - v, 0.0) + np.maximum(v - r.upper, 0.0)
            total = total + np.where(np.isfinite(v), excess / size, np.inf)
    return total


def _starts(problem: _Problem, n_starts: int, n_grid: int = 9) -> np.ndarray:
    """Deterministic starts: grid points that walk, best merit first, spread apart."""
    grid = _grid(problem, n_grid)
    timing = any(r.quantity in ("speed", "step_frequency") for r in problem.rows) or bool(
        problem.weights.get("speed")
    )
    qs = _numpy_quantities(grid, timing=True if timing else False)
    walks = np.ones(len(grid), dtype=bool)
    with np.errstate(invalid="ignore"):
        for name in _CONDITION_ROWS:
            walks &= qs[name] >= (STRICT_MARGIN if _STRICT[name] else 0.0)
    if timing:
        walks &= np.isfinite(qs["speed"])
    objective = _objective_values(problem, qs)
    violation = _violations(problem, qs)
    # Merit: walking points first, then the least constraint violation, then the objective.
    merit = (
        np.where(walks, 0.0, 1e6)
        + 1e3 * np.minimum(violation, 1e3)
        + np.nan_to_num(objective, nan=1e3)
    )
    order = np.argsort(merit, kind="stable")
    span = np.maximum(problem.ubx - problem.lbx, 1e-12)
    chosen: list[np.ndarray] = []
    for idx in order:
        point = grid[idx]
        if all(np.max(np.abs(point - c) / span) > 0.25 for c in chosen):
            chosen.append(point)
        if len(chosen) == n_starts:
            break
    return np.array(chosen)


# --- solve ---------------------------------------------------------------------------------


@dataclass
class _Solve:
    x: np.ndarray
    objective: float
    ipopt_status: str
    success: bool  # IPOPT success and verified
    violation: float
    iterations: int
    feasible: bool  # the final point satisfies every constraint (converged or not)


def _row_scales(problem: _Problem) -> np.ndarray:
    """Rows divided by the size of their bound: targets and bounds become O(1)."""
    scales = []
    for r in problem.rows:
        b = r.lower if math.isfinite(r.lower) else r.upper
        scales.append(1.0 / max(abs(b), 1.0) if r.user else 1.0)
    return np.array(scales)


def _solve_from(problem: _Problem, x0: np.ndarray) -> _Solve:
    solver, _ = _solver(problem)
    terms, _ = problem.structure()
    scales = _row_scales(problem)
    p = np.concatenate([[problem.weights[t] for t in terms], scales])
    lbg = np.array([r.lower for r in problem.rows]) * scales
    ubg = np.array([r.upper for r in problem.rows]) * scales
    # CasADi writes some diagnostics (over-constrained NLP, multipliers not computed) to
    # Python's stderr; the result object carries what matters, so they are swallowed.
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        sol = solver(x0=x0, p=p, lbx=problem.lbx, ubx=problem.ubx, lbg=lbg, ubg=ubg)
    stats = solver.stats()
    status = str(stats.get("return_status", "unknown"))
    x = np.clip(np.array(sol["x"]).reshape(-1), problem.lbx, problem.ubx)
    qs = _numpy_quantities(x[None, :])
    violation = float(_violations(problem, qs)[0])
    objective = float(_objective_values(problem, qs)[0])
    # IPOPT's word is not enough: the closed forms must confirm every constraint and every
    # physical condition must hold in its exact (strict) form.
    walks = all(
        float(qs[name][0]) > 0 or (not _STRICT[name] and float(qs[name][0]) >= 0)
        for name in _CONDITION_ROWS
    ) and bool(problem.ubx[2] < math.pi / 2)
    feasible = (
        violation <= _FEAS_TOL
        and walks
        and math.isfinite(objective)
        and math.isfinite(float(qs["speed"][0]))
    )
    ok = status in _SUCCESS and feasible
    return _Solve(x, objective, status, ok, violation, int(stats.get("iter_count", -1)), feasible)


def _multistart(problem: _Problem, n_starts: int) -> tuple[_Solve | None, list[_Solve]]:
    """Best verified converged solve (or None) and all solves."""
    solves = [_solve_from(problem, x0) for x0 in _starts(problem, n_starts)]
    good = [s for s in solves if s.success]
    best = min(good, key=lambda s: s.objective) if good else None
    return best, solves


def _describe(
    problem: _Problem, solve: _Solve, scale: RobotScale | None, verify: bool
) -> dict[str, Any]:
    """Analysis, active constraints, open boundaries and simulation check of a point."""
    from vsw.analysis import analyze

    x = solve.x
    analysis = analyze(x[0], x[1], x[2], scale)
    qs = _numpy_quantities(x[None, :])
    active, open_boundary = _active(problem, x)
    return {
        "beta": float(x[0]),
        "theta_II": float(x[1]),
        "phi0": float(x[2]),
        "analysis": analysis,
        "objective": solve.objective,
        "cost_of_transport": float(qs["cost_of_transport"][0]),
        "step_frequency": float(qs["step_frequency"][0]),
        "active_constraints": tuple(active),
        "open_boundary": tuple(open_boundary),
        "simulation_rel_error": _simulation_error(x, analysis) if verify else None,
    }


def _open_boundary_note(open_boundary: tuple[str, ...]) -> str:
    if not open_boundary:
        return ""
    return (
        "; the optimum (a supremum or infimum, not attained) lies on an open boundary the "
        "model never reaches (" + ", ".join(open_boundary) + "): the returned design keeps "
        f"a margin of {STRICT_MARGIN:g} (parameter limits: {_TABLE_EPS:g}) inside it"
    )


# --- result --------------------------------------------------------------------------------


@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`design`.

    Attributes
    ----------
    status : {'optimal', 'infeasible', 'not-converged'}
        'optimal': IPOPT converged from at least one start and the closed forms confirm
        every constraint; a local optimum (the best of several starts).
    beta, theta_II, phi0 : float or None
        The design (radians); None unless a design was found.
    analysis : vsw.analysis.Analysis or None
        All outputs of ``vsw analyze`` at the design.
    objective : float or None
        The minimised weighted sum (speed enters with a minus sign).
    cost_of_transport, step_frequency : float or None
        E_c / (m g L) and 1 / step period (dimensionless) at the design; ``to_dict`` adds
        ``step_frequency_hz`` when a scale is given.
    active_constraints : tuple of str
        Constraints at their bound (targets always).
    open_boundary : tuple of str
        Strict conditions or open parameter limits the optimum presses against: the
        supremum is not attained, the returned design keeps a margin of STRICT_MARGIN.
    simulation_rel_error : float or None
        Largest relative difference of q^f, step period, step length and speed between the
        closed form and the time-domain simulation started at q^f.
    conflicting_constraints : tuple of str
        When infeasible: user constraints whose removal alone restores feasibility.
    message : str
    ipopt_status : str
        Return status of the IPOPT solve behind the result (the best start).
    starts : int
        Number of IPOPT starts.
    """

    status: str
    beta: float | None
    theta_II: float | None
    phi0: float | None
    analysis: Any
    objective: float | None
    cost_of_transport: float | None
    step_frequency: float | None
    active_constraints: tuple[str, ...]
    open_boundary: tuple[str, ...]
    simulation_rel_error: float | None
    conflicting_constraints: tuple[str, ...]
    message: str
    ipopt_status: str
    starts: int
    energy_unit: str | None = field(default=None, repr=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON contract of ``vsw design --json``: the analysis keys plus the design's."""
        from vsw.analysis import FIELDS

        out: dict[str, Any] = {"status": self.status}
        if self.analysis is not None:
            out.update(self.analysis.to_dict())
            if self.energy_unit is not None:
                out["energy_unit"] = self.energy_unit
        else:
            out.update({"beta": None, "theta_II": None, "phi0": None})
            out.update({name: None for name in FIELDS})
            out["conditions"] = []
        out["status"] = self.status
        if self.analysis is not None and self.analysis.scale is not None:
            out["step_frequency_hz"] = 1.0 / float(self.analysis.step_period_s)
        out.update(
            {
                "objective": self.objective,
                "cost_of_transport": self.cost_of_transport,
                "step_frequency": self.step_frequency,
                "active_constraints": list(self.active_constraints),
                "open_boundary": list(self.open_boundary),
                "simulation_rel_error": self.simulation_rel_error,
                "conflicting_constraints": list(self.conflicting_constraints),
                "message": self.message,
                "ipopt_status": self.ipopt_status,
                "starts": self.starts,
            }
        )
        return out


def _active(problem: _Problem, x: np.ndarray) -> tuple[list[str], list[str]]:
    """(active constraint names, open-boundary names) at a design."""
    qs = _numpy_quantities(x[None, :])
    active: list[str] = []
    open_boundary: list[str] = []
    for (i, side), name in sorted(problem.bound_names.items()):
        bound = problem.lbx[i] if side == 0 else problem.ubx[i]
        if name.startswith("fix_"):
            if side == 0:
                active.append(name)
        elif abs(x[i] - bound) <= _ACTIVE_TOL * max(1.0, abs(bound)):
            active.append(name)
    for i, side in sorted(problem.table_clipped):
        bound = problem.lbx[i] if side == 0 else problem.ubx[i]
        if abs(x[i] - bound) <= 10 * _TABLE_EPS:
            limit = _TABLE[VARIABLES[i]][side]
            name = VARIABLES[i]
            if name == "phi0" and side == 1:
                open_boundary.append("phi0_below_right_angle")
            else:
                open_boundary.append(f"{name} {'>' if side == 0 else '<'} {limit:.6g}")
    for r in problem.rows:
        v = float(qs[r.quantity][0])
        for bound in (r.lower, r.upper):
            if math.isfinite(bound) and abs(v - bound) <= _ACTIVE_TOL * max(1.0, abs(bound)):
                if r.name not in active:
                    active.append(r.name)
                if not r.user and _STRICT[r.quantity]:
                    open_boundary.append(r.name)
    return active, open_boundary


def _near_open_limits(problem: _Problem, x: np.ndarray) -> list[str]:
    """Open parameter-table limits (not user bounds) that ``x`` is close to."""
    names = []
    for i, side in sorted(problem.table_clipped):
        limit = _TABLE[VARIABLES[i]][side]
        if abs(x[i] - limit) <= 10 * _TABLE_EPS:
            names.append(f"{VARIABLES[i]} {'>' if side == 0 else '<'} {limit:.6g}")
    return names


def _simulation_error(x: np.ndarray, analysis: Any) -> float:
    """Relative error of the closed form against the time-domain simulation at q^f."""
    from vsw.simulate import simulate

    beta, theta_II, phi0 = (float(v) for v in x)
    q_fixed = float(analysis.q_fixed)
    sim = simulate(beta, theta_II, phi0, q_fixed, 2, record=False)
    if sim.ended != "completed":
        return math.inf
    errors = [abs(q - q_fixed) / q_fixed for q in sim.q[1:]]
    for closed, simulated in (
        (float(analysis.step_period), sim.step_periods),
        (float(analysis.step_length), sim.step_lengths),
        (float(analysis.speed), sim.step_lengths / sim.step_periods),
    ):
        errors.extend(abs(s - closed) / abs(closed) for s in simulated)
    return float(max(errors))


def _conflicts(problem: _Problem, n_starts: int) -> list[str]:
    """User constraints whose removal alone makes the request feasible."""
    conflicting = []
    for key in problem.user_constraints():
        relaxed = problem.without(key)
        best, _ = _multistart(relaxed, n_starts)
        if best is not None:
            conflicting.append(key)
    return conflicting


def design(
    objective: str | Mapping[str, float] | None = None,
    targets: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
    fixed: Mapping[str, float] | None = None,
    min_contact_margin: float = 0.0,
    max_eigenvalue: float | None = None,
    scale: RobotScale | None = None,
    *,
    n_starts: int = 4,
    verify: bool = True,
    explain_infeasible: bool = True,
) -> DesignResult:
    """Design gait parameters (beta, theta_II, phi0) by constrained optimisation.

    Parameters
    ----------
    objective : str or mapping, optional
        ``'speed'`` (maximise), ``'eigenvalue'`` or ``'cost_of_transport'`` (minimise), or
        weights ``{'speed': w1, 'eigenvalue': w2, 'cost_of_transport': w3}`` of the sum
        ``-w1 speed + w2 eigenvalue + w3 cost_of_transport`` that is minimised. Default:
        minimise the eigenvalue when a target is given.
    targets : mapping, optional
        Equality constraints: ``speed`` (sqrt(g r_e)), ``speed_m_s``, ``q_fixed`` (g/r_e),
        ``step_length`` (r_e), ``step_length_m``, ``step_frequency`` (1/sqrt(r_e/g)),
        ``step_frequency_hz``. SI names need ``scale``.
    bounds : mapping, optional
        ``name: (lower, upper)``, either may be None: ``beta``, ``theta_II``, ``phi0``
        (radians), ``step_length``, ``step_frequency`` and their SI names.
    fixed : mapping, optional
        Fixed values of ``beta``, ``theta_II``, ``phi0`` (radians).
    min_contact_margin : float
        Lower bound on the minimum ground normal force over the step, in m g (>= 0 is
        always imposed: the stance foot must stay on the ground).
    max_eigenvalue : float, optional
        Upper bound on the eigenvalue of the stride map (eq. 19).
    scale : RobotScale, optional
        Robot scale for SI targets/bounds and SI outputs.
    n_starts : int
        Number of deterministic IPOPT starts.
    verify : bool
        Re-check the design by time-domain simulation (``simulation_rel_error``).
    explain_infeasible : bool
        When infeasible, relax each user constraint in turn to name the conflicting ones.

    Returns
    -------
    DesignResult

    Raises
    ------
    VswInputError
        Malformed request (unknown names, empty bounds, SI values without a scale, ...).
    """
    weights = _normalise_objective(objective, bool(targets))
    if not isinstance(n_starts, int) or n_starts < 1:
        raise VswInputError(f"n_starts = {n_starts!r} must be an integer >= 1")
    problem = _build_problem(
        weights, targets, bounds, fixed, min_contact_margin, max_eigenvalue, scale
    )
    best, solves = _multistart(problem, n_starts)
    if best is None:
        statuses = sorted({s.ipopt_status for s in solves})
        least = min(solves, key=lambda s: s.violation)
        # Infeasible only when every start ends at a point of local infeasibility; running
        # out of iterations is "not converged", whatever the last violation.
        infeasible_like = all(
            s.ipopt_status in ("Infeasible_Problem_Detected", "Restoration_Failed")
            or (s.ipopt_status in _SUCCESS and s.violation > _FEAS_TOL)
            for s in solves
        )
        if infeasible_like:
            conflicting = _conflicts(problem, n_starts) if explain_infeasible else []
            if conflicting:
                detail = "removing any one of these restores feasibility: " + ", ".join(conflicting)
            elif explain_infeasible:
                detail = "no single user constraint's removal restores feasibility"
            else:
                detail = "conflict analysis skipped"
            message = (
                f"infeasible: no feasible design from {len(solves)} starts (IPOPT: "
                f"{', '.join(statuses)}; least violation {least.violation:.3g}); {detail}"
            )
            return DesignResult("infeasible", None, None, None, None, None, None, None, (),
                                (), None, tuple(conflicting), message, least.ipopt_status,
                                len(solves))  # fmt: skip
        message = (
            f"not converged: IPOPT did not converge to a verified design from {len(solves)} "
            f"starts ({', '.join(statuses)})"
        )
        feasible = [s for s in solves if s.feasible]
        if feasible:
            # Not certified optimal, but a design that satisfies every constraint is still
            # useful: return it, clearly labelled.
            point = min(feasible, key=lambda s: s.objective)
            info = _describe(problem, point, scale, verify)
            message += (
                "; returned the best final iterate that satisfies every constraint (not a "
                "certified optimum)" + _open_boundary_note(info["open_boundary"])
            )
            return DesignResult(
                status="not-converged",
                conflicting_constraints=(),
                message=message,
                ipopt_status=point.ipopt_status,
                starts=len(solves),
                **info,
            )
        edges = _near_open_limits(problem, least.x)
        if edges:
            message += (
                "; the iterates run to the open limits " + ", ".join(edges) + " of the model's "
                "parameters, so the optimum is not attained there: add bounds"
            )
        return DesignResult("not-converged", None, None, None, None, None, None, None, (), (),
                            None, (), message, least.ipopt_status, len(solves))  # fmt: skip

    info = _describe(problem, best, scale, verify)
    message = f"optimal (local, best of {len(solves)} starts; IPOPT {best.ipopt_status})"
    message += _open_boundary_note(info["open_boundary"])
    sim_error = info["simulation_rel_error"]
    if sim_error is not None and not sim_error <= 1e-6:
        message += f"; WARNING: simulation disagrees (relative error {sim_error:.3g})"
    return DesignResult(
        status="optimal",
        conflicting_constraints=(),
        message=message,
        ipopt_status=best.ipopt_status,
        starts=len(solves),
        **info,
    )


# --- command line --------------------------------------------------------------------------


def _parse_fix(text: str) -> tuple[str, float]:
    """``NAME=VALUE`` of ``--fix``; angles in degrees."""
    name, sep, value = text.partition("=")
    aliases = {"beta": "beta", "theta_ii": "theta_II", "theta-ii": "theta_II", "phi0": "phi0"}
    key = aliases.get(name.strip().lower())
    if not sep or key is None:
        raise VswInputError(f"--fix {text!r}: expected NAME=VALUE with NAME beta, theta_II or phi0")
    v = _finite(f"--fix {key}", value)
    return key, v if key == "beta" else math.radians(v)


def _design_from_args(args: argparse.Namespace) -> tuple[DesignResult, RobotScale | None, bool]:
    from vsw.params import STEPPER_2D

    mass_given = args.mass is not None or args.stepper_2d
    if args.stepper_2d:
        if args.leg_length is not None or args.mass is not None:
            raise VswInputError(
                "--stepper-2d sets the leg length and mass; drop --leg-length/--mass"
            )
        gravity = STEPPER_2D.gravity if args.gravity is None else args.gravity
        scale: RobotScale | None = RobotScale(STEPPER_2D.leg_length, STEPPER_2D.mass, gravity)
    elif args.leg_length is not None:
        # SI targets need only r_e and g; without --mass energies are per kg (mass 1 kg).
        gravity = 9.81 if args.gravity is None else args.gravity
        scale = RobotScale(args.leg_length, 1.0 if args.mass is None else args.mass, gravity)
    else:
        if args.mass is not None or args.gravity is not None:
            raise VswInputError("--mass/--gravity need --leg-length (or --stepper-2d)")
        scale = None
    si = scale is not None

    objective: dict[str, float] = {}
    if args.maximize is not None:
        objective["speed"] = 1.0
    for name in args.minimize or []:
        objective[name.replace("-", "_")] = 1.0
    targets: dict[str, float] = {}
    if args.target_speed is not None:
        targets["speed_m_s" if si else "speed"] = args.target_speed
    if args.target_q_fixed is not None:
        targets["q_fixed"] = args.target_q_fixed
    if args.target_step_length is not None:
        targets["step_length_m" if si else "step_length"] = args.target_step_length
    if args.target_step_frequency is not None:
        if not si:
            raise VswInputError("--target-step-frequency is in Hz and needs --leg-length")
        targets["step_frequency_hz"] = args.target_step_frequency
    if args.max_step_frequency is not None and not si:
        raise VswInputError("--max-step-frequency is in Hz and needs --leg-length")

    def deg(v: float | None) -> float | None:
        return None if v is None else math.radians(v)

    bounds: dict[str, tuple[float | None, float | None]] = {
        "beta": (args.beta_min, args.beta_max),
        "theta_II": (deg(args.theta_ii_min), deg(args.theta_ii_max)),
        "phi0": (deg(args.phi0_min), deg(args.phi0_max)),
    }
    if args.min_step_length is not None or args.max_step_length is not None:
        bounds["step_length_m" if si else "step_length"] = (
            args.min_step_length,
            args.max_step_length,
        )
    if args.max_step_frequency is not None:
        bounds["step_frequency_hz"] = (None, args.max_step_frequency)
    fixed = dict(_parse_fix(text) for text in args.fix or [])
    result = design(
        objective=objective or None,
        targets=targets,
        bounds=bounds,
        fixed=fixed,
        min_contact_margin=args.min_contact_margin,
        max_eigenvalue=args.max_eigenvalue,
        scale=scale,
        n_starts=args.starts,
    )
    return result, scale, mass_given


def _cmd_design(args: argparse.Namespace) -> int:
    import json

    result, scale, mass_given = _design_from_args(args)
    data = result.to_dict()
    if scale is not None and not mass_given and result.analysis is not None:
        data["energy_unit"] = "J/kg"  # no --mass: energies of a 1 kg walker
    exit_code = 0 if result.status == "optimal" else 3
    out = sys.stdout
    if args.json:
        out.write(json.dumps(data, allow_nan=False, indent=2) + "\n")
        return exit_code
    out.write(f"status           {result.status}\n")
    if result.status != "optimal":
        if result.conflicting_constraints:
            out.write(f"conflicting      {', '.join(result.conflicting_constraints)}\n")
        sys.stderr.write(f"vsw design: {result.message}\n")
        return exit_code

    def fmt(value: Any) -> str:
        if value is None:
            return "-"
        if isinstance(value, bool):
            return "yes" if value else "no"
        return f"{value:.8g}" if isinstance(value, float) else str(value)

    energy_unit = data["energy_unit"]
    rows = [
        ("beta", data["beta"], ""),
        ("theta_II", math.degrees(data["theta_II"]), "deg"),
        ("phi0", math.degrees(data["phi0"]), "deg"),
        ("q_fixed", data["q_fixed"], "g/r_e"),
        ("eigenvalue", data["eigenvalue"], ""),
        ("step_length", data["step_length"], "r_e"),
        ("step_period", data["step_period"], "sqrt(r_e/g)"),
        ("speed", data["speed"], "sqrt(g r_e)"),
        ("cost_of_transport", data["cost_of_transport"], "E_c/(m g L)"),
        ("energy_added", data["energy_added"], energy_unit),
        ("contact_margin", data["contact_margin"], "m g"),
    ]
    if scale is not None:
        rows += [
            ("step_length_m", data["step_length_m"], "m"),
            ("step_period_s", data["step_period_s"], "s"),
            ("step_frequency", 1.0 / data["step_period_s"], "Hz"),
            ("speed_m_s", data["speed_m_s"], "m/s"),
        ]
    for name, value, unit in rows:
        out.write(f"{name:<18} {fmt(value):>16}  {unit}\n")
    out.write(f"active           {', '.join(result.active_constraints) or '-'}\n")
    out.write(f"simulation check relative error {fmt(result.simulation_rel_error)}\n")
    out.write(f"{result.message}\n")
    return exit_code


def register_cli(subparsers: Any) -> None:
    """Add the ``design`` subcommand to the ``vsw`` CLI (called by :mod:`vsw.cli`).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``vsw`` subcommand registry.
    """
    p = subparsers.add_parser(
        "design",
        help="constrained gait design with CasADi/IPOPT",
        description="Find (beta, theta_II, phi0) for an objective and targets under the "
        "existence conditions and your robot's limits. Angles in degrees. Exit 3 when the "
        "request is infeasible or the solver does not converge.",
    )
    goal = p.add_argument_group("objective and targets")
    goal.add_argument("--maximize", choices=["speed"], help="maximise the walking speed")
    goal.add_argument(
        "--minimize",
        choices=["eigenvalue", "cost-of-transport"],
        action="append",
        help="minimise the eigenvalue or the cost of transport (repeat for a sum)",
    )
    goal.add_argument(
        "--target-speed", type=float, help="speed: m/s with --leg-length, else sqrt(g r_e)"
    )
    goal.add_argument("--target-q-fixed", type=float, help="fixed point q^f [g/r_e]")
    goal.add_argument(
        "--target-step-length", type=float, help="step length: m with --leg-length, else r_e"
    )
    goal.add_argument(
        "--target-step-frequency", type=float, help="step frequency [Hz] (needs --leg-length)"
    )
    lim = p.add_argument_group("bounds and constraints")
    lim.add_argument("--beta-min", type=float)
    lim.add_argument("--beta-max", type=float)
    lim.add_argument("--theta-ii-min", type=float, help="[deg]")
    lim.add_argument("--theta-ii-max", type=float, help="[deg]")
    lim.add_argument("--phi0-min", type=float, help="[deg]")
    lim.add_argument("--phi0-max", type=float, help="[deg]")
    lim.add_argument(
        "--fix", action="append", metavar="NAME=VALUE", help="fix beta, theta_II or phi0 [deg]"
    )
    lim.add_argument("--min-contact-margin", type=float, default=0.0, help="min normal force [m g]")
    lim.add_argument("--max-eigenvalue", type=float)
    lim.add_argument("--min-step-length", type=float, help="m with --leg-length, else r_e")
    lim.add_argument("--max-step-length", type=float, help="m with --leg-length, else r_e")
    lim.add_argument("--max-step-frequency", type=float, help="[Hz] (needs --leg-length)")
    sc = p.add_argument_group("robot scale")
    sc.add_argument("--leg-length", type=float, help="extended leg length r_e [m]")
    sc.add_argument("--mass", type=float, help="mass [kg]")
    sc.add_argument("--gravity", type=float, help="g [m/s^2] (default 9.81)")
    sc.add_argument(
        "--stepper-2d", action="store_true", help="Stepper-2D preset: r_e 0.25 m, m 0.78 kg"
    )
    p.add_argument("--starts", type=int, default=4, help="number of IPOPT starts")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=_cmd_design)
