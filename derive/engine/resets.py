"""What happens at an event: the resets of impacts, jumps, locks and continuous
transitions.

* :func:`impact_reset`: an inelastic impact from Lagrange's impulse equations: for every
  coordinate of the phase after, the impulses do no work on its motion,
  ``J+^T M (v+ - v-) = 0`` over the bodies (``v = J u``), since the only impulse acts at the
  new contact, which the phase after pins (:func:`impact_balance`).
* :func:`held_impulse_at_impact`: an impulse along a held coordinate applied with the
  impact.
* :func:`lock_reset`: a joint locking (a knee straightening): the lock's impulse acts on
  the coordinates the phase after holds, so the phase after's free coordinates' generalised
  momenta are conserved (``p_q(q, u-) = p_q(q, u+)`` with the held rates stopped).
* :func:`jump_reset`: an instantaneous actuation: the free coordinates' generalised momenta
  are continuous while the held coordinates jump (``M(q+) u+ = M(q-) u-`` in their rows);
  in the limit of a fast jump the free coordinates turn as well (``Jump(limit=True)``).
* :func:`continuous_reset`: the state carried over where two phases' held values agree.
"""

from __future__ import annotations

import functools
import random
import types
from collections.abc import Mapping

import sympy as sm

from derive.engine.algebra import (
    angle_sums,
    cheap_simplify,
    compact_cramer,
    cramer_fraction,
    numeric_check,
    tidy,
)
from derive.engine.dynamics import (
    PhaseDynamics,
    body_positions,
    chain_rate,
    held_in_state,
    phase_dynamics,
    rate_symbol,
)
from derive.engine.model import Continuous, Impact, Jump, Lock, Model, Phase, PointMass
from derive.engine.trig import tr10i

__all__ = [
    "check_event_angle",
    "continuous_reset",
    "held_impulse_at_impact",
    "impact_balance",
    "impact_body_order",
    "impact_reset",
    "jump_reset",
    "jumping",
    "lock_reset",
    "reset",
]


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
def impact_balance(model: Model, event_name: str) -> types.SimpleNamespace:
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
    pos_before = [body_positions(before)[k] for k in order]
    pos_after = [tuple(c.xreplace(mapping) for c in p) for p in body_positions(after)]
    # The configuration is unchanged: every body where it was, seen from the new contact.
    gaps = [pb[k] - contact[k] - pa[k] for pb, pa in zip(pos_before, pos_after) for k in range(2)]
    numeric_check(gaps, sorted(set().union(*(g.free_symbols for g in gaps)), key=str),
                   f"{event.name}: bodies after the impact")  # fmt: skip
    j_before = _impact_jacobian(pos_before, q_before, before, order)
    # A coordinate the lock holds through the impact is a constant of the phase after's
    # chart there: the Jacobian is taken with it in place.
    held_after = [tuple(c.xreplace(holding) for c in p) for p in body_positions(after)]
    j_after = _impact_jacobian(held_after, q_after, after, range(len(after.bodies)))
    j_after = j_after.xreplace(mapping)
    # The impulses do no work along the phase after's free coordinates with its held chart
    # coordinates fixed: the holding actuators' impulses act on those alone. Where a held
    # value varies with the free coordinates (a torso held at an angle from the vertical by
    # a joint on the stance leg) that direction is not the held motion's (j_after).
    projection = j_after
    if any(sm.sympify(v).free_symbols & set(q_after) for v in after.held.values()):
        frozen = [tuple(sm.sympify(c).xreplace(holding) for c in p)
                  for p in body_positions(after, held=False)]  # fmt: skip
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
    bal = impact_balance(model, event_name)
    u_before = [c.u for c in bal.before.coordinates]
    coordinates = tuple(bal.mapping[c.q] for c in bal.after.coordinates)
    if len(bal.q_after) == 1:
        a = (bal.projection.T * bal.j_after).applyfunc(cheap_simplify)
        b = (bal.projection.T * bal.j_before).applyfunc(cheap_simplify)
        u_after = a.LUsolve(b * sm.Matrix(u_before))
        # Small impact maps simplify to the textbook forms (cos(2 alpha) omega, cos(phi0)/beta
        # omega): the angle differences collapse only under trigsimp.
        rates = tuple(tidy(cheap_simplify(e)) for e in u_after)
    else:
        # Several coordinates: Cramer's rule with the determinant kept as one factor (see
        # phase_dynamics), in the links' relative angles.
        a = (bal.projection.T * bal.j_after).applyfunc(angle_sums)
        b = (bal.projection.T * bal.j_before).applyfunc(angle_sums)
        if len(bal.q_after) > _IMPACT_EXPANDED_UP_TO:
            rates = compact_cramer(a, (b * sm.Matrix(u_before)).applyfunc(angle_sums))
        else:
            determinant = angle_sums(a.det(method="berkowitz"))
            numerators = a.adjugate(method="berkowitz") * b * sm.Matrix(u_before)
            rates = tuple(angle_sums(n) / determinant for n in numerators)
    by_coordinate = dict(zip(bal.q_after, rates))
    return coordinates, tuple(by_coordinate.get(c.q, sm.Integer(0)) for c in bal.after.coordinates)


