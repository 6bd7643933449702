"""A phase's functions for the generic runtime and its record in ``HYBRID``.

:func:`phase_quantities` gives ``<phase>_accelerations``, ``<phase>_energy``,
``<phase>_normal_force``, the failure guards and reported conditions (with their gains
from the phase's inputs), the bodies' positions and inertias, the drawing, the moving
actuators' power and the inputs' gains, all as :class:`~derive.quantities.Quantity`
records over ``(*parameters, *coordinates, *rates)``.
"""

from __future__ import annotations

import sympy as sm

from derive.engine.algebra import cheap_simplify
from derive.engine.dynamics import (
    PhaseDynamics,
    body_positions,
    chain_rate,
    held_in_state,
    phase_dynamics,
)
from derive.engine.model import (
    NORMAL_FORCE,
    Condition,
    Failure,
    Impact,
    Model,
    Phase,
    PointMass,
    Skeleton,
    held_force,
)
from derive.quantities import Quantity

__all__ = ["input_quantities", "phase_quantities"]


def phase_quantities(model: Model, phase: Phase, args: tuple) -> tuple[list[Quantity], dict]:
    """A phase's functions (in the order ``generated/`` lists them) and its ``HYBRID``
    record: its name, failures, whether it is ``conservative`` (no held coordinate moves,
    so no actuator does work and T + V is constant), its drawing, and where they exist the
    failures checked where it begins, its moving actuators, conditions and inputs."""
    dyn = phase_dynamics(phase)
    quantities = [
        Quantity(
            f"{phase.name}_accelerations", args, _state_accelerations(model, phase, dyn),
            f"Second derivatives of the free coordinates in phase {phase.name}.", None,
            "tuple: d2(coordinate)/dt2 for each coordinate",
        ),
        Quantity(
            f"{phase.name}_energy", args, dyn.energy,
            f"Mechanical energy T + V in phase {phase.name}.", None, "energy",
        ),
        Quantity(
            f"{phase.name}_normal_force", args, dyn.normal_force,
            f"Ground reaction on the stance foot along the ground normal in phase {phase.name}.",
            None, "normal force (the foot lifts off below 0)",
        ),
    ]  # fmt: skip
    guards, failures, start_failures, conditions = _guard_quantities(model, phase, dyn, args)
    quantities += guards
    drawn, drawing = _drawing_quantities(model, phase, args)
    quantities += drawn
    free = {c.q for c in phase.coordinates}
    # A held coordinate that follows the free ones moves, and its actuator does work.
    moving = [h for h, v in phase.held.items() if sm.sympify(v).free_symbols & free]
    record = {
        "name": phase.name, "failures": tuple(failures), "conservative": not moving,
    }  # fmt: skip
    record["skeleton"] = drawing
    if start_failures:  # checked where the phase begins, not watched through it
        record["start_failures"] = tuple(start_failures)
    if moving:
        quantities.append(_actuator_power(phase, dyn, moving, args))
        record["actuators"] = tuple(h.name for h in moving)
    if conditions:
        record["conditions"] = tuple(conditions)
    if phase.inputs:
        quantities += input_quantities(model, phase, dyn, args)
        record["inputs"] = tuple(
            {"name": i.name, "actuator": i.actuator, "along": str(i.along), "unit": i.unit,
             "bounds": tuple(i.bounds), "description": i.description}
            for i in phase.inputs
        )  # fmt: skip
    return quantities, record


