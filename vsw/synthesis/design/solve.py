"""A design solved: the gaits it starts from, IPOPT from each, each solve verified by the
runtime's periodic-orbit solver and simulation, the best kept, its status (optimal, not
attained at an open limit, infeasible by the extremes the same starts reach, not
converged): :func:`design`."""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics import conditions
from vsw.dynamics.batch import simulator
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.dynamics.quantities import maximised, report
from vsw.dynamics.quantities import weight as walker_weight
from vsw.orbits.shooting import phase_pieces
from vsw.runtime import blas, forked, stop
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.runtime.threads import default_threads
from vsw.synthesis.design import collocation, pin
from vsw.synthesis.design.nlp import impact_events, kinetic_loss
from vsw.synthesis.design.problem import Problem, margin_floor
from vsw.synthesis.design.request import (
    CLOSED_FAILURES,
    INTERVALS,
    MIN_DURATION,
    SEGMENTS,
    STRICT_MARGIN,
    TARGET_TOL,
    DesignRequest,
    GaitDesign,
    open_distance,
    range_text,
)
from vsw.synthesis.design.shooting import Nlp, build

__all__ = ["design", "orbit_quantities"]


_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


@dataclass
class _Solve:
    start: int
    ipopt_status: str
    w: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    parameters: tuple[float, ...] = ()
    orbit: Orbit | None = None
    quantities: dict[str, float | None] = field(default_factory=dict)
    margins: list[dict[str, Any]] = field(default_factory=list)
    objective: float = math.inf
    failure: str = ""  # why it is not a verified design
    nlp: Any = None  # the NLP whose unknowns and multipliers these are

    @property
    def verified(self) -> bool:
        return self.orbit is not None and not self.failure


def _nontrivial_rank(orbits: Sequence[Orbit]) -> int:
    """How many eigenvalues of the step map are not structural zeros."""
    rank = 1
    for orbit in orbits:
        largest = max(1.0, orbit.max_abs_eigenvalue)
        rank = max(rank, sum(abs(e) > 1e-7 * largest for e in orbit.eigenvalues))
    return rank


def _initial_point(problem: Problem, nlp: Nlp, params: Sequence[float], orbit: Orbit,
                   rho: float) -> np.ndarray:  # fmt: skip
    """IPOPT's start from a gait at ``params``: its free parameters, its state at every
    node, its durations."""
    pieces = _walk(problem.model, params, orbit)
    w = np.zeros(nlp.size)
    w[nlp.layout["free"]] = [params[j] for j in problem.free]
    nodes = []
    for piece in pieces:
        times = piece.start + (piece.end - piece.start) * np.arange(SEGMENTS) / SEGMENTS
        nodes.append(piece.states(times).reshape(-1))
    w[nlp.layout["nodes"]] = np.concatenate(nodes)
    w[nlp.layout["durations"]] = [piece.end - piece.start for piece in pieces]
    w[nlp.layout["rho"]] = rho
    return w


def _walk(model: HybridModel, params: Sequence[float], orbit: Orbit) -> list:
    """A gait's step as one piece a phase by the phases' CVODES flows
    (:func:`vsw.orbits.shooting.phase_pieces`; ConvergenceError where CVODES fails)."""
    state = np.array(list(orbit.state.values()))
    try:
        return phase_pieces(model, params, state, orbit.durations)
    except RuntimeError:
        stop.check()
        raise ConvergenceError(f"{model.name}: the start gait does not walk a step") from None


