"""Design for every model: a seeded suite per model against references that do
not use IPOPT, and SciPy SLSQP side by side.

``python benchmarks/design_every_model.py [--problems N] [--models a,b] [--slsqp K]
[--json FILE]`` (case 13 of ``benchmarks/run.py`` calls :func:`run`).

Each model designs one free parameter (the others fixed), so the reference can be exact
without IPOPT: the gait branches are traced over the parameter's whole range by the
runtime's periodic-orbit Newton solver (natural-parameter continuation from the gaits the
gait search finds at two points of the range), every design quantity evaluated on each
branch point; a problem's reference optimum is the best of, on every branch: the box's
ends, each feasible interval's ends (where max |eigenvalue| crosses its bound, found by
``brentq``), the interior extrema of the objective (``minimize_scalar`` between grid
neighbours) and, for a target, every root of ``quantity - target`` (``brentq``). It shares
with the design the generated model and the runtime's orbit solver, not the NLP.

Problems (seeded): an objective (maximise speed or step length, minimise the eigenvalue,
the cost of transport or the energy per step), a random box of the free parameter, with
probability 1/2 a bound on max |eigenvalue|, with probability 2/5 a target speed or period
drawn around the branches' range (some beyond it: infeasible). Success: a feasible
problem's design is optimal or not-attained with an objective no worse than the
reference's by 1e-6 (relative to max(1, |reference|)); an infeasible one is not called
feasible.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import os
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from scipy.optimize import brentq, minimize, minimize_scalar  # noqa: E402

from vsw import models  # noqa: E402
from vsw.runtime.errors import ConvergenceError  # noqa: E402
from vsw.synthesis import design as gait_design  # noqa: E402
from vsw.synthesis.design.solve import orbit_quantities  # noqa: E402

SETUPS = {
    # model: (free parameter, its range, fixed values): every other parameter is fixed
    # here or a scale (held by the design unless bounded)
    "simplest_walker": ("gamma", (0.004, 0.018), {}),
    "compass_gait": ("gamma", (0.01, 0.09), {}),
    "vsw_biped": ("beta", (0.85, 0.99), {"theta_II": 0.0, "b_over_l": 0.3}),
    # The tests' small run (tests/test_design_every_model.py): seconds, not minutes.
    "rimless_wheel": ("gamma", (0.1, 0.25), {"alpha": 0.39269908169872414}),
}
SUITE_MODELS = ("simplest_walker", "compass_gait", "vsw_biped")
PAIRED_RUNS = 3
"""Runs of the cached design and of SLSQP on each problem given to both (the least kept)."""
GRID = 41
OBJECTIVES = (("speed", +1), ("step_length", +1), ("eigenvalue", -1),
              ("cost_of_transport", -1), ("energy_per_step", -1))  # fmt: skip
"""(quantity, +1 maximised / -1 minimised)."""


@dataclass
class Point:
    value: float  # the free parameter
    state: np.ndarray
    durations: np.ndarray
    quantities: dict
    margins_ok: bool


def _params(model, name: str, value: float, fixed: dict) -> tuple[float, ...]:
    return model.parameters({**fixed, name: value})


def _evaluate(model, name, value, fixed, state, durations) -> Point | None:
    params = _params(model, name, value, fixed)
    try:
        orbit = model.periodic_orbit(params, state, durations)
    except ConvergenceError:
        return None
    quantities = orbit_quantities(model, params, orbit)
    ok = _margins_hold(model, params, orbit)
    return Point(value, np.array(list(orbit.state.values())), np.array(orbit.durations),
                 quantities, ok)  # fmt: skip


def _margins_hold(model, params, orbit) -> bool:
    """Every failure's guard on its safe side at the integrator's own steps of one
    simulated step (coarser than vsw.dynamics.conditions' 400 samples, ten times cheaper: a gait
    whose margin dips between the samples counts as feasible here, which can only make
    the reference better than the design)."""
    walk = model.simulate(params, np.array(list(orbit.state.values())), 1)
    if walk.ended != "completed":
        return False
    for k, phase in enumerate(model.phases):
        samples = walk.states[walk.phase == k]
        for _name, function, direction in phase["failures"]:
            guard = np.asarray(getattr(model.module, function)(*params, *samples.T), float)
            if np.any(-direction * np.broadcast_to(guard, len(samples)) < 0):
                return False
    return True


def branches(model, name: str, span: tuple[float, float], fixed: dict) -> list[list[Point]]:
    """The gait branches over the grid of ``span``, each a list of points in order."""
    grid = np.linspace(span[0], span[1], GRID)
    traced: list[list[Point]] = []
    began = time.perf_counter()
    for start in (grid[GRID // 4], grid[3 * GRID // 4]):
        params = _params(model, name, float(start), fixed)
        for orbit in model.search_gaits(params).gaits:
            state = np.array(list(orbit.state.values()))
            seed = _evaluate(model, name, float(start), fixed, state, np.array(orbit.durations))
            if seed is None or any(_same(seed, b) for b in traced):
                continue
            index = int(np.argmin(abs(grid - start)))
            branch = [seed]
            for direction in (+1, -1):
                last, k = seed, index
                while 0 <= k + direction < GRID:
                    k += direction
                    point = _evaluate(model, name, float(grid[k]), fixed, last.state,
                                      last.durations)  # fmt: skip
                    if point is None:
                        break
                    branch.append(point)
                    last = point
            traced.append(sorted(branch, key=lambda p: p.value))
            print(
                f"  branch {len(traced)}: {len(branch)} points from {start:.4g} "
                f"({time.perf_counter() - began:.1f} s)",
                file=sys.stderr,
                flush=True,
            )
    return traced


def _same(point: Point, branch: list[Point]) -> bool:
    """Whether ``point`` (a grid value) lies on an already traced branch."""
    near = min(branch, key=lambda p: abs(p.value - point.value))
    return abs(near.value - point.value) < 1e-12 and bool(
        np.allclose(near.state, point.state, atol=1e-7)
    )


@dataclass
class Problem:
    label: str
    objective: str
    sense: int
    box: tuple[float, float]
    max_eigenvalue: float | None
    target: tuple[str, float] | None

    def request(self, name: str, fixed: dict) -> gait_design.DesignRequest:
        return gait_design.DesignRequest(
            objective={self.objective: 1.0} if self.objective else {},
            targets=dict([self.target]) if self.target else {},
            fixed=fixed, bounds={name: self.box}, max_eigenvalue=self.max_eigenvalue,
        )  # fmt: skip


def problems(count: int, seed: int, span, traced) -> list[Problem]:
    rng = np.random.default_rng(seed)
    values = {q: [p.quantities[q] for b in traced for p in b] for q in ("speed", "period")}
    out = []
    for k in range(count):
        objective, sense = OBJECTIVES[int(rng.integers(len(OBJECTIVES)))]
        width = (span[1] - span[0]) * rng.uniform(0.25, 1.0)
        low = span[0] + rng.uniform(0, span[1] - span[0] - width)
        eig = float(rng.choice([0.6, 0.8, 1.0, 1.5])) if rng.random() < 0.5 else None
        target = None
        if rng.random() < 0.4:
            what = str(rng.choice(["speed", "period"]))
            lo, hi = min(values[what]), max(values[what])
            target = (what, float(rng.uniform(lo * 0.9, hi * 1.1)))
            if rng.random() < 0.5:
                objective, sense = "eigenvalue", -1
        out.append(Problem(f"{k:03d}", objective, sense, (float(low), float(low + width)),
                           eig, target))  # fmt: skip
    return out


def _reference(model, name, fixed, traced, problem: Problem) -> tuple[float, float] | None:
    """(parameter, objective in the minimised form) of the best feasible point, or None."""
    low, high = problem.box
    sign = -problem.sense  # minimised form: -value when maximised
    candidates: list[tuple[float, float]] = []

    def feasible(p: Point) -> bool:
        ok = p.margins_ok and low - 1e-12 <= p.value <= high + 1e-12
        if problem.max_eigenvalue is not None:
            ok = ok and p.quantities["eigenvalue"] <= problem.max_eigenvalue * (1 + 1e-9)
        return ok

    def at(branch_point: Point, value: float) -> Point | None:
        return _evaluate(model, name, value, fixed, branch_point.state, branch_point.durations)

    def crossing(a: Point, b: Point, fn) -> Point | None:
        try:
            root = brentq(lambda v: fn(at(a, v)), a.value, b.value, xtol=1e-13, rtol=1e-13)
        except (ValueError, TypeError):
            return None
        return at(a, root)

    for branch in traced:
        inside = [p for p in branch if low <= p.value <= high]
        # The box's ends on the branch.
        ends = []
        for edge in (low, high):
            near = min(branch, key=lambda p: abs(p.value - edge))
            if abs(near.value - edge) <= (branch[-1].value - branch[0].value) / (GRID - 1) + 1e-15 \
                    and branch[0].value <= edge <= branch[-1].value:  # fmt: skip
                point = at(near, edge)
                if point is not None:
                    ends.append(point)
        points = sorted(inside + ends, key=lambda p: p.value)
        extra: list[Point] = []
        for a, b in itertools.pairwise(points):
            if problem.max_eigenvalue is not None:
                e = problem.max_eigenvalue
                fa, fb = a.quantities["eigenvalue"] - e, b.quantities["eigenvalue"] - e
                if fa * fb < 0:
                    found = crossing(a, b, lambda p, e=e: p.quantities["eigenvalue"] - e)
                    if found is not None:
                        found.quantities["eigenvalue"] = e  # the bound, to rounding
                        extra.append(found)
            if problem.target is not None:
                what, value = problem.target
                if (a.quantities[what] - value) * (b.quantities[what] - value) <= 0:
                    found = crossing(a, b, lambda p, w=what, v=value: p.quantities[w] - v)
                    if found is not None:
                        extra.append(found)
        if problem.target is not None:
            points = [p for p in extra if abs(p.quantities[problem.target[0]] - problem.target[1])
                      <= 1e-6 * max(1, abs(problem.target[1]))]  # fmt: skip
        else:
            points = sorted(points + extra, key=lambda p: p.value)
            # Interior extrema between grid neighbours.
            objective = problem.objective
            values = [sign * p.quantities[objective] for p in points]
            for i in range(1, len(points) - 1):
                if (values[i] <= values[i - 1] and values[i] <= values[i + 1]
                        and points[i - 1].value < points[i + 1].value):  # fmt: skip
                    a, b, mid = points[i - 1], points[i + 1], points[i]
                    res = minimize_scalar(
                        lambda v, mid=mid, o=objective: _objective_at(at(mid, v), sign, o),
                        bounds=(a.value, b.value), method="bounded",
                        options={"xatol": 1e-12},
                    )  # fmt: skip
                    found = at(mid, float(res.x))
                    if found is not None:
                        points.append(found)
        for p in points:
            if feasible(p):
                candidates.append((p.value, sign * p.quantities[problem.objective]))
    if not candidates:
        return None
    return min(candidates, key=lambda c: c[1])


def _objective_at(point: Point | None, sign: int, objective: str) -> float:
    return math.inf if point is None else sign * point.quantities[objective]


def _slsqp(model, name, fixed, traced, problem: Problem) -> tuple[float, float | None]:
    """SciPy SLSQP over the free parameter, each evaluation a periodic-orbit solve warm
    started from the last (finite-difference gradients): the user's route without the NLP.
    Starts from the branch point nearest the box's centre. (seconds, objective or None)."""
    centre = 0.5 * sum(problem.box)
    start = min((p for b in traced for p in b), key=lambda p: abs(p.value - centre))
    last = [start]
    sign = -problem.sense

    def point(v):
        got = _evaluate(model, name, float(v[0]), fixed, last[0].state, last[0].durations)
        if got is not None:
            last[0] = got
        return got

    def f(v):
        p = point(v)
        return 1e3 if p is None else sign * p.quantities[problem.objective]

    cons = []
    if problem.max_eigenvalue is not None:
        cons.append({"type": "ineq", "fun": lambda v: problem.max_eigenvalue
                     - (point(v) or start).quantities["eigenvalue"]})  # fmt: skip
    if problem.target is not None:
        what, value = problem.target
        cons.append({"type": "eq", "fun": lambda v: (point(v) or start).quantities[what] - value})
    began = time.perf_counter()
    res = minimize(f, [start.value], method="SLSQP", bounds=[problem.box], constraints=cons,
                   options={"maxiter": 50, "ftol": 1e-10})  # fmt: skip
    seconds = time.perf_counter() - began
    return seconds, (float(res.fun) if res.success else None)


