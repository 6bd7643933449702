"""An event's functions for the generic runtime and its record in ``HYBRID``.

:func:`event_quantities` gives ``event_<event>_guard``, ``event_<event>_reset`` (the
whole state after it), the impulses' gains and rates, an impact's new contact point and
``event_<event>_when``, as :class:`~derive.quantities.Quantity` records over
``(*parameters, *coordinates, *rates)``.
"""

from __future__ import annotations

import dataclasses

import sympy as sm

from derive.engine.dynamics import chain_rate, held_in_state, phase_dynamics
from derive.engine.model import Continuous, Event, Impact, Input, Jump, Lock, Model
from derive.engine.phase_quantities import input_quantities
from derive.engine.resets import held_impulse_at_impact, impact_body_order, jumping, reset
from derive.quantities import Quantity

__all__ = ["event_quantities"]


def event_quantities(model: Model, event: Event, args: tuple) -> tuple[list[Quantity], dict]:
    """An event's functions (in the order ``generated/`` lists them) and its ``HYBRID``
    record: source, target, direction, whether it ends the step, its ``when``, its reset's
    kind, an impact's body order, the coordinates a jump or lock actuates, its impulses."""
    # Guards are stated in the source phase's chart: its held coordinates at their values.
    held = {h: sm.sympify(v) for h, v in model.phase(event.source).held.items()}
    coords_after, rates_after = _state_after(model, event)
    quantities = [
        Quantity(
            f"event_{event.name}_guard", args, sm.sympify(event.guard).xreplace(held),
            f"Guard of the event {event.name}: crosses zero when it happens.", None, "guard",
        ),
        Quantity(
            f"event_{event.name}_reset", args, (*coords_after, *rates_after),
            f"State just after the event {event.name} (from the state just before).",
            event.equation, "tuple: coordinates, then rates",
        ),
    ]  # fmt: skip
    impulse_records = ()
    if event.impulses:
        impulse_quantities, impulse_records = _impulse_quantities(model, event, args)
        quantities += impulse_quantities
    if isinstance(event.reset, Impact):
        source = model.phase(event.source)
        contact = source.points[event.reset.new_contact]
        quantities.append(Quantity(
            f"event_{event.name}_contact", args,
            tuple(sm.sympify(c).xreplace(dict(source.held)) for c in contact),
            f"The new contact point of the impact {event.name} (x, y in phase "
            f"{event.source}'s chart).", None, "tuple: x, y",
        ))  # fmt: skip
    when = None
    if event.when is not None:
        when = f"event_{event.name}_when"
        quantities.append(Quantity(
            when, args, sm.sympify(event.when).xreplace(held),
            f"The event {event.name} counts only where this is positive.", None, "sign",
        ))  # fmt: skip
    record = {
        "name": event.name, "source": event.source, "target": event.target,
        "direction": event.direction, "ends_step": event.ends_step, "when": when,
        "reset": _RESET_KINDS[type(event.reset)],
        # Impacts: for each body after, the index of the same body before.
        "bodies": impact_body_order(model, event.name)
        if isinstance(event.reset, Impact) else None,
        **({"actuated": _actuated(model, event)}
           if isinstance(event.reset, (Jump, Lock)) else {}),
        **({"impulses": impulse_records} if impulse_records else {}),
    }  # fmt: skip
    return quantities, record


