"""What keeps the derivation cheap, checked by what it builds rather than by a clock.

The trap: one symbolic solve whose right-hand side holds another solve's fractions
(``LUsolve`` after ``LUsolve``) nests one denominator inside the other; expanding and
cancelling that nest multiplied out every term of one by every term of the other (minutes
for a two-link walker's impact with a push-off). The engine solves by Cramer's rule in
polynomials, and its one expansion refuses a large nested fraction
(:func:`derive.engine.algebra.refuse_nested_fraction`), so every derivation of the test run
(the ``rendered_tree`` fixture derives every model of the registry) checks it.
"""

from __future__ import annotations

import pytest
import sympy as sm

from derive.engine import algebra, hybrid, resets, stride
from derive.engine import dynamics as engine_dynamics
from derive.engine.hybrid import NestedFractionError
from derive.engine.model import Coordinate, Input, Phase, PointMass, RigidSegment


def _symbolic_pair():
    """The shapes of a push-off with an impact: a 2 x 2 balance, a 2 x 3 coupling and a
    3 x 3 extended mass matrix of a two-link walker's kind (masses, lengths, sines and
    cosines of the legs' angles), and a right-hand side."""
    m, m_h, a, b = sm.symbols("m m_h a b", positive=True)
    x, y = sm.symbols("x y", real=True)
    c = sm.cos(x - y)
    balance = sm.Matrix([[m_h * (a + b) ** 2 + m * a**2, m * a * b * c],
                         [m * a * b * c, m * b**2]])  # fmt: skip
    coupling = sm.Matrix([[m * (a + b) * sm.cos(x), m_h * a * sm.sin(y), m * sm.sin(x)],
                          [m * b * sm.cos(y), m_h * (a + b), m * b * sm.cos(y)]])  # fmt: skip
    extended = sm.Matrix([[m_h * (a + b) ** 2 + m * a**2, m * a * b * c, m * a * sm.sin(x - y)],
                          [m * a * b * c, m * b**2, m * b * sm.sin(y)],
                          [m * a * sm.sin(x - y), m * b * sm.sin(y), m_h + 2 * m]])  # fmt: skip
    rhs = sm.Matrix([0, 0, 1])
    return balance, coupling, extended, rhs, (m, m_h, a, b, x, y)


def test_a_solve_inside_a_solve_is_refused_before_it_is_expanded():
    balance, coupling, extended, rhs, _ = _symbolic_pair()
    nested = balance.LUsolve(coupling * extended.LUsolve(rhs))
    with pytest.raises(NestedFractionError, match="solve inside a solve"):
        hybrid.expand(nested[1])


def test_a_models_own_small_nested_ratio_is_expanded():
    a, b, c = sm.symbols("a b c", positive=True)
    ratio = c / (1 + 1 / (a + b))
    assert hybrid.expand(ratio) == sm.expand(ratio)


def test_a_model_whose_leg_length_is_a_nested_ratio_derives():
    """A small nested ratio inside a large expression is the model's own, not a solve
    inside a solve: a compound pendulum of three point masses along a leg whose length is
    ``c / (1 + 1/(a + b))`` derives (its equations hold that ratio in every term)."""
    a, b, c, m, g = sm.symbols("a b c m g", positive=True)
    theta = Coordinate("theta")
    q = theta.q
    length = c / (1 + 1 / (a + b))
    shares = {"hip": (1, 1), "leg": (2, sm.Rational(1, 2)), "foot": (3, 0)}
    bodies = tuple(
        PointMass(name, mass * m, (-share * length * sm.sin(q), share * length * sm.cos(q)))
        for name, (mass, share) in shares.items()
    )
    dynamics = hybrid.phase_dynamics(Phase("stance", (theta,), bodies, (0, -g)))
    # theta'' = g sin(theta) sum(m_k s_k) / (l sum(m_k s_k^2)): a compound pendulum.
    moment = sum(mass * share for mass, share in shares.values())
    inertia = sum(mass * share**2 for mass, share in shares.values()) * length
    wanted = g * moment / inertia * sm.sin(q)
    point = {a: 0.4, b: 0.7, c: 1.3, m: 2.0, g: 9.81, q: 0.3}
    assert float(dynamics.accelerations[0].xreplace(point)) == pytest.approx(
        float(wanted.xreplace(point)), rel=1e-12
    )


