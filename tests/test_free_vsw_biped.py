"""The VSW biped's body with free actuation (derive/models/free_vsw_biped.py, and with an
end stop at l, free_vsw_biped_stop.py): heelstrike, the leg's end
stop and the hip's impulse against Newton and Euler written out for the three masses.

At heelstrike the new foot sticks, the old foot leaves, and the new stance leg's lower
segment slides freely (a massless segment in a prismatic joint passes no force along the
leg): the walker's angular momentum about the new foot, the old stance leg's about the hip
(only the hip joint acts on it) and the walker's momentum along the new stance leg (the
ground's impulse is across it) do not change. Three balances for the three rates after.

At the end stop the stance leg's hip stops dead along the leg (its length's rate becomes
zero) by an impulse along the stance leg, through the foot and through the hip: the
walker's angular momentum about the stance foot and the swing leg's about the hip do not
change. The hip's impulse (a torque between the legs) changes the swing leg's angular
momentum about the hip by itself, counterclockwise, and not the walker's about the foot.
"""

from __future__ import annotations

import dataclasses
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


@pytest.mark.parametrize("name", ["free_vsw_biped", "free_vsw_biped_stop"])
def test_heelstrike_keeps_the_three_balances(name):
    """20 random parameter sets and states on the guard (the swing foot, beta below the
    hip along the swing leg, on the ground ahead; with the end stop the stance leg at l,
    held): the generated reset against the three balances, to 1e-12."""
    walker = load(name)
    module = walker.module
    stopped = name.endswith("_stop")
    rng = np.random.default_rng(28)
    checked = 0
    while checked < 20:
        p = (rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.5), 0.5)
        theta = rng.uniform(0.05, 0.5)
        r = 1.0 if stopped else rng.uniform(0.6, 1.0)
        height = r * math.cos(theta) / p[0]
        if height >= 1.0:
            continue
        psi = -math.acos(height)  # the swing foot on the ground, ahead of the hip
        before = np.array([theta, psi, r, *rng.uniform(-1.5, 1.5, 2),
                           0.0 if stopped else rng.uniform(-1.5, 1.5)])  # fmt: skip
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


def _momenta(p, state) -> tuple[float, float]:
    """The walker's angular momentum about the stance foot and the swing leg's about the
    hip, counterclockwise."""
    masses, _foot = _masses(p, state)
    hip = masses[0][1]
    walker = sum(_cross(x, m * v) for m, x, v in masses)
    swing = _cross(masses[2][1] - hip, masses[2][0] * masses[2][2])
    return walker, swing


def test_the_end_stop_stops_the_leg_and_keeps_both_momenta():
    """20 random parameter sets and states at the stop (r = 1, lengthening): the generated
    reset of end_stop against Newton (r' = 0 after; the two angular momenta kept), 1e-12."""
    walker = load("free_vsw_biped_stop")
    module = walker.module
    rng = np.random.default_rng(31)
    for _ in range(20):
        p = (rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.5), 0.5)
        before = np.array([*rng.uniform(-0.5, 0.5, 2), 1.0, *rng.uniform(-1.5, 1.5, 2),
                           rng.uniform(0.1, 2.0)])  # fmt: skip
        assert float(module.event_end_stop_guard(*p, *before)) == pytest.approx(0, abs=1e-15)
        after = np.array(module.event_end_stop_reset(*p, *before), dtype=float)
        assert after[:3] == pytest.approx(before[:3], abs=1e-15)
        assert after[5] == pytest.approx(0.0, abs=1e-14)
        for kept_before, kept_after in zip(_momenta(p, before), _momenta(p, after)):
            scale = max(1.0, abs(kept_before))
            assert kept_after == pytest.approx(kept_before, abs=1e-12 * scale)


def test_the_hip_impulse_at_the_stop_turns_the_swing_leg_by_itself():
    """20 random cases in the extended phase (r = 1 held): the hip's impulse just before
    heelstrike, from the generated gains, changes the swing leg's angular momentum about
    the hip by the impulse (counterclockwise: it spreads the legs, the swing leg forward),
    the walker's about the foot not at all, and the leg's length's rate not (held)."""
    walker = load("free_vsw_biped_stop")
    module = walker.module
    (event,) = [e for e in walker.events if e["name"] == "heelstrike"]
    before_names = [i["name"] for i in event["impulses"] if i["applied"] == "before"]
    assert before_names == ["hip_impulse_before"]
    rng = np.random.default_rng(37)
    for _ in range(20):
        p = (rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.5), 0.5)
        state = np.array([*rng.uniform(-0.5, 0.5, 2), 1.0, *rng.uniform(-1.5, 1.5, 2), 0.0])
        iota = rng.uniform(-1.0, 1.0)
        gains = np.array(module.event_heelstrike_impulse_gains_before(*p, *state), float)
        after = state.copy()
        after[3:] += gains.reshape(3) * iota
        assert after[5] == 0.0
        (walker_before, swing_before), (walker_after, swing_after) = (
            _momenta(p, state), _momenta(p, after))  # fmt: skip
        assert walker_after == pytest.approx(walker_before, abs=1e-12)
        assert swing_after - swing_before == pytest.approx(iota, abs=1e-12)