def _guard_quantities(
    model: Model, phase: Phase, dyn: PhaseDynamics, args: tuple
) -> tuple[list[Quantity], list, list, list]:
    """The guards of the model's failures that apply in the phase and of its reported
    conditions (each followed by its gains from the inputs, where the phase has inputs),
    and the records ``(name, function, direction)`` of the failures watched through the
    phase, those checked where it begins, and the conditions."""
    quantities: list[Quantity] = []
    failures, start_failures, conditions = [], [], []
    for failure in model.failures:
        if failure.phases and phase.name not in failure.phases:
            continue
        guard = _phase_guard(model, phase, dyn, failure)
        name = f"{phase.name}_{failure.name.replace('-', '_')}"
        quantities.append(Quantity(
            name, args, guard, f"Guard of {failure.name} in phase {phase.name}.", None,
            f"past zero (direction {failure.direction:+d}) where the phase begins when the "
            "walk ends there (checked there only)"
            if failure.at_start
            else f"crosses zero (direction {failure.direction:+d}) when the walk ends",
        ))  # fmt: skip
        (start_failures if failure.at_start else failures).append(
            (failure.name, name, failure.direction)
        )
        if phase.inputs:
            quantities.append(_guard_input_gains(model, phase, dyn, failure, name, args))
    for condition in model.conditions:
        guard = _phase_guard(model, phase, dyn, condition)
        name = f"{phase.name}_{condition.name.replace('-', '_')}"
        quantities.append(Quantity(
            name, args, guard, f"Condition {condition.name} in phase {phase.name} "
            "(reported, not enforced).", None,
            f"crosses zero (direction {condition.direction:+d}) where it fails",
        ))  # fmt: skip
        conditions.append((condition.name, name, condition.direction))
        if phase.inputs:
            quantities.append(_guard_input_gains(model, phase, dyn, condition, name, args))
    return quantities, failures, start_failures, conditions


def _drawing_quantities(model: Model, phase: Phase, args: tuple) -> tuple[list[Quantity], dict]:
    """The bodies' positions and inertias, the drawing's points (and, for a wheel, the
    angle between its spokes), and the drawing's record: the points' and bodies' names,
    the segments between points and the spokes."""
    positions, inertias = _body_table(phase)
    skeleton, skeleton_xy = _skeleton(model, phase, args)
    quantities = [
        Quantity(
            f"{phase.name}_positions", args, positions,
            f"Position (x, y) and angle of each body in phase {phase.name}'s chart.", None,
            "tuple: x, y, angle of each body in order (angle 0 for a point mass)",
        ),
        Quantity(
            f"{phase.name}_inertias", args, inertias,
            f"Mass and central moment of inertia of each body in phase {phase.name}.", None,
            "tuple: mass, inertia of each body in order (inertia 0 for a point mass)",
        ),
        Quantity(
            f"{phase.name}_skeleton", args, skeleton_xy,
            f"Position (x, y) of each point of the drawing in phase {phase.name}'s chart.",
            None, "tuple: x, y of each point in the order of HYBRID's phase 'skeleton'",
        ),
    ]  # fmt: skip
    drawing = {
        "points": tuple(skeleton.points), "segments": tuple(skeleton.segments),
        "bodies": tuple(b.name for b in phase.bodies),
    }  # fmt: skip
    if skeleton.spokes is not None:
        spoke_angle = f"{phase.name}_skeleton_spoke_angle"
        angle = sm.sympify(skeleton.spokes[2])
        if not angle.free_symbols <= set(model.parameter_symbols):
            raise ValueError(f"{model.name}: the skeleton's spoke angle depends on more "
                             "than the parameters")  # fmt: skip
        quantities.append(Quantity(
            spoke_angle, args, angle,
            f"Angle between neighbouring spokes of the drawing in phase {phase.name}.",
            None, "angle",
        ))  # fmt: skip
        drawing["spokes"] = (*skeleton.spokes[:2], spoke_angle)
    return quantities, drawing


def _actuator_power(phase: Phase, dyn: PhaseDynamics, moving: list, args: tuple) -> Quantity:
    """The power of each moving held coordinate's actuator: its generalised force times
    the held value's rate (chain rule), what the energy ledger integrates."""
    powers = tuple(
        dyn.actuator_forces[h]
        * chain_rate(sm.sympify(phase.held[h]), ((c.q, c.u) for c in phase.coordinates))
        for h in moving
    )
    return Quantity(
        f"{phase.name}_actuator_power", args, powers,
        f"Power of each actuator holding a moving coordinate in phase {phase.name} "
        f"({', '.join(h.name for h in moving)}): generalised force times rate.", None,
        "tuple: power of each actuator, in the order of HYBRID's phase 'actuators'",
    )  # fmt: skip


