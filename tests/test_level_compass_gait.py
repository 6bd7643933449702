"""The compass gait on level ground, powered (derive/models/level_compass_gait.py: Kuo's
comparison of push-off and hip torque with massive legs; benchmark case 16).

Independent physics: the impact with the push-off against the two momentum balances of the
compass gait's heelstrike written out here from its three point masses (the walker's
angular momentum about the new foot changes by the push-off's moment about it; the old
stance leg's about the hip does not change, since the push-off acts along that leg through
the hip), and the push-off-only gait's least work against single shooting with SciPy's
SLSQP on a SciPy-integrated step (benchmarks/powered_peer.py), a route that shares only the
generated flow, reset and push-off gain.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from vsw.models import load
from vsw.runtime.errors import VswInputError
from vsw.synthesis.powered import Request, optimize, powered_step
from vsw.synthesis.powered.request import _check_step_target
from vsw.synthesis.powered.verify import verify

pytest.importorskip("casadi")

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"


@pytest.fixture(scope="module")
def walker():
    return load("level_compass_gait")


def _cross(r: np.ndarray, v: np.ndarray) -> float:
    return float(r[0] * v[1] - r[1] * v[0])


def _masses(p, state, extension_rate: float = 0.0):
    """Positions and velocities of the hip, stance-leg and swing-leg masses, the stance
    foot at the origin (x forward, y up); ``extension_rate``: the stance leg's length
    growing (its actuator at the foot moves the hip and the leg's mass along it)."""
    m_h, m, a, b, _g = p
    length = a + b
    theta, psi, theta_dot, psi_dot = state
    along = np.array([math.sin(theta), math.cos(theta)])
    across = np.array([math.cos(theta), -math.sin(theta)])
    swing_along = np.array([math.sin(psi), math.cos(psi)])
    swing_across = np.array([math.cos(psi), -math.sin(psi)])
    hip = length * along
    v_hip = length * theta_dot * across + extension_rate * along
    return [
        (m_h, hip, v_hip),
        (m, a * along, a * theta_dot * across + extension_rate * along),
        (m, hip - b * swing_along, v_hip - b * psi_dot * swing_across),
    ], hip - length * swing_along


def _momenta(p, state, extension_rate, point, hip):
    """The walker's angular momentum about ``point``, the swing leg's about the hip, the
    stance leg's (mass) about the hip, and the linear momentum along the stance leg."""
    masses, _ = _masses(p, state, extension_rate)
    along = hip / np.linalg.norm(hip)
    return np.array([
        sum(_cross(r - point, mass * v) for mass, r, v in masses),
        _cross(masses[2][1] - hip, masses[2][0] * masses[2][2]),
        _cross(masses[1][1] - hip, masses[1][0] * masses[1][2]),
        sum(mass * v @ along for mass, _, v in masses),
    ])  # fmt: skip


def test_push_off_with_the_impact_keeps_the_momentum_balances(walker):
    """At 20 random parameter sets, heelstrike states (the legs at +-theta) and push-offs
    P, the generated reset plus the push-off's gain times P against Newton and Euler
    written out for the three masses, in two instants:

    * the push-off, the stance foot pinned and its leg's actuator (at the foot) pushing:
      the walker's angular momentum about the stance foot and the swing leg's about the
      hip do not change (no impulse has a moment about them), its momentum along the
      stance leg grows by P (the prismatic joint passes P along it, any impulse across);
      three linear equations for the rates and the extension rate just after it;
    * the collision at the new foot, which releases the old: the walker's angular momentum
      about the new foot and the old stance leg's about the hip do not change (the classic
      compass gait's two balances)."""
    rng = np.random.default_rng(28)
    module = walker.module
    for _ in range(20):
        p = (*rng.uniform(0.5, 10.0, 2), *rng.uniform(0.2, 0.8, 2), 9.81)
        theta = rng.uniform(0.05, 0.5)
        before = np.array([theta, -theta, rng.uniform(0.2, 2.0), rng.uniform(-2.0, 2.0)])
        push = rng.uniform(0.0, 5.0)
        masses, new_foot = _masses(p, before)
        hip, origin = masses[0][1], np.zeros(2)

        def balance(x, before=before, hip=hip, origin=origin, p=p):
            pushed = np.array([before[0], before[1], x[0], x[1]])
            return _momenta(p, pushed, x[2], origin, hip)[[0, 1, 3]]

        wanted = _momenta(p, before, 0.0, origin, hip)[[0, 1, 3]] + np.array([0, 0, push])
        base = balance(np.zeros(3))
        jacobian = np.column_stack([balance(np.eye(3)[k]) - base for k in range(3)])
        x = np.linalg.solve(jacobian, wanted - base)
        pushed = np.array([before[0], before[1], x[0], x[1]])

        after = np.array(module.event_heelstrike_reset(*p, *before), dtype=float)
        gains = np.array(module.event_heelstrike_impulse_gains_with(*p, *before), dtype=float)
        after[2:] += gains.reshape(2) * push
        assert after[:2] == pytest.approx([-theta, theta], abs=1e-14)  # the legs swapped
        # After the collision, from the new foot: positions shifted by new_foot.
        h_new = _momenta(p, after, 0.0, origin, masses[0][1] - new_foot)
        h_old = _momenta(p, pushed, x[2], new_foot, hip)
        scale = max(1.0, *np.abs(h_old[:3]))
        assert h_new[0] == pytest.approx(h_old[0], abs=1e-12 * scale)  # about the new foot
        # The old stance leg is the new swing leg.
        assert h_new[1] == pytest.approx(h_old[2], abs=1e-12 * scale)


def test_push_off_alone_equals_single_shooting(walker):
    """The push-off-only gait at step length 0.4 (Drake's parameters): `optimal`, its
    least work equal to SLSQP single shooting's on the SciPy-integrated step within 1e-6
    (the collocation's mesh error at 40 intervals is about 4e-8 here)."""
    sys.path.insert(0, str(BENCHMARKS))
    try:
        from powered_peer import compass_push_off_by_shooting
    finally:
        sys.path.remove(str(BENCHMARKS))
    params = walker.parameters()
    gait = optimize(walker, params, Request("work", target_step_length=0.4, use=("push_off",)))
    assert gait.status == "optimal", gait.reason
    peer = compass_push_off_by_shooting(0.4, params, maxiter=50)
    assert peer.success, peer.message
    assert gait.cost == pytest.approx(peer.cost, rel=1e-6)
    assert gait.step_length == pytest.approx(0.4, rel=1e-9)
    # The open-loop step's fixed point (vsw.synthesis.powered.verify): a motion of the walker whose
    # work, integrated along it, is SLSQP's too; it maps to itself.
    verified = verify(walker, params, gait)
    assert verified.failure == ""
    assert verified.residual <= 1e-9
    assert verified.positive_work == pytest.approx(peer.cost, rel=1e-6)
    again = powered_step(walker, params, gait, verified.state)
    assert np.max(np.abs(again - verified.state)) <= 1e-8
    assert verified.ground_impulses["heelstrike.new_foot"][1] > 0


def test_push_off_alone_cannot_meet_both_a_speed_and_a_step(walker):
    """Push-off alone leaves the swing leg passive: its gaits at a step length are isolated
    (the one found at 0.4 m walks at 0.5835 m/s), so a different speed at that step is
    infeasible."""
    gait = optimize(walker, walker.parameters(),
                    Request("work", target_step_length=0.4, target_speed=0.4,
                            use=("push_off",)))  # fmt: skip
    assert gait.status == "infeasible"


def test_a_step_target_is_not_refused_as_fixed(walker):
    """The compass gait's step length depends on its state: the check that refuses a step
    target on models whose parameters fix it (the Kuo walker's d) lets it through. It used
    to probe states with every coordinate equal, where the compass gait's legs are together
    and its step is 0 whatever the state."""
    params = walker.parameters()
    _check_step_target(walker, params, Request("work", target_step_length=0.5))
    kuo = load("kuo_walker")
    with pytest.raises(VswInputError, match="set by its parameters"):
        _check_step_target(kuo, kuo.parameters(), Request("work", target_step_length=0.5))


def test_no_near_standing_gaits(walker):
    """On level ground the scan's Newton solutions near the standing limit (steps of 1e-7
    to 5e-5 m, a heelstrike loss below Newton's tolerance) are no gaits: none reported,
    each counted as standing."""
    found = walker.search_gaits(walker.parameters())
    assert found.gaits == []
    assert found.standing > 0
    assert "stand" in found.why_none()
