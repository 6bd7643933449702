"""Everything a :class:`~derive.engine.model.Model` implies, derived with sympy: the
functions the generic runtime needs and the ``HYBRID`` descriptor
(:func:`hybrid_quantities`).

The derivation is laid out by idea: :mod:`derive.engine.algebra` (expansion, a cheap
canonical form, angle sums, Cramer's rule in polynomials), :mod:`derive.engine.dynamics`
(a phase's equations of motion, energy, momenta, ground reaction and input gains by Kane's
method on the bodies' Jacobians), :mod:`derive.engine.resets` (impacts, jumps, locks and
continuous transitions), :mod:`derive.engine.stride` (the stride map in closed form),
:mod:`derive.engine.phase_quantities` and :mod:`derive.engine.event_quantities` (each
phase's and event's functions and records). This module puts them together and keeps
their public names where the models and tests import them.
"""

from __future__ import annotations

import dataclasses

import sympy as sm

from derive.engine.algebra import NestedFractionError, expand, refuse_nested_fraction, tidy
from derive.engine.dynamics import PhaseDynamics, chain_rate, phase_dynamics
from derive.engine.event_quantities import event_quantities
from derive.engine.model import NORMAL_FORCE, Condition, Failure, Model
from derive.engine.phase_quantities import phase_quantities
from derive.engine.resets import (
    check_event_angle,
    continuous_reset,
    held_impulse_at_impact,
    impact_reset,
    jump_reset,
    lock_reset,
    reset,
)
from derive.engine.stride import integrate_polynomial_trig, phase_rate_map, stride_closed_form
from derive.quantities import Quantity

__all__ = [
    "NestedFractionError",
    "PhaseDynamics",
    "chain_rate",
    "check_event_angle",
    "continuous_reset",
    "expand",
    "held_impulse_at_impact",
    "hybrid_quantities",
    "impact_reset",
    "integrate_polynomial_trig",
    "jump_reset",
    "lock_reset",
    "phase_dynamics",
    "phase_rate_map",
    "refuse_nested_fraction",
    "reset",
    "stride_closed_form",
]


def hybrid_quantities(model: Model) -> tuple[list[Quantity], dict]:
    """The generic runtime's functions and the ``HYBRID`` descriptor of a model.

    Every function takes ``(*parameters, *coordinates, *rates)``:
    ``<phase>_accelerations``, ``<phase>_energy``, ``<phase>_normal_force``,
    ``<phase>_<failure>`` (failure guards), ``<phase>_positions`` (x, y and angle of each
    body, held coordinates at their values; angle 0 for a point mass),
    ``<phase>_inertias`` (mass and central inertia of each body), ``<phase>_skeleton`` (x
    and y of each point of the drawing: :class:`~derive.engine.model.Skeleton`),
    ``event_<event>_guard``,
    ``event_<event>_when``, ``event_<event>_reset`` (coordinates then rates after),
    ``event_<event>_contact`` (an impact's new contact point in the source phase's chart),
    and ``step_length_of_state`` when the model defines it. The descriptor says per phase
    whether it is ``conservative`` (no held coordinate moves, so no actuator does work and
    T + V is constant) and its drawing (``skeleton``: the names of the points
    ``<phase>_skeleton`` places, the segments between them by name, the bodies' names and,
    for a wheel, its ``spokes``), and per event whether its ``reset`` is an ``impact``, a
    ``jump`` or ``continuous``.
    """
    _check_actuators(model)
    args = _state_args(model)
    quantities: list[Quantity] = []
    phases, events = [], []
    for phase in model.phases:
        found, record = phase_quantities(model, phase, args)
        quantities += found
        phases.append(record)
    for event in model.events:
        found, record = event_quantities(model, event, args)
        quantities += found
        events.append(record)
    quantities += _walker_quantities(model, args)
    unknown = set(model.chosen_parameters) - {q.name for q in model.parameters}
    if unknown:
        raise ValueError(f"{model.name}: chosen parameters that are not parameters: "
                         f"{sorted(unknown)}")  # fmt: skip
    found, condition_records = _parameter_conditions(model, args)
    quantities += found
    quantities += _section_completion(model, args)
    descriptor = _descriptor(model, phases, events, condition_records)
    if model.limits:
        quantities = [_in_the_limit(model, qty) for qty in quantities]
    return quantities, descriptor


