"""A suite of seeded gait-design problems with a reference that does not use IPOPT.

``python benchmarks/design_suite.py [--problems N] [--seed S] [--before COMMIT] [--json F]``
builds the suite, solves every problem with :func:`vsw.models.ile.design.design` (and, with
``--before``, with the ``vsw/design.py`` of an earlier commit, loaded from git), solves it
again with the reference, and prints the summary that ``benchmarks/run.py`` (case 8) puts
into ``benchmarks/results.md``.

The problems
------------
objectives (least eigenvalue, greatest speed, least cost of transport) x targets (speed,
step length, step frequency, q^f, none) x boxes (the default: the parameter table; a random
box) x contact margins (0, 0.05, random). A target is the value of that quantity at a random
walking gait of the box whose contact margin exceeds the requested one, so every such
problem is feasible by construction. The deliberately infeasible problems are infeasible by
a bound that needs no optimiser: an eigenvalue bound below beta_min^2 cos^2 phi0_max (eq.
19), a step length beyond the box's largest (L^2 = (1 - beta)^2 + 2 beta (1 - cos phi0) is
convex in beta and rises with phi0), a contact margin above 1 m g (N / (m g) = cos theta
(cos theta - rho omega^2) < 1 while walking).

The reference
-------------
A dense grid over the box (the design's closed problem: open parameter limits kept
``TABLE_DISTANCE`` away, strict conditions imposed as ``>= STRICT_MARGIN``), every
condition evaluated in its exact form by the generated numpy code, then SciPy SLSQP (finite
differences on the same closed forms, the exact non-smooth margins) from the best grid
points; for targets, from the best grid points within a band of the target. A polished
point counts only when it satisfies every constraint to 1e-8; the reference value is the
best counted point.

A design succeeds when its status is ``optimal`` or ``not-attained``, its design satisfies
every constraint (checked here again from the generated code) and its objective is no
worse than the reference's by more than 1e-6 relative. An infeasible problem succeeds when
the status is ``infeasible``.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from generated import ile  # noqa: E402
from vsw.models.ile import design as design_module  # noqa: E402

R = math.radians
TABLE = {"beta": (0.0, 1.0), "theta_II": (-math.pi / 2, math.pi / 2), "phi0": (0.0, math.pi / 2)}
VARIABLES = ("beta", "theta_II", "phi0")
SIGN = {"speed": -1.0, "eigenvalue": 1.0, "cost_of_transport": 1.0}
FEAS_TOL = 1e-8
MATCH_TOL = 1e-6
CONDITION_NAMES = tuple(c[0] for c in ile.CONDITIONS)
PHYSICAL = tuple(c[0] for c in ile.CONDITIONS if c[4] and c[0] != "phi0_below_right_angle")
STRICT = {c[0]: c[2] for c in ile.CONDITIONS}


@dataclass
class Problem:
    """One design request: keyword arguments of ``design()`` and what is known of it."""

    label: str
    objective: str
    targets: dict[str, float] = field(default_factory=dict)
    bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    min_contact_margin: float = 0.0
    max_eigenvalue: float | None = None
    feasible: bool = True  # False: infeasible by a bound that needs no optimiser
    witness: list[float] | None = None  # a feasible design, known from the construction
    conflict: str | None = None  # infeasible: the user constraint whose removal restores it
    beyond: float | None = None  # infeasible: how far beyond the bound (1.001: 0.1 %)

    def kwargs(self) -> dict[str, Any]:
        return {
            "objective": self.objective,
            "targets": dict(self.targets),
            "bounds": dict(self.bounds),
            "min_contact_margin": self.min_contact_margin,
            "max_eigenvalue": self.max_eigenvalue,
        }


# --- closed forms, the ground truth both sides are checked against -------------------------


def quantities(x: np.ndarray) -> dict[str, np.ndarray]:
    """Objective and constraint quantities at an ``(n, 3)`` array, from generated numpy."""
    b, t, p = x[:, 0], x[:, 1], x[:, 2]
    with np.errstate(all="ignore"):
        margins = ile.condition_margins(b, t, p)
        q_fixed = ile.q_fixed(b, t, p)
        length = ile.step_length(b, p)
        tau = ile.phase_durations(b, t, p, q_fixed)
        period = tau[0] + tau[1]
        out = {
            "q_fixed": q_fixed,
            "eigenvalue": ile.eigenvalue(b, p),
            "step_length": length,
            "step_frequency": 1.0 / period,
            "speed": length / period,
            "cost_of_transport": ile.energy_complement(b, t, p, q_fixed, 1.0, 1.0, 1.0) / length,
            "contact_margin": margins[CONDITION_NAMES.index("stance_contact")],
        }
        out.update(zip(CONDITION_NAMES, margins))
    return {k: np.broadcast_to(np.asarray(v, dtype=float), b.shape) for k, v in out.items()}


def box(problem: Problem, distance: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The closed box of the design's primary problem (open limits kept away)."""
    lo, hi = np.empty(3), np.empty(3)
    keep = design_module.TABLE_DISTANCE * distance
    for i, name in enumerate(VARIABLES):
        t_lo, t_hi = TABLE[name]
        u_lo, u_hi = problem.bounds.get(name, (None, None))
        # A user bound is closed (vsw.models.ile.design refuses one within TABLE_DISTANCE of an open
        # limit); without one the open table limit is kept at the distance.
        lo[i] = t_lo + keep if u_lo is None else u_lo
        hi[i] = t_hi - keep if u_hi is None else u_hi
    return lo, hi


