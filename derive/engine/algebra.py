"""The engine's algebra: expansion by SymEngine, a cheap canonical form, angle sums, and
Cramer's rule kept in polynomials.

Every expansion refuses a large fraction nested in another's denominator
(:func:`refuse_nested_fraction`): the engine solves by Cramer's rule in polynomials
(:func:`cramer_fraction`), and larger systems on placeholders for their entries
(:func:`placeholder_cramer`, :func:`compact_cramer`).
"""

from __future__ import annotations

import functools
import random
from collections.abc import Iterable

import symengine as se
import sympy as sm

from derive.engine.trig import tr10i

__all__ = [
    "TIDY_OPS",
    "NestedFractionError",
    "angle_sums",
    "cheap_simplify",
    "compact_cramer",
    "cramer_fraction",
    "expand",
    "factor_constants",
    "matrix_product",
    "numeric_check",
    "placeholder_cramer",
    "refuse_nested_fraction",
    "tidy",
    "within_ops",
]


class NestedFractionError(ValueError):
    """The engine was about to expand a large fraction nested in another fraction."""


_NESTED_FRACTION_OPS = 400
"""A fraction nested in another's denominator is refused by :func:`expand` where the
inner denominator moves with the configuration (it holds a sine or cosine) and the two
denominators' operations multiply to more than this. A solve's pivot is a mass matrix
entry of the walker's angles (a two-link walker's nests: 69 x 20 and 69 x 53); a model's
own nested ratio, a length ``c / (1 + 1/(a + b))``, divides by its parameters however
large the expression it sits in."""


def refuse_nested_fraction(expr: sm.Expr, powers: Iterable[sm.Pow] | None = None) -> None:
    """Raise :class:`NestedFractionError` where ``expr`` divides by a sum that itself
    divides by a sum of sines or cosines, the two denominators' operations multiplying to
    more than ``_NESTED_FRACTION_OPS``.

    Such a nest is what one symbolic solve inside another builds (``LUsolve`` whose
    right-hand side holds another ``LUsolve``'s fractions). Expanding it multiplies every
    term of one denominator's numerator by every term of the other, and cancelling the
    result takes minutes for a two-link walker's impact with an impulse; the engine solves
    by Cramer's rule in polynomials instead (:func:`cramer_fraction`). Every expansion
    checks this, so the derivation of every model (and of every user's model file) keeps
    to it: a refusal names an engine defect, not a fault of the model. ``powers``: the
    powers in ``expr`` where the caller has them already (``expr.atoms(sm.Pow)``)."""
    for power in expr.atoms(sm.Pow) if powers is None else powers:
        base, exponent = power.args
        if not (exponent.is_negative and base.is_Add):
            continue
        outer = None
        for inner in base.atoms(sm.Pow):
            if not (inner.args[1].is_negative and inner.args[0].is_Add):
                continue
            if not inner.args[0].has(sm.sin, sm.cos):
                continue
            outer = sm.count_ops(base) if outer is None else outer
            size = outer * sm.count_ops(inner.args[0])
            if size > _NESTED_FRACTION_OPS:
                raise NestedFractionError(
                    "the engine was about to expand a fraction nested in another's "
                    f"denominator (their operations multiply to {size}): a solve inside a "
                    "solve, to be written by Cramer's rule; an engine defect to report with "
                    "the model file"
                )


def _scan(expr: sm.Expr) -> tuple[set, set, set, bool] | None:
    """``expr``'s symbols, powers and applied functions, and whether it holds a Float, in
    one walk over its distinct subexpressions (``atoms`` walks every path to a shared
    subexpression, once for each kind asked for). None where ``expr`` holds anything but
    sums, products, powers, applied functions and atoms (then its free symbols may be
    fewer than its symbols)."""
    symbols, powers, functions = set(), set(), set()
    has_float = False
    seen = set()
    stack = [expr]
    while stack:
        node = stack.pop()
        if node in seen:
            continue
        seen.add(node)
        if node.is_Atom:
            if node.is_Symbol:
                symbols.add(node)
            elif node.is_Float:
                has_float = True
            continue
        if node.is_Pow:
            powers.add(node)
        elif isinstance(node, sm.Function):
            functions.add(node)
        elif not (node.is_Add or node.is_Mul):
            return None
        stack.extend(node.args)
    return symbols, powers, functions, has_float


