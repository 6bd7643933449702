"""A phase's dynamics: Kane's method on the bodies' Jacobians in the chart's symbols.

:func:`phase_dynamics` gives a phase's equations of motion (the held coordinates' rows
carry the actuator forces, the free ones' give the motion), its energy, generalised
momenta, ground reaction on the stance foot and, per :class:`Input`, the gains on the
accelerations and the ground reaction. The passive dynamics are derived once per
:func:`dynamics_key` (coordinates, bodies by value, gravity, held values).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Iterable
from dataclasses import dataclass

import sympy as sm

from derive.engine.algebra import (
    angle_sums,
    cheap_simplify,
    expand,
    factor_constants,
    matrix_product,
    placeholder_cramer,
)
from derive.engine.model import Model, Phase, RigidSegment

__all__ = [
    "PhaseDynamics",
    "body_positions",
    "chain_rate",
    "held_in_state",
    "phase_dynamics",
    "phase_rate",
    "rate_symbol",
]


@dataclass(frozen=True)
class PhaseDynamics:
    """What a phase's Lagrangian implies, in plain symbols (coordinates, rates, parameters).

    Attributes
    ----------
    accelerations : tuple of sympy.Expr
        Second derivatives of the free coordinates.
    kinetic, potential : sympy.Expr
        T and V with the held coordinates at their values.
    momenta : dict of sympy.Symbol to sympy.Expr
        ``dL/d(rate)`` of every chart coordinate (free and held), in terms of all chart
        coordinates and rates (held ones as symbols ``<name>`` and ``<name>_rate``).
    actuator_forces : dict of sympy.Symbol to sympy.Expr
        The generalised force each held coordinate's actuator exerts.
    normal_force, tangential_force : sympy.Expr
        Ground reaction on the stance foot along the chart's y and x axes (every input
        zero).
    input_gains : tuple of tuple of sympy.Expr
        ``d(acceleration)/du``: a row per free coordinate, a column per :class:`Input` of
        the phase (the accelerations are linear in the inputs).
    input_rates : tuple of sympy.Expr
        The rate of each input's ``along``: its power is ``u`` times this.
    input_reaction_gains : tuple of tuple of sympy.Expr
        ``d(ground reaction)/du``: the normal force's row, then the tangential force's.
    """

    phase: Phase
    accelerations: tuple[sm.Expr, ...]
    kinetic: sm.Expr
    potential: sm.Expr
    momenta: dict[sm.Symbol, sm.Expr]
    actuator_forces: dict[sm.Symbol, sm.Expr]
    normal_force: sm.Expr
    tangential_force: sm.Expr
    input_gains: tuple[tuple[sm.Expr, ...], ...] = ()
    input_rates: tuple[sm.Expr, ...] = ()
    input_reaction_gains: tuple[tuple[sm.Expr, ...], ...] = ()

    @property
    def energy(self) -> sm.Expr:
        return self.kinetic + self.potential


def rate_symbol(symbol: sm.Symbol) -> sm.Symbol:
    return sm.Symbol(f"{symbol.name}_rate", real=True)


def chain_rate(value: sm.Expr, rates: Iterable[tuple[sm.Symbol, sm.Expr]]) -> sm.Expr:
    """The rate of ``value`` (a held coordinate's, a function of the free coordinates)
    by the chain rule: the sum of ``d value / d q`` times each ``(q, rate of q)``, in
    order. Every held coordinate's rate and acceleration is formed by it."""
    return sum((value.diff(q) * u for q, u in rates), sm.Integer(0))


_ONE_FRACTION_UP_TO = 2
_ONE_FRACTION_BODIES = 3
"""Free coordinates and bodies up to which a phase's accelerations, ground reaction and
actuator forces are expanded and simplified as fractions over the mass matrix's determinant
(the two-link walkers'); larger phases keep Cramer's rule in products of the entries."""


@functools.cache
def phase_dynamics(phase: Phase) -> PhaseDynamics:
    """The equations of motion, energy, momenta and ground reaction of a phase.

    The passive dynamics do not depend on the phase's inputs, its name, its points or its
    bodies' names, so they are derived once for the phases that share coordinates, bodies,
    gravity and held values (a phase with its inputs and the stand-ins with an event's
    impulses as inputs, :func:`_impulse_quantities`; two phases of one model or of two
    models derived in one process); the inputs' terms are added from the same pieces.
    """
    key = _dynamics_key(phase)
    if key not in _PASSIVE:
        _PASSIVE[key] = _passive_dynamics(dataclasses.replace(phase, inputs=()))
    passive, pieces = _PASSIVE[key]
    gains, input_rates, reaction = _input_terms(phase, *pieces)
    # Each phase gets its own dicts: the cached ones are shared by every phase of the key.
    return dataclasses.replace(
        passive, phase=phase, momenta=dict(passive.momenta),
        actuator_forces=dict(passive.actuator_forces), input_gains=gains,
        input_rates=input_rates, input_reaction_gains=reaction,
    )  # fmt: skip


_PASSIVE: dict[tuple, tuple[PhaseDynamics, tuple]] = {}
""":func:`_passive_dynamics` of each phase's :func:`_dynamics_key`."""


def _dynamics_key(phase: Phase) -> tuple:
    """What a phase's passive dynamics are derived from, by value: the free coordinates'
    names, each body's kind, mass, position, angle and inertia, gravity, the held values."""
    bodies = tuple(
        (type(b).__name__, *(sm.sympify(v) for v in (b.mass, *b.position)),
         *((sm.sympify(b.angle), sm.sympify(b.inertia)) if isinstance(b, RigidSegment) else ()))
        for b in phase.bodies
    )  # fmt: skip
    held = tuple((h, sm.sympify(v)) for h, v in phase.held.items())
    return (tuple(c.name for c in phase.coordinates), bodies,
            tuple(sm.sympify(g) for g in phase.gravity), held)  # fmt: skip


def _passive_dynamics(phase: Phase) -> tuple[PhaseDynamics, tuple]:
    """A phase's dynamics with every input zero, and the pieces :func:`_input_terms` forms
    the inputs' terms with."""
    free = [c.q for c in phase.coordinates]
    held = list(phase.held)
    chart = free + held
    gx, gy = phase.gravity
    rates = [phase_rate(phase, s) for s in chart]
    a_symbols = [sm.Symbol(f"{s.name}_acc", real=True) for s in chart]
    mass_matrix, forcing, body_accelerations = _equations_of_motion(phase, chart, rates, a_symbols)
    a_free = a_symbols[: len(free)]
    held_values, placed = _held_values(phase, chart, a_symbols)

    def at_values(expr: sm.Expr) -> sm.Expr:
        return sm.sympify(expr).xreplace(held_values).xreplace(held_values)

    residual = (mass_matrix * sm.Matrix(a_symbols) - forcing).applyfunc(at_values)
    free_rows = residual[: len(free), :]
    system, rhs = sm.linear_eq_to_matrix(list(free_rows), a_free)
    if len(free) == 1:
        solution = _one_coordinate_solution(system, rhs, a_free, placed)
    else:
        solution = _cramer_solution(phase, system, rhs, a_free, placed)
    accelerations = tuple(e.xreplace(placed) for e in solution.in_symbols)
    actuator = {h: solution.linear(residual[chart.index(h)]) for h in held}

    potential = sum((-b.mass * (gx * sm.sympify(b.position[0]) + gy * sm.sympify(b.position[1]))
                     for b in phase.bodies), sm.Integer(0))  # fmt: skip
    # p = dT/dq' = M q' (T = q'^T M q' / 2: no position depends on time by itself); the
    # Lagrangian's derivative gives the same polynomial at several times sympy's cost.
    momenta_of_rates = mass_matrix * sm.Matrix(rates)
    momenta = {s: cheap_simplify(p) for s, p in zip(chart, momenta_of_rates)}
    kinetic = sum((r * p for r, p in zip(rates, momenta_of_rates)), sm.Integer(0)) / 2
    # Ground reaction on the stance foot: the bodies' total rate of momentum minus gravity.
    force = [sm.Integer(0), sm.Integer(0)]
    for body, acceleration in zip(phase.bodies, body_accelerations):
        for k, g_k in enumerate((gx, gy)):
            force[k] += body.mass * (at_values(acceleration[k]) - g_k)
    dynamics = PhaseDynamics(
        phase,
        accelerations,
        solution.finish(at_values(kinetic)),
        solution.finish(at_values(potential)),
        momenta,
        actuator,
        solution.linear(force[1]),
        solution.linear(force[0]),
    )
    cramer = (solution.adjugate, solution.determinant, solution.compact)
    pieces = (chart, cramer, held_values, placed, force, a_free)
    return dynamics, pieces


def _held_values(
    phase: Phase, chart: list[sm.Symbol], a_symbols: list[sm.Symbol]
) -> tuple[dict, dict[sm.Symbol, sm.Expr]]:
    """The held coordinates at their values, their rates and accelerations by the chain
    rule (keyed by the chart's symbols, ``<name>_rate`` and the acceleration symbols), and
    the profiles placed at the end.

    A held value that varies with the free coordinates (a prescribed profile) stays a
    symbol, with symbols for its partial derivatives, until the results are simplified:
    expanding a polynomial profile inside the equations of motion takes minutes; the
    profile goes in at the end (``placed``), unexpanded."""
    free = [c.q for c in phase.coordinates]
    u_free = [c.u for c in phase.coordinates]
    a_free = a_symbols[: len(free)]
    held_values = {}
    placed: dict[sm.Symbol, sm.Expr] = {}
    for h, value in phase.held.items():
        value = sm.sympify(value)
        if value.free_symbols & set(free):
            placed[h] = value
            first = {}
            for q in free:
                first[q] = sm.Symbol(f"{h.name}__d_{q.name}", real=True)
                placed[first[q]] = value.diff(q)
            second = {}
            for i, q1 in enumerate(free):
                for q2 in free[i:]:
                    name = f"{h.name}__d_{q1.name}_{q2.name}"
                    second[q1, q2] = second[q2, q1] = sm.Symbol(name, real=True)
                    placed[second[q1, q2]] = value.diff(q1, q2)
            rate = sum((first[q] * u for q, u in zip(free, u_free)), sm.Integer(0))
            acc = sum(
                (second[q1, q2] * u1 * u2 for q1, u1 in zip(free, u_free)
                 for q2, u2 in zip(free, u_free)),
                sm.Integer(0),
            )  # fmt: skip
            acc += sum((first[q] * a for q, a in zip(free, a_free)), sm.Integer(0))
            held_values[rate_symbol(h)] = rate
            held_values[a_symbols[chart.index(h)]] = acc
            continue
        rate = chain_rate(value, zip(free, u_free))
        acc = chain_rate(rate, zip(free, u_free)) + chain_rate(value, zip(free, a_free))
        held_values[h] = value
        held_values[rate_symbol(h)] = rate
        held_values[a_symbols[chart.index(h)]] = acc
    return held_values, placed


@dataclass(frozen=True)
class _Solution:
    """The free rows ``system a = rhs`` solved for the free accelerations ``a_free``:
    Cramer's rule (``adjugate``, ``determinant``, ``numerators``; ``compact`` where the
    entries stay whole, :func:`placeholder_cramer`), or for one coordinate its one
    quotient (``solved``). ``in_symbols``: the accelerations before the profiles
    (``placed``) go in."""

    a_free: list[sm.Symbol]
    in_symbols: tuple[sm.Expr, ...]
    adjugate: sm.Matrix
    determinant: sm.Expr
    numerators: tuple[sm.Expr, ...] = ()
    solved: dict = dataclasses.field(default_factory=dict)
    compact: bool = False
    placed: dict = dataclasses.field(default_factory=dict)

    def finish(self, expr: sm.Expr) -> sm.Expr:
        """Simplified, then with the profiles in place of their symbols."""
        return cheap_simplify(expr).xreplace(self.placed)

    def linear(self, expr: sm.Expr) -> sm.Expr:
        """``expr``, linear in the accelerations, with them solved."""
        if len(self.a_free) == 1:
            return self.finish(expr.xreplace(self.solved))
        # expr = rest + sum(c_i a_i), so expr * det = rest * det + sum(c_i n_i): a
        # polynomial, where substituting n_i / det and expanding leaves det's inverse
        # in every term for cancel to remove (17 of the compass gait's 29 s).
        rest = expr.xreplace(dict.fromkeys(self.a_free, sm.Integer(0)))
        if self.compact:
            # Three links and more: the expanded polynomial has thousands of terms and
            # pairing them into angle sums takes sympy minutes; the accelerations stay
            # factors (the code generator shares them with the equations of motion).
            terms = [angle_sums(expr.diff(a)) * n / self.determinant
                     for a, n in zip(self.a_free, self.numerators)]  # fmt: skip
            return sm.Add(angle_sums(rest), *terms).xreplace(self.placed)
        over = rest * self.determinant + sum(
            (expr.diff(a) * n for a, n in zip(self.a_free, self.numerators)), sm.Integer(0)
        )
        return (angle_sums(expand(over)) / self.determinant).xreplace(self.placed)


def _one_coordinate_solution(
    system: sm.Matrix, rhs: sm.Matrix, a_free: list[sm.Symbol], placed: dict
) -> _Solution:
    """One free coordinate: its acceleration, the quotient simplified; Cramer's rule of one
    equation is what the inputs' gains are solved with."""
    in_symbols = tuple(cheap_simplify(e) for e in system.LUsolve(rhs))
    return _Solution(a_free, in_symbols, sm.Matrix([[1]]), system[0, 0],
                     solved=dict(zip(a_free, in_symbols)), placed=placed)  # fmt: skip


def _cramer_solution(
    phase: Phase, system: sm.Matrix, rhs: sm.Matrix, a_free: list[sm.Symbol], placed: dict
) -> _Solution:
    """Several free coordinates: Cramer's rule with the determinant kept as one factor
    (cancelling whole rational functions of several angles' sines and cosines takes sympy
    minutes), in the links' relative angles."""
    system = system.applyfunc(angle_sums)
    rhs = rhs.applyfunc(angle_sums)
    size = len(a_free)
    compact = size > _ONE_FRACTION_UP_TO or len(phase.bodies) > _ONE_FRACTION_BODIES
    if compact:
        # A larger walker: the mass matrix's and forcing's entries are small, their
        # expanded cofactor products are not (tens of thousands of operations per
        # acceleration, and minutes of sympy): Cramer's rule is formed on placeholders
        # for the entries, which then go in whole, so the code generator computes each
        # once; their coefficients in the parameters factored.
        state = {*(c.q for c in phase.coordinates), *(c.u for c in phase.coordinates)}
        system = system.applyfunc(lambda e: factor_constants(e, state))
        rhs = rhs.applyfunc(lambda e: factor_constants(e, state))
        slots, forcing_slots, slot_determinant, slot_adjugate, slot_numerators = placeholder_cramer(
            size
        )
        entries = dict(zip(slots, system)) | dict(zip(forcing_slots, rhs))
        determinant = slot_determinant.xreplace(entries)
        numerators = [e.xreplace(entries) for e in slot_numerators]
        adjugate = slot_adjugate.xreplace(entries)
    else:
        determinant = cheap_simplify(system.det(method="berkowitz"))
        adjugate = system.adjugate(method="berkowitz")
        numerators = [cheap_simplify(e) for e in adjugate * rhs]
    in_symbols = tuple(n / determinant for n in numerators)
    return _Solution(a_free, in_symbols, adjugate, determinant, tuple(numerators),
                     compact=compact, placed=placed)  # fmt: skip


_Rows = tuple[tuple[sm.Expr, ...], ...]


def _input_terms(
    phase: Phase, chart: list[sm.Symbol], cramer: tuple[sm.Matrix, sm.Expr, bool],
    held_values: dict, placed: dict, force: list[sm.Expr], a_free: list[sm.Symbol],
) -> tuple[_Rows, tuple[sm.Expr, ...], _Rows]:  # fmt: skip
    """Each input's gain on the free coordinates' accelerations, the rate of its ``along``
    (:class:`Input`) and its gain on the ground reaction (normal, then tangential). Its
    generalised forces on the free rows are ``u d(along)/dq`` (held coordinates independent
    in the chart; their actuators take the held rows), so the gains are Cramer's rule on
    that column with the adjugate and determinant the passive accelerations are solved
    with (``cramer``: adjugate, determinant, and whether the phase keeps its entries whole
    rather than expanded). The ground reaction (``force``, the bodies' rate of momentum
    minus gravity, linear in the accelerations ``a_free``) moves with the accelerations
    alone: an input is internal to the walker."""
    if not phase.inputs:
        return (), (), ()
    _check_inputs(phase)
    adjugate, determinant, compact = cramer
    free = [c.q for c in phase.coordinates]

    def at_values(expr: sm.Expr) -> sm.Expr:
        return expr.xreplace(held_values).xreplace(held_values)

    alongs = [sm.sympify(i.along) for i in phase.inputs]
    forces = sm.Matrix(len(free), len(alongs), lambda j, k: at_values(alongs[k].diff(free[j])))
    # Numerators over the one determinant (simplified as polynomials: cancelling whole
    # rational functions is what the passive accelerations avoid too).
    tidy = cheap_simplify if len(free) == 1 else (lambda e: e) if compact else angle_sums
    numerators = matrix_product(adjugate, forces).applyfunc(tidy)
    gains = tuple(
        tuple((numerators[j, k] / determinant).xreplace(placed) for k in range(len(alongs)))
        for j in range(len(free))
    )
    combine = (lambda e: e) if compact else cheap_simplify
    reaction = tuple(
        tuple((combine(sum((force[c].diff(a) * numerators[j, k] for j, a in enumerate(a_free)),
                           sm.Integer(0))) / determinant).xreplace(placed)
              for k in range(len(alongs)))
        for c in (1, 0)
    )  # fmt: skip
    rates = tuple(
        cheap_simplify(at_values(sum((along.diff(c) * phase_rate(phase, c) for c in chart),
                                sm.Integer(0)))).xreplace(placed)
        for along in alongs
    )  # fmt: skip
    return gains, rates, reaction


def _check_inputs(phase: Phase) -> None:
    """An input acts along an expression of the chart (and the parameters), is named once
    and does work on some free coordinate."""
    names = [i.name for i in phase.inputs]
    if len(set(names)) != len(names):
        raise ValueError(f"phase {phase.name}: input names repeat: {names}")
    for i in phase.inputs:
        if not i.name.isidentifier():
            raise ValueError(f"phase {phase.name}: input name {i.name!r} is no identifier")
        along = sm.sympify(i.along)
        if not along.free_symbols & {c.q for c in phase.coordinates}:
            raise ValueError(
                f"phase {phase.name}: input {i.name} acts along {along}, which no free "
                "coordinate changes: it does no work on the walker"
            )
        low, high = i.bounds
        if low is not None and high is not None and not low < high:
            raise ValueError(f"phase {phase.name}: input {i.name}'s bounds {i.bounds} are empty")


def _equations_of_motion(
    phase: Phase, chart: list[sm.Symbol], rates: list[sm.Symbol], accelerations: list[sm.Symbol]
) -> tuple[sm.Matrix, sm.Matrix, list[tuple[sm.Expr, sm.Expr]]]:
    """``M q'' = forcing`` of the chart, and each body's acceleration (x, y), in the
    chart's symbols, its ``rates`` and ``accelerations``.

    Kane's method with the chart's rates as the generalised speeds: a body's partial
    velocities are its Jacobian's columns (``d(x, y)/dq``, and ``d(angle)/dq`` for a
    rigid segment's rotation), so ``M = sum m J^T J + I J_a^T J_a``, and ``forcing`` is
    the generalised gravity force minus the partial velocities dotted with the
    acceleration the rates alone give (``sum d2(x)/dq dq' q' q'``). The expressions are
    the polynomials :class:`sympy.physics.mechanics.KanesMethod` forms on the same bodies,
    without differentiating functions of time (what took most of sympy's time there)."""
    size = len(chart)
    gx, gy = (sm.sympify(g) for g in phase.gravity)
    mass_matrix = sm.zeros(size, size)
    forcing = sm.zeros(size, 1)
    body_accelerations = []

    def parts(value: sm.Expr) -> tuple[list[sm.Expr], sm.Expr, sm.Expr]:
        """The Jacobian row of ``value``, its rate-only acceleration and its acceleration."""
        row = [value.diff(s) for s in chart]
        rate = sum((d * r for d, r in zip(row, rates)), sm.Integer(0))
        quadratic = chain_rate(rate, zip(chart, rates))
        return row, quadratic, quadratic + sum((d * a for d, a in zip(row, accelerations)),
                                                sm.Integer(0))  # fmt: skip

    for body in phase.bodies:
        mass = sm.sympify(body.mass)
        (x_row, x_quadratic, x_full), (y_row, y_quadratic, y_full) = (
            parts(sm.sympify(c)) for c in body.position
        )
        turning = parts(sm.sympify(body.angle)) if isinstance(body, RigidSegment) else None
        for i in range(size):
            # Grouped as Kane's method groups them (the mass times the partial velocities'
            # dot product): a one-coordinate phase's determinant is this entry as it is.
            for j in range(size):
                mass_matrix[i, j] += mass * (x_row[i] * x_row[j] + y_row[i] * y_row[j])
                if turning is not None:
                    mass_matrix[i, j] += sm.sympify(body.inertia) * turning[0][i] * turning[0][j]
            forcing[i] += mass * (gx * x_row[i] + gy * y_row[i])
            forcing[i] -= mass * (x_row[i] * x_quadratic + y_row[i] * y_quadratic)
            if turning is not None:
                forcing[i] -= sm.sympify(body.inertia) * turning[0][i] * turning[1]
        body_accelerations.append((x_full, y_full))
    return mass_matrix, forcing, body_accelerations


def phase_rate(phase: Phase, symbol: sm.Symbol) -> sm.Symbol:
    """The rate symbol of a chart coordinate (a free coordinate's own name for it)."""
    for c in phase.coordinates:
        if c.q == symbol:
            return c.u
    return rate_symbol(symbol)


def body_positions(phase: Phase, held: bool = True) -> list[tuple[sm.Expr, sm.Expr]]:
    """Body positions (x, y), held coordinates at their values unless ``held`` is False."""
    values = dict(phase.held) if held else {}
    return [tuple(sm.sympify(c).xreplace(values) for c in b.position) for b in phase.bodies]


def held_in_state(model: Model, phase: Phase) -> list[sm.Symbol]:
    """The state's coordinates a phase holds (a knee it keeps locked); every other state
    coordinate must be free in it."""
    free = {c.q for c in phase.coordinates}
    held = []
    for c in model.coordinates:
        if c.q in free:
            continue
        if c.q not in phase.held:
            raise ValueError(f"{model.name}: coordinate {c.name} is neither free nor held in "
                             f"phase {phase.name}")  # fmt: skip
        held.append(c.q)
    return held
