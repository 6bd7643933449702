"""The integral of a polynomial profile's cube times a sine over an interval, in a form that
evaluates to a few ulp for every width (the TLE's extension integral, :mod:`derive.models.tle`).

``J(x) = int_a^(a + w x) r**3 sin(theta) dtheta`` with ``r**3 = sum_j w_j sum_n c_jn s**n``
(``s = (theta - a) / w``) is, with ``s = x t``,
``J = w Im(exp(i a) sum_j w_j sum_n c_jn x**(n+1) E_n(w x))`` through the moments
``E_m(y) = int_0^1 t**m exp(i y t) dt`` (``m = 0..9``): ``E_9`` from its power series
(alternating, truncated where the next term is below 1e-18 for ``y <= pi/2``) and the others by
the downward recurrence ``E_(m-1) = (exp(i y) - i y E_m) / m`` (integration by parts; each
step multiplies an earlier error by at most ``y/m``). The closed form sympy integrates holds
powers of ``1/w`` that cancel.
"""

from __future__ import annotations

import functools
import math

import sympy as sm

SERIES_TERMS = 12
"""Terms of the power series of E_9 (cos and sin parts); the first omitted one is below
1e-18 for y <= pi/2 (checked in :func:`moment_series`)."""
MOMENT_ORDER = 9  # r**3 is a polynomial of degree 9 in s

Terms = tuple[tuple[sm.Expr, tuple[sm.Rational, ...]], ...]
"""``r**3`` as ``(w_j, coefficients of s**0..s**MOMENT_ORDER)`` per term."""


@functools.cache
def moment_series() -> tuple[sm.Expr, sm.Expr, sm.Symbol]:
    """``Re E_9(y)`` and ``Im E_9(y)`` as truncated power series in ``y`` (Horner form in
    ``y**2``), and the symbol ``y``; checks the truncation bound for ``y <= pi/2``."""
    y = sm.Symbol("y", nonnegative=True)
    z = sm.Symbol("z", nonnegative=True)
    m = MOMENT_ORDER
    # int_0^1 t**m exp(i y t) dt = sum_n (i y)**n / (n! (n + m + 1)).
    cos_part = sum(
        (sm.Integer(-1) ** k * z**k / (sm.factorial(2 * k) * (2 * k + m + 1))
         for k in range(SERIES_TERMS)), sm.Integer(0))  # fmt: skip
    sin_part = sum(
        (sm.Integer(-1) ** k * z**k / (sm.factorial(2 * k + 1) * (2 * k + m + 2))
         for k in range(SERIES_TERMS)), sm.Integer(0))  # fmt: skip
    # Alternating with decreasing terms for y < 2: the error is below the first omitted term.
    y_max = sm.pi / 2
    k = SERIES_TERMS
    omitted = max(
        y_max ** (2 * k) / (sm.factorial(2 * k) * (2 * k + m + 1)),
        y_max ** (2 * k + 1) / (sm.factorial(2 * k + 1) * (2 * k + m + 2)),
    )
    if float(omitted) > 1e-18:
        raise AssertionError(f"E_9 series: first omitted term {float(omitted):.3g}")
    cos_part = sm.horner(cos_part, z).xreplace({z: y**2})
    sin_part = y * sm.horner(sin_part, z).xreplace({z: y**2})
    return cos_part, sin_part, y


def moment_integral(
    x: sm.Expr, tag: str, terms: Terms, start: sm.Expr, width: sm.Expr
) -> tuple[list[tuple[sm.Symbol, sm.Expr]], sm.Expr]:
    """``J(x) = int_start^(start + width x) r**3 sin(theta) dtheta`` for ``r**3`` given by its
    ``terms``, as named intermediates (their names end in ``tag``) and an expression over them.

    With ``theta = start + width s`` and ``s = x t``: ``J = width Im(exp(i start)
    sum_j w_j sum_n c_jn x**(n+1) E_n(width x))``. ``x`` must be an expression of the
    generated function's arguments (the code generator evaluates cos/sin pairs first).
    """
    cos_part, sin_part, y = moment_series()
    y_s = sm.Symbol(f"y_{tag}", nonnegative=True)
    y_value = width * x  # also the trig functions' argument, so in terms of arguments only
    inter: list[tuple[sm.Symbol, sm.Expr]] = [(y_s, y_value)]
    c_sym = {MOMENT_ORDER: sm.Symbol(f"C{MOMENT_ORDER}_{tag}", real=True)}
    s_sym = {MOMENT_ORDER: sm.Symbol(f"S{MOMENT_ORDER}_{tag}", real=True)}
    inter += [(c_sym[MOMENT_ORDER], cos_part.xreplace({y: y_s})),
              (s_sym[MOMENT_ORDER], sin_part.xreplace({y: y_s}))]  # fmt: skip
    for n in range(MOMENT_ORDER, 0, -1):
        # E_(n-1) = (exp(i y) - i y E_n) / n.
        c_sym[n - 1] = sm.Symbol(f"C{n - 1}_{tag}", real=True)
        s_sym[n - 1] = sm.Symbol(f"S{n - 1}_{tag}", real=True)
        inter.append((c_sym[n - 1], (sm.cos(y_value) + y_s * s_sym[n]) / n))
        inter.append((s_sym[n - 1], (sm.sin(y_value) - y_s * c_sym[n]) / n))
    re_part, im_part = sm.Integer(0), sm.Integer(0)
    for weight, coeffs in terms:
        re_part += weight * sum((c * x ** (n + 1) * c_sym[n] for n, c in enumerate(coeffs) if c),
                                sm.Integer(0))  # fmt: skip
        im_part += weight * sum((c * x ** (n + 1) * s_sym[n] for n, c in enumerate(coeffs) if c),
                                sm.Integer(0))  # fmt: skip
    return inter, width * (sm.sin(start) * re_part + sm.cos(start) * im_part)


def series_truncation_bound() -> float:
    """The first omitted term of the E_9 series at y = pi/2 (for the docs)."""
    k, m = SERIES_TERMS, MOMENT_ORDER
    return float(
        max(
            (math.pi / 2) ** (2 * k) / (math.factorial(2 * k) * (2 * k + m + 1)),
            (math.pi / 2) ** (2 * k + 1) / (math.factorial(2 * k + 1) * (2 * k + m + 2)),
        )
    )