def constraint_rows(
    problem: Problem, qs: dict[str, np.ndarray], distance: float = 1.0
) -> list[tuple[np.ndarray, float]]:
    """``(value, size)`` per constraint written as ``value >= 0`` (equalities: two rows)."""
    rows = []
    strict = design_module.STRICT_MARGIN * distance
    for name in PHYSICAL:
        if name == "stance_contact":
            floor = max(problem.min_contact_margin, design_module.CLOSED_MARGIN)
            rows.append((qs[name] - floor, 1.0))
        else:
            rows.append((qs[name] - (strict if STRICT[name] else 0.0), 1.0))
    if problem.max_eigenvalue is not None:
        rows.append((problem.max_eigenvalue - qs["eigenvalue"], 1.0))
    for name, value in problem.targets.items():
        size = max(1.0, abs(value))
        rows.append((qs[name] - value, size))
        rows.append((value - qs[name], size))
    return rows


def violation(problem: Problem, x: np.ndarray, distance: float = 1.0) -> np.ndarray:
    """Largest relative violation per point (inf where undefined)."""
    qs = quantities(np.atleast_2d(x))
    total = np.zeros(len(np.atleast_2d(x)))
    for value, size in constraint_rows(problem, qs, distance):
        total = np.maximum(
            total, np.where(np.isfinite(value), np.maximum(-value, 0) / size, np.inf)
        )
    lo, hi = box(problem, distance)
    x = np.atleast_2d(x)
    outside = np.max(np.maximum(lo - x, 0) + np.maximum(x - hi, 0), axis=1)
    return np.maximum(total, outside)


def objective(problem: Problem, x: np.ndarray) -> np.ndarray:
    qs = quantities(np.atleast_2d(x))
    return SIGN[problem.objective] * qs[problem.objective]


# --- the suite -------------------------------------------------------------------------------


def random_box(rng: np.random.Generator) -> dict[str, tuple[float, float]]:
    beta_lo = rng.uniform(0.3, 0.8)
    theta_lo = rng.uniform(-40, 30)
    phi_lo = rng.uniform(10, 60)
    return {
        "beta": (beta_lo, min(0.99, beta_lo + rng.uniform(0.15, 0.4))),
        "theta_II": (R(theta_lo), R(min(60, theta_lo + rng.uniform(20, 50)))),
        "phi0": (R(phi_lo), R(min(80, phi_lo + rng.uniform(15, 40)))),
    }


def walking_gait(problem: Problem, rng: np.random.Generator, margin: float) -> np.ndarray | None:
    """A random gait of the box that walks with contact margin above ``margin``."""
    lo, hi = box(problem)
    x = lo + (hi - lo) * rng.random((20000, 3))
    qs = quantities(x)
    ok = np.isfinite(qs["speed"]) & (qs["contact_margin"] >= margin)
    for name in PHYSICAL:
        ok &= qs[name] > 1e-4 if STRICT[name] else qs[name] >= 0
    idx = np.flatnonzero(ok)
    return None if len(idx) == 0 else x[rng.choice(idx)]


