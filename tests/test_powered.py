"""Powered gaits by Hermite-Simpson collocation (vsw/synthesis/powered/) on the compass gait with
its hip torque.

Checked against what the collocation did not compute: the passive gait of the periodic-orbit
solver (shooting on CVODES, confirmed by simulation) and its eigenvalues where no torque is
needed; the energy balance along the collocated step (the generated energy function, not
the gains); a re-simulation with the inputs as the scheme interpolates them.
"""

from __future__ import annotations

import dataclasses
import types

import numpy as np
import pytest

from vsw.models import load
from vsw.runtime.errors import VswInputError
from vsw.synthesis.powered import Request, best_start, optimize

pytest.importorskip("casadi")


@pytest.fixture(scope="module")
def compass():
    model = load("compass_gait")
    params = model.parameters()
    (stable,) = [o for o in model.fixed_points(params) if o.stable]
    return model, params, stable


@pytest.fixture(scope="module")
def faster(compass):
    """The least squared-torque gait 10 % faster than the stable passive one on 20
    intervals (the request and its optimum), solved once for the tests that start from it."""
    model, params, stable = compass
    request = Request("torque2", target_speed=1.1 * stable.speed, nodes=20)
    return request, optimize(model, params, request)


def test_no_target_needs_no_torque_and_finds_the_passive_gait(compass):
    """Without targets the least squared torque is zero and the step is the passive gait:
    the section state within 1e-7 of the periodic-orbit solver's (the collocation's error
    at 40 intervals), and the open-loop map's eigenvalues are the passive gait's."""
    model, params, stable = compass
    gait = optimize(model, params, Request("torque2", nodes=20))
    assert gait.status == "optimal", gait.reason
    assert gait.cost <= 1e-12
    assert np.max(np.abs(np.concatenate(gait.inputs))) <= 1e-6
    passive = np.array([stable.state[k] for k in (*model.coordinates, *model.rates)])
    assert np.max(np.abs(gait.states[0][0] - passive)) <= 1e-7
    assert gait.period == pytest.approx(stable.period, rel=1e-7)
    ours = sorted(abs(e) for e in gait.extra["eigenvalues"])
    theirs = sorted(abs(e) for e in stable.eigenvalues)
    assert np.allclose(ours, theirs, atol=1e-6)  # 4.5e-8 measured


def test_every_passive_gait_is_a_gait_of_the_nlp_at_its_own_targets(compass):
    """Each passive gait (the fastest one's legs pass each other past mid-stance, the
    swing foot through the ground ahead, a crossing of the guard the model ignores) needs
    no torque at its own speed and step length: no constraint of the NLP may exclude a
    motion the simulation accepts. (A path constraint on the guard's sign at the knots
    once did, and cost this gait 0.059.)"""
    model, params, _ = compass
    first = model.fixed_points(params)[0]
    request = Request("torque2", target_speed=first.step_length / first.period,
                      target_step_length=first.step_length)  # fmt: skip
    gait = optimize(model, params, request, start=first)
    assert gait.status == "optimal", gait.reason
    assert gait.cost <= 1e-10


def test_a_faster_gait_converges_under_refinement_and_closes_its_energy(compass, faster):
    """10 % faster than the passive gait: IPOPT's optimum on 20 and 40 intervals agree to
    1e-4 (relative cost), the re-simulation ends within 1e-6, and along the step the
    walker's energy changes by the torque's net work, to 1e-6 of it (2.7e-7 measured: the
    scheme's own error on 40 intervals). The energy function (q' M q' / 2 + V) and the
    gains (Cramer's rule on the virtual work's generalised force) meet only in the mass
    matrix: the balance checks M B = d(along)/dq along the collocated step, with the
    energy at the ends against Simpson's rule on the power."""
    model, params, stable = compass
    target = 1.1 * stable.speed
    _, gait = faster
    assert gait.status == "optimal", gait.reason
    assert gait.extra["mesh_change"] <= 1e-4
    assert gait.resimulation_error <= 1e-6
    # The target is a constraint of the NLP (CasADi); checked here through numpy's step
    # length function on the knots, the value the result reports.
    assert gait.speed == pytest.approx(target, rel=1e-9)
    assert gait.cost > 0.1  # a faster gait needs torque
    (work,) = gait.work.values()
    net = work["positive"] + work["negative"]
    knots = gait.states[0]
    change = model.energy("stance", params, knots[-1]) - model.energy("stance", params, knots[0])
    assert abs(change - net) <= 1e-6 * abs(net)


