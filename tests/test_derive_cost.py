"""What keeps the derivation cheap, checked by what it builds rather than by a clock.

The trap: one symbolic solve whose right-hand side holds another solve's fractions
(``LUsolve`` after ``LUsolve``) nests one denominator inside the other; expanding and
cancelling that nest multiplied out every term of one by every term of the other (minutes
for a two-link walker's impact with a push-off). The engine solves by Cramer's rule in
polynomials, and its one expansion refuses a large nested fraction
(:func:`derive.engine.hybrid.refuse_nested_fraction`), so every derivation of the test run
(the ``rendered_tree`` fixture derives every model of the registry) checks it.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sm

from derive.engine import hybrid
from derive.engine.hybrid import NestedFractionError


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


def test_cramers_rule_in_polynomials_gives_the_nested_solve_at_random_points():
    """The form the engine uses (adjugates over determinants, each a polynomial) against
    the nested solve evaluated numerically, where no expansion happens."""
    balance, coupling, extended, rhs, symbols = _symbolic_pair()
    numerators = balance.adjugate() * coupling * extended.adjugate() * rhs
    cramer = [n / (balance.det() * extended.det()) for n in numerators]
    nested = balance.LUsolve(coupling * extended.LUsolve(rhs))
    rng = np.random.default_rng(5)
    for _ in range(20):
        point = dict(zip(symbols, rng.uniform(0.2, 1.5, len(symbols))))
        for ours, theirs in zip(cramer, nested):
            value, wanted = float(ours.xreplace(point)), float(theirs.xreplace(point))
            assert value == pytest.approx(wanted, rel=1e-12)


def test_the_push_off_at_heelstrike_expands_nothing_large(monkeypatch):
    """The level compass gait's push-off with the impact (a solve of the impact's balance
    on the extended mass matrix's solve): every expansion stays small."""
    from derive.models.level_compass_gait import MODEL

    sizes = []
    expand = hybrid.expand

    def recorded(expr):
        result = expand(expr)
        sizes.append(len(sm.Add.make_args(result)))
        return result

    monkeypatch.setattr(hybrid, "expand", recorded)
    gains, work = hybrid.held_impulse_at_impact(MODEL, "heelstrike", sm.Symbol("r", positive=True))
    assert len(gains) == 2 and work != 0
    # The nested form expanded to tens of thousands of terms; Cramer's pieces stay near 100.
    assert sizes and max(sizes) < 1000