def _bounds(
    problem: Problem, nlp: Nlp, targets: Mapping[str, float]
) -> dict[str, np.ndarray]:  # fmt: skip
    request = problem.request
    lbx = np.full(nlp.size, -np.inf)
    ubx = np.full(nlp.size, np.inf)
    lbx[nlp.layout["free"]] = [problem.box[j][0] for j in problem.free]
    ubx[nlp.layout["free"]] = [problem.box[j][1] for j in problem.free]
    lbx[nlp.layout["durations"]] = MIN_DURATION
    lbx[nlp.layout["rho"]] = 1e-4
    if request.max_eigenvalue is not None:
        ubx[nlp.layout["rho"]] = request.max_eigenvalue
    lbg = np.zeros(len(nlp.row_kinds))
    ubg = np.zeros(len(nlp.row_kinds))
    for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
        if kind == "margin":
            lbg[i], ubg[i] = margin_floor(name, request), np.inf
        elif kind in ("when", "jury"):
            lbg[i], ubg[i] = 0.0, np.inf
        elif kind == "quantity":
            if name in targets:
                lbg[i] = ubg[i] = targets[name]
            else:
                low, high = request.bounds.get(name, (None, None))
                lbg[i] = -np.inf if low is None else low
                ubg[i] = np.inf if high is None else high
    p = np.array([*problem.start, request.max_eigenvalue or 1.0])
    return {"lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg, "p": p}


def _solve(problem: Problem, nlp: Nlp, bounds: Mapping[str, np.ndarray], w0: np.ndarray,
           start: int) -> _Solve:  # fmt: skip
    # CasADi reports integrator trouble on stderr; the status and the verification say
    # what matters. IPOPT's linear algebra is small: BLAS workers would only spin beside it.
    with (
        blas.limited(1),
        contextlib.redirect_stderr(io.StringIO()),
        contextlib.redirect_stdout(io.StringIO()),
    ):
        try:
            out = nlp.solver(x0=w0, **bounds)
            status = str(nlp.solver.stats().get("return_status", "unknown"))
        except RuntimeError as exc:
            stop.check()
            return _Solve(start, "error: " + " ".join(str(exc).split())[:60], w0,
                          np.zeros_like(w0), np.zeros(len(nlp.row_kinds)), nlp=nlp)  # fmt: skip
    stop.check()  # IPOPT ends an interrupted solve with a status, not an exception
    return _Solve(
        start,
        status,
        np.array(out["x"]).reshape(-1),
        np.array(out["lam_x"]).reshape(-1),
        np.array(out["lam_g"]).reshape(-1),
        nlp=nlp,
    )


def _parameters_of(problem: Problem, nlp: Nlp, w: np.ndarray) -> tuple[float, ...]:
    values = list(problem.start)
    for i, j in enumerate(problem.free):
        values[j] = float(w[nlp.layout["free"]][i])
    return tuple(values)


def _verify(problem: Problem, nlp: Nlp, solve: _Solve, targets: Mapping[str, float],
            objective: Mapping[str, float]) -> _Solve:  # fmt: skip
    """Whether IPOPT's point is a gait that meets the request, by the runtime's own
    periodic-orbit solver (1e-13) and simulation."""
    model = problem.model
    if solve.ipopt_status not in _SUCCESS:
        solve.failure = f"IPOPT {solve.ipopt_status}"
        return solve
    params = _parameters_of(problem, nlp, solve.w)
    m = 2 * model.n
    state = solve.w[nlp.layout["nodes"]][:m]
    try:
        orbit = model.periodic_orbit(
            params, state, solve.w[nlp.layout["durations"]], step=simulator(model).step_phases
        )
    except ConvergenceError as exc:
        solve.failure = f"not confirmed: {exc}"
        return solve
    x_star = np.array(list(orbit.state.values()))
    if not np.max(np.abs(x_star - state)) <= 1e-6 * max(1.0, float(np.max(np.abs(x_star)))):
        solve.failure = "the confirmed orbit is another gait"
        return solve
    return _accept(problem, solve, params, orbit, targets, objective)


def _accept(problem: Problem, solve: _Solve, params: tuple, orbit: Orbit,
            targets: Mapping[str, float], objective: Mapping[str, float]) -> _Solve:  # fmt: skip
    """``solve`` as the confirmed gait ``orbit`` at ``params``, if every request holds on it."""
    solve = _measured(problem, solve, params, orbit, targets, objective)
    return _simulated(problem, solve, targets) if solve.failure == _UNSIMULATED else solve


_UNSIMULATED = "its step not simulated: a better design was verified"


def _measured(problem: Problem, solve: _Solve, params: tuple, orbit: Orbit,
              targets: Mapping[str, float], objective: Mapping[str, float]) -> _Solve:  # fmt: skip
    """``solve`` as the confirmed gait ``orbit`` at ``params`` with its quantities and
    objective; its failure the requests they miss, else :data:`_UNSIMULATED` until
    :func:`_simulated` checks the conditions along its step."""
    # The impacts' losses need the step simulated: only where the request names them.
    quantities = orbit_quantities(problem.model, params, orbit, energy=False)
    if any(name not in quantities for name in _named(problem, targets, objective)):
        quantities = orbit_quantities(problem.model, params, orbit)
    problems = _violations(problem, quantities, [], targets)
    solve.parameters, solve.orbit, solve.quantities = params, orbit, quantities
    solve.failure = "; ".join(problems) or _UNSIMULATED
    if not problems:
        solve.objective = _objective_value(objective, quantities)
    return solve


def _simulated(problem: Problem, solve: _Solve, targets: Mapping[str, float]) -> _Solve:
    """A measured ``solve`` with every condition's margin along its simulated step: verified
    where each holds (the step's simulation is the verification's dearest part)."""
    if "energy_per_step" not in solve.quantities:
        solve.quantities = orbit_quantities(problem.model, solve.parameters, solve.orbit)
    margins = conditions.gait_conditions(problem.model, solve.parameters, solve.orbit)
    problems = _violations(problem, solve.quantities, margins, targets)
    solve.failure = "; ".join(problems)
    if problems:
        solve.objective = math.inf
    else:
        solve.margins = margins
    return solve


def orbit_quantities(model: HybridModel, params: Sequence[float], orbit: Orbit,
                     energy: bool = True) -> dict:  # fmt: skip
    """The design quantities of a confirmed orbit (:func:`vsw.dynamics.quantities.report`): period,
    eigenvalue, the kinetic energy the impacts dissipate, step length, weight. Without
    ``energy`` the quantities made of the impacts' losses are left out (they need the step
    simulated)."""
    facts = {
        "period": orbit.period,
        "eigenvalue": orbit.max_abs_eigenvalue,
        "step_length": orbit.step_length,
        "weight": walker_weight(model, params),
    }
    if energy:
        facts["energy_per_step"] = facts["energy"] = _impact_losses(model, params, orbit)
    return report(facts)


def _impact_losses(model: HybridModel, params: Sequence[float], orbit: Orbit) -> float:
    """The kinetic energy the impacts of one simulated step of ``orbit`` dissipate."""
    state = np.array(list(orbit.state.values()))
    lost = 0.0
    phase = model.step_event["target"]
    for record in simulator(model).step_events(params, state):
        event = next(e for e in model.by_source[phase] if e["name"] == record.name)
        if record.name in impact_events(model):
            lost += float(kinetic_loss(model, phase, event["target"], np.asarray(params),
                                        record.state_before, record.state_after))  # fmt: skip
        phase = event["target"]
    return float(lost)


def _violations(problem: Problem, quantities: Mapping[str, Any], margins: list[dict],
                targets: Mapping[str, float]) -> list[str]:  # fmt: skip
    request = problem.request
    out = []
    for name, value in targets.items():
        got = quantities[name]
        if got is None or not abs(got - value) <= TARGET_TOL * max(1.0, abs(value)):
            out.append(f"target {name} {value:g} missed ({got})")
    for name, (low, high) in request.bounds.items():
        if name in quantities:
            got = quantities[name]
            slack = TARGET_TOL * max(1.0, abs(got))
            if (low is not None and got < low - slack) or (high is not None and got > high + slack):
                out.append(f"{name} {got:.6g} outside {range_text(low, high)}")
    e = request.max_eigenvalue
    if e is not None and not quantities["eigenvalue"] <= e * (1 + TARGET_TOL):
        out.append(f"max |eigenvalue| {quantities['eigenvalue']:.6g} above {e:g}")
    for margin in margins:
        if not margin.get("ends_walk", True):
            continue  # a condition the model reports, not one its walks must meet
        closed = margin["name"] in CLOSED_FAILURES
        if margin["margin"] is not None and not (
            margin["margin"] >= 0 if closed else margin["margin"] > 0
        ):
            out.append(f"condition {margin['name']} fails (margin {margin['margin']:.3g})")
        elif margin["margin"] is not None and margin["margin"] < request.min_margin * (1 - 1e-6):
            out.append(f"condition {margin['name']} margin {margin['margin']:.3g} below "
                       f"{request.min_margin:g}")  # fmt: skip
    return out


def _named(problem: Problem, targets: Mapping[str, float],
           objective: Mapping[str, float]) -> set[str]:  # fmt: skip
    """The quantities a request names: its objective's terms and its NLP's quantity rows."""
    return set(objective) | set(_quantity_rows(problem, targets))


def _quantity_rows(problem: Problem, targets: Mapping[str, float]) -> tuple[str, ...]:
    """The quantities the NLPs constrain: the targets, and the bounded design quantities."""
    return tuple(sorted(set(targets) | (set(problem.request.bounds) & problem.available)))


def _objective_value(objective: Mapping[str, float], quantities: Mapping[str, Any]) -> float:
    total = 0.0
    for term, weight in objective.items():
        value = quantities[term]
        total += (-weight if maximised(term) else weight) * float(value)
    return total


def _multistart(
    problem: Problem,
    seeds: Sequence[Orbit],
    rank: int,
    objective: Mapping[str, float] | None = None,
    targets: Mapping[str, float] | None = None,
    eigen: str | None = "same",
    shoot_seeds: bool = True,
) -> tuple[_Solve | None, list[_Solve]]:
    """IPOPT from each seed on the collocated NLP; each distinct collocated optimum
    carried onto the exact gait by the constraints that pin it (:mod:`.pin`), else polished
    on the shooting NLP, and verified; the seeds themselves on the shooting NLP where no
    polished optimum is verified (:func:`_shot_seeds`, unless ``shoot_seeds`` is False).
    The best verified solve and every solve."""
    objective, targets, structure = _structure(problem, rank, objective, targets, eigen)
    candidates = _collocated_candidates(problem, structure, seeds, objective, targets)
    measured, unpinned = [], []
    for params, orbit, _, vertex in candidates:
        if vertex is None:
            unpinned.append((params, orbit))
        else:
            measured.append((vertex, (params, orbit)))
    best, solves, failed = _best_simulated(problem, measured, targets)
    unpinned += failed
    if unpinned:
        nlp = build(problem.model, structure)
        shot, more = _shoot(problem, nlp, unpinned, 1e-3, objective, targets)
        solves += more
        if shot is not None and (best is None or shot.objective < best.objective - 1e-12):
            best = shot
    if best is None and shoot_seeds:
        best, more = _shot_seeds(problem, seeds, rank, objective, targets, eigen)
        solves += more
    return best, solves


def _structure(problem: Problem, rank: int, objective: Mapping[str, float] | None,
               targets: Mapping[str, float] | None, eigen: str | None) -> tuple:  # fmt: skip
    """The objective, the targets (the request's where None) and the NLPs' structure."""
    objective = problem.objective if objective is None else objective
    targets = problem.request.targets if targets is None else targets
    rows = _quantity_rows(problem, targets)
    return objective, targets, problem.structure(rank, objective, rows, eigen)


def _shot_seeds(problem: Problem, seeds: Sequence[Orbit], rank: int,
                objective: Mapping[str, float] | None = None,
                targets: Mapping[str, float] | None = None,
                eigen: str | None = "same") -> tuple[_Solve | None, list[_Solve]]:  # fmt: skip
    """The seeds themselves on the shooting NLP, each verified: the best and all (the
    rimless wheel's least energy per step lies where the gait ceases to exist, which the
    collocation does not reach and the shooting does)."""
    objective, targets, structure = _structure(problem, rank, objective, targets, eigen)
    starts = [(tuple(problem.start), orbit) for orbit in seeds]
    nlp = build(problem.model, structure)
    return _shoot(problem, nlp, starts, 0.05, objective, targets)


def _pinned(problem: Problem, structure: Any, collocated: _Solve, targets: Mapping[str, float],
            objective: Mapping[str, float]) -> _Solve | None:  # fmt: skip
    """A collocated optimum at its vertex solved on the exact gait and measured
    (:func:`vsw.synthesis.design.pin.pinned_gait`, :func:`_measured`); None where its active
    set does not pin it or the pinned gait misses a request (the shooting NLP polishes it
    instead)."""
    nlp = collocated.nlp
    bounds = _bounds(problem, nlp, targets)
    rows = pin.pinning_rows(problem, nlp, collocated, bounds, targets, structure.eigen)
    if rows is None:
        return None
    params = _parameters_of(problem, nlp, collocated.w)
    state = collocated.w[nlp.layout["states"]][: 2 * problem.model.n]
    found = pin.pinned_gait(problem, params, state, collocated.w[nlp.layout["durations"]], rows)
    if found is None:
        return None
    solve = _measured(problem, dataclasses.replace(collocated), *found, targets, objective)
    return solve if solve.failure == _UNSIMULATED else None


def _best_simulated(
    problem: Problem, measured: list[tuple[_Solve, Any]], targets: Mapping[str, float]
) -> tuple[_Solve | None, list[_Solve], list[Any]]:
    """The best of the measured vertices whose simulated step meets every condition: each
    leader in turn simulated (the first of equal objectives to 1e-12, in the candidates'
    order) until one holds. The others cannot beat it and keep :data:`_UNSIMULATED`.
    (the best, every solve but the failed, the failed ones' starts for the shooting NLP)."""
    pending = list(range(len(measured)))
    best, failed = None, []
    while pending and best is None:
        leader = pending[0]
        for k in pending[1:]:
            if measured[k][0].objective < measured[leader][0].objective - 1e-12:
                leader = k
        pending.remove(leader)
        solve, start = measured[leader]
        if _simulated(problem, solve, targets).verified:
            best = solve
        else:
            failed.append(start)
    solves = [solve for solve, _ in measured if solve is best or solve.failure == _UNSIMULATED]
    return best, solves, failed


def _shoot(problem: Problem, nlp: Nlp, starts: Sequence[tuple[tuple, Orbit]], above: float,
           objective: Mapping[str, float],
           targets: Mapping[str, float]) -> tuple[_Solve | None, list[_Solve]]:  # fmt: skip
    """IPOPT on the shooting NLP from each (parameters, gait), the eigenvalue disc's radius
    ``above`` the gait's largest modulus, each solve verified: the best and all. The starts
    are shared among the cores as the collocated ones are."""
    bounds = _bounds(problem, nlp, targets)
    shoot = functools.partial(_shoot_one, problem, nlp, bounds, above, objective, targets)
    solves, best = [], None
    for solve in forked.split_map(shoot, list(enumerate(starts)), default_threads()):
        if solve is None:
            continue
        solve.nlp = nlp
        solves.append(solve)
        if solve.verified and (best is None or solve.objective < best.objective - 1e-12):
            best = solve
    return best, solves


def _shoot_one(problem: Problem, nlp: Nlp, bounds: Mapping[str, np.ndarray], above: float,
               objective: Mapping[str, float], targets: Mapping[str, float],
               start: tuple[int, tuple[tuple, Orbit]]) -> _Solve | None:  # fmt: skip
    """One start of :func:`_shoot`, verified, without its NLP (it does not pickle)."""
    k, (params, orbit) = start
    rho = (1.0 + above) * max(orbit.max_abs_eigenvalue, 1e-3)
    try:
        w0 = _initial_point(problem, nlp, params, orbit, rho)
    except (ConvergenceError, RuntimeError):  # RuntimeError: CVODES between the nodes
        stop.check()
        return None
    solve = _verify(problem, nlp, _solve(problem, nlp, bounds, w0, k), targets, objective)
    solve.nlp = None
    return solve


def _same_gait(params: Sequence[float], orbit: Orbit, other_params: Sequence[float],
               other: Orbit) -> bool:  # fmt: skip
    """Whether two confirmed gaits are one: equal parameters and section states to 1e-6
    (several gaits share their parameters: the compass gait's short and long steps)."""
    state = np.array(list(orbit.state.values()))
    other_state = np.array(list(other.state.values()))
    return bool(np.allclose(params, other_params, rtol=1e-6, atol=1e-9)
                and np.allclose(state, other_state, rtol=1e-6, atol=1e-9))  # fmt: skip


_Candidate = tuple[tuple, Orbit, _Solve, _Solve | None]
"""A collocated optimum's parameters and confirmed gait (its vertex's, where pinned), its
solve, and its vertex on the exact gait measured (:func:`_pinned`; None where it is no
vertex)."""


def _collocated_candidates(problem: Problem, structure: Any, seeds: Sequence[Orbit],
                           objective: Mapping[str, float],
                           targets: Mapping[str, float]) -> list[_Candidate]:  # fmt: skip
    """Each seed's collocated optimum (:mod:`vsw.synthesis.design.collocation`) that IPOPT
    solved and the periodic-orbit solver confirms as a gait (at its vertex, else at its
    parameters), with its solve and its vertex, best objective first, one of each gait
    (:func:`_same_gait`). The seeds are shared among the cores
    (:func:`vsw.runtime.forked.split_map`: the NLP is built once, before)."""
    model = problem.model
    nlp = collocation.build(model, structure, tuple(INTERVALS for _ in model.phase_sequence()))
    bounds = _bounds(problem, nlp, targets)
    simulator(model).library()  # compiled (or found) here, not in each child
    collocate = functools.partial(_collocate, problem, structure, nlp, bounds, targets,
                                  objective)  # fmt: skip
    found: list[tuple[float, _Candidate]] = []
    for item in forked.split_map(collocate, seeds, default_threads()):
        if item is None:
            continue
        value, candidate = item
        for solve in candidate[2:]:
            if solve is not None:
                solve.nlp = nlp
        if not any(_same_gait(*candidate[:2], *other[1][:2]) for other in found):
            found.append((value, candidate))
    found.sort(key=lambda item: item[0])
    return [candidate for _, candidate in found]


def _collocate(problem: Problem, structure: Any, nlp: Any, bounds: Mapping[str, np.ndarray],
               targets: Mapping[str, float], objective: Mapping[str, float],
               orbit: Orbit) -> tuple[float, _Candidate] | None:  # fmt: skip
    """IPOPT on the collocated NLP from one seed, its vertex (:func:`_pinned`, here so that
    the cores share it too) or else the gait the periodic-orbit solver confirms there:
    (the collocated objective, the candidate with its solves' NLP left out), or None."""
    model = problem.model
    try:
        pieces = _walk(model, problem.start, orbit)
    except ConvergenceError:
        return None
    rho = 1.05 * max(orbit.max_abs_eigenvalue, 1e-3)
    try:
        w0 = collocation.initial_point(model, nlp, np.asarray(problem.start, float), pieces,
                                      [problem.start[j] for j in problem.free], rho)  # fmt: skip
    except RuntimeError:  # CVODES failed between the nodes
        stop.check()
        return None
    solve = _solve(problem, nlp, bounds, w0, 0)
    if solve.ipopt_status not in _SUCCESS:
        return None
    solve.nlp = nlp
    table = np.array(nlp.quantities(solve.w, bounds["p"])).reshape(-1)
    value = _objective_value(objective, dict(zip(nlp.quantities.names, table)))
    # At a vertex the pin's own orbit solves confirm the gait; elsewhere the orbit solver
    # confirms it at the collocated parameters.
    vertex = _pinned(problem, structure, solve, targets, objective)
    if vertex is not None:
        gait = (vertex.parameters, vertex.orbit)
    else:
        params = _parameters_of(problem, nlp, solve.w)
        x = solve.w[nlp.layout["states"]][: 2 * model.n]
        try:
            gait = (params, model.periodic_orbit(params, x, solve.w[nlp.layout["durations"]],
                                                 step=simulator(model).step_phases))  # fmt: skip
        except ConvergenceError:
            return None
    for each in (solve, vertex):
        if each is not None:
            each.nlp = None  # a CasADi function does not pickle: the caller sets it back
    return value, (*gait, solve, vertex)


def _open_limits(problem: Problem, nlp: Nlp, solve: _Solve) -> tuple[str, ...]:
    """The open limits the optimum presses against (its multiplier pulls it there)."""
    out = []
    # Where it is: the verified parameters (a vertex's are the collocated ones moved onto
    # the runtime's gait); what pulls it there: the NLP's multipliers.
    if solve.parameters:
        free_w = np.array([solve.parameters[j] for j in problem.free])
    else:
        free_w = solve.w[nlp.layout["free"]]
    free_lam = solve.lam_x[nlp.layout["free"]]
    for i, j in enumerate(problem.free):
        p = problem.table[j]
        low, high = problem.box[j]
        tol = 1e-7 * max(1.0, abs(high - low))
        pulled = abs(free_lam[i]) > 1e-8
        # Open only where the box's edge is the table's open limit kept at its distance
        # (not a closed bound of the user's, not the computed range's end).
        distance = open_distance(p)
        if pulled and abs(free_w[i] - low) <= tol and low == p.lower + distance:
            out.append(f"{p.name} -> {p.lower:.6g}")
        if pulled and abs(free_w[i] - high) <= tol and high == p.upper - distance:
            out.append(f"{p.name} -> {p.upper:.6g}")
    if problem.request.min_margin <= STRICT_MARGIN:
        g = None
        for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
            if name in CLOSED_FAILURES:
                continue
            margin = margin_floor(name, problem.request)
            if kind == "margin" and abs(solve.lam_g[i]) > 1e-8:
                g = g if g is not None else _constraint_values(nlp, solve.w, problem)
                if abs(g[i] - margin) <= 1e-7:
                    text = f"margin of {name} -> 0"
                    if text not in out:
                        out.append(text)
    return tuple(out)


def _constraint_values(nlp: Nlp, w: np.ndarray, problem: Problem) -> np.ndarray:
    p = np.array([*problem.start, problem.request.max_eigenvalue or 1.0])
    with contextlib.redirect_stderr(io.StringIO()):
        return np.array(nlp.solver.get_function("nlp_g")(w, p)).reshape(-1)


def _active(problem: Problem, nlp: Nlp, solve: _Solve) -> tuple[str, ...]:
    """The constraints the optimum presses against (:func:`pin.pressed_bound`: a multiplier
    and the value at its bound), targets aside."""
    bounds = _bounds(problem, nlp, problem.request.targets)
    g = _constraint_values(nlp, solve.w, problem)
    out = []
    for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
        if kind not in ("margin", "quantity", "jury") or name in problem.request.targets:
            continue
        if pin.pressed_bound(g[i], solve.lam_g[i], bounds["lbg"][i], bounds["ubg"][i], 1.0) is None:
            continue
        label = "max |eigenvalue|" if kind == "jury" else name
        if label not in out:
            out.append(label)
    free = nlp.layout["free"]
    for i, j in enumerate(problem.free):
        low, high = problem.box[j]
        if (
            pin.pressed_bound(solve.w[free][i], solve.lam_x[free][i], low, high, high - low)
            is not None
        ):
            out.append(f"{problem.table[j].name} bound")
    return tuple(out)


def design(model: HybridModel, request: DesignRequest) -> GaitDesign:
    """Design the model's free parameters and its gait for ``request`` (the package's docstring).

    Raises VswInputError for a malformed request (unknown names, bounds outside the
    parameter table, contradictory fixes, bounds and targets, more targets than free
    parameters); every other outcome is a status of the result.
    """
    if not (isinstance(request.starts, int) and 1 <= request.starts <= 50):
        raise VswInputError(f"starts = {request.starts!r} must be an integer from 1 to 50")
    problem = Problem(model, request)
    if not problem.free:
        raise VswInputError(f"every parameter of {model.name} is fixed: nothing to design "
                            "(drop a --fix, or --bound a scale)")  # fmt: skip
    seeds, tried, why_none = _seeds(problem)
    if not seeds:
        return GaitDesign("not-converged", f"not converged: no gait to start from at "
                          f"{tried} parameter set(s) of the box ({why_none})")  # fmt: skip
    # The solves' linear algebra is small. Held for the whole design, BLAS keeps one thread:
    # a pool woken at each solve's end would spin beside the forked children's solves.
    with blas.limited(1):
        return _designed(problem, seeds)


def _designed(problem: Problem, seeds: list[Orbit]) -> GaitDesign:
    """:func:`design` from the gaits it starts from."""
    model = problem.model
    rank = _nontrivial_rank(seeds)
    best, solves = _multistart(problem, seeds, rank, shoot_seeds=False)
    reason = None
    if best is None:
        # Evidence of infeasibility first: the seeds' shooting solves cost seconds each.
        reason = _infeasibility(problem, seeds, rank)
        if reason is None:
            best, more = _shot_seeds(problem, seeds, rank)
            solves += more
    statuses = ", ".join(sorted({s.ipopt_status for s in solves})) or "no start"
    if best is None:
        if reason is not None:
            return GaitDesign("infeasible", f"infeasible: {reason}", ipopt_status=statuses,
                              starts=len(seeds), infeasible_reason=reason)  # fmt: skip
        why = "; ".join(sorted({s.failure for s in solves}))[:300]
        return GaitDesign("not-converged", f"not converged: no verified design from "
                          f"{len(seeds)} start(s) ({why or 'no start walks a step'})",
                          ipopt_status=statuses, starts=len(seeds))  # fmt: skip
    limits = _open_limits(problem, best.nlp, best)
    status = "not-attained" if limits else "optimal"
    if limits:
        message = (f"not attained: the optimum lies on the open limit(s) {', '.join(limits)}; "
                   f"the design keeps its distance (parameters: 1e-3 of the interval or the "
                   f"default, margins {STRICT_MARGIN:g})")  # fmt: skip
    else:
        message = (f"optimal (local, the best verified of {len(solves)} polished optimum(s) "
                   f"from the {len(seeds)} gait(s) at the start; IPOPT "
                   f"{best.ipopt_status})")  # fmt: skip
    state = np.array(list(best.orbit.state.values()))
    # The gap of the simulated step that confirmed the gait (the compiled integrator, or
    # SciPy's route without a compiler: tests/test_batch.py holds the two to 1e-9), taken
    # again here rather than carried; SciPy's import alone would add 0.2 s to the command.
    step = simulator(model).step_phases(best.parameters, state)
    scale = max(1.0, float(np.max(np.abs(state))))
    sim_error = (float(np.max(np.abs(step.state - state))) / scale
                 if step.ended == "completed" else math.inf)  # fmt: skip
    names = [p.name for p in problem.table]
    return GaitDesign(
        status,
        message,
        dict(zip(names, best.parameters)),
        best.orbit,
        best.quantities,
        best.margins,
        best.objective,
        _active(problem, best.nlp, best),
        limits,
        best.ipopt_status,
        len(seeds),
        sim_error,
    )


START_SETS = 6
"""Parameter sets searched for gaits to start from, at most: the request's start (its
``start`` values, else defaults and fixes; a default outside the box replaced by the box's
middle), then the box's centre and Halton points of the box,
until one has gaits (a rimless wheel with wide spokes on a gentle slope has none)."""


def _seeds(problem: Problem) -> tuple[list[Orbit], int, str]:
    """The gaits IPOPT starts from (at most ``starts``), the parameter sets searched and,
    when none has a gait, the last search's reason."""
    free = problem.free
    points = [problem.start]
    centre = list(problem.start)
    for j in free:
        centre[j] = 0.5 * sum(problem.box[j])
    points.append(tuple(centre))
    for k in range(1, START_SETS):
        point = list(problem.start)
        for d, j in enumerate(free):
            low, high = problem.box[j]
            point[j] = low + _halton(k, _PRIMES[d % len(_PRIMES)]) * (high - low)
        points.append(tuple(point))
    why = ""
    for tried, params in enumerate(points[:START_SETS], start=1):
        search = problem.model.search_gaits(params)
        if search.gaits:
            problem.start = tuple(params)
            return list(search.gaits)[: problem.request.starts], tried, ""
        why = search.why_none()
    return [], min(len(points), START_SETS), why


_PRIMES = (2, 3, 5, 7, 11, 13)


def _halton(index: int, base: int) -> float:
    value, fraction = 0.0, 1.0
    while index:
        fraction /= base
        value += fraction * (index % base)
        index //= base
    return value


def _infeasibility(problem: Problem, seeds: Sequence[Orbit], rank: int) -> str | None:
    """Why no design exists, when the extremes the same starts reach prove it: a target
    beyond the largest or smallest value of its quantity under the other constraints, an
    eigenvalue bound below the least max |eigenvalue|."""
    request = problem.request
    for name, value in request.targets.items():
        others = {k: v for k, v in request.targets.items() if k != name}
        for sense in (+1, -1):
            extreme = _extreme(problem, seeds, rank, name, sense, others)
            if extreme is None:
                continue
            slack = TARGET_TOL * max(1.0, abs(extreme))
            beyond = value > extreme + slack if sense > 0 else value < extreme - slack
            if beyond:
                word = "largest" if sense > 0 else "smallest"
                return (f"the target {name} {value:g} lies beyond the {word} {name} of the "
                        f"gaits the design reaches from the same starts under the other "
                        f"constraints, {extreme:.6g} (a local extreme)")  # fmt: skip
    if request.max_eigenvalue is not None:
        least = _extreme(problem, seeds, rank, "eigenvalue", -1, request.targets, eigen=None)
        if least is not None and least > request.max_eigenvalue:
            return (
                f"--max-eigenvalue {request.max_eigenvalue:g} lies below the least max "
                f"|eigenvalue| the design reaches from the same starts, {least:.6g}"
            )
    return None


def _extreme(problem: Problem, seeds: Sequence[Orbit], rank: int, name: str, sense: int,
             targets: Mapping[str, float], eigen: str | None = "same") -> float | None:  # fmt: skip
    """The largest (sense +1) or smallest (-1) verified value of a quantity."""
    if name == "eigenvalue":
        objective = {"eigenvalue": 1.0}
        eigen = "objective"
        saved = problem.request
        problem.request = dataclasses.replace(saved, max_eigenvalue=None)
        try:
            best, _ = _multistart(problem, seeds, rank, objective, targets, eigen)
        finally:
            problem.request = saved
        return None if best is None else float(best.quantities["eigenvalue"])
    # The term enters as -w * value when maximised, +w * value otherwise.
    objective = {name: float(sense if maximised(name) else -sense)}
    eigen_mode = "bound" if problem.request.max_eigenvalue is not None else None
    best, _ = _multistart(problem, seeds, rank, objective, targets, eigen_mode)
    return None if best is None else float(best.quantities[name])
