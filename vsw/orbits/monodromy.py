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

Imports: numpy and :mod:`vsw.orbits.shooting`.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from vsw.orbits.shooting import phase_blocks

__all__ = ["by_modulus", "eigenvalues", "monodromy"]


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