_IMPACT_EXPANDED_UP_TO = 3
"""Coordinates after an impact up to which its map is expanded and paired into angle sums
(the three-link walkers'); a five-link walker's expanded cofactor products are more than
sympy pairs in minutes and more than Python compiles, so larger impacts keep Cramer's rule
in the balance's entries (:func:`compact_cramer`)."""


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
    bal = impact_balance(model, event_name)
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
    if held_in_state(model, bal.after):
        raise ValueError(f"event {event_name}: {bal.after.name} holds a state coordinate: an "
                         "impulse at the impact is not derived there")  # fmt: skip
    # Only the pushed coordinate is freed: the others keep following their held values
    # (a torso held at an angle moves with the legs) before the derivatives are taken.
    others = {h: v for h, v in values.items() if h != held}
    free = [tuple(sm.sympify(c).xreplace(others) for c in p)
            for p in body_positions(before, held=False)]  # fmt: skip
    coords = [*bal.q_before, held]
    j_ext = _impact_jacobian([free[k] for k in bal.order], coords, before, bal.order,
                             angle_values=others).xreplace(values)  # fmt: skip
    # With the pushed coordinate held again, the chart is the phase's own.
    gaps = list(j_ext[:, :-1] - bal.j_before)
    symbols = sorted(set().union(*(sm.sympify(g).free_symbols for g in gaps)), key=str)
    numeric_check(gaps, symbols, f"{event_name}: the chart freed for the impulse")
    m_ext = (j_ext.T * j_ext).applyfunc(cheap_simplify)
    # The rates of (q, h) per unit impulse, M_ext^-1 e_h, are the adjugate's last column
    # over the determinant, and the balance's a^-1 likewise: each polynomial is simplified
    # on its own and the two determinants divide once at the end (cramer_fraction).
    m_det = cheap_simplify(m_ext.det(method="berkowitz"))
    m_column = m_ext.adjugate(method="berkowitz")[:, -1].applyfunc(cheap_simplify)
    work = cheap_simplify(m_column[-1] / m_det)
    a = (bal.projection.T * bal.j_after).applyfunc(cheap_simplify)
    b_ext = (bal.projection.T * j_ext).applyfunc(cheap_simplify)
    a_det = cheap_simplify(a.det(method="berkowitz"))
    numerators = (a.adjugate(method="berkowitz") * b_ext * m_column).applyfunc(cheap_simplify)
    gains = [tidy(cramer_fraction(n, (a_det, m_det))) for n in numerators]
    by_coordinate = dict(zip(bal.q_after, gains))
    per_state = tuple(by_coordinate.get(c.q, sm.Integer(0)) for c in model.coordinates)
    return per_state, work


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
        values.update({rate_symbol(h): 0 for h in phase.held})
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
    determinant = cheap_simplify(system.det(method="berkowitz"))
    if determinant == 0:
        raise ValueError(f"{event.name}: the momentum balance has no unique solution")
    numerators = system.adjugate(method="berkowitz") * rhs
    turn = _jump_turn(event.name, dyn, before, after) if event.reset.limit else {}
    return (
        tuple(q + turn.get(q, 0) for q in free),
        tuple(cheap_simplify(n / determinant) for n in numerators),
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
    moving = jumping(before, after)
    if len(moving) != 1 or set(before.held) != set(after.held):
        raise ValueError(f"{name}: a jump's limit needs both phases to hold the same "
                         "coordinates, exactly one of which changes")  # fmt: skip
    moved = moving[0]
    held = {h: sm.sympify(v) for h, v in before.held.items() if h != moved}
    if any(v.free_symbols & set(free) for v in held.values()):
        raise ValueError(f"{name}: a jump's limit needs the other held coordinates constant")
    # The mass matrix's blocks in the free coordinates and the moving one, the others held.
    momenta = [tr10i(cheap_simplify(dyn.momenta[q].xreplace(held))) for q in (*free, moved)]
    rates = [c.u for c in before.coordinates] + [rate_symbol(moved)]
    blocks = [p.diff(u) for p in momenta for u in rates]
    if any(cheap_simplify(tr10i(m.diff(q))) != 0 for m in blocks for q in free):
        raise ValueError(f"{name}: the kinetic energy depends on the free coordinates, so a "
                         "fast jump has no limit the engine can derive (Jump(limit=False) "
                         "keeps them, as an idealisation the model must state)")  # fmt: skip
    if len(free) != 1:
        raise ValueError(f"{name}: the engine integrates a jump's turn for one free coordinate")
    inertia = sm.Poly(cheap_simplify(momenta[0].diff(rates[0])), moved)
    coupling = cheap_simplify(momenta[0].diff(rates[1]))
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
    discriminant = cheap_simplify(4 * a * c - b**2)
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
        values[rate_symbol(h)] = chain_rate(
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
        numeric_check([guard], sorted(guard.free_symbols, key=str),
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
    system = system.applyfunc(angle_sums)
    rhs = rhs.applyfunc(angle_sums)
    determinant = angle_sums(system.det(method="berkowitz"))
    numerators = system.adjugate(method="berkowitz") * rhs
    rates = tuple(angle_sums(n) / determinant for n in numerators)
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
        numeric_check(gaps, symbols, f"{event.name}: held values and rates at {event.at}")
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
        numeric_check([value], symbols, f"{event.name}: the guard at {event.at}")


def jumping(before: Phase, after: Phase) -> list[sm.Symbol]:
    """The held coordinates whose values differ between two phases (a jump moves them)."""
    return [
        h for h, value in before.held.items()
        if cheap_simplify(sm.sympify(value) - sm.sympify(after.held.get(h, 0))) != 0
    ]  # fmt: skip