def _state_args(model: Model) -> tuple[sm.Symbol, ...]:
    return (
        *model.parameter_symbols,
        *(c.q for c in model.coordinates),
        *(c.u for c in model.coordinates),
    )


def _walker_quantities(model: Model, args: tuple) -> list[Quantity]:
    """``step_length_of_state`` where the model states its step length, and the walker's
    ``weight``."""
    quantities = []
    if model.step_length is not None:
        step_event = next(e for e in model.events if e.ends_step)
        held = {h: sm.sympify(v) for h, v in model.phase(step_event.source).held.items()}
        quantities.append(Quantity(
            "step_length_of_state", args, sm.sympify(model.step_length).xreplace(held),
            "Distance between successive stance feet (state just before the step event).",
            None, "step length",
        ))  # fmt: skip
    step_phase = model.phase(next(e for e in model.events if e.ends_step).target)
    gx, gy = (sm.sympify(v) for v in step_phase.gravity)
    # On a slope gravity is (g sin gamma, -g cos gamma) in the chart: its size is g. No
    # simplify after: it leaves every model's weight as it is, and its first call imports
    # sympy's units (0.2 s of a model derived alone).
    weight = sm.sqrt(sm.trigsimp(gx**2 + gy**2)) * sm.Add(*(b.mass for b in step_phase.bodies))
    quantities.append(Quantity(
        "weight", args, weight,
        "The walker's weight: gravity times the mass of every body (the cost of transport's "
        "scale; it depends on the parameters only).", None, "force",
    ))  # fmt: skip
    return quantities


def _parameter_conditions(model: Model, args: tuple) -> tuple[list[Quantity], list[dict]]:
    """A function per parameter condition of the model, ``parameter_condition_<k>``, and
    the records ``HYBRID`` lists them by (the function, reason, strictness and the
    parameters involved)."""
    quantities, records = [], []
    for k, condition in enumerate(model.parameter_conditions):
        expression = sm.sympify(condition.expression)
        if not expression.free_symbols <= set(model.parameter_symbols):
            raise ValueError(f"{model.name}: a parameter condition depends on more than the "
                             f"parameters: {expression}")  # fmt: skip
        name = f"parameter_condition_{k}"
        sign = ">" if condition.strict else ">="
        quantities.append(Quantity(
            name, args, expression,
            f"Valid parameters have this {sign} 0: {condition.reason} (the state is not used).",
            None, "parameter condition",
        ))  # fmt: skip
        involved = tuple(q.name for q in model.parameters if q.symbol in expression.free_symbols)
        records.append({"function": name, "reason": condition.reason,
                        "strict": condition.strict, "parameters": involved})  # fmt: skip
    return quantities, records


def _section_completion(model: Model, args: tuple) -> list[Quantity]:
    """``section_completion`` where the model's section determines some components of the
    state from the others."""
    if not model.section:
        return []
    state_symbols = {c.name: c.q for c in model.coordinates}
    state_symbols.update({c.rate: c.u for c in model.coordinates})
    unknown = set(model.section) - set(state_symbols)
    if unknown:
        raise ValueError(f"{model.name}: section names {sorted(unknown)} are not its state")
    completed = tuple(
        sm.sympify(model.section.get(name, symbol)) for name, symbol in state_symbols.items()
    )
    return [Quantity(
        "section_completion", args, completed,
        "The section state with the components the section determines recomputed from "
        "the others (the step event's geometry and reset).", None,
        "tuple: coordinates, then rates",
    )]  # fmt: skip


def _state_records(model: Model) -> list[dict]:
    """The state's components for ``HYBRID``: each coordinate, then each rate."""
    time = model.units.get("time", "")
    state = []
    for c in model.coordinates:
        state.append({"name": c.name, "kind": "coordinate", "unit": c.unit,
                      "meaning": c.description, "reference": c.reference,
                      "positive": c.positive, "rate": c.rate})  # fmt: skip
    for c in model.coordinates:
        state.append({"name": c.rate, "kind": "rate", "unit": f"{c.unit}/{time}",
                      "meaning": f"rate of {c.name} ({c.description})", "reference": "",
                      "positive": f"{c.name} increasing", "rate": None})  # fmt: skip
    return state