def expand(expr: sm.Expr) -> sm.Expr:
    """``sympy.expand`` done by SymEngine (what SymForce does its algebra with): the
    expanded polynomial is canonical, so sympy's own expansion and this one are the same
    expression, at a fraction of the time. Symbols come back from SymEngine without their
    assumptions and are put back by name; an expression SymEngine cannot hold (or with
    two symbols of one name) is expanded by sympy. A large nested fraction is refused
    (:func:`refuse_nested_fraction`)."""
    expr = sm.sympify(expr)
    scanned = _scan(expr)
    if scanned is None:
        refuse_nested_fraction(expr)
        free = expr.free_symbols
        functions = expr.atoms(sm.Function)
        has_float = bool(expr.atoms(sm.Float))
    else:
        free, powers, functions, has_float = scanned
        refuse_nested_fraction(expr, powers)
    symbols = {s.name: s for s in free}
    if (
        len(symbols) != len(free)
        or any(not isinstance(f, _SYMENGINE_FUNCTIONS) for f in functions)
        or has_float
    ):
        return sm.expand(expr)
    try:
        expanded = se.expand(se.sympify(expr))
    except (RuntimeError, TypeError, NotImplementedError, KeyError):  # a form SymEngine lacks
        return sm.expand(expr)
    if len(_CONVERTED) > _CONVERTED_LIMIT:
        _CONVERTED.clear()
    try:
        return _from_symengine(expanded, symbols, _CONVERTED.setdefault(frozenset(free), {}))
    except (RuntimeError, TypeError, NotImplementedError, KeyError):
        return sm.expand(expr)


_CONVERTED: dict[frozenset, dict] = {}
"""SymEngine's expressions as sympy's, kept across expansions for each set of symbols
(a name stands for one symbol in each): successive expansions of a derivation share most
of their terms (the mass matrix's, the forcing's), each converted once."""


_CONVERTED_LIMIT = 64
"""Sets of symbols :data:`_CONVERTED` holds before it starts afresh."""


_SYMENGINE_CLASSES = ((se.Add, sm.Add), (se.Mul, sm.Mul), (se.Pow, sm.Pow), (se.sin, sm.sin),
                      (se.cos, sm.cos), (se.atan, sm.atan))  # fmt: skip


_SYMENGINE_FUNCTIONS = (sm.sin, sm.cos, sm.atan)
"""The functions :func:`expand` hands to SymEngine (the TLE's stride integral has an atan)."""


def _from_symengine(expr, symbols: dict[str, sm.Symbol], seen: dict) -> sm.Expr:
    """A SymEngine expression as sympy's, its symbols those of ``symbols`` by name (one
    pass: converting and then replacing the symbols would build every node twice)."""
    if expr in seen:
        return seen[expr]
    if isinstance(expr, se.Symbol):
        result = symbols[expr.name]
    elif isinstance(expr, se.Number):
        result = expr._sympy_()
    else:
        for engine_class, sympy_class in _SYMENGINE_CLASSES:
            if isinstance(expr, engine_class):
                result = sympy_class(*(_from_symengine(a, symbols, seen) for a in expr.args))
                break
        else:
            raise NotImplementedError(type(expr).__name__)
    seen[expr] = result
    return result


def cheap_simplify(expr: sm.Expr) -> sm.Expr:
    """A cheap canonical form: ``sin(a)**2 -> 1 - cos(a)**2`` (no sums of angles expanded),
    expanded and cancelled. ``trigsimp`` would do more at many times the cost."""
    expr = expand(expr)
    squared = _sine_powers(expr)
    if squared is not None:
        if squared:
            expr = expand(expr.xreplace(squared))
    else:
        squares = {
            sm.sin(a) ** 2: 1 - sm.cos(a) ** 2 for a in {s.args[0] for s in expr.atoms(sm.sin)}
        }
        if squares:
            expr = expand(expr.subs(squares))
    # cancel returns an expanded polynomial with rational coefficients unchanged (it puts
    # the terms over their common denominator and multiplies the number back in): finding
    # that out was a second of each two-link walker's derivation.
    return expr if _rational_polynomial(expr) else sm.cancel(expr)


