"""Planar algebra the derivations share: leg directions, cross products, linear solves.

Model-independent helpers. Coordinates are planar: x forward along level ground, y up. A
leg at angle ``theta`` from the vertical (positive when the hip is ahead of the foot) has
unit vector ``(sin theta, cos theta)`` from foot to hip. The equations of motion of every
model come from :mod:`derive.engine.hybrid` (sympy.physics.mechanics).

Examples
--------
>>> import sympy as sm
>>> solve_linear(sm.Symbol("x") * 2 - 4, sm.Symbol("x"))
2
"""

from __future__ import annotations

import sympy as sm


def leg_direction(angle: sm.Expr) -> sm.Matrix:
    """Unit vector from foot to hip, shape (2, 1), for a leg at ``angle`` from the vertical."""
    return sm.Matrix([sm.sin(angle), sm.cos(angle)])


def cross_z(a: sm.Matrix, b: sm.Matrix) -> sm.Expr:
    """z-component of the planar cross product ``a x b`` of two (2, 1) vectors."""
    return a[0] * b[1] - a[1] * b[0]


def angular_momentum(
    mass: sm.Expr, position: sm.Matrix, velocity: sm.Matrix, about: sm.Matrix
) -> sm.Expr:
    """Angular momentum ``(position - about) x mass * velocity`` of a point mass (z-component)."""
    return sm.expand(cross_z(position - about, mass * velocity))


def solve_linear(equation: sm.Expr | sm.Equality, unknown: sm.Expr) -> sm.Expr:
    """Solve an equation that is linear in ``unknown`` (a symbol or a function term).

    Cheaper and more predictable than ``sm.solve``, which simplifies its result.

    Raises
    ------
    ValueError
        If the equation is not linear in ``unknown``.
    """
    if isinstance(equation, sm.Equality):
        equation = equation.lhs - equation.rhs
    x = sm.Dummy("x")
    expr = sm.expand(equation.subs(unknown, x))
    slope = sm.expand(sm.diff(expr, x))
    if slope == 0 or slope.has(x):
        raise ValueError(f"not linear in {unknown}: {equation}")
    return sm.expand(-expr.subs(x, 0)) / slope


def pythagorean_reduce(expr: sm.Expr) -> sm.Expr:
    """Expand trigonometric sums and replace ``sin(a)**2`` by ``1 - cos(a)**2``.

    A canonical form for polynomials in sines and cosines, much cheaper than ``trigsimp``.
    """
    expr = sm.expand(sm.expand_trig(expr))
    angles = sorted({s.args[0] for s in expr.atoms(sm.sin)}, key=sm.default_sort_key)
    return sm.expand(expr.subs({sm.sin(a) ** 2: 1 - sm.cos(a) ** 2 for a in angles}))