def _state_accelerations(model: Model, phase: Phase, dyn: PhaseDynamics) -> tuple:
    """Second derivatives of every state coordinate in a phase: the free ones' from the
    equations of motion, a held one's from its value by the chain rule."""
    if not held_in_state(model, phase):
        return tuple(dyn.accelerations)
    free = [c.q for c in phase.coordinates]
    rates = [c.u for c in phase.coordinates]
    by_coordinate = dict(zip(free, dyn.accelerations))
    out = []
    for c in model.coordinates:
        if c.q in by_coordinate:
            out.append(by_coordinate[c.q])
            continue
        value = sm.sympify(phase.held[c.q])
        rate = chain_rate(value, zip(free, rates))
        out.append(chain_rate(rate, zip(free, rates))
                   + chain_rate(value, zip(free, dyn.accelerations)))  # fmt: skip
    return tuple(out)


def input_quantities(model: Model, phase: Phase, dyn: PhaseDynamics, args: tuple) -> list:
    """A phase's input gains on the state's accelerations (a held state coordinate's by
    the chain rule, as :func:`_state_accelerations`) and its inputs' rates."""
    free = [c.q for c in phase.coordinates]
    known = {*free, *phase.held, *model.parameter_symbols}
    for i in phase.inputs:
        stray = sm.sympify(i.along).free_symbols - known
        if stray:
            raise ValueError(f"{model.name}: input {i.name} of phase {phase.name} acts along "
                             f"{i.along}, whose {', '.join(sorted(map(str, stray)))} is no "
                             "coordinate of the phase and no parameter")  # fmt: skip
    by_coordinate = dict(zip(free, dyn.input_gains))
    rows = []
    for c in model.coordinates:
        if c.q in by_coordinate:
            rows.append(by_coordinate[c.q])
            continue
        value = sm.sympify(phase.held[c.q])
        rows.append(tuple(chain_rate(value, ((q, by_coordinate[q][k]) for q in free))
                          for k in range(len(phase.inputs))))  # fmt: skip
    names = [i.name for i in phase.inputs]
    gains = tuple(g for row in rows for g in row)
    return [
        Quantity(
            f"{phase.name}_input_gains", args, gains,
            f"d(acceleration)/d(input) in phase {phase.name}: the accelerations are "
            f"{phase.name}_accelerations + these times the inputs ({', '.join(names)}).", None,
            "tuple: for each state coordinate in order, its gain from each input in order",
            output_names=tuple(f"{c.name}/{n}" for c in model.coordinates for n in names),
        ),
        Quantity(
            f"{phase.name}_reaction_input_gains", args,
            (*dyn.input_reaction_gains[0], *dyn.input_reaction_gains[1]),
            f"d(ground reaction)/d(input) in phase {phase.name}: normal force's gains, then "
            "the tangential force's, one per input.", None,
            "tuple: normal gains per input, then tangential gains per input",
            output_names=tuple(f"{f}/{n}" for f in ("normal", "tangential") for n in names),
        ),
        Quantity(
            f"{phase.name}_input_rates", args, dyn.input_rates,
            f"Rate of what each input of phase {phase.name} acts along: its power is the "
            "input times this.", None, "tuple: one rate per input, in order",
            output_names=tuple(names),
        ),
    ]  # fmt: skip


def _body_table(phase: Phase) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """(x, y, angle) and (mass, inertia) of each body, held coordinates at their values."""
    held = dict(phase.held)
    positions: list[sm.Expr] = []
    inertias: list[sm.Expr] = []
    for body, (x, y) in zip(phase.bodies, body_positions(phase)):
        point = isinstance(body, PointMass)
        angle = sm.Integer(0) if point else sm.sympify(body.angle).xreplace(held)
        positions += [x, y, angle]
        inertias += [sm.sympify(body.mass), sm.Integer(0) if point else sm.sympify(body.inertia)]
    return tuple(positions), tuple(inertias)


def _default_skeleton(model: Model, phase: Phase) -> Skeleton:
    """The stick figure of a model that states no drawing: the stance foot, body 0 as the
    hip, and the step event's contact point as the swing foot, taken from this phase's
    points where it names it and otherwise from the step event's source phase (its held
    coordinates at that phase's values where this phase leaves them unset)."""
    step = next(e for e in model.events if e.ends_step)
    points = {"stance_foot": (sm.Integer(0), sm.Integer(0)), "hip": phase.bodies[0].position}
    segments = [("stance_foot", "hip")]
    if isinstance(step.reset, Impact):
        name = step.reset.new_contact
        source = model.phase(step.source)
        state = {c.q for c in model.coordinates}
        if name in phase.points:
            foot = phase.points[name]
        else:
            outside = {h: v for h, v in source.held.items() if h not in state}
            foot = tuple(sm.sympify(c).xreplace(dict(phase.held)).xreplace(outside)
                         for c in source.points[name])  # fmt: skip
        points["swing_foot"] = foot
        segments.append(("hip", "swing_foot"))
    return Skeleton(points, tuple(segments))


