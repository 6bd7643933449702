"""Planar point-mass mechanics: Lagrangian, Euler-Lagrange, first integral, angular momentum.

Model-independent machinery. Coordinates are planar: x forward along level ground,
y up. A leg at angle ``theta`` from the vertical (positive when the hip is ahead of
the foot) has unit vector ``(sin theta, cos theta)`` from foot to hip.

Examples
--------
>>> import sympy as sm
>>> m, g, r = sm.symbols("m g r", positive=True)
>>> phase = pendulum_phase(m, g, r)
>>> phase.acceleration
g*sin(theta(t))/r
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sm

t = sm.Symbol("t", real=True)
"""Physical time."""


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


def euler_lagrange(lagrangian: sm.Expr, coordinate: sm.Function) -> sm.Expr:
    """Left-hand side of ``d/dt dL/dq' - dL/dq = 0`` for one generalised coordinate."""
    velocity = coordinate.diff(t)
    return sm.diff(lagrangian.diff(velocity), t) - lagrangian.diff(coordinate)


def energy_function(lagrangian: sm.Expr, coordinate: sm.Function) -> sm.Expr:
    """Jacobi energy function ``q' dL/dq' - L`` (the total energy for natural systems)."""
    velocity = coordinate.diff(t)
    return sm.expand(velocity * lagrangian.diff(velocity) - lagrangian)


@dataclass(frozen=True)
class PendulumPhase:
    """A point mass ``m`` on a massless leg of fixed length pivoting about a fixed foot.

    Attributes
    ----------
    theta : sympy.Function
        Leg angle ``theta(t)`` from the vertical.
    hip : sympy.Matrix, shape (2, 1)
        Hip position relative to the foot.
    lagrangian : sympy.Expr
        ``T - V``.
    acceleration : sympy.Expr
        ``theta''(t)`` solved from the Euler-Lagrange equation.
    energy : sympy.Expr
        First integral (Jacobi energy function) ``T + V``.
    leg_force : sympy.Expr
        Compressive force along the leg, from the radial balance of the hip mass.
    """

    theta: sm.Function
    hip: sm.Matrix
    lagrangian: sm.Expr
    acceleration: sm.Expr
    energy: sm.Expr
    leg_force: sm.Expr


def pendulum_phase(mass: sm.Expr, gravity: sm.Expr, leg_length: sm.Expr) -> PendulumPhase:
    """Derive the swing-phase dynamics of a point mass on a rigid massless leg.

    Parameters
    ----------
    mass, gravity, leg_length : sympy.Expr
        Positive scalars.

    Returns
    -------
    PendulumPhase
    """
    theta = sm.Function("theta", real=True)(t)
    hip = leg_length * leg_direction(theta)
    velocity = hip.diff(t)
    kinetic = sm.Rational(1, 2) * mass * (velocity.T * velocity)[0]
    potential = mass * gravity * hip[1]
    lagrangian = pythagorean_reduce(kinetic - potential)
    equation = euler_lagrange(lagrangian, theta)
    acceleration = sm.cancel(solve_linear(equation, theta.diff(t, 2)))
    energy = pythagorean_reduce(energy_function(lagrangian, theta))
    # Radial balance of the hip mass; the leg is massless, so its force acts along it.
    radial = leg_direction(theta)
    hip_acceleration = hip.diff(t, 2).subs(theta.diff(t, 2), acceleration)
    gravity_force = sm.Matrix([0, -mass * gravity])
    leg_force = pythagorean_reduce(((mass * hip_acceleration - gravity_force).T * radial)[0])
    return PendulumPhase(theta, hip, lagrangian, acceleration, energy, leg_force)
