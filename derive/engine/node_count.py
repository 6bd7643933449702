"""sympy's node count, memoised: the first key by which ``sympy.ordered`` sorts; and a
rational number's ``complex``, which sorting sums by their terms takes for each coefficient.

``ordered`` (in common subexpression elimination with ``order="canonical"``, in TR10i, in
much of sympy) sorts by ``_nodes`` first, which counts an expression's nodes by walking
its whole tree, and walks the subtrees again for every sum and product it sorts on the
way up: quadratic in the depth. A five-link walker's accelerations spent a quarter of
their elimination (1.1 s) there. The count of an expression is a fact of its tree, so it
is kept per expression; the counts, and so every order and every generated file, are
sympy's.

An expression's sort key (``Expr.sort_key``, through ``as_ordered_terms``) turns each
term's numeric coefficient into a Python complex; for a Rational, sympy evaluates it as a
Float and then asks that Float for its real and imaginary parts through the assumptions
system, which was a sixth of eliminating the TLE's largest function. A Float's parts are
itself and zero, so :func:`_rational_complex` takes the same Float's value directly: the
same number, bit for bit.
"""

from __future__ import annotations

import sympy as sm
import sympy.core.sorting as _sorting

__all__ = ["install"]

_LIMIT = 200_000
"""Expressions whose counts are kept before the table starts afresh (each holds its
expression alive, as sympy's own cache does)."""

_COUNTS: dict[sm.Basic, float] = {}


def _node_count(expr: sm.Basic) -> float:
    """sympy 1.14's ``sympy.core.sorting._node_count``: 1 for each node, a Float a half."""
    try:
        return _COUNTS[expr]
    except KeyError:
        pass
    except TypeError:  # an unhashable node: counted as sympy counts it
        return 0.5 if expr.is_Float else 1 + sum(map(_node_count, expr.args))
    count = 0.5 if expr.is_Float else 1 + sum(map(_node_count, expr.args))
    if len(_COUNTS) >= _LIMIT:
        _COUNTS.clear()
    _COUNTS[expr] = count
    return count


def _rational_complex(self: sm.Rational) -> complex:
    """``Expr.__complex__`` of sympy 1.14 for a Rational: its Float (``evalf``, 15 digits)
    as the real part, 0 as the imaginary part."""
    return complex(float(self.evalf()), 0.0)


def install() -> None:
    """Put the memoised count in the place ``sympy.core.sorting._nodes`` looks it up (a
    module global, read at each call). For the sympy the derivation pins (1.14,
    :mod:`derive.manifest`), whose definition :func:`_node_count` repeats; and
    :func:`_rational_complex` as Rational's (and so Integer's) ``complex``."""
    _sorting._node_count = _node_count
    sm.Rational.__complex__ = _rational_complex
