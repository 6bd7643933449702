"""The design's NLP by Gauss-Legendre collocation (:func:`vsw.orbits.collocation.legendre_scheme`):
each phase cut into intervals, the state at every knot and stage, the variational
matrices beside them where the eigenvalues are asked for, the failures' margins at the
knots, the events' guards and resets, periodicity, the design quantities and the
eigenvalue disc's Jury rows; one IPOPT solver (exact Hessian) per :class:`Structure` and
mesh."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.orbits.collocation import legendre_defects, legendre_end, legendre_scheme
from vsw.runtime import blas
from vsw.synthesis.design.nlp import (
    Rows,
    Structure,
    design_quantities,
    event_rows,
    objective_of,
    step_facts,
    vector_field,
)
from vsw.synthesis.design.request import DEGREE, MAX_ITERATIONS

__all__ = ["IPOPT_OPTIONS", "Collocated", "build", "initial_point"]

IPOPT_OPTIONS = {
    "ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": MAX_ITERATIONS,
    "ipopt.acceptable_tol": 1e-7, "ipopt.acceptable_constr_viol_tol": 1e-9,
    "ipopt.acceptable_iter": 5, "ipopt.mu_strategy": "adaptive", "ipopt.print_level": 0,
    "ipopt.max_resto_iter": 20, "ipopt.expect_infeasible_problem": "yes",
    "print_time": False, "ipopt.sb": "yes", "error_on_fail": False, "expand": True,
}  # fmt: skip
"""IPOPT's options for the collocated design NLP: exact first and second derivatives."""


@dataclass
class Collocated:
    """The collocated design NLP of one structure and mesh: the solver, the quantities as a
    function of the unknowns, each constraint row's name and kind, the unknowns' layout and
    where each state unknown lies in time (phase, fraction of its duration)."""

    solver: Any
    quantities: Any
    row_names: list[str]
    row_kinds: list[str]
    layout: dict[str, slice]
    size: int
    mesh: tuple[int, ...]
    state_times: list[tuple[int, float]]


@functools.cache
def phase_field(model: HybridModel, phase: str) -> Any:
    """(p, x) -> the phase's vector field and its Jacobian in x (CasADi SX)."""
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    f = vector_field(model, phase, p, x)
    return ca.Function(f"field_{phase}", [p, x], [f, ca.jacobian(f, x)])


@functools.cache
def interval_function(model: HybridModel, phase: str, eigen: bool) -> Any:
    """One interval's collocation rows as a CasADi function, mapped over a phase's intervals:
    (p, h, start, stages[, phi start, phi stages]) -> (the state's defects, the end[, the
    variational matrices' defects, their end])."""
    import casadi as ca

    m = 2 * model.n
    _, c_matrix, d_row = legendre_scheme(DEGREE)
    field = phase_field(model, phase)
    p = ca.SX.sym("p", len(model.parameter_table))
    h = ca.SX.sym("h")
    x0 = ca.SX.sym("x0", m)
    z = ca.SX.sym("z", m, DEGREE)
    stages = ca.horzsplit(z)
    fields = [field(p, s) for s in stages]
    defects = legendre_defects([x0, *stages], [f for f, _ in fields], h, c_matrix)
    inputs, outputs = [p, h, x0, z], [ca.horzcat(*defects), legendre_end([x0, *stages], d_row)]
    if eigen:
        phi0 = ca.SX.sym("phi0", m * m)
        phiz = ca.SX.sym("phiz", m * m, DEGREE)
        mats = [ca.reshape(v, m, m) for v in ca.horzsplit(phiz)]
        rates = [ca.mtimes(a, v) for (_, a), v in zip(fields, mats)]
        start = ca.reshape(phi0, m, m)
        rows = legendre_defects([start, *mats], rates, h, c_matrix)
        inputs += [phi0, phiz]
        outputs += [ca.horzcat(*(ca.vec(r) for r in rows)),
                    ca.vec(legendre_end([start, *mats], d_row))]  # fmt: skip
    return ca.Function(f"interval_{phase}", inputs, outputs)


@functools.cache
def margin_function(model: HybridModel, phase: str, which: str) -> Any:
    """(p, x) -> each failure's margin (``-direction * guard``) of the phase's ``which``
    list ('failures' or 'start_failures') and their names."""
    import casadi as ca

    spec = model.phases[model.phase_index[phase]]
    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    rows = [-direction * model.symbolic(function, p, x)
            for _, function, direction in spec.get(which, ())]  # fmt: skip
    function = ca.Function(f"margins_{phase}_{which}", [p, x], [ca.vertcat(*rows)])
    function.failures = [name for name, _, _ in spec.get(which, ())]  # type: ignore[attr-defined]
    return function


