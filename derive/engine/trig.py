"""Products of sines and cosines as sines and cosines of sums, fast: sympy's ``TR10i``
with the pairs it cannot combine skipped before it tries them.

``sympy.simplify.fu.TR10i`` tries every pair of an Add's terms (``trig_split``, about 3 ms
a pair): on the two-link walkers' ground reaction, a few hundred terms, that was 7 of the
compass gait's 12 s. A pair combines only when, with their common factor taken out, what
is left of each term is a number times at most two sines, cosines or square roots; so the
parts of the two terms that are none of these (parameters, rates, other powers) must be
equal. :func:`tr10i` is TR10i's algorithm (sympy 1.14, BSD licence) step for step, with
that test in front of each pair: a pair it skips is one TR10i would have tried and left,
so the result is TR10i's, term for term (the tests compare them).
"""

from __future__ import annotations

import bisect
import heapq
from collections import defaultdict
from collections.abc import Iterator

import sympy as sm
from sympy.core.sorting import ordered
from sympy.simplify.fu import _ROOT3, _invROOT3, process_common_addends, trig_split

__all__ = ["tr10i"]

_ANY = object()
"""The key of a term the test cannot judge (a power with a non-integer exponent other
than a square root, which may meet another term's square root): paired with every term."""


def _rest(term: sm.Expr, cache: dict) -> object:
    """The part of ``term`` that is no number, sine, cosine (to any power) or square root:
    two terms whose rests differ cannot be combined by ``trig_split(two=True)``."""
    if term in cache:
        return cache[term]
    if term.is_Add:
        key = _ANY
    else:
        _, body = term.as_coeff_Mul()
        kept = []
        key = None
        for factor in sm.Mul.make_args(body):
            base, exponent = factor.as_base_exp()
            if isinstance(base, (sm.sin, sm.cos)) or (factor.is_Pow and factor.exp is sm.S.Half):
                continue
            if not exponent.is_Integer:
                key = _ANY
                break
            kept.append(factor)
        if key is None:
            key = sm.Mul(*kept)
    cache[term] = key
    return key


def _trig_powers(term: sm.Expr, cache: dict) -> dict | None:
    """``term``'s sines and cosines with their exponents, ``{sin(x): 2, ...}``, as
    ``Factors(term)`` holds them; None where an exponent is no integer."""
    if term in cache:
        return cache[term]
    powers: dict | None = {}
    for factor in sm.Mul.make_args(term):
        base, exponent = factor.as_base_exp()
        if isinstance(base, (sm.sin, sm.cos)):
            if not exponent.is_Integer:
                powers = None
                break
            powers[base] = powers.get(base, 0) + int(exponent)
    cache[term] = powers
    return powers


def _may_pair(a: sm.Expr, b: sm.Expr, rests: dict, powers: dict) -> bool:
    """Whether ``trig_split(a, b, two=True)`` may combine the two terms. Their rests must
    be equal (:func:`_rest`), and with their common factors taken out (``Factors.normal``:
    a factor of both stays, to the exponents' difference, on the term with the larger
    exponent) each must keep one or two sines or cosines, each to the power one, the two
    terms' sharing an argument: what ``trig_split`` accepts (a cosine and a sine of two
    angles in each, or one of the same angle with a square root)."""
    key_a, key_b = _rest(a, rests), _rest(b, rests)
    if key_a is _ANY or key_b is _ANY:
        return True
    if key_a is not key_b and (hash(key_a) != hash(key_b) or key_a != key_b):
        return False
    powers_a, powers_b = _trig_powers(a, powers), _trig_powers(b, powers)
    if powers_a is None or powers_b is None:
        return True
    left, right = {}, {}
    for f in powers_a.keys() | powers_b.keys():
        if f not in powers_b:
            left[f] = powers_a[f]
        elif f not in powers_a:
            right[f] = powers_b[f]
        elif powers_a[f] > powers_b[f]:
            left[f] = powers_a[f] - powers_b[f]
        elif powers_a[f] < powers_b[f]:
            right[f] = powers_b[f] - powers_a[f]
    for part in (left, right):
        if not 1 <= len(part) <= 2 or any(e != 1 for e in part.values()):
            return False
    return not {f.args[0] for f in left}.isdisjoint(f.args[0] for f in right)


def tr10i(rv: sm.Expr) -> sm.Expr:
    """``sympy.simplify.fu.TR10i(rv)``, the same result in a fraction of the time."""
    return sm.bottom_up(rv, _Pairing().sums)


