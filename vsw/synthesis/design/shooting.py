"""The design's exact NLP: multiple shooting on the phases' CVODES flows
(:func:`vsw.orbits.shooting.phase_integrator`), the failures' margins at the nodes, the
events' rows (:func:`vsw.synthesis.design.nlp.event_rows`), the design quantities and the
eigenvalue disc; one IPOPT solver per :class:`~vsw.synthesis.design.nlp.Structure`. It
polishes the collocated optima (:mod:`vsw.synthesis.design.collocation`) to the
integrator's accuracy."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

from vsw.dynamics.hybrid import HybridModel
from vsw.orbits.shooting import phase_integrator
from vsw.runtime import blas
from vsw.synthesis.design.nlp import (
    Rows,
    Structure,
    design_quantities,
    event_rows,
    objective_of,
    step_facts,
)
from vsw.synthesis.design.request import INTEGRATOR_TOL, MAX_ITERATIONS, SEGMENTS

__all__ = ["IPOPT_OPTIONS", "Nlp", "build"]


@dataclass
class Nlp:
    """The design NLP of one :class:`Structure`: IPOPT, the design quantities as a function
    of the unknowns, each constraint row's name and kind, and the unknowns' layout."""

    solver: Any
    quantities: Any  # ca.Function(w, P) -> the design quantities
    row_names: list[str]
    row_kinds: list[str]  # 'equality', 'margin', 'when', 'quantity', 'jury'
    layout: dict[str, slice]
    size: int


def _phase_rows(model: HybridModel, phase: str, p: Any, nodes: list, duration: Any,
                eigen: bool, g: Rows) -> tuple[Any, Any]:  # fmt: skip
    """A phase's segments shot (CVODES, :func:`vsw.orbits.shooting.phase_integrator`),
    their continuity and every failure's margin at each node into ``g``: the phase's end
    state and, with ``eigen``, its variational matrix ``Phi``."""
    import casadi as ca

    m = 2 * model.n
    flow = phase_integrator(model, phase, INTEGRATOR_TOL, 20000, eigen, f"segment_{phase}")
    failures = model.phases[model.phase_index[phase]]["failures"]
    start_failures = model.phases[model.phase_index[phase]].get("start_failures", ())
    h = duration / SEGMENTS
    phi_phase = ca.MX.eye(m)
    for failure, function, direction in start_failures:
        g.add(-direction * model.symbolic(function, p, nodes[0]), failure, "margin")
    for s in range(SEGMENTS):
        x_s = nodes[s]
        for failure, function, direction in failures:
            g.add(-direction * model.symbolic(function, p, x_s), failure, "margin")
        start = ca.vertcat(x_s, ca.vec(ca.MX.eye(m))) if eigen else x_s
        out = flow(x0=start, p=ca.vertcat(p, h))["xf"]
        end = out[:m]
        if eigen:
            phi_phase = ca.mtimes(ca.reshape(out[m:], m, m), phi_phase)
        if s + 1 < SEGMENTS:
            g.add(nodes[s + 1] - end, "continuity", "equality")
    for failure, function, direction in failures:
        g.add(-direction * model.symbolic(function, p, end), failure, "margin")
    return end, phi_phase


def _step_rows(model: HybridModel, p: Any, nodes: list, durations: Any, eigen: bool,
               g: Rows) -> tuple[Any, Any, Any]:  # fmt: skip
    """Each phase (:func:`_phase_rows`) ended on its event
    (:func:`vsw.synthesis.design.nlp.event_rows`) onto the next phase's first node, the
    last onto the first (periodicity), into ``g``: the kinetic energy the impacts
    dissipate, the step's length (None: the model defines none) and, with ``eigen``, the
    monodromy matrix."""
    sequence = model.phase_sequence()
    count = len(sequence)
    ends = []
    for k, (phase, event) in enumerate(sequence):
        end, phi_phase = _phase_rows(model, phase, p, nodes[k], durations[k], eigen, g)
        following = nodes[(k + 1) % count][0]
        ends.append(event_rows(model, phase, event, p, end, following, k + 1 == count,
                               phi_phase if eigen else None, g))  # fmt: skip
    return step_facts(ends)


IPOPT_OPTIONS = {
    "ipopt.tol": 1e-8, "ipopt.constr_viol_tol": 1e-9, "ipopt.max_iter": MAX_ITERATIONS,
    "ipopt.acceptable_tol": 1e-6,
    "ipopt.acceptable_constr_viol_tol": 1e-9, "ipopt.acceptable_iter": 5,
    "ipopt.mu_strategy": "adaptive",
    "ipopt.hessian_approximation": "limited-memory", "ipopt.print_level": 0,
    "print_time": False, "ipopt.sb": "yes", "error_on_fail": False,
}  # fmt: skip
"""IPOPT's options for the design NLP: exact first derivatives, a limited-memory Hessian
(exact second derivatives through CVODES cost several times the first)."""


@functools.cache
def build(model: HybridModel, structure: Structure) -> Nlp:
    """The NLP of one structure; numbers that vary between requests (fixed values, the
    eigenvalue bound) are its parameters, bounds are the solver call's."""
    import casadi as ca

    n_par, m, count = len(model.parameter_table), 2 * model.n, len(model.phase_sequence())
    fixed_values = ca.MX.sym("P", n_par + 1)  # parameter values, then the eigenvalue bound
    free = ca.MX.sym("free", len(structure.free))
    nodes = [[ca.MX.sym(f"x_{k}_{s}", m) for s in range(SEGMENTS)] for k in range(count)]
    durations = ca.MX.sym("T", count)
    rho = ca.MX.sym("rho", 1 if structure.eigen == "objective" else 0)
    position = {j: i for i, j in enumerate(structure.free)}
    p = ca.vertcat(*(free[position[j]] if j in position else fixed_values[j]
                     for j in range(n_par)))  # fmt: skip
    g = Rows()
    energy_lost, step_length, monodromy = _step_rows(model, p, nodes, durations,
                                                     structure.eigen is not None, g)  # fmt: skip
    radius = rho if structure.eigen == "objective" else fixed_values[n_par]
    quantities = design_quantities(model, structure, p, durations, energy_lost, step_length,
                                   monodromy, radius, g)  # fmt: skip
    objective = objective_of(structure, quantities, radius)
    w = ca.vertcat(free, *[x for phase_nodes in nodes for x in phase_nodes], durations, rho)
    layout = {
        "free": slice(0, len(structure.free)),
        "nodes": slice(len(structure.free), len(structure.free) + count * SEGMENTS * m),
    }
    layout["durations"] = slice(layout["nodes"].stop, layout["nodes"].stop + count)
    layout["rho"] = slice(layout["durations"].stop, layout["durations"].stop + rho.shape[0])
    nlp = {"x": w, "p": fixed_values, "f": objective, "g": ca.vertcat(*g.rows)}
    solver = ca.nlpsol(f"design_{model.name}", "ipopt", nlp, IPOPT_OPTIONS)
    blas.libraries_may_have_loaded()  # IPOPT's plugin brings CasADi's OpenBLAS
    table = ca.vertcat(*quantities.values())
    quantity_function = ca.Function("quantities", [w, fixed_values], [table])
    quantity_function.names = list(quantities)  # type: ignore[attr-defined]
    return Nlp(solver, quantity_function, g.names, g.kinds, layout, int(w.shape[0]))
