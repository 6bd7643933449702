"""sympy's node count, memoised: the first key by which ``sympy.ordered`` sorts.

``ordered`` (in common subexpression elimination with ``order="canonical"``, in TR10i, in
much of sympy) sorts by ``_nodes`` first, which counts an expression's nodes by walking
its whole tree, and walks the subtrees again for every sum and product it sorts on the
way up: quadratic in the depth. A five-link walker's accelerations spent a quarter of
their elimination (1.1 s) there. The count of an expression is a fact of its tree, so it
is kept per expression; the counts, and so every order and every generated file, are
sympy's.
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


def install() -> None:
    """Put the memoised count in the place ``sympy.core.sorting._nodes`` looks it up (a
    module global, read at each call). For the sympy the derivation pins (1.14,
    :mod:`derive.manifest`), whose definition :func:`_node_count` repeats."""
    _sorting._node_count = _node_count
