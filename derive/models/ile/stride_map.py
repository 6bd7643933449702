"""The ILE's stride map and its fixed point: the two energy integrals and the two resets
chained into the map of ``q = omega_I**2``, eq. (7)-(10), its eigenvalue (19), and the forms
of the fixed point that evaluate without cancellation."""

from __future__ import annotations

import functools
import random

import sympy as sm

from derive import mechanics
from derive.engine.hybrid import stride_closed_form
from derive.models.ile.model import MODEL, beta, phi0, q, theta_I, theta_II, theta_IV
from derive.models.ile.phases import (
    eliminate_contact_angles,
    extension_reset,
    heelstrike,
    omega_squared_along,
    same_value,
)


@functools.cache
def stride() -> dict[str, sm.Expr]:
    """Chain the two energy integrals and the two resets into the stride map, eq. (7)-(10), (19).

    All results are in terms of ``q = omega_I**2`` (eq. 8), the parameters, and the
    symbol ``theta_I`` (eq. 11), as the paper writes them.
    """
    hs = heelstrike()
    ext = extension_reset()
    omega_II_sq = omega_squared_along(beta, theta_I, q, theta_II)
    omega_III_sq = sm.expand(ext**2 * omega_II_sq)
    omega_IV_sq = omega_squared_along(1, theta_II, omega_III_sq, theta_IV)
    # Guard: the hip height is the same on both legs, cos theta_IV = beta cos theta_I (eq. 5).
    cos_IV_from_guard = mechanics.solve_linear(hs["hip_height_condition"], sm.cos(theta_IV))
    omega_IV_sq = sm.expand(omega_IV_sq.subs(sm.cos(theta_IV), cos_IV_from_guard))
    stride_map = sm.expand(hs["reset_ratio"] ** 2 * omega_IV_sq)
    q_fixed = sm.factor(mechanics.solve_linear(sm.Eq(stride_map, q), q))
    eigenvalue = sm.factor(sm.diff(stride_map, q))
    return {
        "omega_II_squared": omega_II_sq,
        "omega_III_squared": omega_III_sq,
        "omega_IV_squared": omega_IV_sq,
        "stride_map": stride_map,
        "q_fixed": q_fixed,
        "eigenvalue": eigenvalue,
    }


@functools.cache
def one_minus_eigenvalue() -> sm.Expr:
    """``1 - lambda = 1 - beta**2 cos**2 phi0`` as ``(1 - beta)(1 + beta) + beta**2 sin**2 phi0``.

    For short steps (phi0 -> 0, beta -> 1) the first form rounds cos phi0 to 1 and loses
    the ``beta**2 sin**2 phi0`` part (all of it at phi0 = 1e-8); the second is a sum of two
    non-negative terms, each computed to a few ulp (1 - beta is exact for beta >= 1/2).
    """
    form = (1 - beta) * (1 + beta) + beta**2 * sm.sin(phi0) ** 2
    return same_value(form, 1 - stride()["eigenvalue"], "1 - lambda")


def fixed_point_offset() -> sm.Expr:
    """``f(0)``, the stride map (9) at ``q = 0``, grouped by ``cos theta_I`` and
    ``cos theta_II``: the numerator of the fixed point (10) over ``1 - lambda``."""
    offset = sm.expand(stride()["stride_map"].subs(q, 0))
    return sm.collect(offset, [sm.cos(theta_I), sm.cos(theta_II)], sm.factor)


def check_engine_stride() -> None:
    """The engine's stride map (:func:`derive.engine.hybrid.stride_closed_form`) equals the
    paper-shaped one of :func:`stride`, eq. (9) with (11) (numerically, at random walking
    parameter sets)."""
    engine = stride_closed_form(MODEL)
    if engine is None:
        raise AssertionError("the engine finds no closed-form stride map for the ILE")
    st = stride()
    ours = eliminate_contact_angles(st["stride_map"]).subs(theta_I, heelstrike()["theta_I"])
    rng = random.Random(7)
    for _ in range(6):
        point = {
            beta: sm.Float(rng.uniform(0.55, 0.95), 30),
            phi0: sm.Float(rng.uniform(0.5, 1.0), 30),
            theta_II: sm.Float(rng.uniform(-0.05, 0.2), 30),
            q: sm.Float(rng.uniform(0.2, 1.0), 30),
        }
        mine = (engine.slope * q + engine.offset).xreplace(point).evalf(30)
        paper = ours.xreplace(point).evalf(30)
        if abs(mine - paper) > 1e-20:
            raise AssertionError(f"engine stride map {mine} != paper-shaped {paper} at {point}")