def _sine_powers(expr: sm.Expr) -> dict | None:
    """``sin(a)**(2 j) -> (1 - cos(a)**2)**j`` for every even power of a sine in ``expr``,
    what ``subs(sin(a)**2, 1 - cos(a)**2)`` does to positive integer powers in a fraction
    of its time (it leaves odd powers: 3 is no multiple of 2); None when some power of a
    sine is not a positive integer (then ``subs`` does what it does)."""
    if any(sine.args[0].has(sm.sin) for sine in expr.atoms(sm.sin)):
        return None  # subs reaches into the argument first; leave nesting to it
    powers = {}
    for power in expr.atoms(sm.Pow):
        base, exponent = power.args
        if not isinstance(base, sm.sin):
            continue
        if not (exponent.is_Integer and exponent > 0):
            return None
        if exponent % 2 == 0:
            powers[power] = (1 - sm.cos(base.args[0]) ** 2) ** (exponent // 2)
    return powers


def _rational_polynomial(expr: sm.Expr) -> bool:
    """Whether the expanded ``expr`` is a polynomial with rational coefficients in its
    symbols and functions (no division by them, no fractional power)."""
    for term in sm.Add.make_args(expr):
        for factor in sm.Mul.make_args(term):
            if factor.is_Number:
                if not factor.is_Rational:
                    return False
                continue
            exponent = factor.as_base_exp()[1]  # exp(-y) is (E, -y): a division
            if not (exponent.is_Integer and exponent > 0):
                return False
    return True


def factor_constants(expr: sm.Expr, variables: set) -> sm.Expr:
    """``expr`` (expanded) as a sum over its monomials in ``variables`` (and functions of
    them), each with its coefficient in the other symbols factored: a mass matrix entry
    ``m a1**2 + 2 m a1 b1 + m b1**2`` becomes ``m (a1 + b1)**2``."""
    groups: dict[sm.Expr, list[sm.Expr]] = {}
    for term in sm.Add.make_args(expand(expr)):
        constant, varying = [], []
        for factor in sm.Mul.make_args(term):
            (varying if factor.free_symbols & variables else constant).append(factor)
        groups.setdefault(sm.Mul(*varying), []).append(sm.Mul(*constant))
    return sm.Add(*(sm.factor(sm.Add(*c)) * k for k, c in groups.items()))


def angle_sums(expr: sm.Expr) -> sm.Expr:
    """:func:`cheap_simplify`, then products of sines and cosines of different angles as sines
    and cosines of their sums (``sin a sin b + cos a cos b -> cos(a - b)``, fu's TR10i):
    the equations of several rigid links stay small in the links' relative angles."""
    return cheap_simplify(tr10i(cheap_simplify(expr)))


def numeric_check(exprs: list[sm.Expr], symbols: list[sm.Symbol], what: str) -> None:
    """Each expression vanishes at random points (a fact of geometry the model states)."""
    rng = random.Random(20261201)
    for _ in range(4):
        point = {s: sm.Float(rng.uniform(0.1, 0.6), 30) for s in symbols}
        for e in exprs:
            value = abs(complex(sm.sympify(e).xreplace(point).evalf(30)))
            if value > 1e-20:
                raise AssertionError(f"{what}: {e} = {value:.3g} at {point}")


def compact_cramer(system: sm.Matrix, rhs: sm.Matrix) -> tuple[sm.Expr, ...]:
    """``system^-1 rhs`` by Cramer's rule formed on placeholders for the entries, which then
    go in whole (unexpanded products of them, each computed once by the code generator),
    as a larger phase's accelerations are (:func:`phase_dynamics`)."""
    slots, rhs_slots, determinant, _, numerators = placeholder_cramer(system.rows)
    entries = dict(zip(slots, system)) | dict(zip(rhs_slots, rhs))
    determinant = determinant.xreplace(entries)
    return tuple(n.xreplace(entries) / determinant for n in numerators)


@functools.cache
def placeholder_cramer(
    size: int,
) -> tuple[sm.Matrix, sm.Matrix, sm.Expr, sm.Matrix, tuple[sm.Expr, ...]]:
    """Cramer's rule of a ``size`` x ``size`` system on placeholders: the matrix's and the
    right-hand side's, the determinant, the adjugate and the adjugate times the right-hand
    side. Formed once for every phase and impact of that size (Berkowitz's determinant of
    five-by-five placeholders was a fifth of a five-link walker's derivation); the
    placeholders are replaced by each system's entries."""
    slots = sm.Matrix(size, size, lambda i, j: sm.Dummy(f"M{i}{j}"))
    rhs_slots = sm.Matrix(size, 1, lambda i, _: sm.Dummy(f"f{i}"))
    adjugate = _placeholder_adjugate(slots)
    return (slots, rhs_slots, slots.det(method="berkowitz"), adjugate,
            tuple(matrix_product(adjugate, rhs_slots)))  # fmt: skip


def matrix_product(a: sm.Matrix, b: sm.Matrix) -> sm.Matrix:
    """``a * b``, each entry one sum of the products: the same expressions as sympy's
    product, which goes through its domain matrices and summed a five-link walker's
    cofactors against the right-hand side in 0.5 s (this: milliseconds)."""
    return sm.Matrix(a.rows, b.cols,
                     lambda i, j: sm.Add(*(a[i, k] * b[k, j] for k in range(a.cols))))  # fmt: skip


def _placeholder_adjugate(slots: sm.Matrix) -> sm.Matrix:
    """``slots.adjugate(method="berkowitz")`` of a matrix of distinct placeholders, the same
    expressions: each cofactor is Berkowitz's determinant of a minor, and every minor of
    distinct placeholders is one determinant of ``size - 1`` placeholders with the minor's
    in their places (renaming symbols builds the same sums and products). One determinant
    instead of ``size**2``: the five-by-five adjugate took 0.66 s, this 0.06 s."""
    size = slots.rows
    if size < 3:
        return slots.adjugate(method="berkowitz")
    generic = sm.Matrix(size - 1, size - 1, lambda i, j: sm.Dummy(f"m{i}{j}"))
    minor = generic.det(method="berkowitz")
    cofactors = sm.Matrix(size, size, lambda i, j: (-1) ** ((i + j) % 2) * minor.xreplace(
        dict(zip(generic, slots.minor_submatrix(i, j)))))  # fmt: skip
    return cofactors.T


def cramer_fraction(numerator: sm.Expr, determinants: Iterable[sm.Expr]) -> sm.Expr:
    """``numerator`` over the product of ``determinants`` (polynomials, each simplified by
    :func:`cheap_simplify`), their common monomial factors cancelled and the rest left as
    factors.

    A solve whose right-hand side holds another solve's fractions (``LUsolve`` after
    ``LUsolve``) nests one denominator in the other's numerator; expanding that nest before
    cancelling it multiplies out every term of one by every term of the other, which takes
    minutes for a two-link impact with an impulse. Cramer's rule in polynomials keeps the
    numerator and each determinant a polynomial. Cancelling the whole quotient (``cancel``)
    would expand the product of the determinants into a larger expression than these
    factors, at a second's cost; the code generator computes each factor once."""
    denominator = sm.Mul(*(sm.factor_terms(d) for d in determinants))
    return sm.factor_terms(numerator) / denominator


TIDY_OPS = 200
"""Expressions up to this many operations get :func:`sympy.simplify`; larger ones (a
prescribed polynomial profile integrated against gravity) would take minutes in it."""


def within_ops(expr: sm.Expr, limit: int = TIDY_OPS) -> bool:
    """``sympy.count_ops(expr) <= limit``, answered without counting a large expression:
    every sum of ``n`` terms that ``count_ops`` walks counts ``n - 1`` additions or
    subtractions, so once the sums met along ``expr``'s tree (each occurrence, as
    ``count_ops`` walks it) hold more than ``limit`` of them, so does the count (a
    tenth of a second on the TLE's integrated extension, where the walk stops early)."""
    if not isinstance(expr, sm.Expr):
        return sm.count_ops(expr) <= limit
    additions, stack = 0, [expr]
    while stack:
        node = stack.pop()
        if node.is_Add:
            additions += len(node.args) - 1
            if additions > limit:
                return False
        stack.extend(node.args)
    return sm.count_ops(expr) <= limit


def tidy(expr: sm.Expr) -> sm.Expr:
    return sm.simplify(expr) if within_ops(expr) else expr
