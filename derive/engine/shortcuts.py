"""Two of sympy's answers without their detours, the same answers: what a sum's sort key
and the elimination of common subexpressions ask of every coefficient and product.

* ``complex(r)`` of a Rational (``Expr.sort_key`` turns each term's coefficient into a
  complex, through ``as_ordered_terms``): sympy evaluates ``r`` as a Float and then asks
  that Float for its real and imaginary parts through the assumptions system, a sixth of
  eliminating the TLE's largest function. A Float's parts are itself and zero:
  :func:`rational_complex` takes the same Float's value.
* ``could_extract_minus_sign`` of a product (asked of every product by ``cse`` and by the
  sign test of every sum): sympy builds ``-p`` to see whether ``p == -p`` (true only for a
  product holding ``zoo``) before it looks at the coefficient, and then asks the
  coefficient's assumptions whether it is negative (a Rational's are deduced anew for each
  new number): 15 % of printing the TLE. :func:`product_minus_sign` looks at the
  coefficient of a product without ``zoo`` or ``nan`` (where negating changes the
  coefficient, so ``p != -p``), at a Rational's numerator, and asks sympy for the rest.

Both are sympy 1.14's definitions (the version :mod:`derive.manifest` pins) with the detour
left out; the tests compare them with sympy's own.
"""

from __future__ import annotations

import sympy as sm
from sympy.core.mul import Mul

__all__ = ["install", "product_minus_sign", "rational_complex"]

_SYMPY_MINUS_SIGN = Mul.could_extract_minus_sign


def rational_complex(self: sm.Rational) -> complex:
    """``Expr.__complex__`` for a Rational: its Float (``evalf``, 15 digits) as the real
    part, 0 as the imaginary part."""
    return complex(float(self.evalf()), 0.0)


def product_minus_sign(self: Mul) -> bool:
    """``Mul.could_extract_minus_sign``: a product whose coefficient is a negative number
    (sympy's own for a subclass of Mul, or a product holding ``zoo`` or ``nan``)."""
    if type(self) is not Mul or any(a is sm.S.ComplexInfinity or a is sm.S.NaN
                                    for a in self.args):  # fmt: skip
        return _SYMPY_MINUS_SIGN(self)
    c = self.args[0]
    if c.is_Rational:  # sympy asks the assumptions of each new Rational: the sign of p
        return c.p < 0
    return c.is_Number and c.is_extended_negative


def install() -> None:
    """Put :func:`rational_complex` as Rational's (and so Integer's) ``complex`` and
    :func:`product_minus_sign` as Mul's ``could_extract_minus_sign``."""
    sm.Rational.__complex__ = rational_complex
    Mul.could_extract_minus_sign = product_minus_sign