def test_the_ground_impulses_carry_the_legs_pushes():
    """The NLP's ground impulses at heelstrike (vsw.synthesis.powered's event_map: the momentum's
    change): a leg's telescoping foot is massless, so the ground's impulse on it along the
    leg is the leg actuator's: the stance foot's is the push-off along the trailing leg,
    the new foot's the heel-strike along the new leg (zero where it lands free), whatever
    the collision adds across the leg. 20 random cases, 1e-12."""
    import casadi as ca

    from vsw.synthesis.powered.events import apply_impulses, event_map
    from vsw.synthesis.powered.variables import Constraints, Unknowns

    walker = load("free_vsw_biped")
    (event,) = walker.events
    p, x, iota = ca.MX.sym("p", 4), ca.MX.sym("x", 6), ca.MX.sym("iota", 4)
    unknowns = Unknowns([], [], [], [], [], [iota], [], [ca.MX.sym("s", 0)])
    *_, ground = event_map(walker, event, p, x, unknowns, Constraints())
    assert list(ground) == ["heelstrike.stance_foot", "heelstrike.new_foot"]
    impulses = ca.Function("ground", [p, x, iota], list(ground.values()))
    rng = np.random.default_rng(41)
    checked = 0
    while checked < 20:
        params = np.array([rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0),
                           rng.uniform(0.1, 0.5), 0.5])  # fmt: skip
        theta, r = rng.uniform(0.05, 0.5), rng.uniform(0.6, 1.0)
        if r * math.cos(theta) / params[0] >= 1.0:
            continue
        psi = -math.acos(r * math.cos(theta) / params[0])
        state = np.array([theta, psi, r, *rng.uniform(-1.5, 1.5, 3)])
        push, strike = rng.uniform(0.0, 1.0, 2) * (checked % 2)  # half of them zero
        pushes = np.array([push, 0.0, strike, 0.0])  # push-off, hip, heel-strike, hip
        stance_foot, new_foot = (np.array(v, float).reshape(-1)
                                 for v in impulses(params, state, pushes))  # fmt: skip
        trailing = np.array([math.sin(theta), math.cos(theta)])  # from its foot to the hip
        assert stance_foot @ trailing == pytest.approx(push, abs=1e-12)
        after = apply_impulses(walker, event, params, state, pushes)[0]
        landing = np.array([math.sin(after[0]), math.cos(after[0])])
        assert new_foot @ landing == pytest.approx(strike, abs=1e-12)
        checked += 1


# Slow tier: an IPOPT solve and its re-simulation (about 10 s of CPU alone).
@pytest.mark.slow
def test_the_optimiser_walks_the_stop_model_through_its_stop():
    """`vsw optimize` on the end-stop model from its kinematic start for two phases
    (vsw.synthesis.powered.starts._phased_guess): the stroke ends with the leg at l, the extended
    phase begins with it stopped there (the lock's reset), holds it, and ends at heelstrike
    with the swing foot on the ground ahead; the step is periodic (the stroke starts
    beta long)."""
    from vsw.synthesis.powered import Request, optimize

    walker = load("free_vsw_biped_stop")
    params = walker.parameters()
    gait = optimize(walker, params, Request("work", 0.367072, 0.832346, 10))
    assert gait.status in ("optimal", "not-converged")
    stroke, extended = gait.states
    assert stroke[-1][2] == pytest.approx(1.0, abs=1e-8)
    assert extended[0][5] == pytest.approx(0.0, abs=1e-8) and np.allclose(extended[:, 2], 1.0)
    assert stroke[0][2] == pytest.approx(params[0], abs=1e-8)  # beta
    height = float(walker.module.event_heelstrike_guard(*params, *extended[-1]))
    assert height == pytest.approx(0.0, abs=1e-8)
    assert gait.step_length == pytest.approx(0.832346, rel=1e-8)


