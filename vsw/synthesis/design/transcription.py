"""The design's NLP: multiple shooting on the phases' CVODES flows
(:func:`vsw.orbits.shooting.phase_integrator`), the failures' margins at the nodes, the
events' guards and resets, periodicity, the design quantities, the monodromy matrix
(:func:`vsw.orbits.monodromy.phase_derivative`) and its eigenvalue disc by Jury's rows
(:func:`vsw.orbits.monodromy.jury_rows`); one IPOPT solver per :class:`Structure`."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.quantities import kinetic_energy, maximised, report
from vsw.dynamics.quantities import weight as walker_weight
from vsw.orbits.monodromy import characteristic_coefficients, jury_rows, phase_derivative
from vsw.orbits.shooting import phase_integrator
from vsw.synthesis.design.request import INTEGRATOR_TOL, MAX_ITERATIONS, SEGMENTS

__all__ = ["IPOPT_OPTIONS", "Nlp", "Structure", "build", "impact_events", "kinetic_loss"]


@dataclass(frozen=True)
class Structure:
    """What the NLP's shape depends on (one solver per structure, reused across requests)."""

    free: tuple[int, ...]  # indices of the free parameters
    objective: tuple[tuple[str, float], ...]
    rows: tuple[str, ...]  # quantities constrained (targets and bounds)
    eigen: str | None  # None, 'bound' (rho given) or 'objective' (rho an unknown)
    rank: int


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


def _vector_field(model: HybridModel, phase: str, p: Any, x: Any) -> Any:
    import casadi as ca

    return ca.vertcat(x[model.n :], model.symbolic(f"{phase}_accelerations", p, x))


@functools.cache
def _event_jacobians(model: HybridModel, phase: str, event: str) -> Any:
    """(p, x) -> the phase's vector field, the event guard's gradient and the reset's
    Jacobian at x: the pieces of the saltation at the phase's end."""
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    guard = model.symbolic(f"event_{event}_guard", p, x)
    reset = model.symbolic(f"event_{event}_reset", p, x)
    return ca.Function(f"saltation_{phase}", [p, x], [
        _vector_field(model, phase, p, x), ca.jacobian(guard, x), ca.jacobian(reset, x),
    ])  # fmt: skip


def kinetic_loss(model: HybridModel, before: str, after: str, p: Any, x_before: Any,
                 x_after: Any) -> Any:  # fmt: skip
    """Kinetic energy an impact dissipates: ``T = E(q, rates) - E(q, 0)`` on either side.
    Not the change of ``E``: a walker's potential is measured from its stance foot, which
    an impact moves (down the slope's step), while the bodies do not move in the impact.
    On a periodic gait it is the energy a step must get back (gravity's work down a slope,
    an actuator's on level ground). numpy or CasADi."""
    params = _split(p)
    return (kinetic_energy(model, before, params, x_before)
            - kinetic_energy(model, after, params, x_after))  # fmt: skip


def _split(p: Any) -> list[Any]:
    if isinstance(p, np.ndarray):
        return [float(v) for v in p]
    import casadi as ca

    return ca.vertsplit(p)


def impact_events(model: HybridModel) -> set[str]:
    """The names of the model's events whose reset is an impact."""
    return {e["name"] for e in model.events if e["reset"] == "impact"}


@dataclass
class _Rows:
    """The NLP's constraint rows, each with the name and kind its bounds are chosen by."""

    rows: list[Any] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)

    def add(self, expr: Any, name: str, kind: str) -> None:
        self.rows.append(expr)
        self.names.extend([name] * expr.shape[0])
        self.kinds.extend([kind] * expr.shape[0])


