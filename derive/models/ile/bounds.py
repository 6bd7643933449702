"""The ILE's bounds on q over a step: getting over the apex, eq. (14) and its exact form for
either sign of theta_I and theta_II, and keeping the stance foot on the ground (the lift-off
bound the paper draws in Fig. 9 without an equation)."""

from __future__ import annotations

import functools

import sympy as sm

from derive import mechanics
from derive.models.common import closest_to_apex_cos
from derive.models.ile.model import beta, leg_ratio, omega, q, theta, theta_I, theta_II
from derive.models.ile.phases import (
    eliminate_contact_angles,
    heelstrike,
    omega_squared_along,
    phase_energy,
    square_symbol,
    swing_phase_dimensionless,
)
from derive.models.ile.stride_map import stride


@functools.cache
def apex_and_contact() -> dict[str, sm.Expr]:
    """Getting over the apex, eq. (14), and keeping the stance foot on the ground.

    ``omega**2`` along a phase falls as ``cos theta`` rises, so its minimum is at the
    angle of the phase closest to the apex. The stance foot stays down while the normal
    force ``N = (3 cos theta - 2 E) cos theta`` (from the radial balance and the energy
    integral) is non-negative; ``N`` is convex in ``cos theta``.
    """
    st = stride()
    # Paper-shaped (14): the apex is crossed in phase I-II when theta_II >= 0 ...
    apex_in_first = mechanics.solve_linear(omega_squared_along(beta, theta_I, q, 0), q)
    # ... and in phase III-IV when theta_II < 0.
    omega_after_apex = omega_squared_along(1, theta_II, st["omega_III_squared"], 0)
    apex_in_second = sm.expand(mechanics.solve_linear(omega_after_apex, q))

    # Exact form, valid for either sign of theta_I and theta_II.
    hs = heelstrike()
    sin_I, cos_I = hs["sin_theta_I"], hs["cos_theta_I"]
    sin_IV, cos_IV = hs["sin_theta_IV"], hs["cos_theta_IV"]
    c_star_1 = closest_to_apex_cos(sin_I, cos_I, sm.sin(theta_II), sm.cos(theta_II))
    c_star_2 = closest_to_apex_cos(sm.sin(theta_II), sm.cos(theta_II), sin_IV, cos_IV)
    cstar = sm.Symbol("cstar", real=True)
    w2_first = omega_squared_along(beta, theta_I, q, theta).subs(sm.cos(theta), cstar)
    w2_second = omega_squared_along(1, theta_II, st["omega_III_squared"], theta).subs(
        sm.cos(theta), cstar
    )
    q_first = mechanics.solve_linear(w2_first, q)
    q_second = mechanics.solve_linear(w2_second, q)
    q_apex_exact = sm.Max(
        eliminate_contact_angles(q_first).subs(cstar, c_star_1),
        eliminate_contact_angles(q_second).subs(cstar, c_star_2),
    )

    # Normal force along each phase as a function of c = cos theta.
    phase = swing_phase_dimensionless()
    normal = phase["normal_force"]
    c = sm.Symbol("c", positive=True)
    e_level = sm.Symbol("E", real=True)
    # Express omega**2 through the phase's energy level E = energy / leg_ratio.
    w2 = square_symbol("w2")
    omega_sq_of_c = mechanics.solve_linear(
        phase["energy"].subs(omega**2, w2).subs(sm.cos(theta), c) - e_level * leg_ratio, w2
    )
    normal_of_c = sm.expand(
        normal.subs(omega**2, w2).subs(w2, omega_sq_of_c).subs(sm.cos(theta), c)
    )
    vertex = mechanics.solve_linear(sm.diff(normal_of_c, c), c)

    def level(ratio, theta_at, omega_sq_at):
        return sm.expand(phase_energy(theta_at, omega_sq_at, ratio) / ratio)

    level_1 = level(beta, theta_I, q)
    level_2 = level(1, theta_II, st["omega_III_squared"])
    phases = (
        (level_1, sm.Min(cos_I, sm.cos(theta_II)), c_star_1),
        (level_2, sm.Min(sm.cos(theta_II), cos_IV), c_star_2),
    )
    margins, q_limits = [], []
    for lvl, c_min, c_max in phases:
        lvl = eliminate_contact_angles(lvl)
        at_vertex = sm.Min(sm.Max(vertex.subs(e_level, lvl), c_min), c_max)
        margins.append(normal_of_c.subs(e_level, lvl).subs(c, at_vertex))
        # With c > 0, N >= 0 over [c_min, c_max] exactly when N(c_min) >= 0.
        boundary = sm.expand(normal_of_c.subs(c, c_min) / c_min).subs(e_level, lvl)
        q_limits.append(mechanics.solve_linear(boundary, q))
    return {
        "apex_in_first_phase": apex_in_first,
        "apex_in_second_phase": apex_in_second,
        "q_apex_exact": q_apex_exact,
        "normal_force_of_cos": normal_of_c,
        "contact_margin": sm.Min(*margins),
        "q_liftoff": sm.Min(*q_limits),
    }