def _descriptor(model: Model, phases: list, events: list, condition_records: list) -> dict:
    """The ``HYBRID`` descriptor: the model's names, units, state, phases, events,
    failures, section and search box, and what it declares beyond these."""
    state = _state_records(model)
    names = [s["name"] for s in state]
    unknown = (set(model.search) | set(model.section)) - set(names)
    if unknown:
        raise ValueError(f"{model.name}: search/section names {sorted(unknown)} are not its state")
    free = [n for n in names if n not in model.section]
    if sorted(model.search) != sorted(free):
        raise ValueError(f"{model.name}: the search box must give exactly the section's free "
                         f"components {free}, not {sorted(model.search)}")  # fmt: skip
    return {
        "name": model.name,
        "title": model.title,
        "description": model.description,
        "coordinate_units": {c.name: c.unit for c in model.coordinates},
        "parameters": tuple(p.name for p in model.parameters),
        "coordinates": tuple(c.name for c in model.coordinates),
        "rates": tuple(c.rate for c in model.coordinates),
        "state": tuple(state),
        "phases": tuple(phases),
        "events": tuple(events),
        "failures": tuple(_failure_record(model, f) for f in model.failures),
        **(
            {"conditions": tuple(_failure_record(model, c) for c in model.conditions)}
            if model.conditions
            else {}
        ),
        "units": dict(model.units),
        "step_length": model.step_length is not None,
        "section": tuple(n for n in names if n in model.section),
        "search": {n: tuple(float(v) for v in model.search[n]) for n in free},
        **({"actuator_names": {h.name: name for h, name in model.actuators.items()}}
           if model.actuators else {}),
        **({"powered_only": True} if model.powered_only else {}),
        **({"parameter_conditions": tuple(condition_records)} if condition_records else {}),
        **({"chosen_parameters": tuple(model.chosen_parameters)}
           if model.chosen_parameters else {}),
    }  # fmt: skip


def _check_actuators(model: Model) -> None:
    """A named actuator holds a coordinate some phase holds."""
    held = {h for phase in model.phases for h in phase.held}
    if not set(model.actuators) <= held:
        raise ValueError(f"{model.name}: actuators name coordinates no phase holds: "
                         f"{sorted(h.name for h in set(model.actuators) - held)}")  # fmt: skip
    if len(set(model.actuators.values())) != len(model.actuators):
        raise ValueError(f"{model.name}: two held coordinates share an actuator's name")


def _failure_record(model: Model, failure: Failure | Condition) -> dict:
    """A failure for the runtime: its name, direction, meaning and the unit of its guard
    (the ground reaction's force unit, a rate's coordinate unit per time, else stated)."""
    unit = failure.unit
    if unit is None:
        guard = sm.sympify(failure.guard)
        rates = {c.u: c for c in model.coordinates}
        if guard == NORMAL_FORCE:
            unit = model.units.get("force", "")
        elif guard in rates:
            unit = f"{rates[guard].unit}/{model.units.get('time', '')}"
        else:
            unit = "1"
    record = {"name": failure.name, "direction": failure.direction,
              "meaning": failure.meaning, "unit": unit}  # fmt: skip
    if isinstance(failure, Condition) and failure.interior:
        record["interior"] = True
    if isinstance(failure, Failure) and failure.at_start:
        record["at_start"] = True
    return record


def _in_the_limit(model: Model, quantity: Quantity) -> Quantity:
    """A quantity with the model's :attr:`~Model.limits` taken: substituted where that is
    finite, by :func:`sympy.limit` where the substitution is 0/0."""

    def limit(expr: sm.Expr) -> sm.Expr:
        expr = sm.sympify(expr)
        for symbol, value in model.limits.items():
            if not expr.has(symbol):
                continue
            expr = sm.cancel(expr)
            direct = expr.xreplace({symbol: sm.sympify(value)})
            if direct.has(sm.nan, sm.zoo, sm.oo, -sm.oo):
                direct = sm.limit(expr, symbol, value)
            expr = tidy(direct)
        return expr

    expr = quantity.expr
    expr = tuple(limit(e) for e in expr) if isinstance(expr, tuple) else limit(expr)
    return dataclasses.replace(quantity, expr=expr)
