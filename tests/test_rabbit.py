"""RABBIT (derive/models/rabbit.py): the physics its derivation did not use, against the
hand-written mechanics of tests/oracles/rabbit.py (numpy, from the published kinematics).

Sources: Chevallereau et al. 2003, "RABBIT: a testbed for advanced control theory", IEEE
Control Systems Magazine 23(5), the parameter table (the links' masses, lengths, mass
centres and inertias); Westervelt et al. 2007, "Feedback Control of Dynamic Bipedal Robot
Locomotion", chapter 3 (the rigid impact on extended coordinates).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.oracles.rabbit import Rabbit

gen = pytest.importorskip("generated.rabbit", reason="RABBIT's package is not generated")

ORACLE = Rabbit()


def params() -> tuple[float, ...]:
    """The defaults, by name from the generated table, checked against the oracle's."""
    from generated.rabbit.params import PARAMETERS

    values = {p.name: p.default for p in PARAMETERS}
    for name in ("m_torso", "m_femur", "m_tibia", "i_torso", "i_femur", "i_tibia",
                 "l_femur", "l_tibia", "c_torso", "c_femur", "c_tibia", "g"):  # fmt: skip
        assert values[name] == getattr(ORACLE, name), name
    return tuple(values[p.name] for p in PARAMETERS)


def configurations(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform(-1.2, 1.2, size=(n, 5))


def energy(q: np.ndarray, u: np.ndarray) -> float:
    return float(gen.single_support_energy(*params(), *q, *u))


def generated_mass_matrix(q: np.ndarray) -> np.ndarray:
    """The Hessian of the generated energy in the rates (it is quadratic in them)."""
    zero = np.zeros(5)
    base = energy(q, zero)
    e = np.eye(5)
    single = [energy(q, e[i]) - base for i in range(5)]
    m = np.empty((5, 5))
    for i in range(5):
        for j in range(5):
            if i == j:
                m[i, j] = 2 * single[i]
            else:
                m[i, j] = energy(q, e[i] + e[j]) - base - single[i] - single[j]
    return m


def test_the_mass_matrix_is_the_hand_written_one_symmetric_and_positive_definite():
    for q in configurations(20, seed=3):
        m = generated_mass_matrix(q)
        wanted = ORACLE.mass_matrix(q)
        assert np.allclose(m, wanted, rtol=1e-11, atol=1e-11), (q, m - wanted)
        assert np.allclose(m, m.T, atol=1e-12)
        assert np.linalg.eigvalsh(wanted).min() > 0


def test_the_potential_energy_of_two_postures_by_hand():
    """All links vertical: the tibias' mass centres 0.4 - 0.24 = 0.16 m up (both legs
    overlap), the femurs' 0.8 - 0.11 = 0.69 m, the torso's 0.8 + 0.24 = 1.04 m:
    g (2 * 3.2 * 0.16 + 2 * 6.8 * 0.69 + 12 * 1.04) = 9.81 * 22.888 J. The torso
    horizontal: its mass centre at the hip's 0.8 m, 9.81 * 20.008 J."""
    upright = np.zeros(5)
    assert energy(upright, np.zeros(5)) == pytest.approx(9.81 * 22.888, rel=1e-13)
    lying = np.array([0.0, 0.0, np.pi / 2, 0.0, 0.0])
    assert energy(lying, np.zeros(5)) == pytest.approx(9.81 * 20.008, rel=1e-13)


def _fall(q0: np.ndarray, u0: np.ndarray, seconds: float):
    from scipy.integrate import solve_ivp

    p = params()

    def flow(_t, x):
        acc = np.array(gen.single_support_accelerations(*p, *x), dtype=float).ravel()
        return np.concatenate([x[5:], acc])

    return solve_ivp(flow, (0.0, seconds), np.concatenate([q0, u0]), method="DOP853",
                     rtol=1e-12, atol=1e-12, dense_output=True)  # fmt: skip


def test_energy_is_conserved_over_a_passive_fall():
    """Zero inputs: the walker folds under gravity (knees buckle, the torso tips); the
    oracle's T + V stays constant along the generated accelerations' flow."""
    q0 = np.array([-0.15, 0.1, 0.2, 0.25, 0.4])
    u0 = np.array([0.8, 0.5, -0.3, -1.0, 0.6])
    sol = _fall(q0, u0, 0.4)
    assert sol.success
    start = ORACLE.energy(q0, u0)
    for t in np.linspace(0.0, 0.4, 9):
        x = sol.sol(t)
        assert ORACLE.energy(x[:5], x[5:]) == pytest.approx(start, rel=1e-9, abs=1e-9)
    # It did move: the potential energy changed by joules.
    assert abs(ORACLE.potential(sol.y[:5, -1]) - ORACLE.potential(q0)) > 1.0


def _landing_state() -> tuple[np.ndarray, np.ndarray]:
    """A configuration with the swing foot on the ground ahead of the stance foot (its
    tibia's angle solved for), the swing foot moving down and forward."""
    from scipy.optimize import brentq

    q = np.array([0.3, 0.25, 0.1, -0.25, 0.0])
    q[4] = brentq(lambda a: ORACLE.swing_foot(np.r_[q[:4], a])[1], -1.0, 0.0)
    u = np.array([1.2, 0.9, 0.1, -0.4, -1.5])
    foot = ORACLE.swing_foot(q)
    assert abs(foot[1]) < 1e-14 and foot[0] > 0.2
    assert (ORACLE.swing_foot_jacobian(q) @ u)[1] < 0  # falling onto the ground
    return q, u


def test_the_impact_is_the_extended_rigid_impact_and_conserves_angular_momentum():
    q, u = _landing_state()
    after = np.array(gen.event_heelstrike_reset(*params(), *q, *u), dtype=float).ravel()
    q_after, u_after = after[:5], after[5:]
    assert np.allclose(q_after, q[[4, 3, 2, 1, 0]], atol=1e-15)  # relabelled, not moved
    v_extended, impulse, u_wanted = ORACLE.impact(q, u)
    assert np.allclose(u_after, u_wanted, rtol=1e-10, atol=1e-10)
    # The landing foot stops: its velocity in the extended coordinates is zero.
    e = np.zeros((2, 7))
    e[:, :5] = ORACLE.swing_foot_jacobian(q)
    e[:, 5:] = np.eye(2)
    assert np.allclose(e @ v_extended, 0.0, atol=1e-12)
    # The ground pushes up on it, and the old stance foot lifts (no impulse there).
    assert impulse[1] > 0
    assert (ORACLE.swing_foot_jacobian(q_after) @ u_after)[1] > 0
    # Angular momentum about the new contact: before in the old chart about the landing
    # foot, after in the new chart about its origin.
    before = ORACLE.angular_momentum(q, u, ORACLE.swing_foot(q))
    assert ORACLE.angular_momentum(q_after, u_after, np.zeros(2)) == pytest.approx(
        before, rel=1e-11
    )
    # A plastic impact loses kinetic energy.
    assert ORACLE.energy(q_after, u_after) < ORACLE.energy(q, u)


def test_the_section_completion_puts_the_new_swing_foot_on_the_ground():
    q = np.array([-0.3, -0.2, 0.1, 0.25, 0.0])
    state = np.r_[q, np.zeros(5)]
    completed = np.array(gen.section_completion(*params(), *state), dtype=float).ravel()
    foot = ORACLE.swing_foot(completed[:5])
    assert abs(foot[1]) < 1e-14 and foot[0] < 0  # behind the stance foot
