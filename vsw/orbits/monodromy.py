"""The monodromy matrix of a hybrid orbit (the Jacobian of its period-``p`` Poincaré map)
and its eigenvalues: one implementation for every caller.

Phase ``k`` maps its start ``x_k`` to the next phase's start ``F_k = R_k(phi_k(x_k, T_k))``
with its duration fixed by its guard, ``g_k(phi_k(x_k, T_k)) = 0``. By the implicit function
theorem ``dT_k / dx_k = -g_x / g_T``, so the phase's map has the derivative

    D P_k = F_x - F_T g_x / g_T                                                (1)
          = DR_k (I - f_k grad g_k / (grad g_k . f_k)) Phi_k,                  (2)

with ``Phi_k = d phi_k / d x_k`` (the variational equations, integrated by CVODES'
forward sensitivities), ``f_k`` the vector field at the phase's end (``F_T = DR_k f_k``,
``g_T = grad g_k . f_k``) and ``DR_k`` the reset's Jacobian: (2) is the saltation matrix
of the event read on the Poincaré section (the term ``(f^+ - DR f^-) grad g / (grad g .
f^-)`` of the full saltation matrix keeps only ``- DR f^- grad g / (grad g . f^-)`` where
the map stops at the event). The monodromy matrix is the product over the phases,

    M = D P_m ... D P_2 D P_1,                                                 (3)

its blocks read from the exact Jacobian of the shooting residual
(:func:`vsw.orbits.shooting.phase_blocks`). A guard that does not cross at its phase's end
(``g_T = 0``) leaves (1) undefined: the eigenvalues are then none.

The same product inside an NLP (CasADi): :func:`saltation` is (2)'s projection and
:func:`phase_derivative` the phase's factor, from the variational equations
(:func:`vsw.orbits.shooting.phase_integrator`) or a collocation's discrete map
(:func:`vsw.orbits.collocation.sensitivity`). Every eigenvalue within the disc of radius
``rho`` is smooth there as Jury's (Schur-Cohn) inequalities on the characteristic
polynomial of ``M / rho`` (:func:`jury_rows`), its coefficients by Newton's identities on
the traces of ``M``'s powers (:func:`characteristic_coefficients`): ``max |lambda|`` is not
differentiable where two eigenvalues meet.

Imports: numpy, CasADi (inside functions) and :mod:`vsw.orbits.shooting`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from vsw.orbits.shooting import phase_blocks

__all__ = [
    "by_modulus",
    "characteristic_coefficients",
    "eigenvalues",
    "jury_rows",
    "monodromy",
    "phase_derivative",
    "saltation",
]


def by_modulus(values: Iterable[complex]) -> list[complex]:
    """Eigenvalues largest modulus first (ties by real, then imaginary part)."""
    return sorted((complex(v) for v in values), key=lambda v: (-abs(v), v.real, v.imag))


def monodromy(jacobian: np.ndarray, n: int, m: int) -> np.ndarray:
    """The monodromy matrix (3) from the shooting residual's Jacobian in its unknowns
    (``m`` phases, states of size ``n``): the product of each phase's map derivative (1)."""
    out = np.eye(n)
    for g_x, g_t, f_x, f_t in phase_blocks(jacobian, n, m):
        out = (f_x - np.outer(f_t, g_x) / g_t) @ out
    return out


def eigenvalues(jacobian: np.ndarray, n: int, m: int) -> list[complex]:
    """The eigenvalues of :func:`monodromy`, largest modulus first (:func:`by_modulus`);
    none where the matrix is not finite (a guard grazing at its phase's end)."""
    with np.errstate(all="ignore"):
        matrix = monodromy(jacobian, n, m)
    if not np.all(np.isfinite(matrix)):
        return []
    return by_modulus(np.linalg.eigvals(matrix))


def saltation(rate: Any, gradient: Any, size: int) -> Any:
    """``I - f grad g / (grad g . f)``, (2)'s projection at a phase's end (CasADi): a
    perturbation meets the guard ``dt = -grad g dx / (grad g . f)`` later."""
    import casadi as ca

    return ca.DM.eye(size) - ca.mtimes(rate, gradient) / ca.mtimes(gradient, rate)


def phase_derivative(reset_jacobian: Any, rate: Any, gradient: Any, flow: Any,
                     size: int) -> Any:  # fmt: skip
    """``D P_k = DR_k (I - f_k grad g_k / (grad g_k . f_k)) Phi_k`` of (2) (CasADi), with
    ``flow`` the phase's ``Phi_k``."""
    import casadi as ca

    return ca.mtimes(reset_jacobian, ca.mtimes(saltation(rate, gradient, size), flow))


def jury_rows(coefficients: Sequence[Any]) -> list[Any]:
    """Inequalities ``row >= 0`` that hold exactly when every root of the monic polynomial
    ``z^r + a_1 z^(r-1) + ... + a_r`` (``coefficients`` = a_1..a_r) lies in the closed unit
    disc: Jury's conditions with each ``|u| <= v`` written as the two rows ``v - u`` and
    ``v + u`` (smooth; degrees 1-3), the Schur–Cohn recursion for higher degrees. Works on
    floats and on CasADi expressions."""
    a = list(coefficients)
    r = len(a)
    if r == 1:
        return [1 - a[0], 1 + a[0]]
    if r == 2:
        return [1 - a[1], 1 + a[0] + a[1], 1 - a[0] + a[1]]
    if r == 3:
        inner = a[2] * a[0] - a[1]
        return [
            1 + a[0] + a[1] + a[2],
            1 - a[0] + a[1] - a[2],
            1 - a[2],
            1 + a[2],
            1 - a[2] ** 2 - inner,
            1 - a[2] ** 2 + inner,
        ]
    # Schur–Cohn: p stable iff |p_0| < |p_d| and (p_d p - p_0 p*) / z is; lowest first.
    rows = []
    poly = [1, *a][::-1]  # constant first
    while len(poly) > 1:
        lead, const = poly[-1], poly[0]
        rows.append(lead**2 - const**2)
        d = len(poly) - 1
        poly = [lead * poly[j + 1] - const * poly[d - 1 - j] for j in range(d)]
    return rows


def characteristic_coefficients(matrix: Any, count: int) -> list[Any]:
    """a_1..a_count of ``det(z I - M) = z^m + a_1 z^(m-1) + ...`` by Newton's identities
    on the traces of the powers of ``M`` (CasADi or numpy)."""
    import casadi as ca

    traces = []
    power = matrix
    for _ in range(count):
        traces.append(ca.trace(power))
        power = ca.mtimes(power, matrix)
    a: list[Any] = []
    for k in range(1, count + 1):
        total = traces[k - 1]
        for j in range(1, k):
            total = total + a[j - 1] * traces[k - j - 1]
        a.append(-total / k)
    return a