def _phase_rows(model: HybridModel, phase: str, p: Any, nodes: list, duration: Any,
                eigen: bool, g: _Rows) -> tuple[Any, Any]:  # fmt: skip
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
               g: _Rows) -> tuple[Any, Any, Any]:  # fmt: skip
    """Each phase (:func:`_phase_rows`) ended on its event's guard (its ``when`` >= 0) and
    reset onto the next phase's first node, the last onto the first (periodicity), into
    ``g``: the kinetic energy the impacts dissipate, the step's length (None: the model
    defines none) and, with ``eigen``, the monodromy matrix
    (:func:`vsw.orbits.monodromy.phase_derivative`)."""
    import casadi as ca

    sequence = model.phase_sequence()
    count = len(sequence)
    monodromy = ca.MX.eye(2 * model.n)
    energy_lost = 0
    step_length = None
    for k, (phase, event) in enumerate(sequence):
        end, phi_phase = _phase_rows(model, phase, p, nodes[k], durations[k], eigen, g)
        guard = model.symbolic(f"event_{event['name']}_guard", p, end)
        g.add(guard, f"{event['name']} guard", "equality")
        if event["when"] is not None:
            g.add(model.symbolic(event["when"], p, end), f"{event['name']} when", "when")
        after = model.symbolic(f"event_{event['name']}_reset", p, end)
        nxt = nodes[k + 1][0] if k + 1 < count else nodes[0][0]
        g.add(nxt - after, "periodicity" if k + 1 == count else "reset", "equality")
        if event["name"] in impact_events(model):
            energy_lost = energy_lost + kinetic_loss(model, phase, event["target"], p, end,
                                                     after)  # fmt: skip
        if event["ends_step"] and model.spec["step_length"]:
            step_length = model.symbolic("step_length_of_state", p, end)
        if eigen:
            f_end, grad, jac_reset = _event_jacobians(model, phase, event["name"])(p, end)
            monodromy = ca.mtimes(phase_derivative(jac_reset, f_end, grad, phi_phase,
                                                   2 * model.n), monodromy)  # fmt: skip
    return energy_lost, step_length, monodromy


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


def _quantities(model: HybridModel, structure: Structure, p: Any, durations: Any,
                energy_lost: Any, step_length: Any, monodromy: Any, radius: Any,
                g: _Rows) -> dict[str, Any]:  # fmt: skip
    """The design quantities in the NLP's unknowns (:func:`vsw.dynamics.quantities.report`); the
    eigenvalue disc's Jury rows (:func:`vsw.orbits.monodromy.jury_rows`) and each
    constrained quantity's row into ``g``."""
    import casadi as ca

    facts = {
        "period": ca.sum1(durations),
        "energy_per_step": energy_lost,
        "energy": energy_lost,
        "eigenvalue": radius,
        "weight": walker_weight(model, p),
    }
    if step_length is not None:  # else no quantity of the step's length
        facts["step_length"] = step_length
    quantities = report(facts)
    if structure.eigen is not None:
        coefficients = characteristic_coefficients(monodromy, structure.rank)
        scaled = [c / radius ** (k + 1) for k, c in enumerate(coefficients)]
        for row in jury_rows(scaled):
            g.add(row, "eigenvalue", "jury")
        quantities["eigenvalue_radius"] = radius
    for name in structure.rows:
        g.add(quantities[name], name, "quantity")
    return quantities


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
    g = _Rows()
    energy_lost, step_length, monodromy = _step_rows(model, p, nodes, durations,
                                                     structure.eigen is not None, g)  # fmt: skip
    radius = rho if structure.eigen == "objective" else fixed_values[n_par]
    quantities = _quantities(model, structure, p, durations, energy_lost, step_length,
                             monodromy, radius, g)  # fmt: skip
    objective = 0
    for term, weight in structure.objective:
        value = radius if term == "eigenvalue" else quantities[term]
        objective = objective + (-weight if maximised(term) else weight) * value
    w = ca.vertcat(free, *[x for phase_nodes in nodes for x in phase_nodes], durations, rho)
    layout = {
        "free": slice(0, len(structure.free)),
        "nodes": slice(len(structure.free), len(structure.free) + count * SEGMENTS * m),
    }
    layout["durations"] = slice(layout["nodes"].stop, layout["nodes"].stop + count)
    layout["rho"] = slice(layout["durations"].stop, layout["durations"].stop + rho.shape[0])
    nlp = {"x": w, "p": fixed_values, "f": objective, "g": ca.vertcat(*g.rows)}
    solver = ca.nlpsol(f"design_{model.name}", "ipopt", nlp, IPOPT_OPTIONS)
    table = ca.vertcat(*quantities.values())
    quantity_function = ca.Function("quantities", [w, fixed_values], [table])
    quantity_function.names = list(quantities)  # type: ignore[attr-defined]
    return Nlp(solver, quantity_function, g.names, g.kinds, layout, int(w.shape[0]))