def _busy_seconds() -> float:
    """CPU seconds the whole machine has been busy (``/proc/stat``: a child still exiting
    counts too); this process's where that cannot be read."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]
        user, nice, system, _idle, _iowait, irq, softirq, steal = (int(v) for v in fields[:8])
        return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError):
        return time.process_time()


def _quiet(window: float = 0.05, most: float = 2.0) -> None:
    """Wait until the machine is idle (less than a tenth of a core busy over ``window``
    seconds; ``most`` seconds at most): a BLAS pool that the last run woke, or created
    anew after a fork, spins for 0.1-0.2 s of CPU, which made the next run take up to
    three times its time on this 2-core machine (SLSQP after a design: 35 -> 108 ms)."""
    began = time.monotonic()
    while time.monotonic() - began < most:
        busy = _busy_seconds()
        time.sleep(window)
        if _busy_seconds() - busy < 0.1 * window:
            return


def run(count: int, seed: int, model_keys: list[str], slsqp: int) -> dict:
    report: dict = {"models": {}}
    for key in model_keys:
        model = models.load(key)
        name, span, fixed = SETUPS[key]
        began = time.perf_counter()
        traced = branches(model, name, span, fixed)
        trace_seconds = time.perf_counter() - began
        records = []
        for problem in problems(count, seed, span, traced):
            ref = _reference(model, name, fixed, traced, problem)
            began = time.perf_counter()
            result = gait_design.design(model, problem.request(name, fixed))
            seconds = time.perf_counter() - began
            got = None
            if result.found:
                got = (-problem.sense) * result.quantities[problem.objective]
            if ref is None:
                success = not result.found
            else:
                success = got is not None and got <= ref[1] + 1e-6 * max(1.0, abs(ref[1]))
            record = {
                "label": problem.label, "objective": problem.objective, "box": problem.box,
                "max_eigenvalue": problem.max_eigenvalue, "target": problem.target,
                "reference": ref, "status": result.status, "objective_value": got,
                "parameter": None if not result.found else result.parameters[name],
                "seconds": seconds, "success": success, "message": result.message[:200],
            }  # fmt: skip
            if ref is not None and len([r for r in records if "slsqp_seconds" in r]) < slsqp:
                # The design again, its gait search now cached: SLSQP starts from a gait
                # of the traced branches, so this is the like-for-like time. Each side the
                # least of PAIRED_RUNS runs in turn: single runs of either moved by half
                # between two runs of the case.
                record["seconds_cached"] = record["slsqp_seconds"] = math.inf
                for _ in range(PAIRED_RUNS):
                    _quiet()
                    began = time.perf_counter()
                    gait_design.design(model, problem.request(name, fixed))
                    seconds = time.perf_counter() - began
                    record["seconds_cached"] = min(record["seconds_cached"], seconds)
                    _quiet()
                    seconds, record["slsqp_objective"] = _slsqp(model, name, fixed, traced,
                                                                problem)  # fmt: skip
                    record["slsqp_seconds"] = min(record["slsqp_seconds"], seconds)
            records.append(record)
            print(f"{key} {problem.label} {result.status:13s} {seconds:6.1f}s ok={success} "
                  f"ref={ref} got={got}", file=sys.stderr, flush=True)  # fmt: skip
        feasible = [r for r in records if r["reference"] is not None]
        report["models"][key] = {
            "free": name, "span": span, "fixed": fixed, "branches": len(traced),
            "trace_seconds": trace_seconds, "records": records,
            "success": sum(r["success"] for r in records), "problems": len(records),
            "feasible_reported_infeasible": sum(r["status"] == "infeasible" for r in feasible),
            "feasible_not_converged": sum(r["status"] == "not-converged" for r in feasible),
            "infeasible_reported_feasible": sum(
                r["status"] in ("optimal", "not-attained") for r in records
                if r["reference"] is None),
            "median_seconds": statistics.median(r["seconds"] for r in records),
            "slsqp_pairs": [(r["seconds"], r["slsqp_seconds"]) for r in records
                            if "slsqp_seconds" in r],
            "slsqp_cached_pairs": [(r["seconds_cached"], r["slsqp_seconds"]) for r in records
                                   if "seconds_cached" in r],
        }  # fmt: skip
    return report


def rows(report: dict, row: Any, timing: Any) -> list[Any]:
    """benchmarks/run.py's rows (case 13) of a report of :func:`run`."""
    out = []
    for key, m in report["models"].items():
        records = m["records"]
        failed = [r["label"] for r in records if not r["success"]]
        statuses = {}
        for r in records:
            statuses[r["status"]] = statuses.get(r["status"], 0) + 1
        rate = m["success"] / m["problems"]
        out.append(row(
            "13", f"design, {key} ({m['free']} in {m['span']}, {m['problems']} problems): "
            "success (feasible: optimal or not-attained, objective no worse than the "
            "reference's by 1e-6; infeasible: not called feasible)",
            "reference: every gait branch by continuation (runtime Newton, no IPOPT), "
            "brentq/minimize_scalar polish", None, None, ">= 99 %", rate >= 0.99,
            note=f"{m['success']}/{m['problems']} = {100 * rate:.1f} %; statuses "
            + ", ".join(f"{k} {v}" for k, v in sorted(statuses.items()))
            + f"; {m['branches']} branches traced in {m['trace_seconds']:.0f} s"
            + (f"; failed: {', '.join(failed)}" if failed else ""),
        ))  # fmt: skip
        out.append(row(
            "13", f"{key}: feasible problems reported infeasible", "-", None, None, "0",
            m["feasible_reported_infeasible"] == 0,
            note=f"{m['feasible_reported_infeasible']} (not converged: "
            f"{m['feasible_not_converged']}; infeasible reported feasible: "
            f"{m['infeasible_reported_feasible']})",
        ))  # fmt: skip
        pairs = m["slsqp_pairs"]
        ours = timing.of([r["seconds"] for r in records])
        given = [r for r in records if "slsqp_seconds" in r]

        def reached(value: float | None, r: dict) -> bool:
            ref = r["reference"][1]
            return value is not None and value <= ref + 1e-6 * max(1.0, abs(ref))

        slsqp_hits = sum(reached(r["slsqp_objective"], r) for r in given)
        design_hits = sum(reached(r["objective_value"], r) for r in given)
        if pairs:
            out.append(row(
                "13", f"{key}: vsw.synthesis.design per problem, the {len(pairs)} feasible "
                "problems given to SLSQP (gait search at the start included)",
                "SciPy SLSQP over the parameter, each evaluation a warm-started "
                f"periodic-orbit solve, finite differences (the least of {PAIRED_RUNS} runs; "
                "the design's first run, one only)", timing.of([a for a, _ in pairs]),
                timing.of([b for _, b in pairs]), "faster",
                statistics.median(a for a, _ in pairs) < statistics.median(b for _, b in pairs),
                note=f"reached the reference optimum: vsw.synthesis.design "
                f"{design_hits}/{len(given)}, SLSQP {slsqp_hits}/{len(given)} (SLSQP starts "
                f"from the traced branch's gait nearest the box's centre, the design searches "
                f"its gaits); whole suite: "
                f"median {ours.median:.2f} s [{ours.low:.2f}, {ours.high:.2f}]",
            ))  # fmt: skip
        cached = m.get("slsqp_cached_pairs") or []
        if cached:
            out.append(row(
                "13", f"{key}: the same, vsw.synthesis.design again with its gait search cached "
                f"(the least of {PAIRED_RUNS} runs, each before one of SLSQP's)",
                "the same SLSQP runs", timing.of([a for a, _ in cached]),
                timing.of([b for _, b in cached]), "faster",
                statistics.median(a for a, _ in cached) < statistics.median(b for _, b in cached),
            ))  # fmt: skip
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--problems", type=int, default=50)
    parser.add_argument("--seed", type=int, default=2026)
    parser.add_argument("--models", default=",".join(SUITE_MODELS))
    parser.add_argument(
        "--slsqp", type=int, default=5, help="feasible problems per model with SLSQP"
    )
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    report = run(args.problems, args.seed, args.models.split(","), args.slsqp)
    for key, m in report["models"].items():
        pairs = m["slsqp_pairs"]
        ratio = (statistics.median(a for a, _ in pairs) / statistics.median(b for _, b in pairs)
                 if pairs else None)  # fmt: skip
        print(f"{key}: {m['success']}/{m['problems']} success, feasible called infeasible "
              f"{m['feasible_reported_infeasible']}, feasible not converged "
              f"{m['feasible_not_converged']}, infeasible called feasible "
              f"{m['infeasible_reported_feasible']}, median {m['median_seconds']:.2f} s, "
              f"vs SLSQP median ratio {ratio}")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps(report, indent=1, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
