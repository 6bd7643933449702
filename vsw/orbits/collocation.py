"""The collocation discretisation of a hybrid periodic orbit, the second discretisation of
the orbit problem beside multiple shooting (:mod:`vsw.orbits.shooting`), in two schemes:
Hermite-Simpson segments (below; the powered gaits) and Gauss-Legendre collocation of
order six (:func:`legendre_scheme`; the design's search).

A phase of the orbit lasting ``T`` is cut into ``N`` intervals of length ``h = T / N``; the
unknowns are the state at every knot and every interval's midpoint (and the inputs there,
where the flow ``f(x, u)`` has some). Per interval ``[x_i, x_{i+1}]`` with midpoint ``x_c``
the separated Hermite-Simpson form asks

    x_c = (x_i + x_{i+1}) / 2 + h / 8 (f_i - f_{i+1}),                         (1)
    x_{i+1} = x_i + h / 6 (f_i + 4 f_c + f_{i+1}),                             (2)

(1) the cubic through the knots with slopes ``f`` at its midpoint, (2) Simpson's rule on
that cubic: the scheme is fourth order (Betts, *Practical Methods for Optimal Control*,
2nd ed., 4.6). The inputs are quadratic on each interval through ``u_i``, ``u_c``,
``u_{i+1}``. The phase's guard at its last knot and its event's reset onto the next phase's
first knot close the orbit as in shooting's (2).

The exact derivative of the discrete phase map (its monodromy factor, :func:`sensitivity`):
each interval's two equations differentiated, the midpoint eliminated, ``L S_{i+1} = R S_i``
with

    L = I - h/6 A_1 - h/3 A_c + h^2/12 A_c A_1,
    R = I + h/6 A_0 + h/3 A_c + h^2/12 A_c A_0                                  (3)

(``A = df/dx`` at the knots and the midpoint, the inputs held as functions of the time),
which tends to the flow's variational solution as the mesh refines.

The state and the inputs between the knots (:func:`interval_states`,
:func:`interval_inputs`) at :data:`SAMPLES`, and two rules on those samples: composite
Simpson (:data:`SIMPSON_WEIGHTS`) and the quartic's Bernstein coefficients
(:data:`BERNSTEIN_OF_SAMPLES`).

Imports: numpy and CasADi (inside functions). The expressions work on CasADi's symbols
and numpy arrays alike; the powered gaits (:mod:`vsw.synthesis.powered`) transcribe their NLP
with them.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

__all__ = [
    "BERNSTEIN_OF_SAMPLES",
    "SAMPLES",
    "SIMPSON_WEIGHTS",
    "defects",
    "interval_inputs",
    "interval_states",
    "legendre_defects",
    "legendre_end",
    "legendre_scheme",
    "sensitivity",
]

SAMPLES = (0.0, 0.25, 0.5, 0.75, 1.0)
"""Where each interval is sampled (fractions of the interval): knots, quarter points and
midpoint. Five points fix a quartic: the power ``u P(q) q'`` of a linear input along a
linear coordinate on the scheme's cubic state is one."""
SIMPSON_WEIGHTS = np.array([1.0, 4.0, 2.0, 4.0, 1.0]) / 12
"""Composite Simpson's rule on :data:`SAMPLES` (per unit of the interval)."""
BERNSTEIN_OF_SAMPLES = np.linalg.inv(
    [[math.comb(4, j) * s**j * (1 - s) ** (4 - j) for j in range(5)] for s in SAMPLES]
)
"""The quartic through five samples at :data:`SAMPLES`, as its Bernstein coefficients."""
_HERMITE = {
    s: (2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2)
    for s in (0.25, 0.75)
}


def defects(x0: Any, xc: Any, x1: Any, f0: Any, fc: Any, f1: Any, h: Any) -> tuple[Any, Any]:
    """One interval's Hermite-Simpson defects, (1) and (2), zero on the discrete orbit:
    the midpoint's and the step's."""
    return xc - (x0 + x1) / 2 - h / 8 * (f0 - f1), x1 - x0 - h / 6 * (f0 + 4 * fc + f1)