def _skeleton(model: Model, phase: Phase, args: tuple) -> tuple[Skeleton, tuple[sm.Expr, ...]]:
    """A phase's drawing and its points' x, y (held coordinates at their values)."""
    skeleton = phase.skeleton or model.skeleton or _default_skeleton(model, phase)
    names = list(skeleton.points)
    for a, b in skeleton.segments:
        if a not in skeleton.points or b not in skeleton.points:
            raise ValueError(f"{model.name}: a skeleton segment ({a}, {b}) names a point "
                             f"the skeleton does not state in phase {phase.name}")  # fmt: skip
    if skeleton.spokes is not None and not set(skeleton.spokes[:2]) <= set(names):
        raise ValueError(f"{model.name}: the skeleton's spokes name unknown points")
    held = dict(phase.held)
    known = set(args) | set(model.limits)
    xy: list[sm.Expr] = []
    for name in names:
        point = tuple(sm.sympify(c).xreplace(held) for c in skeleton.points[name])
        unknown = set().union(*(c.free_symbols for c in point)) - known
        if unknown:
            raise ValueError(f"{model.name}: skeleton point {name} in phase {phase.name} "
                             f"depends on {sorted(map(str, unknown))}, not the state")  # fmt: skip
        xy += point
    return skeleton, tuple(xy)


def _phase_guard(model: Model, phase: Phase, dyn: PhaseDynamics,
                 check: Failure | Condition) -> sm.Expr:  # fmt: skip
    """A failure's or condition's guard in a phase: the ground reaction, the held
    coordinates' generalised forces and their values in place."""
    guard = sm.sympify(check.guard).xreplace({NORMAL_FORCE: dyn.normal_force})
    forces = {held_force(h): h for h in phase.held}
    wanted = {s for s in guard.free_symbols if s.name.startswith("Q_held_")}
    for symbol in wanted:
        if symbol not in forces:
            raise ValueError(f"{model.name}: {check.name} uses {symbol.name}, but phase "
                             f"{phase.name} does not hold that coordinate")  # fmt: skip
    if wanted:
        guard = guard.xreplace({s: dyn.actuator_forces[forces[s]] for s in wanted})
    return guard.xreplace({h: sm.sympify(v) for h, v in phase.held.items()})


def _guard_input_gains(model: Model, phase: Phase, dyn: PhaseDynamics,
                       check: Failure | Condition, name: str, args: tuple) -> Quantity:  # fmt: skip
    """``<name>_input_gains``: how a failure's or condition's guard moves with each input of
    the phase (through the ground reaction, which the inputs move; a guard of the state
    alone does not), for a guard linear in the ground reaction."""
    guard = sm.sympify(check.guard)
    if any(s.name.startswith("Q_held_") for s in guard.free_symbols):
        raise ValueError(f"{model.name}: {check.name} uses a held coordinate's force in phase "
                         f"{phase.name}, which has inputs: its gains are not derived")  # fmt: skip
    slope = guard.diff(NORMAL_FORCE)
    if slope.has(NORMAL_FORCE):
        raise ValueError(f"{model.name}: {check.name} is not linear in the ground reaction")
    held = {h: sm.sympify(v) for h, v in phase.held.items()}
    normal = dyn.input_reaction_gains[0]
    # A guard that is the ground reaction (slope 1) or of the state alone (0) needs nothing
    # more: its gains are the reaction's, simplified already, or zero.
    gains = tuple((slope * g if slope.is_Number else cheap_simplify(slope * g)).xreplace(held)
                  for g in normal)  # fmt: skip
    return Quantity(
        f"{name}_input_gains", args, gains,
        f"d(guard of {check.name})/d(input) in phase {phase.name}: the guard with the inputs "
        f"on is {name} + these times the inputs.", None, "tuple: one gain per input, in order",
        output_names=tuple(i.name for i in phase.inputs),
    )  # fmt: skip