def make_suite(n: int = 220, seed: int = 2026) -> list[Problem]:
    """``n`` problems (about one in ten infeasible by construction), seeded."""
    rng = np.random.default_rng(seed)
    objectives = ("eigenvalue", "speed", "cost_of_transport")
    targets = ("speed", "step_length", "step_frequency", "q_fixed", None)
    problems: list[Problem] = []
    k = 0
    while len(problems) < n:
        k += 1
        if k % 10 == 0:
            problem = infeasible_problem(rng, len(problems))
            if problem is not None:
                problems.append(problem)
            continue
        obj = objectives[k % 3]
        target = targets[(k // 3) % 5]
        bounds = random_box(rng) if (k // 15) % 2 else {}
        margin = (0.0, 0.05, float(rng.uniform(0.0, 0.15)))[(k // 30) % 3]
        p = Problem(f"{len(problems):03d} {obj} target={target} "
                    f"box={'random' if bounds else 'default'} margin={margin:.3g}",
                    obj, {}, bounds, margin)  # fmt: skip
        # Feasible by construction: a gait of the box walks with a margin to spare (and,
        # with a target, the target is its value). It is the witness the reference uses.
        gait = walking_gait(p, rng, margin + 0.01)
        if gait is None:
            continue
        p.witness = [float(v) for v in gait]
        if target is not None:
            p.targets[target] = float(quantities(gait[None, :])[target][0])
        problems.append(p)
    return problems


def subset(problems: list[Problem]) -> list[Problem]:
    """A stratified subset: one feasible problem for each objective and target (random and
    default boxes alternating, margins as they come) and every kind of infeasible problem
    at both distances beyond its bound."""
    chosen: dict[tuple, Problem] = {}
    for p in problems:
        if not p.feasible:
            chosen.setdefault((p.conflict, p.beyond), p)
    groups: dict[tuple, list[Problem]] = {}
    for p in problems:
        if p.feasible:
            target = next(iter(p.targets), None)
            groups.setdefault((p.objective, target), []).append(p)
    for k, (key, members) in enumerate(sorted(groups.items(), key=lambda g: str(g[0]))):
        want_random = k % 2 == 1
        pick = next((p for p in members if bool(p.bounds) == want_random), members[0])
        chosen[key] = pick
    return sorted(chosen.values(), key=lambda p: p.label)


def infeasible_problem(rng: np.random.Generator, index: int) -> Problem | None:
    """A problem infeasible by a bound, in a box with walking gaits (so that removing the
    offending constraint, named in ``conflict``, restores feasibility); half of them lie
    just beyond the bound (0.1 %)."""
    kind = index % 3
    bounds = random_box(rng)
    beyond = 1.001 if (index // 3) % 2 else 1.5
    probe = Problem("", "speed", {}, bounds)
    if walking_gait(probe, rng, 0.01) is None:
        return None
    if kind == 0:
        (b_lo, _), (_, p_hi) = bounds["beta"], bounds["phi0"]
        least = b_lo**2 * math.cos(p_hi) ** 2  # eq. (19) over the box
        return Problem(f"{index:03d} infeasible: max_eigenvalue below the box's least "
                       f"(/{beyond:g})",
                       "speed", {}, bounds, 0.0, least / beyond, feasible=False,
                       conflict="max_eigenvalue", beyond=beyond)  # fmt: skip
    if kind == 1:
        (b_lo, b_hi), (_, p_hi) = bounds["beta"], bounds["phi0"]
        longest = max(math.sqrt((1 - b) ** 2 + 2 * b * (1 - math.cos(p_hi))) for b in (b_lo, b_hi))
        return Problem(f"{index:03d} infeasible: step length beyond the box's longest "
                       f"(x{beyond:g})",
                       "eigenvalue", {"step_length": beyond * longest}, bounds,
                       feasible=False, conflict="target_step_length", beyond=beyond)  # fmt: skip
    return Problem(f"{index:03d} infeasible: contact margin {beyond:g} m g", "eigenvalue", {},
                   bounds, 1.0 * beyond, feasible=False, conflict="min_contact_margin",
                   beyond=beyond)  # fmt: skip


# --- the reference (no IPOPT) ---------------------------------------------------------------


def reference(
    problem: Problem,
    grid: int = 48,
    polish: int = 4,
    distance: float = 1.0,
    starts_from: list[np.ndarray] | None = None,
) -> dict[str, Any]:
    """Dense grid + SLSQP polish; ``objective`` None when no feasible point is found.

    ``distance`` scales the distances kept from the open limits (as the design's
    continuation does); ``starts_from`` adds SLSQP starts (the witness always is one).
    """
    from scipy.optimize import minimize

    lo, hi = box(problem, distance)
    axes = [np.linspace(lo[i], hi[i], grid) for i in range(3)]
    x = np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=1)
    qs = quantities(x)
    f = SIGN[problem.objective] * qs[problem.objective]
    rows = constraint_rows(problem, qs, distance)
    inequality = np.ones(len(x), dtype=bool)
    band = np.ones(len(x), dtype=bool)
    for value, _ in rows:
        inequality &= np.isfinite(value)
    for value, _ in rows[: len(PHYSICAL) + (problem.max_eigenvalue is not None)]:
        inequality &= value >= 0
    for name, value in problem.targets.items():
        band &= np.abs(qs[name] - value) <= 0.03 * abs(value)
    candidates = np.flatnonzero(inequality & band & np.isfinite(f))
    best_x, best_f = None, math.inf
    if not problem.targets and len(candidates):
        i = candidates[np.argmin(f[candidates])]
        if violation(problem, x[i], distance)[0] <= FEAS_TOL:
            best_x, best_f = x[i], float(f[i])
    order = candidates[np.argsort(f[candidates])]
    starts: list[np.ndarray] = []
    extra = list(starts_from or [])
    if problem.witness is not None:
        extra.append(np.clip(np.array(problem.witness), lo, hi))
    for z in extra:
        if violation(problem, z, distance)[0] <= FEAS_TOL:
            value = float(objective(problem, z)[0])
            if value < best_f:
                best_x, best_f = np.array(z, dtype=float), value
    span = hi - lo + 1e-12
    for i in order:
        if all(np.max(np.abs(x[i] - s) / span) > 0.1 for s in starts):
            starts.append(x[i])
        if len(starts) == polish:
            break

    # With a target on the objective's own quantity every feasible point is optimal;
    # SLSQP zigzags on such a flat Lagrangian, so it is given feasibility alone to solve.
    flat = problem.objective in problem.targets

    def fun(z):
        if flat:
            return 0.0
        v = objective(problem, z)[0]
        return float(v) if np.isfinite(v) else 1e3

    def inequalities(z):
        qs = quantities(z[None, :])
        no_targets = Problem(problem.label, problem.objective, {}, problem.bounds,
                             problem.min_contact_margin, problem.max_eigenvalue)  # fmt: skip
        values = [float(v[0]) / s for v, s in constraint_rows(no_targets, qs, distance)]
        return np.nan_to_num(np.array(values), nan=-1e3, posinf=-1e3, neginf=-1e3)

    def equalities(z):
        qs = quantities(z[None, :])
        values = [(float(qs[k][0]) - v) / max(1.0, abs(v)) for k, v in problem.targets.items()]
        return np.nan_to_num(np.array(values), nan=1e3, posinf=1e3, neginf=-1e3)

    def central(g):
        # SLSQP's own forward differences (step 1.5e-8) leave errors of about 1e-8, the
        # size of the feasibility tolerance: central differences are ~1e-11.
        def jac(z):
            columns = []
            for i in range(3):
                h = 1e-6 * max(1.0, abs(z[i]))
                up, down = z.copy(), z.copy()
                up[i] = min(z[i] + h, hi[i])
                down[i] = max(z[i] - h, lo[i])
                columns.append((np.atleast_1d(g(up)) - np.atleast_1d(g(down))) / (up[i] - down[i]))
            return np.stack(columns, axis=-1)

        return jac

    def gradient(z):
        return central(fun)(z).reshape(-1)

    constraints = [{"type": "ineq", "fun": inequalities, "jac": central(inequalities)}]
    if problem.targets:
        constraints.append({"type": "eq", "fun": equalities, "jac": central(equalities)})
    for start in starts + extra:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = minimize(fun, start, jac=gradient, method="SLSQP", bounds=list(zip(lo, hi)),
                           constraints=constraints,
                           options={"maxiter": 200, "ftol": 1e-12})  # fmt: skip
        z = np.clip(res.x, lo, hi)
        if violation(problem, z, distance)[0] <= FEAS_TOL:
            value = float(objective(problem, z)[0])
            if value < best_f:
                best_x, best_f = z, value
    return {
        "objective": None if best_x is None else best_f,
        "x": None if best_x is None else [float(v) for v in best_x],
        "at_open_limit": None if best_x is None else at_open_limit(problem, best_x, distance),
        "grid_points": len(x),
        "candidates": len(candidates),
    }


def at_open_limit(problem: Problem, x: np.ndarray, distance: float = 1.0) -> bool:
    """Whether a point presses on a kept distance: a strict condition at STRICT_MARGIN or
    a variable at the distance kept from an open table limit (to 1e-7)."""
    qs = quantities(np.atleast_2d(x))
    strict = design_module.STRICT_MARGIN * distance
    for name in PHYSICAL:
        if STRICT[name] and abs(float(qs[name][0]) - strict) <= 1e-7:
            return True
    lo, hi = box(problem, distance)
    for i, name in enumerate(VARIABLES):
        u_lo, u_hi = problem.bounds.get(name, (None, None))
        if u_lo is None and abs(x[i] - lo[i]) <= 1e-7:
            return True
        if u_hi is None and abs(x[i] - hi[i]) <= 1e-7:
            return True
    return False


# --- running a design function --------------------------------------------------------------


MOVED_MODULES = {"from generated.ile_params import": "from generated.ile.params import"}
"""Imports of the code before the engine, as they read now."""


def load_before(commit: str) -> Any:
    """``vsw/design.py`` as it was at ``commit``, as a module (needs git)."""
    source = subprocess.run(["git", "show", f"{commit}:vsw/design.py"], cwd=ROOT, check=True,
                            capture_output=True, text=True).stdout  # fmt: skip
    # The model engine moved the ILE's generated modules into generated/ile/; the
    # functions themselves are byte-identical, so the old code runs on them renamed.
    for old, new in MOVED_MODULES.items():
        source = source.replace(old, new)
    path = Path(tempfile.mkdtemp()) / f"design_{commit[:8]}.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location(f"vsw_design_{commit[:8]}", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def solve(problem: Problem, module: Any) -> dict[str, Any]:
    """Run ``module.design`` on a problem (no simulation check inside the timing)."""
    kwargs = problem.kwargs()
    start = time.perf_counter()
    with contextlib.redirect_stderr(io.StringIO()):
        result = module.design(**kwargs, verify=False)
    seconds = time.perf_counter() - start
    out: dict[str, Any] = {"status": result.status, "seconds": seconds, "objective": None,
                           "conflicting": list(result.conflicting_constraints)}  # fmt: skip
    if result.beta is not None:
        x = np.array([result.beta, result.theta_II, result.phi0])
        out["x"] = [float(v) for v in x]
        out["objective"] = float(objective(problem, x)[0])
        out["violation"] = float(violation(problem, x)[0])
        # The simulation re-checks q^f, step period, length and speed (the constraints
        # were re-checked just above from the closed forms).
        out["simulation_rel_error"] = design_module.simulation_check(result.analysis)
    limit = getattr(result, "limit", None)
    if limit is not None:
        out["limit"] = limit.to_dict()
    return out


def check_path(problem: Problem, got: dict[str, Any], grid: int) -> bool | None:
    """A not-attained design's last converged path point against the reference solved at
    the same distance: the path must be optimal there too (None: nothing to check)."""
    path = [p for p in got.get("limit", {}).get("path", []) if p["converged"]]
    if len(path) < 2:
        return None
    last = path[-1]
    x = np.array([last["beta"], last["theta_II"], last["phi0"]])
    if violation(problem, x, last["distance_scale"])[0] > FEAS_TOL:
        return False
    ref = reference(problem, grid, 2, last["distance_scale"], starts_from=[x])
    value = float(objective(problem, x)[0])
    return ref["objective"] is not None and value <= ref["objective"] + MATCH_TOL * max(
        1.0, abs(ref["objective"])
    )


def judge(problem: Problem, got: dict[str, Any], ref: dict[str, Any]) -> dict[str, Any]:
    """The verdicts the summary counts."""
    found = got["status"] in ("optimal", "not-attained")
    if not problem.feasible:
        named = problem.conflict in got.get("conflicting", [])
        return {"success": got["status"] == "infeasible" and named, "false_infeasible": False,
                "false_feasible": found, "reference_missing": False,
                "status_agrees": None}  # fmt: skip
    ok_point = found and got.get("violation", math.inf) <= FEAS_TOL
    ok_sim = found and got.get("simulation_rel_error", math.inf) <= 1e-6
    ref_f = ref["objective"]
    matches = (
        ok_point
        and ref_f is not None
        and got["objective"] <= ref_f + MATCH_TOL * max(1.0, abs(ref_f))
    )
    agrees = None
    if found and ref_f is not None:
        agrees = (got["status"] == "not-attained") == bool(ref["at_open_limit"])
    return {
        "success": bool(matches and ok_sim),
        "false_infeasible": got["status"] in ("infeasible", "not-converged"),
        "false_feasible": False,
        # A feasible problem always has its witness: a missing reference is a suite error.
        "reference_missing": ref_f is None,
        "status_agrees": agrees,
    }


def summarise(records: list[dict[str, Any]], side: str) -> dict[str, Any]:
    feasible = [r for r in records if r["feasible"]]
    infeasible = [r for r in records if not r["feasible"]]
    verdicts = [r[f"{side}_verdict"] for r in records]
    times = sorted(r[side]["seconds"] for r in records)
    p95 = times[min(len(times) - 1, math.ceil(0.95 * len(times)) - 1)]
    statuses: dict[str, int] = {}
    for r in records:
        statuses[r[side]["status"]] = statuses.get(r[side]["status"], 0) + 1
    agreement = [v["status_agrees"] for v in verdicts if v["status_agrees"] is not None]
    paths = [r.get(f"{side}_path_ok") for r in records if r.get(f"{side}_path_ok") is not None]
    return {
        "problems": len(records),
        "success": sum(v["success"] for v in verdicts),
        "success_rate": sum(v["success"] for v in verdicts) / len(records),
        "feasible_reported_infeasible_or_not_converged": sum(
            r[f"{side}_verdict"]["false_infeasible"] for r in feasible
        ),
        "infeasible_reported_feasible": sum(
            r[f"{side}_verdict"]["false_feasible"] for r in infeasible
        ),
        "reference_missing": sum(v["reference_missing"] for v in verdicts),
        "status_agrees_with_reference": f"{sum(agreement)}/{len(agreement)}",
        "not_attained_paths_optimal": f"{sum(paths)}/{len(paths)}",
        "median_s": statistics.median(times),
        "p95_s": p95,
        "statuses": dict(sorted(statuses.items())),
    }


def _reference_job(args: tuple[Problem, int]) -> dict[str, Any]:
    return reference(*args)


def run(
    n: int, seed: int, before: str | None, grid: int = 48, processes: int = 1
) -> dict[str, Any]:
    """The suite: references first (on ``processes`` workers), then each side, timed alone."""
    problems = make_suite(n, seed)
    jobs = [(p, grid) for p in problems]
    if processes > 1:
        import multiprocessing

        with multiprocessing.get_context("spawn").Pool(processes) as pool:
            references = pool.map(_reference_job, jobs)
    else:
        references = [_reference_job(job) for job in jobs]
    sides = {"after": design_module}
    if before:
        sides["before"] = load_before(before)
    for module in sides.values():  # build the cached solvers outside the timings
        with contextlib.redirect_stderr(io.StringIO()):
            for p in problems[:12]:
                module.design(**p.kwargs(), verify=False)
    records = []
    for p, ref in zip(problems, references):
        record: dict[str, Any] = {"label": p.label, "feasible": p.feasible, "reference": ref}
        for side, module in sides.items():
            got = solve(p, module)
            record[side] = got
            record[f"{side}_verdict"] = judge(p, got, ref)
            if side == "after" and got["status"] == "not-attained":
                record["after_path_ok"] = check_path(p, got, grid)
        records.append(record)
    summary = {side: summarise(records, side) for side in sides}
    return {"seed": seed, "before": before, "summary": summary, "records": records,
            "problems": [asdict(p) for p in problems]}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--problems", type=int, default=220)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--before", help="git commit of the design code to compare with")
    parser.add_argument("--grid", type=int, default=48, help="reference grid points per axis")
    parser.add_argument("--json", help="write every record to this file")
    parser.add_argument("--processes", type=int, default=1, help="workers for the references")
    args = parser.parse_args(argv)
    out = run(args.problems, args.seed, args.before, args.grid, args.processes)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1, default=float))
    print(json.dumps(out["summary"], indent=2))
    for r in out["records"]:
        if not r["after_verdict"]["success"]:
            ref = r["reference"]["objective"]
            print(f"FAIL {r['label']}: {r['after']['status']} {r['after']['objective']} "
                  f"ref {ref}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