def _phase(model: HybridModel, phase: str, p: Any, duration: Any, intervals: int,
           eigen: bool, unknowns: dict[str, list], k: int,
           g: Rows) -> tuple[Any, Any, Any]:  # fmt: skip
    """One phase's unknowns (appended to ``unknowns``), its collocation rows and the
    failures' margins at its knots into ``g``: its first and last state and, with
    ``eigen``, its variational matrix at the end."""
    import casadi as ca

    m = 2 * model.n
    roots, _, _ = legendre_scheme(DEGREE)
    knots = ca.MX.sym(f"x_{k}", m, intervals + 1)
    stages = ca.MX.sym(f"z_{k}", m, DEGREE * intervals)
    unknowns["states"].append(knots)
    unknowns["stages"].append(stages)
    unknowns["knot_times"].extend((k, i / intervals) for i in range(intervals + 1))
    unknowns["stage_times"].extend((k, (i + roots[j]) / intervals)
                                   for i in range(intervals) for j in range(DEGREE))  # fmt: skip
    h = duration / intervals
    mapped = interval_function(model, phase, eigen).map(intervals)
    starts = knots[:, :intervals]
    if eigen:
        phis = ca.MX.sym(f"phi_{k}", m * m, intervals)
        phi_stages = ca.MX.sym(f"phiz_{k}", m * m, DEGREE * intervals)
        unknowns["variational"] += [phis, phi_stages]
        phi_starts = ca.horzcat(ca.vec(ca.DM.eye(m)), phis[:, : intervals - 1])
        defects, ends, phi_defects, phi_ends = mapped(p, h, starts, stages, phi_starts,
                                                      phi_stages)  # fmt: skip
        g.add(ca.vec(phi_defects), "collocation", "equality")
        g.add(ca.vec(phis - phi_ends), "continuity", "equality")
        phi_end = ca.reshape(phis[:, intervals - 1], m, m)
    else:
        defects, ends = mapped(p, h, starts, stages)
        phi_end = None
    g.add(ca.vec(defects), "collocation", "equality")
    g.add(ca.vec(knots[:, 1:] - ends), "continuity", "equality")
    first = margin_function(model, phase, "start_failures")
    if first.failures:
        for name, row in zip(first.failures, ca.vertsplit(first(p, knots[:, 0]))):
            g.add(row, name, "margin")
    every = margin_function(model, phase, "failures")
    if every.failures:
        margins = every.map(intervals + 1)(p, knots)
        for r, name in enumerate(every.failures):
            g.add(ca.vec(margins[r, :]), name, "margin")
    return knots[:, 0], knots[:, intervals], phi_end


@functools.cache
def build(model: HybridModel, structure: Structure, mesh: tuple[int, ...]) -> Collocated:
    """The collocated NLP of one structure on ``mesh`` (intervals per phase); numbers that
    vary between requests are its parameters, bounds are the solver call's."""
    import casadi as ca

    n_par = len(model.parameter_table)
    sequence = model.phase_sequence()
    eigen = structure.eigen is not None
    fixed_values = ca.MX.sym("P", n_par + 1)
    free = ca.MX.sym("free", len(structure.free))
    durations = ca.MX.sym("T", len(sequence))
    rho = ca.MX.sym("rho", 1 if structure.eigen == "objective" else 0)
    position = {j: i for i, j in enumerate(structure.free)}
    p = ca.vertcat(*(free[position[j]] if j in position else fixed_values[j]
                     for j in range(n_par)))  # fmt: skip
    g = Rows()
    unknowns: dict[str, list] = {"states": [], "stages": [], "knot_times": [],
                                 "stage_times": [], "variational": []}  # fmt: skip
    ends = []
    for k, (phase, _event) in enumerate(sequence):
        ends.append(_phase(model, phase, p, durations[k], mesh[k], eigen, unknowns, k, g))
    events = []
    for k, (phase, event) in enumerate(sequence):
        following = ends[(k + 1) % len(sequence)][0]
        events.append(event_rows(model, phase, event, p, ends[k][1], following,
                                 k + 1 == len(sequence), ends[k][2], g))  # fmt: skip
    energy_lost, step_length, monodromy = step_facts(events)
    radius = rho if structure.eigen == "objective" else fixed_values[n_par]
    quantities = design_quantities(model, structure, p, durations, energy_lost, step_length,
                                   monodromy, radius, g)  # fmt: skip
    objective = objective_of(structure, quantities, radius)
    state_vector = ca.vertcat(*(ca.vec(v) for v in unknowns["states"] + unknowns["stages"]))
    phi_vector = ca.vertcat(*(ca.vec(v) for v in unknowns["variational"]))
    w = ca.vertcat(free, state_vector, phi_vector, durations, rho)
    nf, ns, nv = len(structure.free), int(state_vector.shape[0]), int(phi_vector.shape[0])
    layout = {"free": slice(0, nf), "states": slice(nf, nf + ns),
              "variational": slice(nf + ns, nf + ns + nv)}  # fmt: skip
    layout["durations"] = slice(nf + ns + nv, nf + ns + nv + len(sequence))
    layout["rho"] = slice(layout["durations"].stop, layout["durations"].stop + rho.shape[0])
    nlp = {"x": w, "p": fixed_values, "f": objective, "g": ca.vertcat(*g.rows)}
    solver = ca.nlpsol(f"design_{model.name}", "ipopt", nlp, IPOPT_OPTIONS)
    blas.libraries_may_have_loaded()  # IPOPT's plugin brings CasADi's OpenBLAS
    table = ca.vertcat(*quantities.values())
    quantity_function = ca.Function("quantities", [w, fixed_values], [table])
    quantity_function.names = list(quantities)  # type: ignore[attr-defined]
    return Collocated(solver, quantity_function, g.names, g.kinds, layout, int(w.shape[0]),
                      mesh, unknowns["knot_times"] + unknowns["stage_times"])  # fmt: skip