def test_phases_share_their_passive_dynamics_by_value_and_keep_their_own_inputs():
    """Phases equal in coordinates, bodies, gravity and held values share one passive
    derivation (whatever their names and inputs); a different inertia, gravity or held
    value is a different derivation."""
    m, l, g, i_a = sm.symbols("m l g I_a", positive=True)
    theta = Coordinate("theta")
    q = theta.q
    r = sm.Symbol("r", positive=True)

    def phase(name, inertia=i_a, gravity=(0, -g), held=l, inputs=()):
        bodies = (RigidSegment("leg", m, (-r * sm.sin(q), r * sm.cos(q)), q, inertia),)
        return Phase(name, (theta,), bodies, gravity, held={r: held}, inputs=inputs)

    plain = hybrid.phase_dynamics(phase("a"))
    powered = hybrid.phase_dynamics(phase("b", inputs=(Input("ankle", q, "ankle"),)))
    assert powered.phase.name == "b" and plain.phase.name == "a"
    assert powered.accelerations == plain.accelerations
    assert powered.kinetic == plain.kinetic and powered.momenta == plain.momenta
    assert plain.input_gains == () and len(powered.input_gains) == 1
    # d(theta'')/d(torque) = 1 / (m l^2 + I_a), formed with the shared Cramer pieces.
    point = {m: 2.0, l: 0.9, g: 9.81, i_a: 0.3, q: 0.2}
    gain = float(powered.input_gains[0][0].xreplace(point))
    assert gain == pytest.approx(1 / (2.0 * 0.9**2 + 0.3), rel=1e-12)
    powered.momenta.clear()  # each phase's dicts are its own
    assert hybrid.phase_dynamics(phase("c")).momenta == plain.momenta
    for other in (phase("d", inertia=2 * i_a), phase("e", gravity=(g, -g)),
                  phase("f", held=2 * l)):  # fmt: skip
        assert hybrid.phase_dynamics(other).accelerations != plain.accelerations


def test_the_push_off_at_heelstrike_expands_nothing_large(monkeypatch):
    """The level compass gait's push-off with the impact (a solve of the impact's balance
    on the extended mass matrix's solve): every expansion stays small."""
    from derive.models.level_compass_gait import MODEL

    sizes = []
    expand = algebra.expand

    def recorded(expr):
        result = expand(expr)
        sizes.append(len(sm.Add.make_args(result)))
        return result

    for module in (algebra, engine_dynamics, stride):  # every module that expands
        monkeypatch.setattr(module, "expand", recorded)
    gains, work = hybrid.held_impulse_at_impact(MODEL, "heelstrike", sm.Symbol("r", positive=True))
    assert len(gains) == 2 and work != 0
    # The nested form expanded to tens of thousands of terms; Cramer's pieces stay near 100.
    assert sizes and max(sizes) < 1000


def test_the_fast_angle_sums_are_sympys_tr10i_term_for_term():
    """:func:`derive.engine.trig.tr10i` skips the pairs of terms ``trig_split`` cannot
    combine before it tries them: on sums of products of sines, cosines, square roots and
    symbols to powers -1, 1 and 2, its result is sympy's TR10i's."""
    import random

    from sympy.simplify.fu import TR10i

    from derive.engine.trig import tr10i

    x, y, z, a, b = sm.symbols("x y z a b", real=True)
    factors = [sm.sin(x), sm.cos(x), sm.sin(y), sm.cos(y), sm.sin(x - y), sm.cos(x - y),
               sm.sin(z), sm.cos(z), sm.sqrt(2), sm.sqrt(3), a, b]  # fmt: skip
    rng = random.Random(7)
    for _ in range(300):
        terms = []
        for _ in range(rng.randint(2, 7)):
            term = sm.Integer(rng.choice([1, -1, 2, -2, 3]))
            for _ in range(rng.randint(1, 4)):
                term *= rng.choice(factors) ** rng.choice([1, 1, 1, 2, -1])
            terms.append(term)
        expr = sm.Add(*terms)
        assert tr10i(expr) == TR10i(expr), expr


def test_models_grouped_for_a_worker_are_registered_once():
    """Each group of :data:`derive.registry.MODEL_GROUPS` (derived in turn by one worker,
    sharing a phase's dynamics) names registered models, none in two groups."""
    from derive.registry import MODEL_GROUPS, MODEL_NAMES

    grouped = [name for group in MODEL_GROUPS for name in group]
    assert len(grouped) == len(set(grouped))
    assert set(grouped) <= set(MODEL_NAMES)