def sensitivity(jacobian: Callable[[Any, Any], Any], knots: Sequence, middles: Sequence,
                u_knots: Sequence, u_middles: Sequence, duration: Any,
                size: int) -> Any:  # fmt: skip
    """d(last knot)/d(first knot) of a phase's Hermite-Simpson equations, (3), with
    ``jacobian(x, u) = df/dx`` (CasADi)."""
    import casadi as ca

    nodes = len(middles)
    h = duration / nodes
    eye = ca.DM.eye(size)
    out = eye
    for i in range(nodes):
        a0 = jacobian(knots[i], u_knots[i])
        a1 = jacobian(knots[i + 1], u_knots[i + 1])
        ac = jacobian(middles[i], u_middles[i])
        left = eye - h / 6 * a1 - h / 3 * ac + h * h / 12 * ca.mtimes(ac, a1)
        right = eye + h / 6 * a0 + h / 3 * ac + h * h / 12 * ca.mtimes(ac, a0)
        out = ca.solve(left, ca.mtimes(right, out))
    return out


def interval_states(x0: Any, xc: Any, x1: Any, step0: Any, step1: Any) -> tuple:
    """The state at :data:`SAMPLES` of an interval: its knots and midpoint, and the
    scheme's cubic (Hermite, through the knots with slopes ``step = h f``) at the quarter
    points."""
    quarter, three = (a * x0 + b * step0 + c * x1 + d * step1
                      for a, b, c, d in (_HERMITE[0.25], _HERMITE[0.75]))  # fmt: skip
    return x0, quarter, xc, three, x1


def interval_inputs(u0: Any, uc: Any, u1: Any) -> tuple:
    """The inputs at :data:`SAMPLES` of an interval, on the quadratic through knot,
    midpoint and knot (the line through the knots where the midpoint is tied to them)."""
    return (u0, 0.375 * u0 + 0.75 * uc - 0.125 * u1, uc,
            -0.125 * u0 + 0.75 * uc + 0.375 * u1, u1)  # fmt: skip


@functools.cache  # built with numpy's polynomials: 2 ms, asked once a design's start
def legendre_scheme(degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gauss-Legendre collocation of ``degree`` points per interval, of order ``2 degree``:
    the points ``tau`` in (0, 1), the matrix ``C`` with ``C[r, j]`` the derivative at
    ``tau_j`` of the Lagrange polynomial of point ``r`` (point 0 is the interval's start,
    ``tau_0 = 0``) and the row ``D`` of their values at 1 (the interval's end).

    On an interval of length ``h`` from ``x_0`` through the stage states ``x_1..x_d``
    (:func:`legendre_defects`), ``sum_r C[r, j] x_r = h f(x_j)`` and the end is
    ``sum_r D[r] x_r``. Collocation is an implicit Runge-Kutta method, and a Runge-Kutta
    method's map differentiated is the same method on the variational equations: the
    stage matrices ``Phi_j`` collocated by the same rows give the exact derivative of the
    discrete phase map (Hairer, Norsett & Wanner, *Solving ODEs I*, II.7 and II.14)."""
    roots = 0.5 * (np.polynomial.legendre.leggauss(degree)[0] + 1.0)
    tau = np.concatenate([[0.0], roots])
    c_matrix = np.zeros((degree + 1, degree + 1))
    d_row = np.zeros(degree + 1)
    for r in range(degree + 1):
        basis = np.poly1d([1.0])
        for s in range(degree + 1):
            if s != r:
                basis *= np.poly1d([1.0, -tau[s]]) / (tau[r] - tau[s])
        d_row[r] = basis(1.0)
        slope = np.polyder(basis)
        c_matrix[r] = [slope(t) for t in tau]
    for shared in (roots, c_matrix, d_row):
        shared.flags.writeable = False  # one copy for every caller
    return roots, c_matrix, d_row


def legendre_defects(points: Sequence, rates: Sequence, h: Any, c_matrix: np.ndarray) -> list:
    """One interval's collocation defects, zero on the discrete orbit: for each stage
    ``j``, ``sum_r C[r, j] x_r - h f_j`` (:func:`legendre_scheme`), with ``points`` the
    start and the stage states and ``rates`` the vector field at the stages."""
    out = []
    for j in range(1, len(points)):
        slope = sum(float(c_matrix[r, j]) * points[r] for r in range(len(points)))
        out.append(slope - h * rates[j - 1])
    return out


def legendre_end(points: Sequence, d_row: np.ndarray) -> Any:
    """The interval's end on its collocation polynomial: ``sum_r D[r] x_r``."""
    return sum(float(d_row[r]) * points[r] for r in range(len(points)))
