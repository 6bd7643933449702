"""The point-mass biped (derive/models/point_mass_biped.py; Srinivasan & Ruina 2006) and
its impulses at the step: the engine's impulse gains against Newton's law for a particle,
and the least-work gait against the inverted-pendulum walking Srinivasan & Ruina found
optimal at low speed.

The inverted-pendulum gait's cost is derived in paper_check/powered.py (its module
docstring), by quadrature: nothing of it comes from the collocation.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from paper_check.powered import SR06_ACTUATORS, inverted_pendulum_gait
from vsw.models import load
from vsw.synthesis.powered import Request, optimize
from vsw.synthesis.powered.dynamics import flow_function
from vsw.synthesis.powered.problem import _build
from vsw.synthesis.powered.starts import perturbed_inputs

pytest.importorskip("casadi")


@pytest.fixture(scope="module")
def biped():
    return load("point_mass_biped")


def test_impulse_gains_are_newtons_law_for_the_hip(biped):
    """An impulse along a leg changes the hip's velocity by the impulse over the mass,
    along the leg (from the foot to the hip), a torque's impulse about the foot by the
    impulse over mass and leg length, across it: the generated gains, derived through
    Lagrange's equations in the chart, against that at random states and parameters; the
    impulse's work from the generated rates against the kinetic energy's change."""
    rng = np.random.default_rng(7)
    fn = biped.module
    for _ in range(20):
        m, g, l, d, l_min = rng.uniform(0.5, 3.0, 5)
        x, y, xd, yd = rng.uniform(-1.0, 1.0, 4)
        y = abs(y) + 0.1
        r = math.hypot(x, y)
        state = (m, g, l, d, l_min, x, y, xd, yd)
        # Along the leg: dv = iota / m along it. The stance torque's impulse about the foot:
        # a force iota / r across the leg, turning the hip forward: dv = iota / (m r) (y, -x) / r.
        along, across = (x / r / m, y / r / m), (y / r**2 / m, -x / r**2 / m)
        before = fn.event_heelstrike_impulse_gains_before(*state)
        assert np.allclose(before, along, rtol=1e-13, atol=0)
        after = fn.event_heelstrike_impulse_gains_after(*state)  # heel strike, torque impulse
        expected = (along[0], across[0], along[1], across[1])
        assert np.allclose(after, expected, rtol=1e-13, atol=1e-15)
        iota = rng.uniform(0.1, 2.0)
        xd2, yd2 = xd + iota * x / r / m, yd + iota * y / r / m
        rate = fn.event_heelstrike_impulse_rates_before
        params = (m, g, l, d, l_min)
        mean = (rate(*params, x, y, xd, yd)[0] + rate(*params, x, y, xd2, yd2)[0]) / 2
        work = iota * mean
        assert work == pytest.approx(m * (xd2**2 + yd2**2 - xd**2 - yd**2) / 2, rel=1e-12)


def test_the_ground_reaction_is_the_legs_push_and_the_torques_pull(biped):
    """The lift-off guard (the ground's normal reaction, with the inputs on) against statics
    of the massless stance leg, 50 random states and inputs, 1e-12: the leg force F along
    the leg pushes the hip, and so the ground, by F y / r; the stance torque tau about the
    foot pushes the hip by tau / r across the leg, forward, so the ground's normal
    reaction by -tau x / r^2; and Newton for the hip, m (y'' + g), from the flow."""
    module = biped.module
    rng = np.random.default_rng(53)
    for _ in range(50):
        m, g = rng.uniform(0.5, 80.0), rng.uniform(1.0, 10.0)
        p = (m, g, 1.0, 0.6, 0.5)
        x, y = rng.uniform(-0.4, 0.4), rng.uniform(0.6, 1.0)
        state = (x, y, *rng.uniform(-1.0, 1.0, 2))
        force, torque = rng.uniform(0.0, 3.0) * m * g, rng.uniform(-1.0, 1.0) * m * g
        gains = np.array(module.stance_lift_off_input_gains(*p, *state), float).reshape(-1)
        normal = float(module.stance_lift_off(*p, *state)) + gains @ (force, torque)
        r = math.hypot(x, y)
        scale = m * g
        assert normal == pytest.approx(force * y / r - torque * x / r**2, abs=1e-12 * scale)
        rates = np.array(flow_function(biped, "stance")(p, state, (force, torque)), float)
        assert normal == pytest.approx(m * (rates[3, 0] + g), abs=1e-12 * scale)


@pytest.mark.parametrize(
    ("values", "speed"),
    [
        # Both IPOPT solves (10 s and more on two cores) in the slow tier; the default tier
        # keeps the biped's refusals and its force balance.
        pytest.param({}, 0.3, marks=pytest.mark.slow),
        # SI units at a higher speed: IPOPT takes longer there.
        pytest.param({"m": 70.0, "g": 9.81, "l": 0.9, "d": 0.6}, 0.8, marks=pytest.mark.slow),
    ],
)
def test_least_work_gait_is_inverted_pendulum_walking_at_its_analytic_cost(biped, values, speed):
    """Srinivasan & Ruina's finding at low speed, from a start that is no gait (the search
    box's centre moving at constant rates): the least positive work per step is the
    inverted-pendulum gait with equal push-off and heel-strike impulses; its cost and
    impulses equal the quadrature's to 1e-5 (the collocation converges under refinement:
    IPOPT's 40 and 80 intervals agree to 1e-4), the leg stays at its full length and does
    no work, and the step's energy ledger closes: the push-off's work is what the
    heel-strike takes, and along the stance the energy changes by the leg's net work."""
    params = biped.parameters(values)
    m, g, l, d, _shortest = params
    cost, push, v_e = inverted_pendulum_gait(speed, d, m, g, l)
    # 40 intervals: the leg force holds the leg at its length between the knots too, where
    # its power wiggles about zero on the scheme's cubic (O(h^3)), and the cost prices it.
    gait = optimize(biped, params, Request("work", target_speed=speed, nodes=40,
                                           use=SR06_ACTUATORS))  # fmt: skip
    assert gait.status == "optimal", gait.reason
    assert gait.impulses["heelstrike.torque_impulse"] == 0.0  # not used: held at zero
    assert not np.any(gait.inputs[0][:, 1])
    assert gait.speed == pytest.approx(speed, rel=1e-9)
    assert gait.cost == pytest.approx(cost, rel=1e-5)
    assert gait.impulses["heelstrike.push_off"] == pytest.approx(push, rel=1e-5)
    assert gait.impulses["heelstrike.heel_strike"] == pytest.approx(push, rel=1e-5)
    knots = gait.states[0]
    legs = np.hypot(knots[:, 0], knots[:, 1])
    assert np.all(np.abs(legs - l) <= 1e-6 * l)
    assert np.hypot(*knots[-1, 2:]) == pytest.approx(v_e, rel=1e-5)
    leg = gait.work["stance.leg_force"]
    assert leg["positive"] <= 1e-5 * cost
    push_off, heel_strike = gait.work["heelstrike.push_off"], gait.work["heelstrike.heel_strike"]
    assert push_off["positive"] == pytest.approx(cost, rel=1e-5)
    assert abs(push_off["negative"]) <= 1e-9  # IPOPT holds the slack to its tolerance
    assert heel_strike["negative"] == pytest.approx(-cost, rel=1e-5)
    change = biped.energy("stance", params, knots[-1]) - biped.energy("stance", params, knots[0])
    assert abs(change - (leg["positive"] + leg["negative"])) <= 1e-6 * cost


@pytest.mark.slow  # four IPOPT solves of 40 and 80 intervals
def test_every_start_returns_to_the_analytic_least_work(biped):
    """``starts``: the least work from three starts (the least squared-input step, then its
    leg force perturbed by up to its own size) is the inverted-pendulum gait's analytic
    cost from each of them; the first start is the single-start solve, number for number;
    the one reported is the least. The perturbation itself moves only the inputs, within
    their bounds, and the same way on every run."""
    params = biped.parameters()
    m, g, l, d, _shortest = params
    cost = inverted_pendulum_gait(0.3, d, m, g, l)[0]
    request = Request("work", target_speed=0.3, nodes=40, use=SR06_ACTUATORS)
    one = optimize(biped, params, request)
    three = optimize(biped, params, dataclasses.replace(request, starts=3))
    starts = three.extra["starts"]
    assert len(starts) == 3 and "starts" not in one.extra
    assert starts[0]["fine"] == one.cost and starts[0]["coarse"] == one.extra["coarse"]["cost"]
    for start in starts:
        assert start["fine"] == pytest.approx(cost, rel=1e-5), start
    assert three.cost == min(start["fine"] for start in starts)
    assert starts[three.extra["best_start"]]["fine"] == three.cost

    nlp = _build(biped, dataclasses.replace(request, nodes=2 * request.nodes))
    w = one.extra["w"]  # the optimum on that (the fine) mesh
    moved = perturbed_inputs(biped, params, nlp, w, 1)
    assert np.array_equal(moved, perturbed_inputs(biped, params, nlp, w, 1))
    assert not np.array_equal(moved, perturbed_inputs(biped, params, nlp, w, 2))
    inputs = np.zeros(nlp.size, bool)
    for entry in nlp.layout:
        for key in ("u_knots", "u_middles"):
            first, parts, width = entry[key]
            inputs[first : first + parts * width] = True
    lbx, ubx = nlp.bounds[0][inputs], nlp.bounds[1][inputs]
    assert np.all(moved[inputs] >= lbx) and np.all(moved[inputs] <= ubx)
    assert np.any((moved != w) & inputs)
    assert np.array_equal(moved[: len(nlp.layout)], w[: len(nlp.layout)])  # the durations
    for entry in nlp.layout:
        for key in ("knots", "middles"):
            first, parts, width = entry[key]
            assert np.array_equal(moved[first : first + parts * width],
                                  w[first : first + parts * width])  # fmt: skip


@pytest.mark.slow  # every command on the biped
def test_commands_say_it_walks_only_powered(capsys):
    """`vsw models` lists its impulses and the optimize feature; the commands that work on
    passive gaits refuse it in one line naming `vsw optimize`; analyze says why it found no
    gait; a step-length target against its parameter d is refused; `vsw optimize --json`
    reports the impulses and their work."""
    import json

    from vsw.cli import main

    assert main(["models", "--json"]) == 0
    (model,) = [m for m in json.loads(capsys.readouterr().out)["models"]
                if m["name"] == "point-mass-biped"]  # fmt: skip
    impulses = model["impulses"]["heelstrike"]
    assert [i["name"] for i in impulses] == ["push_off", "heel_strike", "torque_impulse"]
    assert [i["applied"] for i in impulses] == ["before", "after", "after"]
    assert "optimize" in model["features"] and "design" not in model["features"]
    assert model["units"]["rate"] == "m/s"
    refused = ((["design", "--target-speed", "0.3"], "walks only powered"),
               (["explore", "--out", "page.html"], "walks only powered"),
               (["optimize", "--target-step-length", "0.7"], "contradicts it"))  # fmt: skip
    for (command, *rest), message in refused:
        assert main([command, "--model", "point-mass-biped", *rest]) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert message in line, line
    assert main(["analyze", "--model", "point-mass-biped"]) == 0
    assert "walks only powered" in capsys.readouterr().out
    argv = ["optimize", "--model", "point-mass-biped", "--minimize", "work", "--target-speed",
            "0.4", "--json"]  # fmt: skip
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["status"] == "optimal"
    assert set(data["impulses"]) == {"heelstrike.push_off", "heelstrike.heel_strike",
                                     "heelstrike.torque_impulse"}  # fmt: skip
    assert set(data["work"]) == {"stance.leg_force", "stance.stance_torque",
                                 "heelstrike.push_off", "heelstrike.heel_strike",
                                 "heelstrike.torque_impulse"}  # fmt: skip
    # Every actuator free, the stance torque included: the least work is still the
    # inverted-pendulum gait's (the torque does no work), as with SR06's actuators only.
    cost = inverted_pendulum_gait(0.4, 0.6)[0]
    assert data["cost"] == pytest.approx(cost, rel=1e-5)
    assert data["work"]["heelstrike.push_off"]["positive"] == pytest.approx(cost, rel=1e-5)
    assert data["work"]["stance.stance_torque"]["positive"] <= 1e-8
    assert main(["optimize", "--model", "point-mass-biped", "--use", "kick"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "--use kick: point-mass-biped has no input or impulse kick" in line


def test_parameters_that_cannot_walk_are_refused_and_a_gait_that_cannot_be_is_infeasible(capsys):
    """The conditions between parameters (a step the legs can reach, l_min <= l) are one
    line each, exit 2; rigid legs (l_min = l) powered by the push-off alone cannot walk:
    between steps only gravity acts, and a ballistic hip does not stay on the leg's
    circle. IPOPT says so (locally), and the status is `infeasible`, exit 3."""
    import json

    from vsw.cli import main

    for param, message in (("l_min=1.2", "l_min must be at most l (got l = 1, l_min = 1.2)"),
                           ("d=2", "d must be shorter than 2 l")):  # fmt: skip
        assert main(["optimize", "--model", "point-mass-biped", "--param", param]) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert message in line, line
    argv = ["optimize", "--model", "point-mass-biped", "--param", "l_min=1", "--use",
            "push_off", "--minimize", "work", "--target-speed", "0.4", "--json"]  # fmt: skip
    assert main(argv) == 3
    captured = capsys.readouterr()
    assert json.loads(captured.out)["status"] == "infeasible"
    assert (
        "vsw optimize: infeasible: IPOPT found the constraints locally infeasible" in captured.err
    )


def test_the_nlps_event_map_is_the_simulations_and_its_work_the_energys(biped):
    """With all three impulses nonzero (push-off before the reset; heel-strike and the
    torque's impulse together after it): the NLP's event map (CasADi, vsw.synthesis.powered's
    event_map) and the open-loop step's (numpy, apply_impulses) give the same state and
    works, and the works sum to the walker's energy change over the event (the reset moves
    the chart, not the hip)."""
    import casadi as ca

    from vsw.synthesis.powered.events import apply_impulses, event_map
    from vsw.synthesis.powered.variables import Constraints, Unknowns

    (event,) = biped.events
    p, x, iota = ca.MX.sym("p", 5), ca.MX.sym("x", 4), ca.MX.sym("iota", 3)
    unknowns = Unknowns([], [], [], [], [], [iota], [], [ca.MX.sym("s", 0)])
    after, _priced, plus, minus, _ground = event_map(biped, event, p, x, unknowns, Constraints())
    works = [plus[k] + minus[k] for k in plus]
    mapped = ca.Function("event", [p, x, iota], [after, ca.vertcat(*works)])
    rng = np.random.default_rng(3)
    for _ in range(20):
        params = (*rng.uniform(0.5, 2.0, 3), rng.uniform(0.3, 1.0), 0.2)
        state = np.array([params[3] / 2, rng.uniform(0.5, 1.0), *rng.uniform(-1, 1, 2)])
        impulses = rng.uniform(0.05, 1.0, 3)
        ours, our_works, _ends = apply_impulses(biped, event, np.array(params), state, impulses)
        theirs, their_works = (np.array(v, float).reshape(-1)
                               for v in mapped(params, state, impulses))  # fmt: skip
        assert np.allclose(ours, theirs, rtol=1e-13, atol=1e-14)
        assert np.allclose(our_works, their_works, rtol=1e-12, atol=1e-14)
        change = biped.energy("stance", params, ours) - biped.energy("stance", params, state)
        assert np.sum(our_works) == pytest.approx(change, rel=1e-11, abs=1e-13)


def test_a_reversing_impulses_positive_work_is_what_it_puts_back(biped):
    """A push-off along the leg while the hip moves toward the foot, large enough to send
    it away: by Newton the hip's speed along the leg goes from ``a < 0`` to
    ``b = a + iota / m > 0``; the actuator first absorbs ``m a^2 / 2``, then does
    ``m b^2 / 2`` of positive work. The NLP's ledger (CasADi, ``event_map``) has that
    whatever the push's split into two parts; its price (the slacks at their least, at the
    parts' power ends) is that where the split stops the hip (numpy's
    ``stopping_splits``), and more where the push is one part (``iota b / 2``)."""
    import casadi as ca

    from vsw.synthesis.powered.events import apply_impulses, event_map, stopping_splits
    from vsw.synthesis.powered.variables import Constraints, Unknowns

    (event,) = biped.events
    p, x, iota = ca.MX.sym("p", 5), ca.MX.sym("x", 4), ca.MX.sym("iota", 3)
    split, slacks = ca.MX.sym("f", 3), ca.MX.sym("s", 12)
    unknowns = Unknowns([], [], [], [], [], [iota], [split], [slacks])
    _after, priced, plus, _minus, _ground = event_map(biped, event, p, x, unknowns, Constraints())
    ledger = ca.Function("ledger", [p, x, iota, split, slacks],
                         [plus["heelstrike.push_off"], priced])  # fmt: skip
    rng = np.random.default_rng(11)
    for _ in range(20):
        m, g, l, d, l_min = (*rng.uniform(0.5, 2.0, 3), rng.uniform(0.3, 1.0), 0.2)
        x0, y0 = rng.uniform(-0.5, 0.5), rng.uniform(0.5, 1.0)
        r = math.hypot(x0, y0)
        along = np.array([x0, y0]) / r
        a = -rng.uniform(0.1, 1.0)  # toward the foot
        velocity = a * along + rng.uniform(-1, 1) * np.array([along[1], -along[0]])
        push = m * (-a + rng.uniform(0.1, 1.0))  # b = a + push / m > 0
        b = a + push / m
        params = np.array([m, g, l, d, l_min])
        state = np.array([x0, y0, *velocity])
        impulses = np.array([push, 0.0, 0.0])
        _state, works, _ends = apply_impulses(biped, event, params, state, impulses)
        assert works[0] == pytest.approx(m * (b**2 - a**2) / 2, rel=1e-12)  # the net work
        stopping = stopping_splits(biped, event, params, state, impulses)
        assert stopping[0] == pytest.approx(-a / (b - a), rel=1e-12)
        for fractions, price in ((stopping, m * b**2 / 2), (np.ones(3), push * b / 2)):
            ends = apply_impulses(biped, event, params, state, impulses, fractions)[2]
            exact, cost = ledger(params, state, impulses, fractions, np.maximum(ends, 0))
            assert float(exact) == pytest.approx(m * b**2 / 2, rel=1e-12)
            assert float(cost) == pytest.approx(price, rel=1e-12)


def test_the_switch_point_model_is_the_midpoint_model_with_its_switch_moved(biped):
    """point_mass_biped_switch: at sigma = 1/2 every generated function is the midpoint
    model's, bit for bit (the same body, event and section); at any sigma its step event
    is where the hip passes sigma d and the step starts (1 - sigma) d behind the new foot,
    which the reset (the new foot d ahead) makes of the state at the event."""
    switch = load("point_mass_biped_switch")
    rng = np.random.default_rng(11)
    names = [n for n in dir(biped.module) if n.startswith(("stance_", "event_", "section_"))]
    assert len(names) > 20 and all(hasattr(switch.module, n) for n in names)
    for _ in range(10):
        params = tuple(rng.uniform(0.5, 2.0, 5))
        state = tuple(rng.uniform(-1.0, 1.0, 4))
        for name in names:
            mid = np.asarray(getattr(switch.module, name)(*params, 0.5, *state))
            assert (
                mid.tobytes() == np.asarray(getattr(biped.module, name)(*params, *state)).tobytes()
            ), name
        sigma = rng.uniform(0.05, 0.95)
        d = params[3]
        at_switch = (sigma * d, state[1], *state[2:])
        assert abs(switch.module.event_heelstrike_guard(*params, sigma, *at_switch)) < 1e-15
        after = switch.module.event_heelstrike_reset(*params, sigma, *at_switch)
        assert after[0] == pytest.approx(-(1 - sigma) * d, abs=1e-15)
        assert tuple(after[1:]) == pytest.approx(at_switch[1:], abs=1e-15)
        completed = switch.module.section_completion(*params, sigma, 0.3, *after[1:])
        assert completed[0] == pytest.approx(-(1 - sigma) * d, abs=1e-15)