def test_the_equations_of_motion_are_kanes_methods():
    """The engine forms ``M q'' = forcing`` from the bodies' Jacobians (no functions of
    time): its accelerations are those of sympy.physics.mechanics' KanesMethod on the same
    bodies (a point-mass hip and a rigid shank on a knee, the knee held at a value that
    moves with the stance angle), at random states."""
    import random

    import sympy.physics.mechanics as me

    m, m_h, l, r, i_s, g, k = sm.symbols("m m_h l r I_s g k", positive=True)
    theta, knee = Coordinate("theta"), Coordinate("knee")
    q, s = theta.q, knee.q
    bend = sm.Symbol("bend", real=True)
    hip = (-l * sm.sin(q), l * sm.cos(q))
    shank = (hip[0] + r * sm.sin(s - q + bend), hip[1] - r * sm.cos(s - q + bend))
    phase = Phase("swing", (theta, knee),
                  (PointMass("hip", m_h, hip), RigidSegment("shank", m, shank, s - q + bend, i_s)),
                  (0, -g), held={bend: k * q})  # fmt: skip
    accelerations = hybrid.phase_dynamics(phase).accelerations

    t = me.dynamicsymbols._t
    q_t, s_t = me.dynamicsymbols("q s")
    u_t, w_t = me.dynamicsymbols("u w")
    to_time = {q: q_t, s: s_t, bend: k * q_t}
    frame, origin = me.ReferenceFrame("N"), me.Point("O")
    origin.set_vel(frame, 0)
    bodies, loads = [], []
    for body in phase.bodies:
        x, y = (c.xreplace(to_time) for c in body.position)
        point = origin.locatenew(body.name, x * frame.x + y * frame.y)
        point.set_vel(
            frame, point.pos_from(origin).dt(frame).subs({q_t.diff(t): u_t, s_t.diff(t): w_t})
        )
        if isinstance(body, PointMass):
            bodies.append(me.Particle(body.name, point, body.mass))
        else:
            own = frame.orientnew("own", "Axis", (body.angle.xreplace(to_time), frame.z))
            own.set_ang_vel(frame, own.ang_vel_in(frame).subs({q_t.diff(t): u_t, s_t.diff(t): w_t}))
            bodies.append(
                me.RigidBody(
                    body.name, point, own, body.mass, (me.inertia(own, 0, 0, body.inertia), point)
                )
            )
        loads.append((point, -body.mass * g * frame.y))
    kane = me.KanesMethod(frame, [q_t, s_t], [u_t, w_t],
                          kd_eqs=[q_t.diff(t) - u_t, s_t.diff(t) - w_t])  # fmt: skip
    kane.kanes_equations(bodies, loads)
    plain = {q_t: q, s_t: s, u_t: theta.u, w_t: knee.u}
    wanted = kane.mass_matrix.xreplace(plain).LUsolve(kane.forcing.xreplace(plain))
    rng = random.Random(3)
    for _ in range(5):
        point = {v: rng.uniform(0.2, 1.5) for v in (m, m_h, l, r, i_s, g, k, q, s,
                                                    theta.u, knee.u)}  # fmt: skip
        for ours, theirs in zip(accelerations, wanted):
            assert float(ours.xreplace(point)) == pytest.approx(
                float(theirs.xreplace(point)), rel=1e-10
            )


def test_a_five_link_impact_keeps_cramers_rule_in_the_balance(monkeypatch):
    """RABBIT's heelstrike (five coordinates after the impact) is solved on the balance's
    entries, not expanded into cofactor products (which took sympy minutes and gave more
    than Python compiles): every expansion stays small, and the rates after it solve the
    momentum balance ``a u+ = b u-`` at a random state (numpy's solve of the same
    matrices)."""
    import random

    import numpy as np

    from derive.models.rabbit import MODEL

    sizes = []
    expand = algebra.expand

    def recorded(expr):
        result = expand(expr)
        sizes.append(len(sm.Add.make_args(result)))
        return result

    for module in (algebra, engine_dynamics, stride):  # every module that expands
        monkeypatch.setattr(module, "expand", recorded)
    _, rates = hybrid.impact_reset(MODEL, "heelstrike")
    assert sizes and max(sizes) < 1000
    balance = resets.impact_balance(MODEL, "heelstrike")
    a = balance.projection.T * balance.j_after
    b = balance.projection.T * balance.j_before
    u_before = [c.u for c in balance.before.coordinates]
    rng = random.Random(11)
    symbols = set().union(*(sm.sympify(r).free_symbols for r in rates), a.free_symbols,
                          b.free_symbols, u_before)  # fmt: skip
    point = {s: rng.uniform(0.2, 1.2) for s in symbols}
    a_num = np.array(a.xreplace(point).evalf(), dtype=float)
    b_num = np.array(b.xreplace(point).evalf(), dtype=float)
    wanted = np.linalg.solve(a_num, b_num @ np.array([point[u] for u in u_before]))
    by_coordinate = dict(zip([c.q for c in balance.after.coordinates], rates))
    ours = [float(by_coordinate[q].xreplace(point)) for q in balance.q_after]
    np.testing.assert_allclose(ours, wanted, rtol=1e-9)


