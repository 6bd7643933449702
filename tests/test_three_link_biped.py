"""The three-link biped (derive/models/three_link_biped.py) against physics its derivation
did not use: the mass matrix, Coriolis and gravity terms typed in from Westervelt et al.
2007's form (tests/oracles/three_link_biped.py), the impact by the extended-coordinates
rule with a hand-written foot Jacobian, the angular momentum about the new stance foot
through the impact, and the energy balance of a powered motion (the change of T + V is the
inputs' power integrated)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.oracles import three_link_biped as oracle
from vsw.models import load

RNG = np.random.default_rng(20010101)


@pytest.fixture(scope="module")
def walker():
    return load("three_link_biped")


def _params(walker) -> tuple[float, ...]:
    return walker.parameters(oracle.DEFAULTS)


def _states(count: int) -> np.ndarray:
    q = RNG.uniform([-0.5, -0.5, -0.4], [0.5, 0.5, 0.9], size=(count, 3))
    qd = RNG.uniform(-2.0, 2.0, size=(count, 3))
    return np.hstack([q, qd])


def test_parameters_are_the_papers(walker):
    names = [p.name for p in walker.parameter_table]
    assert dict(zip(names, walker.parameters())) == oracle.DEFAULTS


@pytest.mark.parametrize("params", [oracle.DEFAULTS, {**oracle.DEFAULTS, "m_t": 3.0, "l": 0.8}])
def test_accelerations_are_the_books_equations(walker, params):
    """D q'' + C q' + G = B u with the book's D, C, G, for passive and powered motion."""
    p = walker.parameters(params)
    for x in _states(20):
        u = RNG.uniform(-30.0, 30.0, size=2)
        passive = np.array(walker.module.stance_accelerations(*p, *x), float)
        gains = np.array(walker.module.stance_input_gains(*p, *x), float).reshape(3, 2)
        expected = oracle.accelerations(x[:3], x[3:], u, params)
        assert np.allclose(passive + gains @ u, expected, rtol=0, atol=1e-11)


def test_energy_is_the_books(walker):
    p = _params(walker)
    for x in _states(10):
        got = walker.energy("stance", p, x)
        assert got == pytest.approx(oracle.energy(x[:3], x[3:]), rel=1e-13, abs=1e-12)


def test_energy_change_is_the_inputs_work(walker):
    """Under a state feedback the inputs do work along theta3 - theta1 and theta3 - theta2:
    T + V changes by the integral of u . (rates) (the power integrated with the motion)."""
    from scipy.integrate import solve_ivp

    p = _params(walker)
    mod = walker.module

    def torque(x):
        return np.array([-40.0 * (x[2] - 0.5) - 5.0 * x[5], 20.0 * math.sin(3 * x[1]) - x[4]])

    def rhs(_t, z):
        x = z[:6]
        u = torque(x)
        acc = np.array(mod.stance_accelerations(*p, *x), float)
        acc += np.array(mod.stance_input_gains(*p, *x), float).reshape(3, 2) @ u
        power = float(u @ np.array(mod.stance_input_rates(*p, *x), float))
        return np.concatenate([x[3:], acc, [power]])

    x0 = np.array([-0.3, 0.3, 0.5, 1.2, -0.4, 0.2])
    sol = solve_ivp(rhs, (0.0, 0.6), np.concatenate([x0, [0.0]]), method="DOP853",
                    rtol=1e-12, atol=1e-12)  # fmt: skip
    end = sol.y[:, -1]
    change = walker.energy("stance", p, end[:6]) - walker.energy("stance", p, x0)
    assert abs(end[6]) > 1.0  # the inputs do work worth testing
    assert change == pytest.approx(end[6], abs=1e-9)
    # The rates the inputs act along are the relative angles' (the book's B).
    rates = np.array(mod.stance_input_rates(*p, *x0), float)
    assert np.allclose(rates, [x0[5] - x0[3], x0[5] - x0[4]], atol=1e-15)


def test_impact_is_the_papers_and_conserves_angular_momentum(walker):
    p = _params(walker)
    for _ in range(10):
        t = RNG.uniform(0.1, 0.6)
        x = np.array([t, -t, RNG.uniform(-0.3, 0.8), *RNG.uniform(-2.0, 2.0, 3)])
        after = walker.reset("heelstrike", p, x)
        q_plus, qd_plus = oracle.impact(x[:3], x[3:])
        assert np.allclose(after[:3], q_plus, atol=1e-14)
        assert np.allclose(after[3:], qd_plus, rtol=0, atol=1e-12)
        # About the swing foot just before = about the new stance foot just after.
        before = oracle.angular_momentum(x[:3], x[3:], oracle.swing_foot(x[:3]))
        assert oracle.angular_momentum(after[:3], after[3:], (0, 0)) == pytest.approx(
            before, rel=1e-12
        )
        # A plastic impact loses kinetic energy.
        assert walker.energy("stance", p, after) < walker.energy("stance", p, x)


def test_angular_momentum_is_the_unactuated_momentum():
    """The oracle's angular momentum about the stance foot is (1, 1, 1) D q' (B_perp's
    momentum, which the zero-dynamics oracle integrates): two hand routes agree."""
    for x in _states(5):
        left = oracle.angular_momentum(x[:3], x[3:], (0, 0))
        assert left == pytest.approx(np.sum(oracle.mass_matrix(x[:3]) @ x[3:]), rel=1e-13)


def test_step_geometry(walker):
    p = _params(walker)
    x = np.array([math.pi / 8, -math.pi / 8, 0.5, 1.0, 0.0, 0.0])
    assert walker.step_length(p, x) == pytest.approx(2 * math.sin(math.pi / 8), rel=1e-15)
