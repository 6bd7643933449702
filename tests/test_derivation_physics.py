"""Physics checks the derivation did not use (in the spirit of Drake's compass-gait tests).

Each test derives the same fact another way: Newton instead of Lagrange, an impulse
instead of a momentum balance, the law of cosines instead of foot positions, a numerical
quadrature instead of Carlson's form.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
import sympy as sm
from scipy.integrate import quad

import generated.ile as gen
from derive import mechanics
from derive.engine.algebra import expand
from derive.engine.dynamics import phase_dynamics, rate_symbol
from derive.engine.model import Jump
from derive.engine.resets import _jump_turn, jump_reset
from derive.models import ile
from derive.models import vsw_biped as biped
from derive.models import vsw_biped_phi0 as caught
from tests.conftest import random_walking_parameters


def test_energy_is_constant_along_a_swing_phase():
    # The engine's equation of motion and energy of a stance phase (Lagrange's equations from
    # sympy.physics.mechanics): dE/dt = (dE/dtheta) omega + (dE/domega) theta'' = 0.
    m, g, r = sm.symbols("m g r", positive=True)
    dyn = phase_dynamics(ile.stance_phase("test", r, m, g))
    theta, omega = ile.THETA.q, ile.THETA.u
    rate = dyn.energy.diff(theta) * omega + dyn.energy.diff(omega) * dyn.accelerations[0]
    assert sm.simplify(rate) == 0


def test_equation_of_motion_matches_newton_tangential_balance():
    # Tangential component of gravity on the hip, m g sin(theta), over m r.
    m, g = sm.symbols("m g", positive=True)
    dyn = phase_dynamics(ile.stance_phase("test", ile.beta, m, g, ile.r_e))
    newton = g * sm.sin(ile.theta) / (ile.beta * ile.r_e)
    assert sm.simplify(dyn.accelerations[0] - newton) == 0
    dimensionless = ile.swing_phase_dimensionless()["accel"].subs(ile.leg_ratio, ile.beta)
    assert sm.simplify(dimensionless - sm.sin(ile.theta) / ile.beta) == 0
    # The leg force from the radial balance of the hip mass: m (g cos(theta) - r omega**2),
    # what the actuator holding the leg length must push.
    leg_force = m * (g * sm.cos(ile.theta) - ile.beta * ile.r_e * ile.THETA.u**2)
    assert sm.simplify(dyn.actuator_forces[ile.r] - leg_force) == 0


def test_radial_extension_force_exerts_no_moment_about_the_foot():
    # Why eq. (3) may conserve angular momentum: the leg force is along the leg.
    r, f = sm.symbols("r f", positive=True)
    along_leg = mechanics.leg_direction(ile.theta)
    assert sm.simplify(mechanics.cross_z(r * along_leg, f * along_leg)) == 0


def test_heelstrike_reset_from_an_impulse_along_the_new_leg():
    # Inelastic impact: an impulse J along the new stance leg (massless leg) removes the
    # hip velocity component along that leg. Not a momentum balance, a velocity projection.
    b, p = ile.beta, ile.phi0
    th_I = ile.theta_I
    th_IV = th_I + p
    w = sm.Symbol("w", positive=True)
    v_before = w * sm.Matrix([sm.cos(th_IV), -sm.sin(th_IV)])  # r_e = 1
    n = mechanics.leg_direction(th_I)  # from new foot to hip
    J = sm.Symbol("J")
    v_after = v_before + J * n
    J_value = mechanics.solve_linear(mechanics.pythagorean_reduce((v_after.T * n)[0]), J)
    v_after = v_after.subs(J, J_value)
    tangent = sm.Matrix([sm.cos(th_I), -sm.sin(th_I)])
    omega_after = sm.simplify((v_after.T * tangent)[0] / b)  # leg length r_s = beta r_e
    derived = ile.heelstrike()["reset_ratio"] * w
    assert sm.simplify(sm.expand_trig(omega_after - derived)) == 0
    # The impulse pushes (J > 0): the ground can only push.
    assert sm.simplify(J_value - w * sm.sin(p)) == 0


def test_step_length_is_the_law_of_cosines():
    # Triangle: stance leg r_e, swing leg r_s = beta r_e, included angle phi0.
    law = 1 + ile.beta**2 - 2 * ile.beta * sm.cos(ile.phi0)
    assert sm.simplify(ile.heelstrike()["step_length_squared"] - law) == 0


def test_contact_angles_satisfy_the_guard():
    hs = ile.heelstrike()
    theta_IV_closed = sm.atan2(hs["sin_theta_IV"], hs["cos_theta_IV"])
    guard = hs["guard"].subs(ile.theta_IV, theta_IV_closed)
    rng = np.random.default_rng(0)
    for b, p in rng.uniform([0.05, 0.05], [0.99, 1.5], (50, 2)):
        assert abs(float(guard.subs({ile.beta: b, ile.phi0: p}).evalf())) < 1e-14


def test_stride_map_is_linear_in_q():
    f = ile.stride()["stride_map"]
    assert sm.diff(f, ile.q, 2) == 0


def _omega(theta, level, rho):
    # phase_energy = rho^2 omega^2 / 2 + rho cos theta, solved for omega.
    return np.sqrt(2 * (level - rho * np.cos(theta)) / rho**2)


def _time(level, rho, start, end):
    integrand = lambda x: 1 / _omega(x, level, rho)  # noqa: E731
    return quad(integrand, start, end, epsabs=0, epsrel=1e-13, limit=200)[0]


def test_phase_times_match_numerical_quadrature():
    """Carlson closed form vs adaptive quadrature of dtheta / omega with omega from the energy."""
    draws = random_walking_parameters(40, seed=5)
    for b, t, p in zip(draws["beta"], draws["theta_II"], draws["phi0"]):
        qf = gen.q_fixed(b, t, p)
        th_I, th_IV = gen.theta_I(b, p), gen.theta_IV(b, p)
        level_1 = gen.phase_energy(th_I, np.sqrt(qf), b)
        omega_III = gen.extension_reset(b, np.sqrt(gen.omega_II_squared(b, t, p, qf)))
        level_2 = gen.phase_energy(t, omega_III, 1.0)

        t1 = _time(level_1, b, th_I, t)
        t2 = _time(level_2, 1.0, t, th_IV)
        d1, d2 = gen.phase_durations(b, t, p, qf)
        assert d1 == pytest.approx(t1, rel=1e-10)
        assert d2 == pytest.approx(t2, rel=1e-10)


def test_closest_to_apex_cosine_is_the_largest_cosine_on_the_interval():
    """closest_to_apex_cos (a maximum with an indicator) against sampling cos over [lo, hi]."""
    s_lo, c_lo, s_hi, c_hi = sm.symbols("s_lo c_lo s_hi c_hi", real=True)
    form = sm.lambdify((s_lo, c_lo, s_hi, c_hi), ile.closest_to_apex_cos(s_lo, c_lo, s_hi, c_hi))
    rng = np.random.default_rng(13)
    ends = np.sort(rng.uniform(-1.5, 1.5, (500, 2)), axis=1)
    ends[:5] = [[-0.3, 0.0], [0.0, 0.4], [0.2, 0.9], [-1.2, -0.1], [-0.5, 0.5]]
    for lo, hi in ends:
        sampled = np.cos(np.linspace(lo, hi, 20001)).max()
        value = form(np.sin(lo), np.cos(lo), np.sin(hi), np.cos(hi))
        assert value == pytest.approx(max(sampled, 1.0 if lo <= 0 <= hi else sampled), abs=1e-8)


def test_staged_quantity_explicit_form_equals_the_explicit_derivation(ile_derivation):
    """Quantity.explicit() of the staged fixed_point_conditions against q_fixed, eigenvalue
    and the condition margins of the same derivation, at random walking sets."""
    d = ile_derivation
    staged = d.quantities["fixed_point_conditions"]
    assert staged.intermediates
    explicit = staged.explicit()
    assert not any(e.has(*(s for s, _ in staged.intermediates)) for e in explicit)
    args = (ile.beta, ile.theta_II, ile.phi0)
    reference = (d.quantities["q_fixed"].expr, d.quantities["eigenvalue"].expr)
    reference += tuple(c.margin for c in d.conditions)
    f_staged, f_ref = sm.lambdify(args, explicit), sm.lambdify(args, reference)
    p = random_walking_parameters(20, seed=17)
    for b, t, f in zip(p["beta"], p["theta_II"], p["phi0"]):
        np.testing.assert_allclose(f_staged(b, t, f), f_ref(b, t, f), rtol=1e-9, atol=1e-12)


def test_a_fast_jumps_turn_is_the_integral_of_its_coupling():
    """Jump(limit=True)'s closed form (an arctangent, derive.engine.resets._jump_turn)
    against SciPy's quadrature of ``-M_qr / M_qq`` over the leg's length (both from the
    caught VSW biped's momentum), on a grid that reaches heavy legs whose mass sits near the
    foot (the inertia's complex roots then come near the path)."""
    dyn = phase_dynamics(caught.CAUGHT_SHORT)
    turn = _jump_turn("extension", dyn, caught.CAUGHT_SHORT, caught.CAUGHT_LONG)[caught.theta]
    momentum = dyn.momenta[caught.theta]
    slope = -momentum.diff(rate_symbol(caught.r)) / momentum.diff(caught.THETA.u)
    symbols = (caught.beta, caught.phi0, caught.mu, caught.b)
    closed = sm.lambdify(symbols, turn)
    integrand = sm.lambdify((caught.r, caught.theta, *symbols), slope.subs(caught.phi, caught.phi0))
    grid = itertools.product((0.3, 0.9, 0.99), (0.1, 1.0, 1.5), (0.01, 10.0, 100.0),
                             (0.01, 0.3, 0.9))  # fmt: skip
    for beta, phi0, mu, b in grid:
        reference, _ = quad(integrand, beta, 1.0, args=(0.3, beta, phi0, mu, b),
                                epsabs=0, epsrel=1e-13, limit=200)  # fmt: skip
        assert closed(beta, phi0, mu, b) == pytest.approx(reference, rel=1e-12, abs=1e-300)


def test_a_fast_jump_of_the_free_hip_biped_has_no_limit_the_engine_derives():
    """The held-hip biped's swing leg is free through the extension: its inertia depends on
    the legs' angles, and a fast extension has no limit (its hip would need ever more work,
    tests/test_vsw_biped.py), so the engine refuses ``Jump(limit=True)`` there."""
    events = tuple(dataclasses.replace(e, reset=Jump(limit=True)) if e.name == "extension"
                   else e for e in biped.MODEL.events)  # fmt: skip
    model = dataclasses.replace(biped.MODEL, events=events)
    with pytest.raises(ValueError, match="kinetic energy depends on the free coordinates"):
        jump_reset(model, "extension")


def test_a_fast_jump_whose_other_held_coordinate_follows_the_walker_is_refused():
    """A hip held on a profile of the stance angle (phi = phi0 + theta / 2) makes the
    kinetic energy depend on theta once held: the fast extension has no limit the engine
    derives, and it says so rather than integrating with theta inside the turn."""
    phases = tuple(
        dataclasses.replace(p, held={**p.held, caught.phi: caught.phi0 + caught.theta / 2})
        if caught.phi in p.held else p for p in caught.MODEL.phases
    )  # fmt: skip
    model = dataclasses.replace(caught.MODEL, phases=phases)
    with pytest.raises(ValueError, match="other held coordinates constant"):
        jump_reset(model, "extension")


def test_the_engines_expansion_by_symengine_is_sympys():
    """The engine expands with SymEngine and converts back (``expand``); its output is
    printed into generated code, so it must be sympy's own canonical expansion, node for
    node, for the forms the models produce: sines and cosines of sums, the TLE's atan,
    rational powers, symbols with assumptions."""
    a, b = sm.symbols("a b", real=True)
    c = sm.Symbol("c", positive=True)
    forms = [
        (sm.sin(a - b) + 2 * sm.cos(a) * c) ** 3 * (a - sm.Rational(1, 3) * b),
        sm.atan(c * a + 1) ** 2 * (sm.cos(2 * a) - c) ** 2 / (c + 1),
        sm.sqrt(c) * (c ** sm.Rational(3, 2) - a * sm.sin(b)) ** 2 - a / c**2,
    ]
    for form in forms:
        ours = expand(form)
        assert ours == sm.expand(form)
        assert sm.srepr(ours) == sm.srepr(sm.expand(form))
        assert {s.name: s.assumptions0 for s in ours.free_symbols} == {
            s.name: s.assumptions0 for s in form.free_symbols
        }