@pytest.mark.slow  # two optimisations
def test_a_period_target_is_the_speed_target_it_implies(compass):
    """Shorter steps in time: the period 0.9 times the stable passive gait's, with its
    step length. The optimum's durations sum to the target (1e-9), and it is the optimum
    of the same step length at the speed the two imply (cost within 1e-8 relative): two
    different constraint rows of the NLP, one gait."""
    model, params, stable = compass
    period, step = 0.9 * stable.period, stable.step_length
    by_period = optimize(model, params, Request("torque2", target_step_length=step,
                                                target_period=period, nodes=20))  # fmt: skip
    by_speed = optimize(model, params, Request("torque2", target_step_length=step,
                                               target_speed=step / period, nodes=20))  # fmt: skip
    assert by_period.status == by_speed.status == "optimal", (by_period.reason, by_speed.reason)
    assert sum(by_period.durations) == pytest.approx(period, rel=1e-9)
    assert by_period.speed == pytest.approx(step / period, rel=1e-9)
    assert by_period.cost == pytest.approx(by_speed.cost, rel=1e-8)
    assert by_period.cost > 0.01  # quicker steps than the passive gait's need torque


def test_a_limit_on_an_input_holds_and_costs(compass, faster):
    """The hip torque limited to 0.8 of its peak in the least squared-torque gait 10 %
    faster than the passive one: the limited optimum keeps the torque within the limit at
    every knot and midpoint, reaches it, and costs more."""
    model, params, _ = compass
    request, free = faster
    bound = 0.8 * float(np.max(np.abs(np.concatenate(free.inputs))))
    limited = optimize(model, params, dataclasses.replace(
        request, limits=(("hip_torque", -bound, bound),)))  # fmt: skip
    assert free.status == limited.status == "optimal", (free.reason, limited.reason)
    peak = float(np.max(np.abs(np.concatenate(limited.inputs))))
    assert bound * (1 - 1e-6) <= peak <= bound * (1 + 1e-9)
    assert limited.cost > free.cost * (1 + 1e-6)


def test_the_positive_works_optimum_is_not_called_optimal_when_the_mesh_cannot_resolve_it(
    compass,
):
    """10 % faster than the fastest passive gait, the least positive work drives the
    torque towards an impulse (180 N m on 40 intervals): the re-simulation and the mesh
    disagree, which the result says instead of 'optimal'. Between the passive gaits'
    speeds the hip only brakes (no positive work) and the optimum is resolved."""
    model, params, _ = compass
    fastest = max(o.speed for o in model.fixed_points(params))
    gait = optimize(model, params, Request("work", target_speed=1.1 * fastest, nodes=20))
    assert gait.status == "not-converged"
    assert "mesh does not resolve" in gait.reason or "re-simulation" in gait.reason
    assert np.max(np.abs(np.concatenate(gait.inputs))) > 50


