"""Travel time of an inverted-pendulum swing phase in closed form (Carlson's R_F).

Model-independent. Along a phase with first integral ``omega**2 = (2/rho) (E - cos theta)``
(an inverted pendulum of leg ratio ``rho`` and energy level ``E``), the time to move
between two angles is ``int dtheta / omega``. Substituting ``c = cos theta`` on a piece
where ``|theta|`` is monotone,

    T = sqrt(rho / 2) * int_y^x dc / sqrt((1 - c) (1 + c) (E - c)),

an incomplete elliptic integral of the first kind with three real linear factors. By
DLMF 19.29.4 (with a fourth factor equal to one) and the homogeneity of R_F (DLMF 19.16.1)

    int_y^x dc / sqrt(prod_j (a_j + b_j c)) = 2 (x - y) R_F(N12**2, N13**2, N14**2),
    N12 = X1 X2 Y3 + Y1 Y2 X3,  N13 = X1 X3 Y2 + Y1 Y3 X2,  N14 = X1 Y2 Y3 + Y1 X2 X3,

with ``X_j = sqrt(a_j + b_j x)`` and ``Y_j = sqrt(a_j + b_j y)``; no division, so it stays
finite as the two ends meet. A phase that passes the apex (``theta = 0``) is split there.
``R_F`` is evaluated at run time by Carlson's duplication algorithm with a fixed number of
steps, which works unchanged on numpy arrays and CasADi expressions.
"""

from __future__ import annotations

import sympy as sm


class carlson_rf(sm.Function):  # noqa: N801 - sympy functions are lower case
    """Carlson's symmetric elliptic integral of the first kind ``R_F(x, y, z)``.

    ``R_F(x, y, z) = 1/2 int_0^inf dt / sqrt((t + x)(t + y)(t + z))`` (DLMF 19.16.1).
    Numerical evaluation (``evalf``) uses mpmath.
    """

    nargs = 3

    def _eval_evalf(self, prec):
        import mpmath

        args = [a.evalf(prec) for a in self.args]
        if not all(a.is_Number for a in args):
            return None
        with mpmath.workprec(prec):
            value = mpmath.elliprf(*[a._to_mpmath(prec) for a in args])
            return sm.Expr._from_mpmath(value, prec)


def cos_interval_integral(
    c_lo: sm.Expr,
    one_minus_c_lo: sm.Expr,
    c_hi: sm.Expr,
    one_minus_c_hi: sm.Expr,
    energy_level: sm.Expr,
) -> sm.Expr:
    """``int_{c_lo}^{c_hi} dc / sqrt((1 - c)(1 + c)(E - c))`` in Carlson form.

    Parameters
    ----------
    c_lo, c_hi : sympy.Expr
        Cosines of the two ends, ``c_lo <= c_hi <= 1``.
    one_minus_c_lo, one_minus_c_hi : sympy.Expr
        ``1 - c`` at each end, passed separately so callers can supply a form without
        cancellation (``2 sin(theta/2)**2``).
    energy_level : sympy.Expr
        ``E``, with ``E > c`` on the interval.
    """
    x1, y1 = sm.sqrt(one_minus_c_hi), sm.sqrt(one_minus_c_lo)
    x2, y2 = sm.sqrt(1 + c_hi), sm.sqrt(1 + c_lo)
    x3, y3 = sm.sqrt(energy_level - c_hi), sm.sqrt(energy_level - c_lo)
    n12 = x1 * x2 * y3 + y1 * y2 * x3
    n13 = x1 * x3 * y2 + y1 * y3 * x2
    n14 = x1 * y2 * y3 + y1 * x2 * x3
    return 2 * (one_minus_c_lo - one_minus_c_hi) * carlson_rf(n12**2, n13**2, n14**2)


def pendulum_travel_time(
    start: tuple[sm.Expr, sm.Expr, sm.Expr],
    end: tuple[sm.Expr, sm.Expr, sm.Expr],
    energy_level: sm.Expr,
    leg_ratio: sm.Expr,
) -> sm.Expr:
    """Time for ``theta`` to go from ``start`` to ``end`` (start < end) along a phase.

    Parameters
    ----------
    start, end : tuple (sin theta, cos theta, 1 - cos theta)
        The two ends, given by their sine (for the side of the apex), cosine and
        ``1 - cos``.
    energy_level : sympy.Expr
        ``E`` in ``omega**2 = (2 / leg_ratio) (E - cos theta)``.
    leg_ratio : sympy.Expr
        Leg length over the reference length ``r_e``.

    Returns
    -------
    sympy.Expr
        At most two R_F evaluations: a phase that passes the apex is split there into
        two pieces that each end at ``c = 1``; otherwise the second piece is empty. The
        pieces' end points are selected first so that vectorised backends, which evaluate
        every branch, evaluate R_F only twice.
    """
    sin_a, cos_a, omc_a = start
    sin_b, cos_b, omc_b = end
    through_apex = sm.And(sin_a < 0, sin_b > 0)
    before_apex = sin_b <= 0  # both ends at theta <= 0: the end nearer the apex is b

    def pick(if_through, if_before, otherwise):
        return sm.Piecewise((if_through, through_apex), (if_before, before_apex), (otherwise, True))

    apex = (sm.Integer(1), sm.Integer(0))
    first_lo = [pick(a, a, b) for a, b in zip((cos_a, omc_a), (cos_b, omc_b))]
    first_hi = [pick(x, b, a) for x, a, b in zip(apex, (cos_a, omc_a), (cos_b, omc_b))]
    first = cos_interval_integral(first_lo[0], first_lo[1], first_hi[0], first_hi[1], energy_level)
    # Second piece: from b to the apex when the phase passes it, else empty (b to b).
    second_hi = [sm.Piecewise((x, through_apex), (b, True)) for x, b in zip(apex, (cos_b, omc_b))]
    second = cos_interval_integral(cos_b, omc_b, second_hi[0], second_hi[1], energy_level)
    return sm.sqrt(leg_ratio / 2) * (first + sm.Piecewise((second, through_apex), (0, True)))
