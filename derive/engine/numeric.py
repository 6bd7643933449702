"""Expressions evaluated at a point with many digits, for a derivation's checks of one form
against another (two forms of one quantity must agree where one of them cancels badly).

sympy's way, ``expr.xreplace(point).evalf(digits)``, rebuilds the whole tree with Floats in
it (a sum or product of Floats is evaluated as it is built), once for every path to a
shared subexpression. :func:`evaluate` walks the tree once in mpmath at the same working
precision, each distinct subexpression evaluated once; an intermediate (a name for a
value, as a generated function has them) is evaluated once and then stands for its value.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import mpmath
import sympy as sm

__all__ = ["evaluate"]

_FUNCTIONS = {
    sm.sin: mpmath.sin, sm.cos: mpmath.cos, sm.tan: mpmath.tan, sm.exp: mpmath.exp,
    sm.log: mpmath.log, sm.asin: mpmath.asin, sm.acos: mpmath.acos, sm.atan: mpmath.atan,
    sm.atan2: mpmath.atan2, sm.Abs: abs,
}  # fmt: skip
"""The functions :func:`evaluate` knows, with mpmath's for them."""


def evaluate(
    exprs: Iterable[sm.Expr],
    point: Mapping[sm.Symbol, object],
    digits: int = 60,
    intermediates: Iterable[tuple[sm.Symbol, sm.Expr]] = (),
) -> list:
    """Each of ``exprs`` at ``point`` (symbol -> number: sympy's or Python's), as mpmath
    numbers computed with ``digits`` significant digits; ``intermediates`` (name, value),
    each in terms of the point and the names before it, are evaluated first, in order.
    An expression holding a function other than :data:`_FUNCTIONS`' (or a symbol with no
    value) raises ValueError: a check that cannot be evaluated does not pass."""
    with mpmath.workdps(digits):
        memo: dict = {}
        values = {symbol: _value(sm.sympify(v), memo) for symbol, v in point.items()}
        memo = dict(values)
        for symbol, value in intermediates:
            memo[symbol] = _value(value, memo)
        return [_value(sm.sympify(e), memo) for e in exprs]


def _value(expr: sm.Expr, memo: dict):
    """``expr``'s value in mpmath at the current precision, names taken from ``memo``."""
    if expr in memo:
        return memo[expr]
    if expr.is_Rational:
        result = mpmath.mpf(expr.p) / expr.q
    elif expr.is_Float:
        result = mpmath.mpf(expr)
    elif expr.is_NumberSymbol:
        result = mpmath.mpf(expr.evalf(mpmath.mp.dps + 5))
    elif expr is sm.I:
        result = mpmath.mpc(0, 1)
    elif expr.is_Add:
        result = mpmath.fsum(_value(a, memo) for a in expr.args)
    elif expr.is_Mul:
        result = mpmath.fprod(_value(a, memo) for a in expr.args)
    elif expr.is_Pow:
        base, exponent = expr.args
        power = int(exponent) if exponent.is_Integer else _value(exponent, memo)
        result = _value(base, memo) ** power
    elif type(expr) in _FUNCTIONS:
        result = _FUNCTIONS[type(expr)](*(_value(a, memo) for a in expr.args))
    else:
        raise ValueError(f"cannot evaluate {expr!r} ({type(expr).__name__}) numerically")
    memo[expr] = result
    return result