@pytest.mark.slow  # two-stage stability optimisation
def test_the_most_stable_gait_at_the_passive_speed_is_more_stable_than_the_passive_one(compass):
    """`--minimize stability` at the stable passive gait's speed: the spectral radius of the
    collocated step map (its Hermite-Simpson equations differentiated, the saltation's
    projection and the reset's Jacobian at heelstrike), minimised with the hip torque
    free, is below the passive gait's own (0.580: the passive gait is one of the gaits
    allowed, at zero torque). The collocated step map's Jacobian is the open-loop step
    map's found independently, by central differences of the simulated step at 5e-4 and
    1e-3 extrapolated (vsw.synthesis.powered.powered_step_jacobian), to the mesh's error:
    2.5e-5 of its largest entry measured (asserted 1e-3; plain differences at 1e-6 are
    0.11 % off). The radius is the dominant pair's, a double root where it is least (the
    two eigenvalues meet), so it moves as the square root of an error in the matrix: the
    reported radius (the same extrapolation) is the collocated one's to 1.1e-5 measured,
    asserted 1e-3 (plain differences at 1e-6 give 0.33 %). The regularisation's share of
    the objective is reported: at most 5 % (4 % measured: the first stage's squared torque,
    by which it is scaled, is almost zero at a passive gait's speed)."""
    from vsw.synthesis.powered import powered_step_jacobian

    model, params, stable = compass
    passive = max(abs(e) for e in stable.eigenvalues)
    gait = optimize(model, params, Request("stability", target_speed=stable.speed, nodes=10))
    assert gait.status in ("optimal", "not-converged"), gait.reason
    assert gait.cost < 0.95 * passive
    collocated = np.asarray(gait.extra["step_jacobian"])
    fine, coarse = (powered_step_jacobian(model, gait.parameters, gait, gait.states[0][0], h)
                    for h in (5e-4, 1e-3))  # fmt: skip
    found = (4 * fine - coarse) / 3
    assert np.max(np.abs(collocated - found)) <= 1e-3 * np.max(np.abs(found))
    assert gait.cost == pytest.approx(max(abs(np.linalg.eigvals(found))), rel=1e-3)
    assert max(abs(e) for e in gait.extra["eigenvalues"]) == pytest.approx(gait.cost, rel=1e-3)
    assert gait.extra["radius_unknown"] == pytest.approx(gait.cost, rel=1e-6)
    assert 0 < gait.extra["objective"] - gait.extra["radius_unknown"] <= 0.05 * gait.cost
    assert gait.speed == pytest.approx(stable.speed, rel=1e-9)


@pytest.mark.parametrize(
    ("name", "request_", "message"),
    [
        ("simplest_walker", Request(), "declares no inputs"),
        ("compass_gait", Request("speed"), "--minimize speed"),
        (
            "kuo_walker",
            Request("stability", use=("push_off",)),
            r"--minimize eigenvalue holds every impulse at zero .* \(--use names only impulses\)",
        ),
        ("compass_gait", Request(nodes=1), "--nodes 1"),
        ("compass_gait", Request("work", starts=0), "--starts 0 must be from 1 to 50"),
        ("compass_gait", Request(starts=2), "--starts 2: only the second stage"),
        (
            "kuo_walker",
            Request("work", use=("push_off",), starts=2),
            "this request solves one stage from one start",
        ),
        ("compass_gait", Request(target_speed=-1.0), "target speed must be a positive"),
        ("compass_gait", Request(target_period=0.0), "target period must be a positive"),
        (
            "compass_gait",
            Request(target_speed=1.0, target_step_length=0.5, target_period=0.5),
            "give at most two",
        ),
        (
            "point_mass_biped",
            Request("work", target_speed=0.5, target_period=2.0),
            "--target-speed times --target-period, 1, contradicts it",
        ),
        ("point_mass_biped", Request(limits=(("leg_force", 5.0, 3.0),)), "above its high"),
        ("point_mass_biped", Request(limits=(("legs", None, 3.0),)), "--limit legs: point"),
        (
            "point_mass_biped",
            Request(limits=(("leg_force", None, -1.0),)),
            r"no value within both it and the bounds point-mass-biped declares \(0 to inf\)",
        ),
    ],
)
def test_bad_requests_are_one_line_errors(name, request_, message):
    model = load(name)
    with pytest.raises(VswInputError, match=message):
        optimize(model, model.parameters(), request_)


@pytest.mark.slow  # a work optimum
def test_between_the_passive_gaits_speeds_the_hip_only_brakes(compass):
    """10 % faster than the stable passive gait (slower than another passive gait), the
    least positive work is none: the torque only brakes, and that optimum is resolved."""
    model, params, stable = compass
    gait = optimize(model, params, Request("work", target_speed=1.1 * stable.speed, nodes=20))
    assert gait.status == "optimal", gait.reason
    (work,) = gait.work.values()
    assert work["positive"] <= 1e-6
    assert work["negative"] < -0.1