class _Pairing:
    """TR10i's passes over one expression, with what they learn of its terms kept: each
    term's rest and sines and cosines (:func:`_may_pair`) and each pair's ``trig_split``
    (a pair is tried again after each hit in its sum)."""

    def __init__(self) -> None:
        self.rests: dict = {}
        self.powers: dict = {}
        self.splits: dict = {}

    def sums(self, rv: sm.Expr) -> sm.Expr:
        """TR10i on one node: its terms paired within the groups of equal free symbols,
        then the pairs whose coefficients are in the ratio sqrt(3) : 1."""
        if not rv.is_Add:
            return rv
        # TR10i groups the terms by ``tuple(ordered(free_symbols))``: equal exactly where
        # the sets are, and the groups are taken in the order they are met.
        rv = process_common_addends(rv, self.pair, lambda x: frozenset(x.free_symbols))
        while rv.is_Add:
            byrad = defaultdict(list)
            for a in rv.args:
                hit = 0
                if a.is_Mul:
                    for ai in a.args:
                        if ai.is_Pow and ai.exp is sm.S.Half and ai.base.is_Integer:
                            byrad[ai].append(a)
                            hit = 1
                            break
                if not hit:
                    byrad[sm.S.One].append(a)
            args = self._radical_pairs(byrad)
            if args:
                rv = sm.Add(*(args + [sm.Add(*[_f for _f in v if _f]) for v in byrad.values()]))
            else:
                rv = self.pair(rv)
                break
        return rv

    def _radical_pairs(self, byrad: dict) -> list:
        """The sums of the terms of ``byrad`` (terms by their square root of an integer)
        whose radicals are in the ratio sqrt(3) : 1 and that combine, each pair's terms
        taken out of ``byrad``."""
        args = []
        for a in byrad:
            for b in [_ROOT3() * a, _invROOT3()]:
                if b in byrad:
                    for i in range(len(byrad[a])):
                        if byrad[a][i] is None:
                            continue
                        for j in range(len(byrad[b])):
                            if byrad[b][j] is None:
                                continue
                            was = sm.Add(byrad[a][i] + byrad[b][j])
                            new = self.pair(was)
                            if new != was:
                                args.append(new)
                                byrad[a][i] = None
                                byrad[b][j] = None
                                break
        return args

    def pair(self, rv: sm.Expr) -> sm.Expr:
        """TR10i's ``do``: a sum of two terms combined into one sine or cosine where
        ``trig_split`` finds them to be one; a longer sum's terms paired in order, each
        with the first later term it combines with, until none do."""
        if not rv.is_Add:
            return rv
        if len(rv.args) == 2 and not _may_pair(*rv.args, self.rests, self.powers):
            return rv  # trig_split would find nothing to combine (in either order)
        args = list(ordered(rv.args))
        if len(args) == 2:
            return self._combined(args[0], args[1], rv)
        hit = False
        for i, j in self._candidates(args):
            ai, aj = args[i], args[j]
            if ai is None or aj is None or not _may_pair(ai, aj, self.rests, self.powers):
                continue
            was = ai + aj
            new = self.pair(was)
            if new != was:
                args[i] = new
                args[j] = None
                hit = True
        if hit:
            rv = sm.Add(*[_f for _f in args if _f])
            if rv.is_Add:
                rv = self.pair(rv)
        return rv

    def _candidates(self, args: list) -> Iterator[tuple[int, int]]:
        """TR10i's pairs ``(i, j)``, ``i < j``, in its order, but only those whose terms'
        rests (:func:`_rest`) are equal or not judged: the others :func:`_may_pair` turns
        down, and a sum of hundreds of terms has tens of thousands. After a hit at ``(i,
        j)`` TR10i goes on to ``i + 1``: the caller's ``args[i]`` then stops being the
        original term, which this notices by identity."""
        keys = [_rest(a, self.rests) for a in args]
        by_key: dict = defaultdict(list)
        judged_none = []
        for k, key in enumerate(keys):
            (judged_none if key is _ANY else by_key[key]).append(k)
        for i, term in enumerate(args):
            if term is None:
                continue
            if keys[i] is _ANY:
                later = range(i + 1, len(args))
            else:
                same = by_key[keys[i]]
                later = heapq.merge(same[bisect.bisect_right(same, i):],
                                    judged_none[bisect.bisect_right(judged_none, i):])  # fmt: skip
            for j in later:
                if args[i] is not term:
                    break  # a hit: on to the next i
                yield i, j

    def _combined(self, first: sm.Expr, second: sm.Expr, rv: sm.Expr) -> sm.Expr:
        """Two terms as one sine or cosine of a sum or difference of their angles, where
        ``trig_split`` finds them so (``rv``, their sum, where it does not)."""
        pair = (first, second)
        if pair not in self.splits:
            self.splits[pair] = trig_split(first, second, two=True)
        split = self.splits[pair]
        if not split:
            return rv
        gcd, n1, n2, a, b, same = split
        if same:
            gcd = n1 * gcd
            if n1 == n2:
                return gcd * sm.cos(a - b)
            return gcd * sm.cos(a + b)
        gcd = n1 * gcd
        if n1 == n2:
            return gcd * sm.sin(a + b)
        return gcd * sm.sin(b - a)