def test_the_push_at_a_chosen_angle_keeps_both_momenta_and_pushes_along_the_leg():
    """free_vsw_biped_push's push where the stance leg passes theta_push: 20 random cases,
    the generated gains of its two impulses against Newton and Euler: the leg's impulse
    (its foot massless, the ground's impulse along the leg is the leg's) changes the
    walker's momentum along the stance leg by itself and neither the walker's angular
    momentum about the stance foot (it passes through the foot) nor the swing leg's about
    the hip (it acts on the swing leg through the hip only); the hip's impulse changes the
    swing leg's angular momentum about the hip by itself, counterclockwise, and not the
    walker's about the foot. Nothing else jumps (a continuous change of phase), 1e-12."""
    walker = load("free_vsw_biped_push")
    module = walker.module
    (event,) = [e for e in walker.events if e["name"] == "push"]
    assert [i["name"] for i in event["impulses"]] == ["push", "hip_impulse_push"]
    assert walker.spec["chosen_parameters"] == ("theta_push",)
    rng = np.random.default_rng(43)
    for _ in range(20):
        p = (rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.5), 0.5,
             rng.uniform(-0.5, 0.5))  # fmt: skip
        state = np.array([p[4], rng.uniform(-0.5, 0.5), rng.uniform(0.6, 1.0),
                          *rng.uniform(-1.5, 1.5, 3)])  # fmt: skip
        assert float(module.event_push_guard(*p, *state)) == pytest.approx(0, abs=1e-15)
        reset = np.array(module.event_push_reset(*p, *state), dtype=float).reshape(-1)
        assert reset == pytest.approx(state, abs=1e-15)
        push, hip = rng.uniform(0.0, 1.0), rng.uniform(-1.0, 1.0)
        gains = np.array(module.event_push_impulse_gains_before(*p, *state), float)
        after = state.copy()
        after[3:] += gains.reshape(3, 2) @ np.array([push, hip])
        body = p[:4]
        (walker_before, swing_before), (walker_after, swing_after) = (
            _momenta(body, state), _momenta(body, after))  # fmt: skip
        assert walker_after == pytest.approx(walker_before, abs=1e-12)
        assert swing_after - swing_before == pytest.approx(hip, abs=1e-12)
        axis = np.array([math.sin(state[0]), math.cos(state[0])])  # foot to hip
        momentum = [sum(m * v for m, _, v in _masses(body, x)[0]) for x in (state, after)]
        assert (momentum[1] - momentum[0]) @ axis == pytest.approx(push, abs=1e-12)


@pytest.mark.slow  # IPOPT with the push angle free
def test_the_optimiser_chooses_the_push_angle_with_the_gait():
    """`vsw optimize` on free_vsw_biped_push (a chosen parameter, theta_push): the first
    stage (the squared inputs' integral, which prices no impulse) keeps it at its start,
    the work stage moves it; the stance ends where the stance leg passes the chosen value
    (the guard theta - theta_push at the split), the gait records it, and the step
    re-simulated at the gait's parameters (vsw.synthesis.powered.powered_step) ends near the start
    of the periodic step, while at the start's value the push comes elsewhere."""
    from vsw.synthesis.powered import Request, chosen_indices, optimize, powered_step

    walker = load("free_vsw_biped_push")
    (index,) = chosen_indices(walker)
    params = walker.parameters({"beta": 0.8, "l_min": 0.78, "theta_push": 0.3})
    gait = optimize(walker, params, Request("work", 0.367072, 0.832346, 5, friction=1.0))
    assert gait.status in ("optimal", "not-converged")
    assert gait.extra["warm_start"]["parameters"][index] == 0.3  # held in the first stage
    chosen = gait.parameters[index]
    assert chosen != pytest.approx(0.3, abs=1e-3)  # the work stage moved it
    assert gait.parameters[:index] == pytest.approx(params[:index], abs=0)
    stance, pushed = gait.states
    assert stance[-1][0] == pytest.approx(chosen, abs=1e-8)
    assert pushed[0][:3] == pytest.approx(stance[-1][:3], abs=1e-12)
    start = gait.states[0][0]
    scale = float(np.max(np.abs(start)))
    ended = powered_step(walker, params, gait, start)
    assert np.max(np.abs(ended - start)) < 1e-3 * scale
    unchosen = dataclasses.replace(gait, parameters=())  # the push at the given 0.3
    assert np.max(np.abs(powered_step(walker, params, unchosen, start) - start)) > 1e-2 * scale


