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
    root_lo: sm.Expr,
    c_hi: sm.Expr,
    root_hi: sm.Expr,
    energy_level: sm.Expr,
) -> sm.Expr:
    """``int_{c_lo}^{c_hi} dc / sqrt((1 - c)(1 + c)(E - c))`` in Carlson form.

    Parameters
    ----------
    c_lo, c_hi : sympy.Expr
        Cosines of the two ends, ``c_lo <= c_hi <= 1``.
    root_lo, root_hi : sympy.Expr
        ``sqrt(1 - c)`` at each end, passed in so callers can supply a form without
        cancellation and with the right derivative (see :func:`pendulum_travel_time`).
    energy_level : sympy.Expr
        ``E``, with ``E > c`` on the interval.
    """
    x1, y1 = root_hi, root_lo
    x2, y2 = sm.sqrt(1 + c_hi), sm.sqrt(1 + c_lo)
    x3, y3 = sm.sqrt(energy_level - c_hi), sm.sqrt(energy_level - c_lo)
    n12 = x1 * x2 * y3 + y1 * y2 * x3
    n13 = x1 * x3 * y2 + y1 * y3 * x2
    n14 = x1 * y2 * y3 + y1 * x2 * x3
    return 2 * (root_lo**2 - root_hi**2) * carlson_rf(n12**2, n13**2, n14**2)


def half_chord(sin_theta: sm.Expr, cos_theta: sm.Expr) -> sm.Expr:
    """``sin theta / sqrt(1 + cos theta) = sqrt(2) sin(theta / 2)`` for ``|theta| < pi``.

    Signed like ``theta``, smooth through ``theta = 0``, and its square is ``1 - cos theta``
    without the cancellation of that difference near the apex.
    """
    return sin_theta / sm.sqrt(1 + cos_theta)


def pendulum_travel_time(
    start: tuple[sm.Expr, sm.Expr],
    end: tuple[sm.Expr, sm.Expr],
    energy_level: sm.Expr,
    leg_ratio: sm.Expr,
) -> sm.Expr:
    """Time for ``theta`` to go from ``start`` to ``end`` (start < end) along a phase.

    Parameters
    ----------
    start, end : tuple (sin theta, cos theta)
        The two ends, given by their sine (which also gives the side of the apex) and
        cosine.
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

    Notes
    -----
    ``sqrt(1 - cos theta)`` at an end is ``|h|`` with ``h`` the :func:`half_chord`. Each
    branch knows the sign of its ends, so it uses ``h`` or ``-h`` rather than ``|h|``: the
    time is smooth in the end angles, and so is every branch's expression, which keeps
    automatic derivatives right at an end exactly on the apex (``|h|`` has derivative 0
    there in CasADi).
    """
    sin_a, cos_a = start
    sin_b, cos_b = end
    h_a, h_b = half_chord(sin_a, cos_a), half_chord(sin_b, cos_b)
    through_apex = sm.And(sin_a < 0, sin_b > 0)
    before_apex = sin_b <= 0  # both ends at theta <= 0: the end nearer the apex is b

    def pick(if_through, if_before, otherwise):
        return sm.Piecewise((if_through, through_apex), (if_before, before_apex), (otherwise, True))

    apex = (sm.Integer(1), sm.Integer(0))
    # (cos, sqrt(1 - cos)) of each piece's ends. Before the apex both angles are <= 0 and
    # sqrt(1 - cos) = -h; after it (the otherwise branch) both are >= 0 and it is h.
    end_a_left, end_b_left = (cos_a, -h_a), (cos_b, -h_b)
    end_a_right, end_b_right = (cos_a, h_a), (cos_b, h_b)
    first_lo = [pick(a, a, b) for a, b in zip(end_a_left, end_b_right)]
    first_hi = [pick(x, b, a) for x, b, a in zip(apex, end_b_left, end_a_right)]
    first = cos_interval_integral(first_lo[0], first_lo[1], first_hi[0], first_hi[1], energy_level)
    # Second piece: from b to the apex when the phase passes it, else empty (b to b).
    second_hi = [sm.Piecewise((x, through_apex), (b, True)) for x, b in zip(apex, end_b_right)]
    second = cos_interval_integral(
        end_b_right[0], end_b_right[1], second_hi[0], second_hi[1], energy_level
    )
    return sm.sqrt(leg_ratio / 2) * (first + sm.Piecewise((second, through_apex), (0, True)))