def initial_point(model: HybridModel, nlp: Collocated, params: Any, pieces: list,
                  free_values: list[float], rho: float) -> np.ndarray:  # fmt: skip
    """IPOPT's start from a gait walked as ``pieces`` (one a phase): its free parameters,
    its state at every knot and stage, the variational matrices the collocation rows give
    on those states, its durations and ``rho``."""
    m = 2 * model.n
    w = np.zeros(nlp.size)
    w[nlp.layout["free"]] = free_values
    states = np.empty((len(nlp.state_times), m))
    for k, piece in enumerate(pieces):
        which = [i for i, (phase, _) in enumerate(nlp.state_times) if phase == k]
        span = piece.end - piece.start
        times = np.array([piece.start + nlp.state_times[i][1] * span for i in which])
        states[which] = piece.states(np.clip(times, piece.start, piece.end))
    w[nlp.layout["states"]] = states.reshape(-1)
    w[nlp.layout["variational"]] = _variational(model, nlp, params, pieces, states)
    w[nlp.layout["durations"]] = [piece.end - piece.start for piece in pieces]
    w[nlp.layout["rho"]] = rho
    return w


def _variational(model: HybridModel, nlp: Collocated, params: Any, pieces: list,
                 states: np.ndarray) -> np.ndarray:  # fmt: skip
    """The variational matrices the collocation rows give on ``states`` (each interval's
    linear rows solved), in the NLP's order (a phase's knots, then its stages), or none
    where the NLP has none."""
    if nlp.layout["variational"].stop == nlp.layout["variational"].start:
        return np.zeros(0)
    m, d = 2 * model.n, DEGREE
    _, c_matrix, d_row = legendre_scheme(d)
    stage_row = sum(n + 1 for n in nlp.mesh)  # the stages follow every phase's knots
    out = []
    for k, (phase, _event) in enumerate(model.phase_sequence()):
        field = phase_field(model, phase)
        h = (pieces[k].end - pieces[k].start) / nlp.mesh[k]
        phi = np.eye(m)
        knots, stage_list = [], []
        for i in range(nlp.mesh[k]):
            rows = states[stage_row + i * d : stage_row + (i + 1) * d]
            system = np.kron(c_matrix[1:, 1:].T, np.eye(m))
            for j in range(d):
                jacobian = np.array(field(params, rows[j])[1])
                system[j * m : (j + 1) * m, j * m : (j + 1) * m] -= h * jacobian
            rhs = -np.concatenate([c_matrix[0, j] * phi for j in range(1, d + 1)])
            stages = np.linalg.solve(system, rhs).reshape(d, m, m)
            stage_list.extend(s.reshape(-1, order="F") for s in stages)
            phi = d_row[0] * phi + sum(d_row[j + 1] * stages[j] for j in range(d))
            knots.append(phi.reshape(-1, order="F"))
        out += knots + stage_list
        stage_row += d * nlp.mesh[k]
    return np.concatenate(out)
