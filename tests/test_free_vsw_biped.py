"""The VSW biped's body with free actuation (derive/models/free_vsw_biped.py; issue 28,
question 3): its heelstrike against Newton and Euler written out for its three masses.

At heelstrike the new foot sticks, the old foot leaves, and the new stance leg's lower
segment slides freely (a massless segment in a prismatic joint passes no force along the
leg): the walker's angular momentum about the new foot, the old stance leg's about the hip
(only the hip joint acts on it) and the walker's momentum along the new stance leg (the
ground's impulse is across it) do not change. Three balances for the three rates after.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsw.models import load


def _cross(r: np.ndarray, v: np.ndarray) -> float:
    return float(r[0] * v[1] - r[1] * v[0])


def _masses(p, state):
    """(mass, position, velocity) of the hip, stance-leg and swing-leg masses, the stance
    foot at the origin, and the swing foot's position."""
    beta, mu, b, _l_min = p
    theta, psi, r, theta_dot, psi_dot, r_dot = state
    along = np.array([math.sin(theta), math.cos(theta)])
    across = np.array([math.cos(theta), -math.sin(theta)])
    swing_along = np.array([math.sin(psi), math.cos(psi)])
    swing_across = np.array([math.cos(psi), -math.sin(psi)])
    hip = r * along
    v_hip = r_dot * along + r * theta_dot * across
    return [
        (1.0, hip, v_hip),
        (mu, (r - b) * along, r_dot * along + (r - b) * theta_dot * across),
        (mu, hip - b * swing_along, v_hip - b * psi_dot * swing_across),
    ], hip - beta * swing_along


def test_heelstrike_keeps_the_three_balances():
    """20 random parameter sets and states on the guard (the swing foot, beta below the
    hip along the swing leg, on the ground ahead): the generated reset against the three
    balances, to 1e-12."""
    walker = load("free_vsw_biped")
    module = walker.module
    rng = np.random.default_rng(28)
    checked = 0
    while checked < 20:
        p = (rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.5), 0.5)
        theta, r = rng.uniform(0.05, 0.5), rng.uniform(0.6, 1.0)
        height = r * math.cos(theta) / p[0]
        if height >= 1.0:
            continue
        psi = -math.acos(height)  # the swing foot on the ground, ahead of the hip
        before = np.array([theta, psi, r, *rng.uniform(-1.5, 1.5, 3)])
        assert float(module.event_heelstrike_guard(*p, *before)) == pytest.approx(0, abs=1e-14)
        after = np.array(module.event_heelstrike_reset(*p, *before), dtype=float)
        assert after[:3] == pytest.approx([psi, theta, p[0]], abs=1e-14)

        masses, foot = _masses(p, before)
        masses_after, _ = _masses(p, after)  # positions from the new foot
        hip = masses[0][1]
        h_before = sum(_cross(x - foot, m * v) for m, x, v in masses)
        h_after = sum(_cross(x, m * v) for m, x, v in masses_after)
        scale = max(1.0, abs(h_before))
        assert h_after == pytest.approx(h_before, abs=1e-12 * scale)
        # The old stance leg (its mass) is the new swing leg's: about the hip.
        old = _cross(masses[1][1] - hip, masses[1][0] * masses[1][2])
        new = _cross(masses_after[2][1] - (hip - foot), masses_after[2][0] * masses_after[2][2])
        assert new == pytest.approx(old, abs=1e-12 * max(1.0, abs(old)))
        # Along the new stance leg (from the new foot to the hip): the momentum is kept.
        axis = (hip - foot) / np.linalg.norm(hip - foot)
        p_before = sum(m * v @ axis for m, _, v in masses)
        p_after = sum(m * v @ axis for m, _, v in masses_after)
        assert p_after == pytest.approx(p_before, abs=1e-12 * max(1.0, abs(p_before)))
        checked += 1