@pytest.mark.slow  # three optimisations
def test_vsw_optimize_json_and_exit_statuses(capsys, tmp_path):
    """`vsw optimize`: JSON with the envelope, the trajectories per phase, the ledger and
    the re-simulation; exit 0 when optimal, 3 when not, 2 (one line) for a model without
    inputs; the plot is written."""
    import json

    from vsw.cli import main

    plot = tmp_path / "step.png"
    argv = ["optimize", "--model", "compass-gait", "--target-speed", "0.8", "--json",
            "--plot", str(plot)]  # fmt: skip
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data)[:4] == ["model", "parameters", "units", "provenance"]
    assert data["status"] == "optimal" and data["reason"] is None
    assert data["starts"] is None and data["best_start"] is None  # one start
    assert data["speed"] == pytest.approx(0.8, rel=1e-9)
    assert data["mesh_change"] <= 1e-4 and data["resimulation_error"] <= 1e-6
    (phase,) = data["phases"]
    assert len(phase["time"]) == 41 and len(phase["input_time"]) == 81
    assert set(phase["state"]) == {"theta", "psi", "theta_dot", "psi_dot"}
    assert set(phase["inputs"]) == {"hip_torque"}
    assert set(data["work"]) == {"stance.hip_torque"}
    assert plot.stat().st_size > 0
    assert main(["optimize", "--model", "compass-gait", "--target-speed", "0.8", "--nodes",
                 "5"]) == 3  # fmt: skip
    assert "not-converged" in capsys.readouterr().out
    assert main(["optimize", "--model", "simplest-walker"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vsw: error: simplest-walker declares no inputs: nothing to power it with"]
    assert main(["optimize", "--model", "compass-gait", "--minimize", "work", "--starts",
                 "51"]) == 2  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vsw: error: --starts 51 must be from 1 to 50"]


@pytest.mark.slow  # a work optimum and its verification
def test_vsw_optimize_verify_and_the_ground(capsys):
    """`vsw optimize --verify --json`: the periodic motion driven by the optimum's inputs
    (its step's gap within 1e-7), at the target speed within 1e-4, its work integrated
    along it within 1e-3 of the mesh's ledger; the ground's impulses at heelstrike, the new
    foot's pushing (on the slope's normal) within the friction cone asked for; a negative
    friction coefficient is one line, exit 2."""
    import json

    from vsw.cli import main

    argv = ["optimize", "--model", "compass-gait", "--target-speed", "0.8", "--minimize",
            "work", "--friction", "1", "--verify", "--json"]  # fmt: skip
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    verified = data["verified"]
    assert verified["status"] == "verified" and verified["residual"] <= 1e-7
    assert verified["speed"] == pytest.approx(0.8, rel=1e-4)
    mesh = sum(w["positive"] for w in data["work"].values())
    assert verified["positive_work"] == pytest.approx(mesh, rel=1e-3)
    assert verified["stance_friction"] <= 1 + 1e-6  # the knots' cone, between them too
    for ground in (data["ground_impulses"], verified["ground_impulses"]):
        landing = ground["heelstrike.new_foot"]
        assert landing["normal"] > 0 and abs(landing["tangential"]) <= landing["normal"] + 1e-9
    assert main(["optimize", "--model", "compass-gait", "--friction", "-1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vsw: error: --friction -1.0 must be a number >= 0"]
    assert main(["optimize", "--model", "point-mass-biped", "--clearance", "0.1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["vsw: error: --clearance: point-mass-biped declares no swing foot's clearance"]


@pytest.mark.parametrize(
    "name",
    ["compass_gait", "point_mass_biped", "kuo_walker", "level_compass_gait", "free_vsw_biped",
     "free_vsw_biped_stop"],
)  # fmt: skip
def test_the_reaction_from_the_momentum_is_the_engines(name):
    """The stance foot's reaction the friction cone uses (vsw.synthesis.powered: the walker's rate
    of momentum less its weight, gravity along the slope's chart) against the engine's
    normal force with the inputs' share (derived from the phase's own equations of
    motion), and the inputs' share of the tangential reaction against the engine's gains,
    every phase, 10 random states, parameters near the defaults and inputs each, to 1e-9
    of the weight."""
    import casadi as ca

    from vsw.synthesis.powered import input_names
    from vsw.synthesis.powered.dynamics import reaction_function

    walker = load(name)
    rng = np.random.default_rng(43)
    for spec in walker.phases:
        phase = spec["name"]
        count = len(input_names(walker)[phase])
        reaction = reaction_function(walker, phase)
        for _ in range(10):
            params = np.array(walker.parameters()) * rng.uniform(0.9, 1.1)
            state = np.concatenate([rng.uniform(-0.4, 0.4, walker.n),
                                    rng.uniform(-1.0, 1.0, walker.n)])  # fmt: skip
            if name == "point_mass_biped":
                state[1] = abs(state[1]) + 0.5  # the hip above the foot
            for k, coordinate in enumerate(walker.coordinates):
                if coordinate == "r":
                    state[k] = rng.uniform(0.6, 1.0)
            u = rng.uniform(-1.0, 1.0, count)
            ours = np.array(reaction(params, state, u), dtype=float).reshape(-1)
            normal = walker.normal_force(phase, params, state)
            if count:
                gains = np.array(walker.function(f"{phase}_reaction_input_gains")(*params, *state),
                                 dtype=float)  # fmt: skip
                normal += gains[:count] @ u
                # The inputs' share of the tangential reaction: the engine's gains too.
                passive = np.array(reaction(params, state, 0 * u), dtype=float).reshape(-1)
                assert ours[0] - passive[0] == pytest.approx(gains[count:] @ u, abs=1e-9)
            weight = float(walker.symbolic_weight(ca.DM(params)))
            assert ours[1] == pytest.approx(normal, abs=1e-9 * weight)


def test_the_best_start_is_optimal_before_it_is_cheap():
    """Of several starts' judged results, an optimal one beats a cheaper one the mesh or
    the re-simulation does not confirm; then IPOPT's success, then cost, then the earlier
    start; a failed start (None) is never chosen."""

    def judged(status, cost, ipopt="Solve_Succeeded"):
        return types.SimpleNamespace(status=status, cost=cost, ipopt_status=ipopt)

    assert best_start([judged("optimal", 1.0), judged("not-converged", 0.9)]) == 0
    assert best_start([None, judged("not-converged", 0.9), judged("optimal", 1.2)]) == 2
    assert best_start([judged("not-converged", 0.8, "Maximum_Iterations_Exceeded"),
                       judged("not-converged", 0.9)]) == 1  # fmt: skip
    assert best_start([judged("optimal", 1.0), None, judged("optimal", 1.0)]) == 0
    assert best_start([judged("optimal", 1.0), judged("optimal", 0.5)]) == 1


def test_the_open_loop_eigenvalues_are_extrapolated_differences_of_the_step(monkeypatch):
    """powered_eigenvalues on a map whose Jacobian is known: the plain differences carry
    the cubic term's O(h^2) error, the extrapolation none (exact for a cubic); a map that
    jumps between the two steps (another event counting) gives no eigenvalues."""
    from vsw.runtime.errors import ConvergenceError
    from vsw.synthesis.powered import step

    matrix = np.array([[0.5, 2.0, 0.0], [-1.0, 0.3, 0.1], [0.0, 0.0, 1.2]])
    x = np.array([0.3, -1.5, 2.0])
    model, gait = types.SimpleNamespace(name="stub"), types.SimpleNamespace(states=[[x]])

    def smooth(model, params, gait, y):
        return matrix @ y + 0.1 * y**3

    monkeypatch.setattr(step, "powered_step", smooth)
    exact = matrix + np.diag(0.3 * x**2)
    plain = step.powered_step_jacobian(model, (), gait, x, step.EIGENVALUE_STEP)
    assert 1e-8 < np.max(np.abs(plain - exact)) < 1e-5
    found = sorted(abs(v) for v in step.powered_eigenvalues(model, (), gait))
    assert found == pytest.approx(sorted(abs(np.linalg.eigvals(exact))), rel=1e-9)

    def jumping(model, params, gait, y):  # a jump past the finer step, inside the coarser
        return smooth(model, params, gait, y) + float(y[0] > x[0] + 1.5 * step.EIGENVALUE_STEP)

    monkeypatch.setattr(step, "powered_step", jumping)
    with pytest.raises(ConvergenceError, match="not smooth at the gait"):
        step.powered_eigenvalues(model, (), gait)
