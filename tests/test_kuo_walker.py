"""Kuo's powered simplest walker (derive/models/kuo_walker.py; Kuo 2002): a push-off along
the rigid trailing leg with heelstrike against a torque on the stance leg, at one speed and
step length.

Independent physics: the impact with the push-off against Newton's law for the hip (the
impulse along the trailing leg, then the collision that keeps only the velocity across the
new leg), and the least costs against the inverted-pendulum gait's, derived by quadrature
in paper_check/powered.py: with the push-off ``m v^2 tan^2(alpha) / 2`` a step; with the
torque's impulse just after heelstrike (restoring what the collision took) ``m v^2
sin^2(2 alpha) / 2``; their ratio ``4 cos^4(alpha)``, Kuo's factor of four at small
angles.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from paper_check.powered import inverted_pendulum_gait
from vsw.models import load
from vsw.synthesis.powered import Request, optimize

pytest.importorskip("casadi")


@pytest.fixture(scope="module")
def walker():
    return load("kuo_walker")


def test_push_off_with_the_impact_is_newtons_law_for_the_hip(walker):
    """Before heelstrike the hip moves across the stance leg at l theta'; the push-off P
    along that leg adds P / m along it (work P^2 / 2m: the leg's rate goes from 0 to P / m);
    the collision keeps the velocity across the new leg. At 20 random states and
    parameters, the generated reset plus the push-off's gain times P against that, to
    1e-12."""
    rng = np.random.default_rng(28)
    module = walker.module
    for _ in range(20):
        m, g, l = rng.uniform(0.5, 2.0, 3)
        theta, theta_dot, push = rng.uniform(0.05, 0.6), rng.uniform(0.1, 2.0), rng.uniform(0, 1)
        d = 2 * l * math.sin(theta)  # on the guard: the legs at +-theta
        p = (m, g, l, d)
        velocity = l * theta_dot * np.array([math.cos(theta), -math.sin(theta)])
        trailing = np.array([math.sin(theta), math.cos(theta)])  # from its foot to the hip
        pushed = velocity + push / m * trailing
        across_new = np.array([math.cos(theta), math.sin(theta)])  # d(hip)/d(theta+) / l
        expected = pushed @ across_new / l
        state = np.array(module.event_heelstrike_reset(*p, theta, theta_dot), dtype=float)
        gain = float(module.event_heelstrike_impulse_gains_with(*p, theta, theta_dot)[0])
        assert state[0] == pytest.approx(-theta, abs=1e-15)
        assert state[1] + gain * push == pytest.approx(expected, rel=1e-12, abs=1e-12)
        c = float(module.event_heelstrike_impulse_work_with(*p, theta, theta_dot))
        assert c * push**2 / 2 == pytest.approx(push**2 / (2 * m), rel=1e-12)


@pytest.mark.parametrize(("step", "speed"), [(0.6, 0.4), (0.4, 0.3), (0.8, 0.5)])
def test_kuos_ratio_is_four_cos_to_the_fourth(walker, step, speed):
    """Least positive work a step at one speed and step length: the push-off alone, and
    the stance torque alone (its impulse just after heelstrike, the limit its continuous
    form approaches): both the inverted-pendulum stance at the derived costs, to 1e-6,
    both optimal, and their ratio 4 cos^4(alpha)."""
    params = walker.parameters({"d": step})
    cost, push_off, v_end = inverted_pendulum_gait(speed, step)
    alpha = math.asin(step / 2)
    torque_cost = 0.5 * v_end**2 * math.sin(2 * alpha) ** 2
    pushed = optimize(walker, params, Request("work", target_speed=speed, use=("push_off",)))
    turned = optimize(walker, params, Request("work", target_speed=speed,
                                              use=("stance_torque", "torque_impulse")))  # fmt: skip
    assert pushed.status == "optimal" and turned.status == "optimal", (pushed.reason,
                                                                      turned.reason)  # fmt: skip
    assert pushed.cost == pytest.approx(cost, rel=1e-6)
    assert pushed.impulses["heelstrike.push_off"] == pytest.approx(push_off, rel=1e-6)
    assert turned.cost == pytest.approx(torque_cost, rel=1e-6)
    assert turned.cost / pushed.cost == pytest.approx(4 * math.cos(alpha) ** 4, rel=1e-6)
    # Just after heelstrike the torque and its impulse are worth the same, a flat
    # direction of the cost that IPOPT's tolerance leaves undecided (the regularization
    # would put it all on the impulse, but its gradient at torques of 1e-5 is below that
    # tolerance): the torque there does 1.0e-5 of the work (measured), the impulse the rest.
    assert turned.work["stance.stance_torque"]["positive"] <= 2e-5 * turned.cost


def test_the_torque_alone_approaches_its_impulse_from_above(walker):
    """Without its impulse the stance torque cannot do the work at an instant: the least
    work on a mesh lies above the impulse's, and the result is not called optimal (the
    mesh does not resolve an impulse)."""
    params = walker.parameters()
    impulse_cost = optimize(walker, params, Request("work", target_speed=0.4,
                                                    use=("torque_impulse",))).cost  # fmt: skip
    smooth = optimize(walker, params, Request("work", target_speed=0.4, use=("stance_torque",)))
    assert smooth.status != "optimal"
    assert impulse_cost < smooth.cost < 1.01 * impulse_cost


def test_the_nlps_event_map_is_the_steps_and_the_energy_closes(walker):
    """Push-off with the impact and the torque's impulse after it, both nonzero: the NLP's
    event map (CasADi, event_map) and the open-loop step's (numpy, apply_impulses) give
    the same state and works, and the energy after is the energy before plus both works
    minus what the collision takes, m (v' . n)^2 / 2 with v' the hip's velocity after the
    push and n along the new leg (Newton, not the engine)."""
    import casadi as ca

    from vsw.synthesis.powered.events import apply_impulses, event_map
    from vsw.synthesis.powered.variables import Constraints, Unknowns

    (event,) = walker.events
    p, x, iota = ca.MX.sym("p", 4), ca.MX.sym("x", 2), ca.MX.sym("iota", 2)
    unknowns = Unknowns([], [], [], [], [], [iota], [], [ca.MX.sym("s", 0)])
    after, _priced, plus, minus, _ground = event_map(walker, event, p, x, unknowns, Constraints())
    assert list(plus) == ["heelstrike.push_off", "heelstrike.torque_impulse"]
    works = [plus[k] + minus[k] for k in plus]
    mapped = ca.Function("event", [p, x, iota], [after, ca.vertcat(*works)])
    rng = np.random.default_rng(5)
    for _ in range(20):
        m, g, l = rng.uniform(0.5, 2.0, 3)
        theta, theta_dot = rng.uniform(0.05, 0.6), rng.uniform(0.1, 2.0)
        params = np.array([m, g, l, 2 * l * math.sin(theta)])
        state = np.array([theta, theta_dot])
        impulses = np.array([rng.uniform(0.0, 1.0), rng.uniform(-0.5, 0.5)])
        ours, our_works, _ends = apply_impulses(walker, event, params, state, impulses)
        theirs, their_works = (np.array(v, float).reshape(-1)
                               for v in mapped(params, state, impulses))  # fmt: skip
        assert np.allclose(ours, theirs, rtol=1e-13, atol=1e-14)
        assert np.allclose(our_works, their_works, rtol=1e-12, atol=1e-14)
        assert our_works[0] == pytest.approx(impulses[0] ** 2 / (2 * m), rel=1e-12)
        pushed = (l * theta_dot * np.array([math.cos(theta), -math.sin(theta)])
                  + impulses[0] / m * np.array([math.sin(theta), math.cos(theta)]))  # fmt: skip
        lost = m * (pushed @ np.array([-math.sin(theta), math.cos(theta)])) ** 2 / 2
        change = walker.energy("stance", params, ours) - walker.energy("stance", params, state)
        assert change == pytest.approx(np.sum(our_works) - lost, rel=1e-10, abs=1e-12)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ("not_held", "acts along a coordinate stance holds"),
        ("moving_hold", "held at a value that moves"),
        ("two", "one impulse at the impact"),
    ],
)
def test_impulses_at_the_impact_it_cannot_derive_are_refused(change, message):
    """Along a coordinate the phase does not hold, along one held at a value that moves
    with the chart (its rate before the push is not zero), or two at one impact: the
    engine refuses them in words, not with a wrong map."""
    import dataclasses

    from derive.engine import model_derivation
    from derive.models import kuo_walker as source

    (event,) = source.MODEL.events
    push = event.impulses[0]
    impulses, phases = event.impulses, source.MODEL.phases
    if change == "not_held":
        impulses = (dataclasses.replace(push, along=source.theta),)
    elif change == "moving_hold":
        (stance,) = phases
        phases = (dataclasses.replace(stance, held={source.r: source.l + source.theta**2}),)
    else:
        impulses = (push, dataclasses.replace(push, name="again"))
    variant = dataclasses.replace(
        source.MODEL, phases=phases, events=(dataclasses.replace(event, impulses=impulses),)
    )
    with pytest.raises(ValueError, match=message):
        model_derivation(variant, "")