def test_the_kinematic_start_splits_the_stance_where_the_push_comes():
    """The kinematic start of several phases (vsw.synthesis.powered.starts._phased_guess) ends the
    stance where the push's guard vanishes along its straight path: the stance leg at theta_push
    at the split, the phases' durations in proportion, the path continuous there."""
    from vsw.synthesis.powered import Request
    from vsw.synthesis.powered.problem import _build
    from vsw.synthesis.powered.starts import kinematic_guess

    walker = load("free_vsw_biped_push")
    params = walker.parameters({"theta_push": 0.1})
    request = Request("torque2", 0.367072, 0.832346, 6)
    nlp = _build(walker, request)
    w = kinematic_guess(walker, params, nlp, request)
    stance, pushed = (w[e["knots"][0] : e["knots"][0] + 7 * 6].reshape(7, 6) for e in nlp.layout)
    assert stance[-1][0] == pytest.approx(0.1, abs=1e-12)
    assert pushed[0][:3] == pytest.approx(stance[-1][:3], abs=1e-12)
    theta_rate = stance[0][3]
    assert pushed[0][3] == pytest.approx(theta_rate, rel=1e-12)  # one straight path
    assert w[0] * theta_rate == pytest.approx(0.1 - stance[0][0], rel=1e-12)


@pytest.mark.slow  # IPOPT with the push angle free
def test_vsw_optimize_reports_the_chosen_angle_within_its_limit(capsys):
    """`vsw optimize --model free-vsw-biped-push --limit theta_push=0.4:0.45 --json`: the
    chosen angle is reported within the limit (``chosen_parameters``, and the envelope's
    parameters are the gait's), and the stance ends there; the text says which parameters
    were chosen; under torque2, which prices no impulse, they are held at the given value
    and said to be; a limit on a parameter the optimiser does not choose is one line,
    exit 2."""
    import json

    from vsw.cli import main

    argv = ["optimize", "--model", "free-vsw-biped-push", "--minimize", "work",
            "--target-speed", "0.367072", "--target-step-length", "0.832346", "--param",
            "l_min=0.78", "--nodes", "4", "--limit", "theta_push=0.4:0.45"]  # fmt: skip
    assert main([*argv, "--json"]) in (0, 3)
    data = json.loads(capsys.readouterr().out)
    chosen = data["chosen_parameters"]["theta_push"]
    assert 0.4 <= chosen <= 0.45
    assert data["parameters"]["theta_push"] == chosen
    assert data["limits"] == {"theta_push": [0.4, 0.45]}
    assert data["phases"][0]["state"]["theta"][-1] == pytest.approx(chosen, abs=1e-8)
    assert main(argv) in (0, 3)
    out = capsys.readouterr().out
    assert "chosen             theta_push (by the optimiser, with the gait)" in out
    torque2 = [*argv[:4], "torque2", *argv[5:-2], "--param", "theta_push=0.42", "--json"]
    assert main(torque2) in (0, 3)
    data = json.loads(capsys.readouterr().out)
    assert data["chosen_parameters"] is None and data["parameters"]["theta_push"] == 0.42
    assert main(torque2[:-1]) in (0, 3)
    assert "held               theta_push at the given value" in capsys.readouterr().out
    assert main([*argv[:-2], "--limit", "beta=0.7:0.9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vsw: error: --limit beta: free-vsw-biped-push has no input or impulse or "
                   "chosen parameter beta (its: leg_force, hip_torque, push, "
                   "hip_impulse_push, push_off, hip_impulse_before, heel_strike, "
                   "hip_impulse_after, theta_push)"]  # fmt: skip


def test_a_limit_on_the_push_angle_takes_its_start_into_it():
    """The start 0.5 outside --limit theta_push=0.4:0.45: the first stage holds the angle
    at the limit's nearest end, 0.45 (vsw.synthesis.powered.request.started_within_limits), and the
    work stage keeps it within the limit."""
    from vsw.synthesis.powered import Request, chosen_indices, optimize

    walker = load("free_vsw_biped_push")
    (index,) = chosen_indices(walker)
    params = walker.parameters({"l_min": 0.78, "theta_push": 0.5})
    request = Request("work", 0.367072, 0.832346, 3, limits=(("theta_push", 0.4, 0.45),))
    gait = optimize(walker, params, request)
    assert gait.extra["warm_start"]["parameters"][index] == 0.45
    assert 0.4 <= gait.parameters[index] <= 0.45


def test_the_push_is_taken_by_the_ground_pushing_within_the_cone():
    """The NLP's event map at the push (vsw.synthesis.powered.events.event_map, a change of phase
    where impulses act): the ground's impulse through the stance foot is the walker's momentum's
    change by Newton for the three masses, and along the stance leg it is the leg's push
    (its foot massless; the foot's pivot takes the rest, across the leg) when the hip does
    not act, 20 random cases, 1e-12;
    with a friction coefficient the map adds three rows (the normal part >= 0 and the
    cone's two sides), none where the impulses are held at zero (torque2)."""
    import casadi as ca

    from vsw.synthesis.powered import Request
    from vsw.synthesis.powered.events import event_map
    from vsw.synthesis.powered.variables import Constraints, Unknowns

    walker = load("free_vsw_biped_push")
    (event,) = [e for e in walker.events if e["name"] == "push"]
    p, x, iota = ca.MX.sym("p", 5), ca.MX.sym("x", 6), ca.MX.sym("iota", 2)

    def mapped(request):
        unknowns = Unknowns([], [], [], [], [], [iota], [], [ca.MX.sym("s", 0)])
        rows = Constraints()
        *_, ground = event_map(walker, event, p, x, unknowns, rows, request)
        return ground, rows

    ground, rows = mapped(Request("work", friction=1.0))
    assert list(ground) == ["push.stance_foot"] and len(rows.rows) == 3
    assert len(mapped(Request("torque2", friction=1.0))[1].rows) == 0
    impulse = ca.Function("ground", [p, x, iota], [ground["push.stance_foot"]])
    rng = np.random.default_rng(47)
    checked = 0
    for _ in range(20):
        params = (rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.5), 0.5,
                  rng.uniform(-0.5, 0.5))  # fmt: skip
        state = np.array([params[4], rng.uniform(-0.5, 0.5), rng.uniform(0.6, 1.0),
                          *rng.uniform(-1.5, 1.5, 3)])  # fmt: skip
        push, hip = rng.uniform(0.0, 1.0), rng.uniform(-1.0, 1.0) * (checked % 2)
        checked += 1
        through_foot = np.array(impulse(params, state, [push, hip]), float).reshape(-1)
        gains = np.array(walker.module.event_push_impulse_gains_before(*params, *state), float)
        after = state.copy()
        after[3:] += gains.reshape(3, 2) @ np.array([push, hip])
        body = params[:4]
        momentum = [sum(m * v for m, _, v in _masses(body, s)[0]) for s in (state, after)]
        assert through_foot == pytest.approx(momentum[1] - momentum[0], abs=1e-12)
        if hip == 0.0:  # the leg's push along the leg, the foot's pivot across it
            axis = np.array([math.sin(state[0]), math.cos(state[0])])
            assert through_foot @ axis == pytest.approx(push, abs=1e-12)


