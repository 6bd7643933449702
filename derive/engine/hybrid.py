"""Everything a :class:`~derive.engine.model.Model` implies, derived with sympy.

* :func:`phase_dynamics`: the equations of motion of a phase (Kane's method on the chart
  of all its coordinates, from the bodies' Jacobians;
  the held coordinates' rows carry the actuator forces, the free ones' give the motion),
  its energy, generalised momenta and the ground reaction on the stance foot.
* :func:`impact_reset`: an inelastic impact from Lagrange's impulse equations: for every
  coordinate of the phase after, the impulses do no work on its motion,
  ``J+^T M (v+ - v-) = 0`` over the bodies (``v = J u``), since the only impulse acts at the
  new contact, which the phase after pins.
* :func:`lock_reset`: a joint locking (a knee straightening): the lock's impulse acts on
  the coordinates the phase after holds, so the phase after's free coordinates' generalised
  momenta are conserved (``p_q(q, u-) = p_q(q, u+)`` with the held rates stopped).
* :func:`jump_reset`: an instantaneous actuation: the free coordinates' generalised momenta
  are continuous while the held coordinates jump (``M(q+) u+ = M(q-) u-`` in their rows);
  in the limit of a fast jump the free coordinates turn as well (``Jump(limit=True)``).
* :func:`stride_closed_form`: for one free coordinate and events at fixed angles, the
  stride map in ``q = (rate)**2`` in closed form: along a phase ``u = rate**2`` obeys the
  linear equation ``du/dtheta = 2 A + 2 B u`` (``theta'' = A + B theta'^2``), solved with
  its integrating factor; the resets scale ``u`` by a constant.
* :func:`hybrid_quantities`: the functions the generic runtime needs (accelerations,
  guards, resets, energies, ground reactions, failure guards) and those the tests check
  the physics with (bodies' positions and inertias, impacts' contact points), as
  :class:`~derive.quantities.Quantity` records for the code generator, and the
  ``HYBRID`` descriptor of the model.
"""

from __future__ import annotations

import dataclasses
import functools
import random
import types
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import symengine as se
import sympy as sm

from derive.engine.model import (
    NORMAL_FORCE,
    Condition,
    Continuous,
    Event,
    Failure,
    Impact,
    Input,
    Jump,
    Lock,
    Model,
    Phase,
    PointMass,
    RigidSegment,
    Skeleton,
    held_force,
)
from derive.engine.trig import tr10i
from derive.quantities import Quantity