def _impulse_quantities(model: Model, event: Event, args: tuple) -> tuple[list, tuple]:
    """An event's impulsive inputs (:class:`Impulse`): for those applied before the reset
    (in the source phase's chart) and after it (the target's), the rates' change per unit
    impulse and each impulse's ``along`` rate, and their records for ``HYBRID``.

    The rates' change is the gain a continuous input along the same ``along`` has on the
    accelerations (``M dq' = iota d(along)/dq``, Lagrange's equations over the instant), so
    it is derived by :func:`phase_dynamics` of the phase with the impulses as its inputs."""
    quantities: list[Quantity] = []
    records = []
    names = [i.name for i in event.impulses]
    if len(set(names)) != len(names):
        raise ValueError(f"event {event.name}: impulse names repeat: {names}")
    at_impact = [i for i in event.impulses if i.at_impact]
    if at_impact:
        quantities_with, records_with = _impulses_at_impact(model, event, at_impact, args)
        quantities += quantities_with
        records += records_with
    for after, side in ((False, "before"), (True, "after")):
        impulses = [i for i in event.impulses if i.after == after and not i.at_impact]
        if not impulses:
            continue
        phase = model.phase(event.target if after else event.source)
        # A state coordinate the phase holds jumps with its held value's chain rule, as
        # a continuous input's gain on its acceleration (input_quantities): zero where
        # the value is a constant (a leg at its end stop).
        stand_in = dataclasses.replace(
            phase,
            inputs=tuple(Input(i.name, i.along, i.actuator, i.unit, i.bounds) for i in impulses),
        )
        try:
            dyn = phase_dynamics(stand_in)
        except ValueError as exc:
            raise type(exc)(f"event {event.name}: {exc}") from None
        for quantity in input_quantities(model, stand_in, dyn, args):
            # The ground reaction's impulsive share is not derived: an impulse's foot
            # contact is not checked (docs/models/powered_walking.md).
            if quantity.name == f"{phase.name}_input_gains":
                quantities.append(dataclasses.replace(
                    quantity, name=f"event_{event.name}_impulse_gains_{side}",
                    summary=f"d(rate)/d(impulse) of the impulses applied {side} the reset "
                    f"of {event.name} (in phase {phase.name}'s chart): the rates jump by these "
                    "times the impulses, the coordinates do not move."))  # fmt: skip
            elif quantity.name == f"{phase.name}_input_rates":
                quantities.append(dataclasses.replace(
                    quantity, name=f"event_{event.name}_impulse_rates_{side}",
                    summary=f"Rate of what each impulse applied {side} the reset of "
                    f"{event.name} acts along: its work is the impulse times the mean of this "
                    "just before and just after it."))  # fmt: skip
        records += [
            {"name": i.name, "actuator": i.actuator, "along": str(i.along), "unit": i.unit,
             "bounds": tuple(i.bounds), "description": i.description, "applied": side}
            for i in impulses
        ]  # fmt: skip
    return quantities, tuple(records)


def _impulses_at_impact(model: Model, event: Event, impulses: list, args: tuple
                        ) -> tuple[list, list]:  # fmt: skip
    """The impulse applied with an event's impact along a held coordinate
    (:attr:`Impulse.at_impact`): its gains on the rates after the impact and its work's
    coefficient, and its record for ``HYBRID``."""
    if not isinstance(event.reset, Impact):
        raise ValueError(f"event {event.name}: an impulse at the impact needs an Impact reset")
    if len(impulses) != 1 or impulses[0].after:
        raise ValueError(f"event {event.name}: one impulse at the impact, not also after it")
    impulse = impulses[0]
    gains, work = held_impulse_at_impact(model, event.name, sm.sympify(impulse.along))
    quantities = [
        Quantity(f"event_{event.name}_impulse_gains_with", args, gains,
                 f"d(rate after)/d(impulse) of {impulse.name}, applied with the impact of "
                 f"{event.name} along the held {impulse.along}: the rates after the impact are "
                 "the reset's plus these times the impulse.", None, "tuple: rates"),
        Quantity(f"event_{event.name}_impulse_work_with", args, work,
                 f"c of {impulse.name}'s work c iota^2 / 2 (the held {impulse.along}'s rate per "
                 "unit impulse, from zero).", None, "work per impulse squared"),
    ]  # fmt: skip
    record = {"name": impulse.name, "actuator": impulse.actuator, "along": str(impulse.along),
              "unit": impulse.unit, "bounds": tuple(impulse.bounds),
              "description": impulse.description, "applied": "with"}  # fmt: skip
    return quantities, [record]


def _state_after(model: Model, event) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """An event's reset as the whole state after it: the target phase's free coordinates
    and rates from the reset, a coordinate it holds at its value (moving with it)."""
    coords, rates = reset(model, event.name)
    after = model.phase(event.target)
    held = held_in_state(model, after)
    if not held:
        return coords, rates
    free = [c.q for c in after.coordinates]
    values = dict(zip(free, coords))
    speeds = dict(zip(free, rates))
    state_coords, state_rates = [], []
    for c in model.coordinates:
        if c.q in values:
            state_coords.append(values[c.q])
            state_rates.append(speeds[c.q])
            continue
        value = sm.sympify(after.held[c.q])
        state_coords.append(value.xreplace(values))
        state_rates.append(chain_rate(value, ((q, speeds[q]) for q in free)).xreplace(values))
    return tuple(state_coords), tuple(state_rates)


_RESET_KINDS = {Impact: "impact", Jump: "jump", Lock: "lock", Continuous: "continuous"}


def _actuated(model: Model, event: Event) -> tuple[str, ...]:
    """The coordinates whose actuators act at a jump (those that jump) or a lock (those
    it stops), by name."""
    before, after = model.phase(event.source), model.phase(event.target)
    if isinstance(event.reset, Lock):
        free_after = {c.q for c in after.coordinates}
        return tuple(c.name for c in before.coordinates if c.q not in free_after)
    return tuple(h.name for h in jumping(before, after))