def _random_expression(rng, symbols, depth: int) -> sm.Expr:
    """A random expression of sums (signed terms too), products, quotients, powers and
    sines over ``symbols``."""
    if depth == 0:
        return rng.choice([*symbols, sm.Rational(rng.randint(-5, 5), rng.randint(1, 4))])
    parts = [_random_expression(rng, symbols, depth - 1) for _ in range(rng.randint(2, 4))]
    kind = rng.randrange(5)
    if kind == 0:
        return sm.Add(*(p * rng.choice([1, -1, 2, sm.Rational(-1, 3)]) for p in parts))
    if kind == 1:
        return sm.Mul(*parts)
    if kind == 2:
        return parts[0] / (parts[1] + 1)
    if kind == 3:
        return parts[0] ** rng.choice([2, 3, -1, -2, sm.Rational(1, 2)])
    return sm.sin(parts[0]) - parts[1]


def test_the_operation_bound_answers_as_count_ops():
    """``within_ops`` (which stops counting a large expression's additions early) answers
    ``count_ops(expr) <= limit`` for every expression and limit."""
    import random

    rng = random.Random(3)
    symbols = sm.symbols("a b c", real=True)
    exprs = [_random_expression(rng, symbols, rng.randint(0, 4)) for _ in range(300)]
    exprs.append(sm.expand(sum(symbols, sm.Integer(1)) ** 9))
    for expr in exprs:
        count = sm.count_ops(expr)
        for limit in (0, 1, 5, 20, count - 1, count, 200):
            assert algebra.within_ops(expr, limit) == (count <= limit), expr


def test_rationals_convert_to_complex_as_sympy_converts_them():
    """The engine's ``complex`` of a Rational (sorting's key takes it for each coefficient)
    is sympy's own, bit for bit."""
    import random

    from sympy.core.expr import Expr

    from derive.engine.shortcuts import rational_complex

    rng = random.Random(5)
    numbers = [sm.Integer(10**400), sm.Rational(-1, 10**330), sm.S.Zero, sm.S.Half]
    for _ in range(2000):
        digits = rng.randint(1, 40)
        numbers.append(sm.Rational(rng.randint(-(10**digits), 10**digits),
                                   rng.randint(1, 10 ** rng.randint(1, 40))))  # fmt: skip
    for number in numbers:
        assert repr(complex(number)) == repr(Expr.__complex__(number))
        assert repr(rational_complex(number)) == repr(Expr.__complex__(number))


def test_a_products_minus_sign_is_sympys():
    """The engine's ``could_extract_minus_sign`` of a product is sympy 1.14's (which
    compares the product with its negative first), zoo and nan included."""
    import random

    from derive.engine.shortcuts import product_minus_sign

    def sympys(product):
        if product == -product:
            return False
        c = product.args[0]
        return c.is_Number and c.is_extended_negative

    rng = random.Random(9)
    symbols = sm.symbols("a b c", real=True)
    a, b = symbols[:2]
    products = [sm.Mul(sm.S.ComplexInfinity, a), sm.Mul(-2, sm.S.NaN, b, evaluate=False),
                sm.Float(-2.5) * a, sm.Float(2) * a * b, -a, sm.pi * a, -sm.pi * a]  # fmt: skip
    for _ in range(400):
        expr = _random_expression(rng, symbols, rng.randint(1, 3))
        products += [p for p in sm.preorder_traversal(expr) if type(p) is sm.Mul]
        products.append(-expr * rng.choice(symbols))
    products = [p for p in products if type(p) is sm.Mul]
    assert len(products) > 300
    for product in products:
        assert product_minus_sign(product) == sympys(product), product
        assert product.could_extract_minus_sign() == sympys(product), product


def test_the_polynomial_trig_integral_at_zero_and_with_a_polynomial_part():
    s, a, b = sm.symbols("s a b", real=True)
    integrand = s**4 + a * s * sm.sin(2 * s + a) + 3 - b * s**2 * sm.cos(s)
    ours = stride.integrate_polynomial_trig(integrand, s, 0, b)
    assert sm.simplify(ours - sm.integrate(integrand, (s, 0, b))) == 0


def test_numeric_evaluation_agrees_with_sympys():
    """:func:`derive.engine.numeric.evaluate` at 60 digits: sympy's value, intermediates
    evaluated in order; a function it does not know is refused."""
    from derive.engine.numeric import evaluate

    x, y, k = sm.symbols("x y k", real=True)
    expr = sm.sin(x) ** 2 / (1 + y) - sm.sqrt(x * y) + sm.atan2(y, x) + sm.pi / 3 - k**-3
    point = {x: 0.3, y: sm.Float("0.7", 60)}
    (value,) = evaluate([expr], point, 60, [(k, sm.cos(x) + y)])
    exact = expr.xreplace({k: sm.cos(x) + y}).xreplace({x: sm.Float(0.3, 60), y: point[y]})
    assert abs(value - exact.evalf(60)) < 1e-55
    with pytest.raises(ValueError, match="besselj"):
        evaluate([sm.besselj(0, x)], point)
    with pytest.raises(ValueError, match="Symbol"):
        evaluate([x + y + k], point)
