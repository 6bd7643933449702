"""What the design's two NLPs (:mod:`~vsw.synthesis.design.collocation`,
:mod:`~vsw.synthesis.design.shooting`) share: the :class:`Structure` a solver is built for,
the constraint rows with their names and kinds, each event's rows at a phase's end (guard,
``when``, reset onto the next phase, the energy an impact dissipates, the step's length,
the phase's factor of the monodromy matrix, :func:`vsw.orbits.monodromy.phase_derivative`),
the design quantities with the eigenvalue disc's Jury rows
(:func:`vsw.orbits.monodromy.jury_rows`) and the objective."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.quantities import kinetic_energy, maximised, report
from vsw.dynamics.quantities import weight as walker_weight
from vsw.orbits.monodromy import characteristic_coefficients, jury_rows, phase_derivative

__all__ = [
    "EndOfPhase",
    "Rows",
    "Structure",
    "design_quantities",
    "event_jacobians",
    "event_rows",
    "impact_events",
    "kinetic_loss",
    "objective_of",
    "step_facts",
    "vector_field",
]


@dataclass(frozen=True)
class Structure:
    """What the NLP's shape depends on (one solver per structure, reused across requests)."""

    free: tuple[int, ...]  # indices of the free parameters
    objective: tuple[tuple[str, float], ...]
    rows: tuple[str, ...]  # quantities constrained (targets and bounds)
    eigen: str | None  # None, 'bound' (rho given) or 'objective' (rho an unknown)
    rank: int


def vector_field(model: HybridModel, phase: str, p: Any, x: Any) -> Any:
    """The phase's first-order vector field ``(rates, accelerations)`` (CasADi)."""
    import casadi as ca

    return ca.vertcat(x[model.n :], model.symbolic(f"{phase}_accelerations", p, x))


@functools.cache
def event_jacobians(model: HybridModel, phase: str, event: str) -> Any:
    """(p, x) -> the phase's vector field, the event guard's gradient and the reset's
    Jacobian at x: the pieces of the saltation at the phase's end."""
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    guard = model.symbolic(f"event_{event}_guard", p, x)
    reset = model.symbolic(f"event_{event}_reset", p, x)
    return ca.Function(f"saltation_{phase}", [p, x], [
        vector_field(model, phase, p, x), ca.jacobian(guard, x), ca.jacobian(reset, x),
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
class Rows:
    """The NLP's constraint rows, each with the name and kind its bounds are chosen by."""

    rows: list[Any] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    kinds: list[str] = field(default_factory=list)

    def add(self, expr: Any, name: str, kind: str) -> None:
        self.rows.append(expr)
        self.names.extend([name] * expr.shape[0])
        self.kinds.extend([kind] * expr.shape[0])


@dataclass
class EndOfPhase:
    """What a phase's event contributes: the energy its impact dissipates (0 where it is
    no impact), the step's length where it ends the step and the model defines one, and
    with the eigenvalues asked for the phase's factor of the monodromy matrix."""

    energy_lost: Any = 0
    step_length: Any = None
    factor: Any = None


def event_rows(model: HybridModel, phase: str, event: dict, p: Any, end: Any, following: Any,
               last: bool, flow: Any, g: Rows) -> EndOfPhase:  # fmt: skip
    """The phase's event at its end state ``end``: its guard (= 0) and ``when`` (>= 0),
    its reset onto ``following`` (the next phase's first state; periodicity where
    ``last``), into ``g``; with ``flow`` (the phase's variational matrix) the phase's
    factor of the monodromy matrix."""
    name = event["name"]
    g.add(model.symbolic(f"event_{name}_guard", p, end), f"{name} guard", "equality")
    if event["when"] is not None:
        g.add(model.symbolic(event["when"], p, end), f"{name} when", "when")
    after = model.symbolic(f"event_{name}_reset", p, end)
    g.add(following - after, "periodicity" if last else "reset", "equality")
    out = EndOfPhase()
    if name in impact_events(model):
        out.energy_lost = kinetic_loss(model, phase, event["target"], p, end, after)
    if event["ends_step"] and model.spec["step_length"]:
        out.step_length = model.symbolic("step_length_of_state", p, end)
    if flow is not None:
        f_end, grad, jac_reset = event_jacobians(model, phase, name)(p, end)
        out.factor = phase_derivative(jac_reset, f_end, grad, flow, 2 * model.n)
    return out


def step_facts(ends: list[EndOfPhase]) -> tuple[Any, Any, Any]:
    """The step's dissipated energy, its length and its monodromy matrix (the phases'
    factors multiplied in order; None without them) from each phase's event."""
    import casadi as ca

    energy_lost, step_length, monodromy = 0, None, None
    for end in ends:
        energy_lost = energy_lost + end.energy_lost
        step_length = end.step_length if end.step_length is not None else step_length
        if end.factor is not None:
            monodromy = end.factor if monodromy is None else ca.mtimes(end.factor, monodromy)
    return energy_lost, step_length, monodromy


def design_quantities(model: HybridModel, structure: Structure, p: Any, durations: Any,
                energy_lost: Any, step_length: Any, monodromy: Any, radius: Any,
                g: Rows) -> dict[str, Any]:  # fmt: skip
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


def objective_of(structure: Structure, quantities: dict[str, Any], radius: Any) -> Any:
    """The structure's objective: each term weighted, a maximised one negated."""
    objective = 0
    for term, weight in structure.objective:
        value = radius if term == "eigenvalue" else quantities[term]
        objective = objective + (-weight if maximised(term) else weight) * value
    return objective