__all__ = [
    "NestedFractionError",
    "PhaseDynamics",
    "check_event_angle",
    "continuous_reset",
    "hybrid_quantities",
    "impact_reset",
    "integrate_polynomial_trig",
    "jump_reset",
    "lock_reset",
    "phase_dynamics",
    "refuse_nested_fraction",
    "stride_closed_form",
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


def _rate_symbol(symbol: sm.Symbol) -> sm.Symbol:
    return sm.Symbol(f"{symbol.name}_rate", real=True)


def chain_rate(value: sm.Expr, rates: Iterable[tuple[sm.Symbol, sm.Expr]]) -> sm.Expr:
    """The rate of ``value`` (a held coordinate's, a function of the free coordinates)
    by the chain rule: the sum of ``d value / d q`` times each ``(q, rate of q)``, in
    order. Every held coordinate's rate and acceleration is formed by it."""
    return sum((value.diff(q) * u for q, u in rates), sm.Integer(0))


class NestedFractionError(ValueError):
    """The engine was about to expand a large fraction nested in another fraction."""


_NESTED_FRACTION_OPS = 400
"""A fraction nested in another's denominator is refused by :func:`expand` where the
inner denominator moves with the configuration (it holds a sine or cosine) and the two
denominators' operations multiply to more than this. A solve's pivot is a mass matrix
entry of the walker's angles (a two-link walker's nests: 69 x 20 and 69 x 53); a model's
own nested ratio, a length ``c / (1 + 1/(a + b))``, divides by its parameters however
large the expression it sits in."""


def refuse_nested_fraction(expr: sm.Expr, powers: Iterable[sm.Pow] | None = None) -> None:
    """Raise :class:`NestedFractionError` where ``expr`` divides by a sum that itself
    divides by a sum of sines or cosines, the two denominators' operations multiplying to
    more than ``_NESTED_FRACTION_OPS``.

    Such a nest is what one symbolic solve inside another builds (``LUsolve`` whose
    right-hand side holds another ``LUsolve``'s fractions). Expanding it multiplies every
    term of one denominator's numerator by every term of the other, and cancelling the
    result takes minutes for a two-link walker's impact with an impulse; the engine solves
    by Cramer's rule in polynomials instead (:func:`_cramer_fraction`). Every expansion
    checks this, so the derivation of every model (and of every user's model file) keeps
    to it: a refusal names an engine defect, not a fault of the model. ``powers``: the
    powers in ``expr`` where the caller has them already (``expr.atoms(sm.Pow)``)."""
    for power in expr.atoms(sm.Pow) if powers is None else powers:
        base, exponent = power.args
        if not (exponent.is_negative and base.is_Add):
            continue
        outer = None
        for inner in base.atoms(sm.Pow):
            if not (inner.args[1].is_negative and inner.args[0].is_Add):
                continue
            if not inner.args[0].has(sm.sin, sm.cos):
                continue
            outer = sm.count_ops(base) if outer is None else outer
            size = outer * sm.count_ops(inner.args[0])
            if size > _NESTED_FRACTION_OPS:
                raise NestedFractionError(
                    "the engine was about to expand a fraction nested in another's "
                    f"denominator (their operations multiply to {size}): a solve inside a "
                    "solve, to be written by Cramer's rule; an engine defect to report with "
                    "the model file"
                )


def _scan(expr: sm.Expr) -> tuple[set, set, set, bool] | None:
    """``expr``'s symbols, powers and applied functions, and whether it holds a Float, in
    one walk over its distinct subexpressions (``atoms`` walks every path to a shared
    subexpression, once for each kind asked for). None where ``expr`` holds anything but
    sums, products, powers, applied functions and atoms (then its free symbols may be
    fewer than its symbols)."""
    symbols, powers, functions = set(), set(), set()
    has_float = False
    seen = set()
    stack = [expr]
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        if node.is_Atom:
            if node.is_Symbol:
                symbols.add(node)
            elif node.is_Float:
                has_float = True
            continue
        if node.is_Pow:
            powers.add(node)
        elif isinstance(node, sm.Function):
            functions.add(node)
        elif not (node.is_Add or node.is_Mul):
            return None
        stack.extend(node.args)
    return symbols, powers, functions, has_float


def expand(expr: sm.Expr) -> sm.Expr:
    """``sympy.expand`` done by SymEngine (what SymForce does its algebra with): the
    expanded polynomial is canonical, so sympy's own expansion and this one are the same
    expression, at a fraction of the time. Symbols come back from SymEngine without their
    assumptions and are put back by name; an expression SymEngine cannot hold (or with
    two symbols of one name) is expanded by sympy. A large nested fraction is refused
    (:func:`refuse_nested_fraction`)."""
    expr = sm.sympify(expr)
    scanned = _scan(expr)
    if scanned is None:
        refuse_nested_fraction(expr)
        free = expr.free_symbols
        functions = expr.atoms(sm.Function)
        has_float = bool(expr.atoms(sm.Float))
    else:
        free, powers, functions, has_float = scanned
        refuse_nested_fraction(expr, powers)
    symbols = {s.name: s for s in free}
    if (
        len(symbols) != len(free)
        or any(not isinstance(f, _SYMENGINE_FUNCTIONS) for f in functions)
        or has_float
    ):
        return sm.expand(expr)
    try:
        expanded = se.expand(se.sympify(expr))
    except (RuntimeError, TypeError, NotImplementedError, KeyError):  # a form SymEngine lacks
        return sm.expand(expr)
    if len(_CONVERTED) > _CONVERTED_LIMIT:
        _CONVERTED.clear()
    try:
        return _from_symengine(expanded, symbols, _CONVERTED.setdefault(frozenset(free), {}))
    except (RuntimeError, TypeError, NotImplementedError, KeyError):
        return sm.expand(expr)


_CONVERTED: dict[frozenset, dict] = {}
"""SymEngine's expressions as sympy's, kept across expansions for each set of symbols
(a name stands for one symbol in each): successive expansions of a derivation share most
of their terms (the mass matrix's, the forcing's), each converted once."""
_CONVERTED_LIMIT = 64
"""Sets of symbols :data:`_CONVERTED` holds before it starts afresh."""


_SYMENGINE_CLASSES = ((se.Add, sm.Add), (se.Mul, sm.Mul), (se.Pow, sm.Pow), (se.sin, sm.sin),
                      (se.cos, sm.cos), (se.atan, sm.atan))  # fmt: skip
_SYMENGINE_FUNCTIONS = (sm.sin, sm.cos, sm.atan)
"""The functions :func:`expand` hands to SymEngine (the TLE's stride integral has an atan)."""


def _from_symengine(expr, symbols: dict[str, sm.Symbol], seen: dict) -> sm.Expr:
    """A SymEngine expression as sympy's, its symbols those of ``symbols`` by name (one
    pass: converting and then replacing the symbols would build every node twice)."""
    if expr in seen:
        return seen[expr]
    if isinstance(expr, se.Symbol):
        result = symbols[expr.name]
    elif isinstance(expr, se.Number):
        result = expr._sympy_()
    else:
        for engine_class, sympy_class in _SYMENGINE_CLASSES:
            if isinstance(expr, engine_class):
                result = sympy_class(*(_from_symengine(a, symbols, seen) for a in expr.args))
                break
        else:
            raise NotImplementedError(type(expr).__name__)
    seen[expr] = result
    return result


def _simplify(expr: sm.Expr) -> sm.Expr:
    """A cheap canonical form: ``sin(a)**2 -> 1 - cos(a)**2`` (no sums of angles expanded),
    expanded and cancelled. ``trigsimp`` would do more at many times the cost."""
    expr = expand(expr)
    squared = _sine_powers(expr)
    if squared is not None:
        if squared:
            expr = expand(expr.xreplace(squared))
    else:
        squares = {
            sm.sin(a) ** 2: 1 - sm.cos(a) ** 2 for a in {s.args[0] for s in expr.atoms(sm.sin)}
        }
        if squares:
            expr = expand(expr.subs(squares))
    # cancel returns an expanded polynomial with rational coefficients unchanged (it puts
    # the terms over their common denominator and multiplies the number back in): finding
    # that out was a second of each two-link walker's derivation.
    return expr if _rational_polynomial(expr) else sm.cancel(expr)


def _sine_powers(expr: sm.Expr) -> dict | None:
    """``sin(a)**(2 j) -> (1 - cos(a)**2)**j`` for every even power of a sine in ``expr``,
    what ``subs(sin(a)**2, 1 - cos(a)**2)`` does to positive integer powers in a fraction
    of its time (it leaves odd powers: 3 is no multiple of 2); None when some power of a
    sine is not a positive integer (then ``subs`` does what it does)."""
    if any(sine.args[0].has(sm.sin) for sine in expr.atoms(sm.sin)):
        return None  # subs reaches into the argument first; leave nesting to it
    powers = {}
    for power in expr.atoms(sm.Pow):
        base, exponent = power.args
        if not isinstance(base, sm.sin):
            continue
        if not (exponent.is_Integer and exponent > 0):
            return None
        if exponent % 2 == 0:
            powers[power] = (1 - sm.cos(base.args[0]) ** 2) ** (exponent // 2)
    return powers


def _rational_polynomial(expr: sm.Expr) -> bool:
    """Whether the expanded ``expr`` is a polynomial with rational coefficients in its
    symbols and functions (no division by them, no fractional power)."""
    for term in sm.Add.make_args(expr):
        for factor in sm.Mul.make_args(term):
            if factor.is_Number:
                if not factor.is_Rational:
                    return False
                continue
            exponent = factor.as_base_exp()[1]  # exp(-y) is (E, -y): a division
            if not (exponent.is_Integer and exponent > 0):
                return False
    return True


def _factor_constants(expr: sm.Expr, variables: set) -> sm.Expr:
    """``expr`` (expanded) as a sum over its monomials in ``variables`` (and functions of
    them), each with its coefficient in the other symbols factored: a mass matrix entry
    ``m a1**2 + 2 m a1 b1 + m b1**2`` becomes ``m (a1 + b1)**2``."""
    groups: dict[sm.Expr, list[sm.Expr]] = {}
    for term in sm.Add.make_args(expand(expr)):
        constant, varying = [], []
        for factor in sm.Mul.make_args(term):
            (varying if factor.free_symbols & variables else constant).append(factor)
        groups.setdefault(sm.Mul(*varying), []).append(sm.Mul(*constant))
    return sm.Add(*(sm.factor(sm.Add(*c)) * k for k, c in groups.items()))


def _angle_sums(expr: sm.Expr) -> sm.Expr:
    """:func:`_simplify`, then products of sines and cosines of different angles as sines
    and cosines of their sums (``sin a sin b + cos a cos b -> cos(a - b)``, fu's TR10i):
    the equations of several rigid links stay small in the links' relative angles."""
    return _simplify(tr10i(_simplify(expr)))


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
    # Held coordinates at their values; their rates and accelerations by the chain rule.
    u_free = [c.u for c in phase.coordinates]
    a_free = a_symbols[: len(free)]
    held_values = {}
    # A held value that varies with the free coordinates (a prescribed profile) stays a
    # symbol, with symbols for its partial derivatives, until the results are simplified:
    # expanding a polynomial profile inside the equations of motion takes minutes; the
    # profile goes in at the end (``placed``), unexpanded.
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
            held_values[_rate_symbol(h)] = rate
            held_values[a_symbols[chart.index(h)]] = acc
            continue
        rate = chain_rate(value, zip(free, u_free))
        acc = chain_rate(rate, zip(free, u_free)) + chain_rate(value, zip(free, a_free))
        held_values[h] = value
        held_values[_rate_symbol(h)] = rate
        held_values[a_symbols[chart.index(h)]] = acc

    def finish(expr: sm.Expr) -> sm.Expr:
        """Simplified, then with the profiles in place of their symbols."""
        return _simplify(expr).xreplace(placed)

    def at_values(expr: sm.Expr) -> sm.Expr:
        return sm.sympify(expr).xreplace(held_values).xreplace(held_values)

    residual = (mass_matrix * sm.Matrix(a_symbols) - forcing).applyfunc(at_values)
    free_rows = residual[: len(free), :]
    system, rhs = sm.linear_eq_to_matrix(list(free_rows), a_free)
    compact = False
    if len(free) == 1:
        solution = system.LUsolve(rhs)
        in_symbols = tuple(_simplify(e) for e in solution)
        solved = dict(zip(a_free, in_symbols))
        # Cramer's rule of one equation: what the inputs' gains are solved with.
        adjugate, determinant = sm.Matrix([[1]]), system[0, 0]

        def linear_in_accelerations(expr: sm.Expr) -> sm.Expr:
            return finish(expr.xreplace(solved))
    else:
        # Cramer's rule with the determinant kept as one factor: cancelling whole rational
        # functions of several angles' sines and cosines takes sympy minutes.
        system = system.applyfunc(_angle_sums)
        rhs = rhs.applyfunc(_angle_sums)
        compact = len(free) > _ONE_FRACTION_UP_TO or len(phase.bodies) > _ONE_FRACTION_BODIES
        if compact:
            # A larger walker: the mass matrix's and forcing's entries are small, their
            # expanded cofactor products are not (tens of thousands of operations per
            # acceleration, and minutes of sympy): Cramer's rule is formed on placeholders
            # for the entries, which then go in whole, so the code generator computes each
            # once; their coefficients in the parameters factored.
            state = {*free, *u_free}
            system = system.applyfunc(lambda e: _factor_constants(e, state))
            rhs = rhs.applyfunc(lambda e: _factor_constants(e, state))
            slots, forcing_slots, slot_determinant, slot_adjugate, slot_numerators = (
                _placeholder_cramer(len(free))
            )
            entries = dict(zip(slots, system)) | dict(zip(forcing_slots, rhs))
            determinant = slot_determinant.xreplace(entries)
            numerators = [e.xreplace(entries) for e in slot_numerators]
            adjugate = slot_adjugate.xreplace(entries)
        else:
            determinant = _simplify(system.det(method="berkowitz"))
            adjugate = system.adjugate(method="berkowitz")
            numerators = [_simplify(e) for e in adjugate * rhs]
        in_symbols = tuple(n / determinant for n in numerators)
        solved = {a: n / determinant for a, n in zip(a_free, numerators)}

        def linear_in_accelerations(expr: sm.Expr) -> sm.Expr:
            # expr = rest + sum(c_i a_i), so expr * det = rest * det + sum(c_i n_i): a
            # polynomial, where substituting n_i / det and expanding leaves det's inverse
            # in every term for cancel to remove (17 of the compass gait's 29 s).
            rest = expr.xreplace(dict.fromkeys(a_free, sm.Integer(0)))
            if compact:
                # Three links and more: the expanded polynomial has thousands of terms and
                # pairing them into angle sums takes sympy minutes; the accelerations stay
                # factors (the code generator shares them with the equations of motion).
                terms = [_angle_sums(expr.diff(a)) * n / determinant
                         for a, n in zip(a_free, numerators)]  # fmt: skip
                return sm.Add(_angle_sums(rest), *terms).xreplace(placed)
            over = rest * determinant + sum(
                (expr.diff(a) * n for a, n in zip(a_free, numerators)), sm.Integer(0)
            )
            return (_angle_sums(expand(over)) / determinant).xreplace(placed)

    accelerations = tuple(e.xreplace(placed) for e in in_symbols)
    actuator = {h: linear_in_accelerations(residual[chart.index(h)]) for h in held}

    potential = sum((-b.mass * (gx * sm.sympify(b.position[0]) + gy * sm.sympify(b.position[1]))
                     for b in phase.bodies), sm.Integer(0))  # fmt: skip
    # p = dT/dq' = M q' (T = q'^T M q' / 2: no position depends on time by itself); the
    # Lagrangian's derivative gives the same polynomial at several times sympy's cost.
    momenta_of_rates = mass_matrix * sm.Matrix(rates)
    momenta = {s: _simplify(p) for s, p in zip(chart, momenta_of_rates)}
    kinetic = sum((r * p for r, p in zip(rates, momenta_of_rates)), sm.Integer(0)) / 2
    # Ground reaction on the stance foot: the bodies' total rate of momentum minus gravity.
    force = [sm.Integer(0), sm.Integer(0)]
    for body, acceleration in zip(phase.bodies, body_accelerations):
        for k, g_k in enumerate((gx, gy)):
            force[k] += body.mass * (at_values(acceleration[k]) - g_k)
    dynamics = PhaseDynamics(
        phase,
        accelerations,
        finish(at_values(kinetic)),
        finish(at_values(potential)),
        momenta,
        actuator,
        linear_in_accelerations(force[1]),
        linear_in_accelerations(force[0]),
    )
    pieces = (chart, (adjugate, determinant, compact), held_values, placed, force, a_free)
    return dynamics, pieces


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
    tidy = _simplify if len(free) == 1 else (lambda e: e) if compact else _angle_sums
    numerators = (adjugate * forces).applyfunc(tidy)
    gains = tuple(
        tuple((numerators[j, k] / determinant).xreplace(placed) for k in range(len(alongs)))
        for j in range(len(free))
    )
    combine = (lambda e: e) if compact else _simplify
    reaction = tuple(
        tuple((combine(sum((force[c].diff(a) * numerators[j, k] for j, a in enumerate(a_free)),
                           sm.Integer(0))) / determinant).xreplace(placed)
              for k in range(len(alongs)))
        for c in (1, 0)
    )  # fmt: skip
    rates = tuple(
        _simplify(at_values(sum((along.diff(c) * phase_rate(phase, c) for c in chart),
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
    return _rate_symbol(symbol)


def _positions(phase: Phase, held: bool = True) -> list[tuple[sm.Expr, sm.Expr]]:
    """Body positions (x, y), held coordinates at their values unless ``held`` is False."""
    values = dict(phase.held) if held else {}
    return [tuple(sm.sympify(c).xreplace(values) for c in b.position) for b in phase.bodies]


def _numeric_check(exprs: list[sm.Expr], symbols: list[sm.Symbol], what: str) -> None:
    """Each expression vanishes at random points (a fact of geometry the model states)."""
    rng = random.Random(20261201)
    for _ in range(4):
        point = {s: sm.Float(rng.uniform(0.1, 0.6), 30) for s in symbols}
        for e in exprs:
            value = abs(complex(sm.sympify(e).xreplace(point).evalf(30)))
            if value > 1e-20:
                raise AssertionError(f"{what}: {e} = {value:.3g} at {point}")


def _impact_jacobian(positions, coords, phase: Phase, order, held: bool = True,
                     angle_values: Mapping | None = None) -> sm.Matrix:  # fmt: skip
    """The bodies' mass-weighted Jacobian: rows sqrt(m) d(x, y)/dq and sqrt(I) d(angle)/dq,
    so that its Gram matrix is the mass matrix and J^T J q' the generalised momentum. The
    angles take the held values (``held``), or ``angle_values`` where given."""
    if angle_values is None:
        angle_values = dict(phase.held) if held else {}
    rows = []
    for body, position in zip((phase.bodies[k] for k in order), positions):
        weight = sm.sqrt(body.mass)
        rows += [[weight * sm.diff(position[k], q) for q in coords] for k in range(2)]
        if not isinstance(body, PointMass):
            angle = sm.sympify(body.angle).xreplace(angle_values)
            rows.append([sm.sqrt(body.inertia) * sm.diff(angle, q) for q in coords])
    return sm.Matrix(rows)


@functools.cache
def _impact_balance(model: Model, event_name: str) -> types.SimpleNamespace:
    """An impact's momentum balance ``a u+ = b u-`` over the phase after's free coordinates
    (``projection``: the motions the impulse at the new contact does no work on), with the
    pieces :func:`impact_reset` and :func:`held_impulse_at_impact` build from."""
    event = next(e for e in model.events if e.name == event_name)
    if not isinstance(event.reset, Impact):
        raise TypeError(f"{event.name} is not an impact")
    before, after = model.phase(event.source), model.phase(event.target)
    q_before = [c.q for c in before.coordinates]
    holding = {q: sm.sympify(v) for q, v in event.reset.holding.items()}
    if any(v.free_symbols for v in holding.values()):
        raise ValueError(f"{event.name}: an impact holds coordinates at constant values")
    mapping = {c.q: sm.sympify(event.reset.coordinates[c.q]) for c in after.coordinates}
    q_after = [c.q for c in after.coordinates if c.q not in holding]
    held = {h: sm.sympify(v) for h, v in before.held.items()}
    contact = [sm.sympify(c).xreplace(held) for c in before.points[event.reset.new_contact]]
    order = impact_body_order(model, event_name)
    pos_before = [_positions(before)[k] for k in order]
    pos_after = [tuple(c.xreplace(mapping) for c in p) for p in _positions(after)]
    # The configuration is unchanged: every body where it was, seen from the new contact.
    gaps = [pb[k] - contact[k] - pa[k] for pb, pa in zip(pos_before, pos_after) for k in range(2)]
    _numeric_check(gaps, sorted(set().union(*(g.free_symbols for g in gaps)), key=str),
                   f"{event.name}: bodies after the impact")  # fmt: skip
    j_before = _impact_jacobian(pos_before, q_before, before, order)
    # A coordinate the lock holds through the impact is a constant of the phase after's
    # chart there: the Jacobian is taken with it in place.
    held_after = [tuple(c.xreplace(holding) for c in p) for p in _positions(after)]
    j_after = _impact_jacobian(held_after, q_after, after, range(len(after.bodies)))
    j_after = j_after.xreplace(mapping)
    # The impulses do no work along the phase after's free coordinates with its held chart
    # coordinates fixed: the holding actuators' impulses act on those alone. Where a held
    # value varies with the free coordinates (a torso held at an angle from the vertical by
    # a joint on the stance leg) that direction is not the held motion's (j_after).
    projection = j_after
    if any(sm.sympify(v).free_symbols & set(q_after) for v in after.held.values()):
        frozen = [tuple(sm.sympify(c).xreplace(holding) for c in p)
                  for p in _positions(after, held=False)]  # fmt: skip
        projection = _impact_jacobian(frozen, q_after, after, range(len(after.bodies)),
                                      held=False)  # fmt: skip
        projection = projection.xreplace(dict(after.held)).xreplace(mapping)
    return types.SimpleNamespace(
        event=event, before=before, after=after, q_before=q_before, q_after=q_after,
        mapping=mapping, order=order, j_before=j_before, j_after=j_after,
        projection=projection,
    )  # fmt: skip


@functools.cache
def impact_reset(model: Model, event_name: str) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """Coordinates and rates just after an inelastic impact, from the momentum balance."""
    bal = _impact_balance(model, event_name)
    u_before = [c.u for c in bal.before.coordinates]
    coordinates = tuple(bal.mapping[c.q] for c in bal.after.coordinates)
    if len(bal.q_after) == 1:
        a = (bal.projection.T * bal.j_after).applyfunc(_simplify)
        b = (bal.projection.T * bal.j_before).applyfunc(_simplify)
        u_after = a.LUsolve(b * sm.Matrix(u_before))
        # Small impact maps simplify to the textbook forms (cos(2 alpha) omega, cos(phi0)/beta
        # omega): the angle differences collapse only under trigsimp.
        rates = tuple(_tidy(_simplify(e)) for e in u_after)
    else:
        # Several coordinates: Cramer's rule with the determinant kept as one factor (see
        # phase_dynamics), in the links' relative angles.
        a = (bal.projection.T * bal.j_after).applyfunc(_angle_sums)
        b = (bal.projection.T * bal.j_before).applyfunc(_angle_sums)
        if len(bal.q_after) > _IMPACT_EXPANDED_UP_TO:
            rates = _compact_cramer(a, (b * sm.Matrix(u_before)).applyfunc(_angle_sums))
        else:
            determinant = _angle_sums(a.det(method="berkowitz"))
            numerators = a.adjugate(method="berkowitz") * b * sm.Matrix(u_before)
            rates = tuple(_angle_sums(n) / determinant for n in numerators)
    by_coordinate = dict(zip(bal.q_after, rates))
    return coordinates, tuple(by_coordinate.get(c.q, sm.Integer(0)) for c in bal.after.coordinates)


_IMPACT_EXPANDED_UP_TO = 3
"""Coordinates after an impact up to which its map is expanded and paired into angle sums
(the three-link walkers'); a five-link walker's expanded cofactor products are more than
sympy pairs in minutes and more than Python compiles, so larger impacts keep Cramer's rule
in the balance's entries (:func:`_compact_cramer`)."""


def _compact_cramer(system: sm.Matrix, rhs: sm.Matrix) -> tuple[sm.Expr, ...]:
    """``system^-1 rhs`` by Cramer's rule formed on placeholders for the entries, which then
    go in whole (unexpanded products of them, each computed once by the code generator),
    as a larger phase's accelerations are (:func:`phase_dynamics`)."""
    slots, rhs_slots, determinant, _, numerators = _placeholder_cramer(system.rows)
    entries = dict(zip(slots, system)) | dict(zip(rhs_slots, rhs))
    determinant = determinant.xreplace(entries)
    return tuple(n.xreplace(entries) / determinant for n in numerators)


@functools.cache
def _placeholder_cramer(
    size: int,
) -> tuple[sm.Matrix, sm.Matrix, sm.Expr, sm.Matrix, tuple[sm.Expr, ...]]:
    """Cramer's rule of a ``size`` x ``size`` system on placeholders: the matrix's and the
    right-hand side's, the determinant, the adjugate and the adjugate times the right-hand
    side. Formed once for every phase and impact of that size (Berkowitz's determinant of
    five-by-five placeholders was a fifth of a five-link walker's derivation); the
    placeholders are replaced by each system's entries."""
    slots = sm.Matrix(size, size, lambda i, j: sm.Dummy(f"M{i}{j}"))
    rhs_slots = sm.Matrix(size, 1, lambda i, _: sm.Dummy(f"f{i}"))
    adjugate = slots.adjugate(method="berkowitz")
    return (slots, rhs_slots, slots.det(method="berkowitz"), adjugate,
            tuple(adjugate * rhs_slots))  # fmt: skip


def held_impulse_at_impact(model: Model, event_name: str, held: sm.Symbol
                           ) -> tuple[tuple[sm.Expr, ...], sm.Expr]:  # fmt: skip
    """An impulse along a coordinate the source phase holds (a rigid leg's length), applied
    with the impact: the push-off of a trailing leg whose foot the impact releases
    (:attr:`Impulse.at_impact`). Over the instant the held coordinate is free: the impulse
    ``iota`` changes the rates of (q, h) by ``M_ext^-1 e_h iota`` (``M_ext`` the mass
    matrix with ``h`` free), and the impact's balance takes the bodies' velocities then.
    Returns the rates after the impact per unit impulse (the phase after's coordinates in
    the model's state order) and ``c``, the impulse's work being ``c iota^2 / 2`` (its
    mean ``h`` rate, 0 before it, times ``iota``)."""
    bal = _impact_balance(model, event_name)
    before = bal.before
    if held not in before.held:
        raise ValueError(f"event {event_name}: an impulse at the impact acts along a coordinate "
                         f"{before.name} holds, not {held}")  # fmt: skip
    values = {h: sm.sympify(v) for h, v in before.held.items()}
    # Its rate just before is zero only where its held value is a constant of the chart.
    if values[held].free_symbols & set(bal.q_before):
        raise ValueError(f"event {event_name}: {held} is held at a value that moves with "
                         f"{before.name}'s coordinates: an impulse at the impact along it is "
                         "not derived")  # fmt: skip
    if _held_in_state(model, bal.after):
        raise ValueError(f"event {event_name}: {bal.after.name} holds a state coordinate: an "
                         "impulse at the impact is not derived there")  # fmt: skip
    # Only the pushed coordinate is freed: the others keep following their held values
    # (a torso held at an angle moves with the legs) before the derivatives are taken.
    others = {h: v for h, v in values.items() if h != held}
    free = [tuple(sm.sympify(c).xreplace(others) for c in p)
            for p in _positions(before, held=False)]  # fmt: skip
    coords = [*bal.q_before, held]
    j_ext = _impact_jacobian([free[k] for k in bal.order], coords, before, bal.order,
                             angle_values=others).xreplace(values)  # fmt: skip
    # With the pushed coordinate held again, the chart is the phase's own.
    gaps = list(j_ext[:, :-1] - bal.j_before)
    symbols = sorted(set().union(*(sm.sympify(g).free_symbols for g in gaps)), key=str)
    _numeric_check(gaps, symbols, f"{event_name}: the chart freed for the impulse")
    m_ext = (j_ext.T * j_ext).applyfunc(_simplify)
    # The rates of (q, h) per unit impulse, M_ext^-1 e_h, are the adjugate's last column
    # over the determinant, and the balance's a^-1 likewise: each polynomial is simplified
    # on its own and the two determinants divide once at the end (_cramer_fraction).
    m_det = _simplify(m_ext.det(method="berkowitz"))
    m_column = m_ext.adjugate(method="berkowitz")[:, -1].applyfunc(_simplify)
    work = _simplify(m_column[-1] / m_det)
    a = (bal.projection.T * bal.j_after).applyfunc(_simplify)
    b_ext = (bal.projection.T * j_ext).applyfunc(_simplify)
    a_det = _simplify(a.det(method="berkowitz"))
    numerators = (a.adjugate(method="berkowitz") * b_ext * m_column).applyfunc(_simplify)
    gains = [_tidy(_cramer_fraction(n, (a_det, m_det))) for n in numerators]
    by_coordinate = dict(zip(bal.q_after, gains))
    per_state = tuple(by_coordinate.get(c.q, sm.Integer(0)) for c in model.coordinates)
    return per_state, work


def _cramer_fraction(numerator: sm.Expr, determinants: Iterable[sm.Expr]) -> sm.Expr:
    """``numerator`` over the product of ``determinants`` (polynomials, each simplified by
    :func:`_simplify`), their common monomial factors cancelled and the rest left as
    factors.

    A solve whose right-hand side holds another solve's fractions (``LUsolve`` after
    ``LUsolve``) nests one denominator in the other's numerator; expanding that nest before
    cancelling it multiplies out every term of one by every term of the other, which takes
    minutes for a two-link impact with an impulse. Cramer's rule in polynomials keeps the
    numerator and each determinant a polynomial. Cancelling the whole quotient (``cancel``)
    would expand the product of the determinants into a larger expression than these
    factors, at a second's cost; the code generator computes each factor once."""
    denominator = sm.Mul(*(sm.factor_terms(d) for d in determinants))
    return sm.factor_terms(numerator) / denominator


def impact_body_order(model: Model, event_name: str) -> tuple[int, ...]:
    """For each body of an impact's phase after, the index of the same body in the phase
    before (the legs swap roles; :attr:`Impact.bodies`)."""
    event = next(e for e in model.events if e.name == event_name)
    before, after = model.phase(event.source), model.phase(event.target)
    index = {b.name: k for k, b in enumerate(before.bodies)}
    order = []
    for body in after.bodies:
        name = event.reset.bodies.get(body.name, body.name)
        if name not in index:
            raise ValueError(f"{event.name}: body {body.name} of {after.name} is no body of "
                             f"{before.name} (name it in Impact.bodies)")  # fmt: skip
        order.append(index[name])
    if sorted(order) != list(range(len(before.bodies))):
        raise ValueError(f"{event.name}: Impact.bodies must pair the bodies one to one")
    return tuple(order)


@functools.cache
def jump_reset(model: Model, event_name: str) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """Coordinates and rates just after an instantaneous actuation (held coordinates jump)."""
    event = next(e for e in model.events if e.name == event_name)
    if not isinstance(event.reset, Jump):
        raise TypeError(f"{event.name} is not a jump")
    before, after = model.phase(event.source), model.phase(event.target)
    if [c.q for c in before.coordinates] != [c.q for c in after.coordinates]:
        raise ValueError(f"{event.name}: a jump keeps the free coordinates")
    dyn = phase_dynamics(before)
    free = [c.q for c in before.coordinates]
    u_before = [c.u for c in before.coordinates]
    u_new = [sm.Symbol(f"{c.rate}_after", real=True) for c in before.coordinates]

    def state(phase: Phase, rates: list[sm.Symbol]) -> dict:
        values = {h: sm.sympify(v) for h, v in phase.held.items()}
        # Held coordinates are at rest just before and just after the jump.
        values.update({_rate_symbol(h): 0 for h in phase.held})
        values.update(dict(zip(u_before, rates)))
        return values

    balance = [
        dyn.momenta[q].xreplace(state(after, u_new))
        - dyn.momenta[q].xreplace(state(before, u_before))
        for q in free
    ]
    # Linear in the rates after: Cramer's rule, as the impacts are solved (the same
    # fractions as sympy's solve gave, byte for byte in generated/). The determinant is
    # simplified to a canonical polynomial, so zero means singular.
    system, rhs = sm.linear_eq_to_matrix(balance, u_new)
    determinant = _simplify(system.det(method="berkowitz"))
    if determinant == 0:
        raise ValueError(f"{event.name}: the momentum balance has no unique solution")
    numerators = system.adjugate(method="berkowitz") * rhs
    turn = _jump_turn(event.name, dyn, before, after) if event.reset.limit else {}
    return (
        tuple(q + turn.get(q, 0) for q in free),
        tuple(_simplify(n / determinant) for n in numerators),
    )


def _jump_turn(
    name: str, dyn: PhaseDynamics, before: Phase, after: Phase
) -> dict[sm.Symbol, sm.Expr]:
    """How far the free coordinates turn in the limit of a fast jump (:class:`Jump`
    ``limit``): ``dq = -M_qq^-1 M_qh dh`` integrated along the held coordinate's path."""
    moved, inertia, coupling = _fast_jump_blocks(name, dyn, before, after)
    if coupling == 0:
        return {}
    start, end = sm.sympify(before.held[moved]), sm.sympify(after.held[moved])
    return {before.coordinates[0].q: -coupling * _reciprocal_integral(name, inertia, start, end)}


def _fast_jump_blocks(
    name: str, dyn: PhaseDynamics, before: Phase, after: Phase
) -> tuple[sm.Symbol, sm.Poly, sm.Expr]:
    """The moving held coordinate ``h``, the free coordinate's inertia ``M_qq`` as a
    polynomial in ``h`` and its coupling ``M_qh``, with the other held coordinates at their
    values; refused (one line each) where the limit does not exist or is not integrated
    here: the kinetic energy depending on the free coordinates, another held coordinate
    following them, several free coordinates or held coordinates moving, an inertia not
    quadratic in ``h`` or a coupling that varies along it."""
    free = [c.q for c in before.coordinates]
    moving = _jumping(before, after)
    if len(moving) != 1 or set(before.held) != set(after.held):
        raise ValueError(f"{name}: a jump's limit needs both phases to hold the same "
                         "coordinates, exactly one of which changes")  # fmt: skip
    moved = moving[0]
    held = {h: sm.sympify(v) for h, v in before.held.items() if h != moved}
    if any(v.free_symbols & set(free) for v in held.values()):
        raise ValueError(f"{name}: a jump's limit needs the other held coordinates constant")
    # The mass matrix's blocks in the free coordinates and the moving one, the others held.
    momenta = [tr10i(_simplify(dyn.momenta[q].xreplace(held))) for q in (*free, moved)]
    rates = [c.u for c in before.coordinates] + [_rate_symbol(moved)]
    blocks = [p.diff(u) for p in momenta for u in rates]
    if any(_simplify(tr10i(m.diff(q))) != 0 for m in blocks for q in free):
        raise ValueError(f"{name}: the kinetic energy depends on the free coordinates, so a "
                         "fast jump has no limit the engine can derive (Jump(limit=False) "
                         "keeps them, as an idealisation the model must state)")  # fmt: skip
    if len(free) != 1:
        raise ValueError(f"{name}: the engine integrates a jump's turn for one free coordinate")
    inertia = sm.Poly(_simplify(momenta[0].diff(rates[0])), moved)
    coupling = _simplify(momenta[0].diff(rates[1]))
    if inertia.degree() != 2 or moved in coupling.free_symbols:
        raise ValueError(f"{name}: the engine integrates a jump's turn where the inertia is "
                         "quadratic in the held coordinate and the coupling constant")  # fmt: skip
    return moved, inertia, coupling


def _reciprocal_integral(name: str, inertia: sm.Poly, start: sm.Expr, end: sm.Expr) -> sm.Expr:
    """``integral of dh / (a h^2 + b h + c)`` from ``start`` to ``end``:
    ``2 / sqrt(D) (atan((2 a end + b) / sqrt(D)) - atan((2 a start + b) / sqrt(D)))`` with
    ``D = 4 a c - b^2 > 0`` (an inertia is positive at every length; checked at random
    points: a sampled check, not a proof; the caught biped's is
    ``4 mu b^2 (2 + mu (1 - cos phi0)(3 + cos phi0))``). sympy's ``integrate`` gave a
    wrong zero and then complex logarithms for it; a 16-node Gauss-Legendre rule was off by
    4e-5 where heavy legs bring the poles near the path."""
    a, b, c = inertia.all_coeffs()
    discriminant = _simplify(4 * a * c - b**2)
    rng = random.Random(20261203)
    for _ in range(8):
        point = {s: rng.uniform(0.05, 3.0) for s in discriminant.free_symbols}
        if not float(discriminant.xreplace(point)) > 0:
            raise ValueError(f"{name}: the inertia {inertia.as_expr()} has a real root, "
                             "so the turn's integral is not the arctangent's")  # fmt: skip
    root = sm.sqrt(discriminant)
    x_start, x_end = ((2 * a * h + b) / root for h in (start, end))
    # atan(x_end) - atan(x_start) as one angle, the argument of (1 + i x_end)(1 - i x_start):
    # the difference of two close arctangents would lose digits for a short extension.
    return 2 / root * sm.atan2(2 * a * (end - start) / root, 1 + x_end * x_start)


def _held_state(phase: Phase, free_rates: dict[sm.Symbol, sm.Expr]) -> dict:
    """The chart's held coordinates at their values and their rates by the chain rule
    (as :func:`phase_dynamics`' momenta name them), from the free coordinates' rates."""
    values = {}
    for h, value in phase.held.items():
        value = sm.sympify(value)
        values[h] = value
        values[_rate_symbol(h)] = chain_rate(
            value, ((c.q, free_rates[c.u]) for c in phase.coordinates)
        )
    return values


@functools.cache
def lock_reset(model: Model, event_name: str) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """Coordinates and rates just after a joint locks (:class:`Lock`): the generalised
    momenta of the phase after's free coordinates are conserved, taken in the phase
    before's chart (where the locked coordinate is still free) on the guard's surface."""
    event = next(e for e in model.events if e.name == event_name)
    if not isinstance(event.reset, Lock):
        raise TypeError(f"{event.name} is not a lock")
    before, after = model.phase(event.source), model.phase(event.target)
    free_before = [c.q for c in before.coordinates]
    free_after = [c.q for c in after.coordinates]
    locked = [q for q in free_before if q not in free_after]
    if not locked or not set(free_after) <= set(free_before):
        raise ValueError(f"{event.name}: a lock stops some of the phase before's free "
                         "coordinates and frees none")  # fmt: skip
    if any(q not in after.held for q in locked):
        raise ValueError(f"{event.name}: the phase after must hold every locked coordinate")
    surface = {q: sm.sympify(after.held[q]) for q in locked}
    # The lock happens where the joint reaches its stop: the guard vanishes there, so the
    # configuration the phase after holds is the one the walker is in.
    guard = sm.sympify(event.guard).xreplace(dict(before.held)).xreplace(surface)
    if guard != 0:
        _numeric_check([guard], sorted(guard.free_symbols, key=str),
                       f"{event.name}: the guard where the phase after holds the lock")  # fmt: skip
    momenta = phase_dynamics(before).momenta
    u_before = {c.u: c.u for c in before.coordinates}
    u_new = {c.u: sm.Symbol(f"{c.rate}_after", real=True) for c in after.coordinates}
    # After the lock the held coordinates move with their values (at rest for constants).
    rates_after = dict(u_new)
    for q in locked:
        rate = chain_rate(surface[q], ((c.q, u_new[c.u]) for c in after.coordinates))
        rates_after[next(c.u for c in before.coordinates if c.q == q)] = rate
    state_before = {**_held_state(before, u_before), **surface}
    state_after = {**_held_state(before, rates_after), **rates_after, **surface}
    balance = [
        momenta[q].xreplace(state_after).xreplace(surface)
        - momenta[q].xreplace(state_before).xreplace(surface)
        for q in free_after
    ]
    system, rhs = sm.linear_eq_to_matrix(balance, list(u_new.values()))
    system = system.applyfunc(_angle_sums)
    rhs = rhs.applyfunc(_angle_sums)
    determinant = _angle_sums(system.det(method="berkowitz"))
    numerators = system.adjugate(method="berkowitz") * rhs
    rates = tuple(_angle_sums(n) / determinant for n in numerators)
    return tuple(free_after), rates


@functools.cache
def continuous_reset(
    model: Model, event_name: str
) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """The state just after a :class:`Continuous` event: the state just before, once the
    held coordinates of both phases are shown to agree in value and rate at ``at``."""
    event = next(e for e in model.events if e.name == event_name)
    if not isinstance(event.reset, Continuous):
        raise TypeError(f"{event.name} is not continuous")
    before, after = model.phase(event.source), model.phase(event.target)
    free = [c.q for c in before.coordinates]
    if free != [c.q for c in after.coordinates]:
        raise ValueError(f"{event.name}: a continuous transition keeps the free coordinates")
    if set(before.held) != set(after.held):
        raise ValueError(f"{event.name}: both phases must hold the same coordinates")
    # `at` is the value of the one free coordinate the guard depends on (the stance angle
    # where a leg-length profile starts or ends); the others are anywhere.
    on = [q for q in free if q in sm.sympify(event.guard).free_symbols]
    if event.at is None or len(on) != 1:
        raise ValueError(f"{event.name}: a continuous transition needs `at` and a guard of "
                         "one coordinate")  # fmt: skip
    at = {on[0]: sm.sympify(event.at)}
    gaps = []
    for h in before.held:
        v_before, v_after = sm.sympify(before.held[h]), sm.sympify(after.held[h])
        gaps.append((v_before - v_after).xreplace(at))
        gaps.extend((v_before.diff(q) - v_after.diff(q)).xreplace(at) for q in free)
    gaps = [g for g in gaps if g != 0]
    if gaps:
        symbols = sorted(set().union(*(g.free_symbols for g in gaps)), key=str)
        _numeric_check(gaps, symbols, f"{event.name}: held values and rates at {event.at}")
    return tuple(free), tuple(c.u for c in before.coordinates)


def reset(model: Model, event_name: str) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    event = next(e for e in model.events if e.name == event_name)
    if isinstance(event.reset, Impact):
        return impact_reset(model, event_name)
    if isinstance(event.reset, Continuous):
        return continuous_reset(model, event_name)
    if isinstance(event.reset, Lock):
        return lock_reset(model, event_name)
    return jump_reset(model, event_name)


def check_event_angle(model: Model, event_name: str) -> None:
    """The guard of an event with ``at`` vanishes there (``Event.at`` is a stated fact)."""
    event = next(e for e in model.events if e.name == event_name)
    if event.at is None or len(model.coordinates) != 1:
        return
    held = {h: sm.sympify(v) for h, v in model.phase(event.source).held.items()}
    guard = sm.sympify(event.guard).xreplace(held)
    value = guard.xreplace({model.coordinates[0].q: sm.sympify(event.at)})
    if value.free_symbols & {c.u for c in model.coordinates}:
        raise ValueError(f"{event.name}: `at` needs a guard of the configuration only")
    if value != 0:
        symbols = sorted(value.free_symbols, key=str)
        _numeric_check([value], symbols, f"{event.name}: the guard at {event.at}")


@dataclass(frozen=True)
class StrideForm:
    """The closed-form stride map ``q' = slope q + offset`` in ``q = rate**2``."""

    slope: sm.Expr
    offset: sm.Expr
    section_angle: sm.Expr  # the coordinate just after the step event

    @property
    def fixed_point(self) -> sm.Expr:
        return self.offset / (1 - self.slope)


_SMALL = 200
"""Expressions up to this many operations get :func:`sympy.simplify`; larger ones (a
prescribed polynomial profile integrated against gravity) would take minutes in it."""


def _tidy(expr: sm.Expr) -> sm.Expr:
    return sm.simplify(expr) if sm.count_ops(expr) <= _SMALL else expr


def integrate_polynomial_trig(expr: sm.Expr, s: sm.Symbol, low: sm.Expr, high: sm.Expr):
    """``int_low^high expr ds`` for ``expr = sum_k p_k(s) f_k(a_k s + b_k)`` with polynomials
    ``p_k``, ``f_k`` in {sin, cos, 1} and ``a_k`` free of ``s``, by repeated integration by
    parts (``int p sin u = -cos u sum_j (-1)**j p^(2j) / a**(2j+1) + sin u sum_j (-1)**j
    p^(2j+1) / a**(2j+2)``); None for any other integrand. Seconds faster than
    :func:`sympy.integrate` on a degree-9 polynomial with symbolic coefficients.
    """
    groups: dict[sm.Expr, list[sm.Expr]] = {}
    for term in sm.Add.make_args(expand(expr)):
        trig = [f for f in sm.Mul.make_args(term) if isinstance(f, (sm.sin, sm.cos)) and f.has(s)]
        if len(trig) > 1:
            return None
        key = trig[0] if trig else sm.Integer(1)
        rest = term / key
        if not rest.is_polynomial(s):
            return None
        groups.setdefault(key, []).append(rest)
    antiderivative = sm.Integer(0)
    for key, terms in sorted(groups.items(), key=lambda kv: sm.default_sort_key(kv[0])):
        # One sum of the group's terms (adding them one by one rebuilt it for each term).
        poly = sm.Poly(sm.Add(*terms), s)
        if key == 1:
            antiderivative += poly.integrate().as_expr()
            continue
        argument = key.args[0]
        slope = argument.diff(s)
        if slope.has(s) or slope == 0:
            return None
        derivatives = [poly]
        while not derivatives[-1].is_zero:
            derivatives.append(derivatives[-1].diff(s))
        even = sum((sm.Integer(-1) ** (k // 2) * d.as_expr() / slope ** (k + 1)
                    for k, d in enumerate(derivatives) if k % 2 == 0), sm.Integer(0))  # fmt: skip
        odd = sum((sm.Integer(-1) ** (k // 2) * d.as_expr() / slope ** (k + 1)
                   for k, d in enumerate(derivatives) if k % 2 == 1), sm.Integer(0))  # fmt: skip
        if isinstance(key, sm.sin):
            antiderivative += -sm.cos(argument) * even + sm.sin(argument) * odd
        else:
            antiderivative += sm.sin(argument) * even + sm.cos(argument) * odd
    return antiderivative.xreplace({s: high}) - antiderivative.xreplace({s: low})


def phase_rate_map(
    phase: Phase, angle_from: sm.Expr, rate_squared_from: sm.Expr, angle_to: sm.Expr
) -> sm.Expr | None:
    """``rate**2`` at ``angle_to`` along a one-coordinate phase started at ``angle_from``.

    With ``theta'' = A(theta) + B(theta) theta'**2`` (Lagrange's equations are quadratic in
    the rates), ``u = theta'**2`` obeys ``du/dtheta = 2 A + 2 B u``; with the integrating
    factor ``mu = exp(-int 2 B)``: ``u(to) = (mu(from) u(from) + int 2 A mu) / mu(to)``.
    None when the phase has more coordinates or the integrals are not elementary.
    """
    if len(phase.coordinates) != 1:
        return None
    theta, omega = phase.coordinates[0].q, phase.coordinates[0].u
    w = sm.Symbol("w", positive=True)
    acc = phase_dynamics(phase).accelerations[0].xreplace({omega: sm.sqrt(w)})
    small = sm.count_ops(acc) <= _SMALL
    slope_b = expand(acc.diff(w)) if small else acc.diff(w)
    if slope_b.has(w) or slope_b.has(omega):
        return None
    a_part = expand(acc - slope_b * w) if small else acc.xreplace({w: 0})
    s = sm.Dummy("s", real=True)
    if slope_b == 0:  # a leg of constant length: the energy integral
        integral = sm.integrate((2 * a_part).xreplace({theta: s}), (s, angle_from, angle_to))
        return expand(rate_squared_from + integral)
    # A logarithmic derivative c D'/D (a held profile D) integrates to c log D; sympy's
    # integrate finds it too, in seconds rather than milliseconds.
    numerator, denominator = sm.fraction(sm.cancel(2 * slope_b))
    ratio = sm.cancel(numerator / denominator.diff(theta))
    if ratio.has(theta):
        antiderivative = sm.integrate(2 * slope_b, theta)
    else:
        antiderivative = ratio * sm.log(denominator)
    if antiderivative.has(sm.Integral):
        return None
    # exp(k log P) evaluates to P**k: mu is a power of the profile.
    start = antiderivative.xreplace({theta: angle_from})
    mu = sm.factor(sm.exp(-antiderivative) * sm.exp(start))
    integrand = sm.factor(2 * a_part * mu).xreplace({theta: s})
    integral = integrate_polynomial_trig(integrand, s, angle_from, angle_to)
    if integral is None:
        integral = sm.integrate(integrand, (s, angle_from, angle_to))
    if integral.has(sm.Integral):
        return None
    return _tidy((rate_squared_from + integral) / sm.factor(mu.xreplace({theta: angle_to})))


@functools.cache
def stride_closed_form(model: Model) -> StrideForm | None:
    """The stride map in closed form, when the model has one free coordinate, every event
    sits at a fixed angle (``Event.at``) and every reset scales the rate by a factor.

    Along a phase ``theta'' = A + B theta'**2``, so ``w = theta'**2`` obeys
    ``dw/dtheta = 2 A + 2 B w``: with the integrating factor ``mu = exp(-int 2 B)``,
    ``w mu`` changes by ``int 2 A mu`` from the phase's first angle to its last. Where the
    phase holds a coordinate on a profile (``B != 0``) the antiderivative of ``2 B`` is a
    logarithm, so ``mu`` is a power of the profile; the integrand is factored first so the
    profile cancels before sympy integrates it.
    """
    if len(model.coordinates) != 1 or any(e.at is None for e in model.events):
        return None
    theta, omega = model.coordinates[0].q, model.coordinates[0].u
    by_source = {e.source: e for e in model.events}
    step_event = next(e for e in model.events if e.ends_step)
    for event in model.events:
        check_event_angle(model, event.name)
    q = sm.Symbol("q", nonnegative=True)
    angle = reset(model, step_event.name)[0][0].xreplace({theta: step_event.at})
    u = q
    phase = model.phase(step_event.target)
    for _ in range(len(model.phases) + 1):
        event = by_source[phase.name]
        end = sm.sympify(event.at)
        u = phase_rate_map(phase, angle, u, end)
        if u is None:
            return None
        # The reset scales the rate: u -> factor**2 u.
        coords_after, rates_after = reset(model, event.name)
        factor = sm.cancel(rates_after[0].xreplace({theta: end}) / omega)
        if factor.has(omega):
            return None
        u = expand(factor**2 * u) if sm.count_ops(u) <= _SMALL else factor**2 * u
        angle = coords_after[0].xreplace({theta: end})
        if event.ends_step:
            break
        phase = model.phase(event.target)
    if sm.count_ops(u) <= _SMALL:
        u = expand(u)
        if u.diff(q, 2) != 0:
            return None
        return StrideForm(sm.factor(u.diff(q)), u.xreplace({q: 0}), angle)
    slope = u.diff(q)
    if slope.has(q):  # each phase and reset maps u affinely: only the slope can fail
        return None
    return StrideForm(_tidy(slope), _tidy(u.xreplace({q: 0})), angle)


def _state_args(model: Model) -> tuple[sm.Symbol, ...]:
    return (
        *model.parameter_symbols,
        *(c.q for c in model.coordinates),
        *(c.u for c in model.coordinates),
    )


def _held_in_state(model: Model, phase: Phase) -> list[sm.Symbol]:
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


def _state_accelerations(model: Model, phase: Phase, dyn: PhaseDynamics) -> tuple:
    """Second derivatives of every state coordinate in a phase: the free ones' from the
    equations of motion, a held one's from its value by the chain rule."""
    if not _held_in_state(model, phase):
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


def _input_quantities(model: Model, phase: Phase, dyn: PhaseDynamics, args: tuple) -> list:
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
        # a continuous input's gain on its acceleration (_input_quantities): zero where
        # the value is a constant (a leg at its end stop).
        stand_in = dataclasses.replace(
            phase,
            inputs=tuple(Input(i.name, i.along, i.actuator, i.unit, i.bounds) for i in impulses),
        )
        try:
            dyn = phase_dynamics(stand_in)
        except ValueError as exc:
            raise type(exc)(f"event {event.name}: {exc}") from None
        for quantity in _input_quantities(model, stand_in, dyn, args):
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
    held = _held_in_state(model, after)
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


def _body_table(phase: Phase) -> tuple[tuple[sm.Expr, ...], tuple[sm.Expr, ...]]:
    """(x, y, angle) and (mass, inertia) of each body, held coordinates at their values."""
    held = dict(phase.held)
    positions: list[sm.Expr] = []
    inertias: list[sm.Expr] = []
    for body, (x, y) in zip(phase.bodies, _positions(phase)):
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


_RESET_KINDS = {Impact: "impact", Jump: "jump", Lock: "lock", Continuous: "continuous"}


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
    phases = []
    for phase in model.phases:
        dyn = phase_dynamics(phase)
        quantities.append(Quantity(
            f"{phase.name}_accelerations", args, _state_accelerations(model, phase, dyn),
            f"Second derivatives of the free coordinates in phase {phase.name}.", None,
            "tuple: d2(coordinate)/dt2 for each coordinate",
        ))  # fmt: skip
        quantities.append(Quantity(
            f"{phase.name}_energy", args, dyn.energy,
            f"Mechanical energy T + V in phase {phase.name}.", None, "energy",
        ))  # fmt: skip
        quantities.append(Quantity(
            f"{phase.name}_normal_force", args, dyn.normal_force,
            f"Ground reaction on the stance foot along the ground normal in phase {phase.name}.",
            None, "normal force (the foot lifts off below 0)",
        ))  # fmt: skip
        failures, start_failures = [], []
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
        conditions = []
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
        positions, inertias = _body_table(phase)
        quantities.append(Quantity(
            f"{phase.name}_positions", args, positions,
            f"Position (x, y) and angle of each body in phase {phase.name}'s chart.", None,
            "tuple: x, y, angle of each body in order (angle 0 for a point mass)",
        ))  # fmt: skip
        quantities.append(Quantity(
            f"{phase.name}_inertias", args, inertias,
            f"Mass and central moment of inertia of each body in phase {phase.name}.", None,
            "tuple: mass, inertia of each body in order (inertia 0 for a point mass)",
        ))  # fmt: skip
        skeleton, skeleton_xy = _skeleton(model, phase, args)
        quantities.append(Quantity(
            f"{phase.name}_skeleton", args, skeleton_xy,
            f"Position (x, y) of each point of the drawing in phase {phase.name}'s chart.",
            None, "tuple: x, y of each point in the order of HYBRID's phase 'skeleton'",
        ))  # fmt: skip
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
        free = {c.q for c in phase.coordinates}
        # A held coordinate that follows the free ones moves, and its actuator does work.
        moving = [h for h, v in phase.held.items() if sm.sympify(v).free_symbols & free]
        conservative = not moving
        record = {
            "name": phase.name, "failures": tuple(failures), "conservative": conservative,
        }  # fmt: skip
        record["skeleton"] = drawing
        if start_failures:  # checked where the phase begins, not watched through it
            record["start_failures"] = tuple(start_failures)
        if moving:
            # The power of each moving held coordinate's actuator: its generalised force
            # times the held value's rate (chain rule), what the energy ledger integrates.
            powers = tuple(
                dyn.actuator_forces[h]
                * chain_rate(sm.sympify(phase.held[h]), ((c.q, c.u) for c in phase.coordinates))
                for h in moving
            )
            quantities.append(Quantity(
                f"{phase.name}_actuator_power", args, powers,
                f"Power of each actuator holding a moving coordinate in phase {phase.name} "
                f"({', '.join(h.name for h in moving)}): generalised force times rate.", None,
                "tuple: power of each actuator, in the order of HYBRID's phase 'actuators'",
            ))  # fmt: skip
            record["actuators"] = tuple(h.name for h in moving)
        if conditions:
            record["conditions"] = tuple(conditions)
        if phase.inputs:
            quantities += _input_quantities(model, phase, dyn, args)
            record["inputs"] = tuple(
                {"name": i.name, "actuator": i.actuator, "along": str(i.along), "unit": i.unit,
                 "bounds": tuple(i.bounds), "description": i.description}
                for i in phase.inputs
            )  # fmt: skip
        phases.append(record)
    events = []
    for event in model.events:
        # Guards are stated in the source phase's chart: its held coordinates at their values.
        held = {h: sm.sympify(v) for h, v in model.phase(event.source).held.items()}
        coords_after, rates_after = _state_after(model, event)
        quantities.append(Quantity(
            f"event_{event.name}_guard", args, sm.sympify(event.guard).xreplace(held),
            f"Guard of the event {event.name}: crosses zero when it happens.", None, "guard",
        ))  # fmt: skip
        quantities.append(Quantity(
            f"event_{event.name}_reset", args, (*coords_after, *rates_after),
            f"State just after the event {event.name} (from the state just before).",
            event.equation, "tuple: coordinates, then rates",
        ))  # fmt: skip
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
        events.append({
            "name": event.name, "source": event.source, "target": event.target,
            "direction": event.direction, "ends_step": event.ends_step, "when": when,
            "reset": _RESET_KINDS[type(event.reset)],
            # Impacts: for each body after, the index of the same body before.
            "bodies": impact_body_order(model, event.name)
            if isinstance(event.reset, Impact) else None,
            **({"actuated": _actuated(model, event)}
               if isinstance(event.reset, (Jump, Lock)) else {}),
            **({"impulses": impulse_records} if impulse_records else {}),
        })  # fmt: skip
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
    # On a slope gravity is (g sin gamma, -g cos gamma) in the chart: its size is g.
    weight = sm.sqrt(sm.trigsimp(gx**2 + gy**2)) * sm.Add(*(b.mass for b in step_phase.bodies))
    quantities.append(Quantity(
        "weight", args, sm.simplify(weight),
        "The walker's weight: gravity times the mass of every body (the cost of transport's "
        "scale; it depends on the parameters only).", None, "force",
    ))  # fmt: skip
    unknown = set(model.chosen_parameters) - {q.name for q in model.parameters}
    if unknown:
        raise ValueError(f"{model.name}: chosen parameters that are not parameters: "
                         f"{sorted(unknown)}")  # fmt: skip
    condition_records = []
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
        condition_records.append({"function": name, "reason": condition.reason,
                                  "strict": condition.strict, "parameters": involved})  # fmt: skip
    if model.section:
        state_symbols = {c.name: c.q for c in model.coordinates}
        state_symbols.update({c.rate: c.u for c in model.coordinates})
        unknown = set(model.section) - set(state_symbols)
        if unknown:
            raise ValueError(f"{model.name}: section names {sorted(unknown)} are not its state")
        completed = tuple(
            sm.sympify(model.section.get(name, symbol)) for name, symbol in state_symbols.items()
        )
        quantities.append(Quantity(
            "section_completion", args, completed,
            "The section state with the components the section determines recomputed from "
            "the others (the step event's geometry and reset).", None,
            "tuple: coordinates, then rates",
        ))  # fmt: skip
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
    names = [s["name"] for s in state]
    unknown = (set(model.search) | set(model.section)) - set(names)
    if unknown:
        raise ValueError(f"{model.name}: search/section names {sorted(unknown)} are not its state")
    free = [n for n in names if n not in model.section]
    if sorted(model.search) != sorted(free):
        raise ValueError(f"{model.name}: the search box must give exactly the section's free "
                         f"components {free}, not {sorted(model.search)}")  # fmt: skip
    descriptor = {
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
    if model.limits:
        quantities = [_in_the_limit(model, qty) for qty in quantities]
    return quantities, descriptor


def _check_actuators(model: Model) -> None:
    """A named actuator holds a coordinate some phase holds."""
    held = {h for phase in model.phases for h in phase.held}
    if not set(model.actuators) <= held:
        raise ValueError(f"{model.name}: actuators name coordinates no phase holds: "
                         f"{sorted(h.name for h in set(model.actuators) - held)}")  # fmt: skip
    if len(set(model.actuators.values())) != len(model.actuators):
        raise ValueError(f"{model.name}: two held coordinates share an actuator's name")


def _actuated(model: Model, event: Event) -> tuple[str, ...]:
    """The coordinates whose actuators act at a jump (those that jump) or a lock (those
    it stops), by name."""
    before, after = model.phase(event.source), model.phase(event.target)
    if isinstance(event.reset, Lock):
        free_after = {c.q for c in after.coordinates}
        return tuple(c.name for c in before.coordinates if c.q not in free_after)
    return tuple(h.name for h in _jumping(before, after))


def _jumping(before: Phase, after: Phase) -> list[sm.Symbol]:
    """The held coordinates whose values differ between two phases (a jump moves them)."""
    return [h for h, value in before.held.items()
            if _simplify(sm.sympify(value) - sm.sympify(after.held.get(h, 0))) != 0]  # fmt: skip


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
    gains = tuple((slope * g if slope.is_Number else _simplify(slope * g)).xreplace(held)
                  for g in normal)  # fmt: skip
    return Quantity(
        f"{name}_input_gains", args, gains,
        f"d(guard of {check.name})/d(input) in phase {phase.name}: the guard with the inputs "
        f"on is {name} + these times the inputs.", None, "tuple: one gain per input, in order",
        output_names=tuple(i.name for i in phase.inputs),
    )  # fmt: skip


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
            expr = _tidy(direct)
        return expr

    expr = quantity.expr
    expr = tuple(limit(e) for e in expr) if isinstance(expr, tuple) else limit(expr)
    return dataclasses.replace(quantity, expr=expr)