def test_the_hip_torque_in_the_phase_that_holds_the_leg_is_newtons():
    """An input in a phase that holds a coordinate in the state (free_vsw_biped_stop's
    extended phase, the stance leg held at l; the engine's chain rule for held coordinates,
    otherwise untested): the hip torque's gains on the accelerations are M^-1 (1, -1)
    with M the three masses' mass matrix in (theta, psi) from their positions' Jacobians
    (the torque's virtual work tau d(theta - psi)), none on the held length; its gains on
    the ground reaction are the walker's momentum's rate those accelerations give, and the
    lift-off guard's are the normal part. 20 random cases, 1e-12."""
    walker = load("free_vsw_biped_stop")
    module = walker.module
    rng = np.random.default_rng(59)
    for _ in range(20):
        beta, mu, b = rng.uniform(0.6, 0.95), rng.uniform(0.01, 1.0), rng.uniform(0.1, 0.9)
        p = (beta, mu, b, 0.5)
        theta, psi = rng.uniform(-0.6, 0.6, 2)
        state = (theta, psi, 1.0, *rng.uniform(-1.5, 1.5, 2), 0.0)
        across, across_psi = (np.array([math.cos(a), -math.sin(a)]) for a in (theta, psi))
        # d(position)/d(theta, psi) of the hip, the stance leg's mass and the swing leg's
        jacobians = [(1.0, np.column_stack([across, 0 * across])),
                     (mu, np.column_stack([(1 - b) * across, 0 * across])),
                     (mu, np.column_stack([across, -b * across_psi]))]  # fmt: skip
        mass = sum(m * j.T @ j for m, j in jacobians)
        expected = np.linalg.solve(mass, [1.0, -1.0])
        gains = np.array(module.extended_input_gains(*p, *state), float).reshape(-1)
        assert gains == pytest.approx([*expected, 0.0], abs=1e-12)
        momentum_rate = sum(m * j @ expected for m, j in jacobians)  # tangential, normal
        reaction = np.array(module.extended_reaction_input_gains(*p, *state), float).reshape(-1)
        assert reaction == pytest.approx([momentum_rate[1], momentum_rate[0]], abs=1e-12)
        lift_off = np.array(module.extended_lift_off_input_gains(*p, *state), float).reshape(-1)
        assert lift_off == pytest.approx([momentum_rate[1]], abs=1e-12)
