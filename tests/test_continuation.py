"""Continuation of gaits (vsw.gaits.continuation, ``vsw continue``): special points located to
their defining equations and checked against routes the continuation does not use: the
SciPy-simulated map's Jacobian by central differences, the single-shooting Poincaré map of
:meth:`vsw.dynamics.hybrid.HybridModel.eigenvalues`, the batch simulator's iterated map, the ILE's
closed forms, and the published values (cited beside each)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from vsw.cli import main
from vsw.dynamics.batch import simulator
from vsw.gaits import continuation, special_curves
from vsw.models import load

# Bhounsule et al. 2013 (paper_check.walkers.BHOUNSULE_LONG): the simplest walker's long
# gait at gamma = 0.009 to 15 digits, (q1, u1, q2, u2) with q1 = -theta, q2 = -phi.
LONG_GAIT_0009 = (-0.200310900563820, -0.400621801127640, 0.199832473025474, 0.015822999949030)
LONG_PERIOD_0009 = 3.882


def _central_difference_map_jacobian(model, params, state, h=1e-6):
    """The Poincaré map's Jacobian from SciPy-simulated steps (DOP853, 1e-12)."""
    n = len(state)
    jac = np.empty((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        jac[:, j] = (model.step(params, state + e).state - model.step(params, state - e).state) / (
            2 * h
        )
    return jac


def _long_gait_branch(stop_value: float) -> continuation.Branch:
    """The simplest walker's long gait continued from gamma = 0.009, no switching."""
    m = load("simplest-walker")
    (branch,) = continuation.continue_gaits(
        m, m.parameters({"gamma": 0.009}), "gamma", 0.009, stop_value, LONG_GAIT_0009,
        (LONG_PERIOD_0009,), options=continuation.Options(switch=False),
    )  # fmt: skip
    return branch


@pytest.fixture(scope="module")
def simplest_cascade():
    """The simplest walker's long gait from gamma = 0.009 to 0.0183, switching at every
    flip up to period 4."""
    m = load("simplest-walker")
    params = m.parameters({"gamma": 0.009})
    options = continuation.Options(max_period=4)
    branches = continuation.continue_gaits(
        m, params, "gamma", 0.009, 0.0183, LONG_GAIT_0009, (LONG_PERIOD_0009,), options=options
    )
    return m, branches


def test_the_simplest_walkers_first_flip_is_garcias(simplest_cascade):
    """Garcia et al. 1998: the long gait is stable up to gamma = 0.0151 (sec. 5; 0.015 in
    the abstract). Located: an eigenvalue at -1 to 1e-9; the single-shooting Poincaré map
    and central differences of the SciPy-simulated map agree there."""
    m, branches = simplest_cascade
    (flip,) = [s for s in branches[0].special_points if s.type == "flip"]
    assert branches[0].period == 1 and abs(flip.parameter - 0.0151) <= 5e-5
    assert flip.defining <= 1e-9
    params = m.parameters({"gamma": flip.parameter})
    state = np.array(list(flip.state.values()))
    single_shooting = m.eigenvalues(params, state)
    assert min(abs(mu + 1) for mu in single_shooting) <= 1e-8
    simulated = np.linalg.eigvals(_central_difference_map_jacobian(m, params, state))
    assert min(abs(mu + 1) for mu in simulated) <= 1e-5
    # The located state is the period-one gait there: one simulated step returns to it.
    step = m.step(params, state)
    assert np.max(np.abs(step.state - state)) <= 1e-9


def test_the_cascade_is_followed_and_each_flip_brackets_the_iterated_maps_doubling(
    simplest_cascade,
):
    """Periods 1, 2, 4 each from the previous one's flip, at increasing slopes; on either
    side of the period-2 branch's flip the batch simulator's iterated map (no continuation)
    settles on period 2 below and period 4 above."""
    m, branches = simplest_cascade
    assert [b.period for b in branches] == [1, 2, 4]
    flips = [next(s for s in b.special_points if s.type == "flip") for b in branches[:2]]
    assert branches[1].from_flip == flips[0].parameter
    assert branches[2].from_flip == flips[1].parameter
    assert flips[0].parameter < flips[1].parameter < 0.0183
    assert all(f.defining <= 1e-9 for f in flips)
    sim = simulator(m)
    start = np.array(list(flips[1].state.values()))
    gammas = [flips[1].parameter - 2e-4, flips[1].parameter + 2e-4]
    walks = sim.walk(np.array([m.parameters({"gamma": g}) for g in gammas]),
                     np.array([start, start]), 3000, converge_tol=0.0,
                     period_tol=1e-9, max_period=8)  # fmt: skip
    assert walks.ended() == ["period-2", "period-4"]


def test_points_of_a_branch_are_gaits_of_the_stated_period(simplest_cascade):
    """Every point of the period-2 branch: two simulated steps return to it, one does not,
    and the stability flag follows the eigenvalues."""
    m, branches = simplest_cascade
    for point in branches[1].points[1::4]:
        params = m.parameters({"gamma": point["parameter"]})
        x0 = np.array(list(point["state"].values()))
        one = m.step(params, x0).state
        two = m.step(params, one).state
        assert np.max(np.abs(two - x0)) <= 1e-8
        assert np.max(np.abs(one - x0)) > 1e-6
        assert point["stable"] == (point["max_abs_eigenvalue"] < 1)
        assert len(point["step_lengths"]) == 2


@pytest.mark.slow  # a continuation to the flip
def test_the_compass_gaits_first_flip_is_goswamis():
    """Goswami, Thuilot, Espiau 1996 (as quoted by the walkers' report): the first period
    doubling at 4.37 degrees (read off a diagram: 5e-3 relative)."""
    m = load("compass-gait")
    three = math.radians(3.0)
    params = m.parameters({"gamma": three})
    # A guess near the 3-degree gait (the corrector solves it).
    guess = (-0.271, 0.271, 1.09, 0.38)
    branches = continuation.continue_gaits(
        m, params, "gamma", three, math.radians(4.6), guess, (0.73,),
        options=continuation.Options(switch=False),
    )  # fmt: skip
    (flip,) = [s for s in branches[0].special_points if s.type == "flip"]
    assert abs(math.degrees(flip.parameter) - 4.37) <= 5e-3 * 4.37
    at = m.parameters({"gamma": flip.parameter})
    assert min(abs(mu + 1) for mu in m.eigenvalues(at, list(flip.state.values()))) <= 1e-8


def test_the_biped_branch_ends_where_heelstrike_reaches_the_extension():
    """The VSW biped at (beta, theta_II) = (0.97, -0.2): the branch ends at mu = 0.3634 (an
    independent re-implementation of the model), where the short phase's duration reaches 0;
    just before it the single-shooting solver finds the gait with that phase almost gone."""
    m = load("vsw-biped")
    params = m.parameters({"beta": 0.97, "theta_II": -0.2, "mu": 0.3})
    orbit = next(o for o in m.fixed_points(params) if o.stable)
    (branch,) = continuation.continue_gaits(
        m, params, "mu", 0.3, 0.5, list(orbit.state.values()), orbit.durations
    )
    assert branch.ended == "boundary"
    (end,) = branch.special_points
    assert end.type == "boundary" and "phase short of no duration" in end.condition
    assert abs(end.parameter - 0.3634) <= 5e-5 and end.defining <= 1e-12
    before = m.parameters({"beta": 0.97, "theta_II": -0.2, "mu": end.parameter - 1e-6})
    near = m.periodic_orbit(before, np.array(list(end.state.values())), end.durations)
    short = near.durations[[p["name"] for p in m.phases].index("short")]
    assert 0 < short < 1e-4


def test_the_ile_branch_ends_on_its_closed_form_conditions():
    """The ILE through the generic runtime (no closed form used): decreasing beta, the
    branch ends where the stance leg's normal force reaches zero, the closed form's margin
    'stance_contact' (its last); decreasing theta_II, where the extension angle reaches
    theta_I (the closed form's 'extension_reached')."""
    m = load("ile")
    params = m.parameters({})
    q_f = float(m.module.q_fixed(*params))
    state = m.section_state_from_q(params, q_f)
    durations = m.step(params, state).durations

    def branch_end(over, stop_value):
        index = [p.name for p in m.parameter_table].index(over)
        (branch,) = continuation.continue_gaits(
            m, params, over, params[index], stop_value, state, durations
        )
        assert branch.ended == "boundary"
        return branch.special_points[-1]

    end = branch_end("beta", 0.5)
    assert "lift-off" in end.condition

    def contact(beta):
        return m.module.fixed_point_conditions(beta, params[1], params[2])[-1]

    assert abs(end.parameter - brentq(contact, 0.6, 0.8, xtol=1e-15)) <= 1e-9
    end = branch_end("theta_II", -0.6)
    theta_i = float(m.module.theta_I(params[0], params[2]))
    assert "of no duration" in end.condition and abs(end.parameter - theta_i) <= 1e-10


def test_continue_json_and_plot(capsys, tmp_path):
    plot = tmp_path / "cascade.png"
    argv = ["continue", "--model", "simplest-walker", "--over", "gamma=0.009:0.0155",
            "--state", f"theta={LONG_GAIT_0009[0]}", "--state",
            f"phi={LONG_GAIT_0009[1]}", "--state", f"theta_dot={LONG_GAIT_0009[2]}",
            "--state", f"phi_dot={LONG_GAIT_0009[3]}", "--no-switch",
            "--json", "--plot", str(plot)]  # fmt: skip
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    assert list(data)[:4] == ["model", "parameters", "units", "provenance"]
    assert data["over"] == "gamma" and data["range"] == [0.009, 0.0155]
    (branch,) = data["branches"]
    assert branch["period"] == 1 and branch["ended"] == "range"
    assert {"parameter", "state", "max_abs_eigenvalue", "stable", "step_length", "speed"} <= set(
        branch["points"][0]
    )
    (flip,) = branch["special_points"]
    assert flip["type"] == "flip" and set(flip) >= {"parameter", "state", "eigenvalues"}
    assert branch["points"][0]["parameter"] == 0.009
    assert branch["points"][-1]["parameter"] == pytest.approx(0.0155, abs=1e-12)
    assert plot.stat().st_size > 10_000


BAD = [
    (["--over", "gamma=0.01"], "expected NAME=START:STOP"),
    (["--over", "mass=0.01:0.02"], "mass"),
    (["--over", "gamma=0.01:0.01"], "equal"),
    (["--over", "gamma=-0.1:0.01"], "gamma"),
    (["--over", "gamma=0.01:0.02", "--period", "0"], "--period 0"),
    (["--over", "gamma=0.01:0.02", "--period", "2"], "--state"),
    (["--over", "gamma=0.01:0.02", "--y", "theta"], "--plot"),
    (
        [
            "--over",
            "gamma=0.01:0.02",
            "--state",
            "theta=0.5",
            "--state",
            "phi=1",
            "--state",
            "theta_dot=0",
            "--state",
            "phi_dot=0",
        ],
        "gait at 0.01 near the start",
    ),
    (
        ["--over", "gamma=0.016:0.0175", "--period", "2"]
        + [
            f"--state={item}"
            for item in ("theta=-0.2", "phi=-0.4", "theta_dot=0.2", "phi_dot=0.016")
        ],
        "leads to a period-1 gait at 0.016, not period 2",
    ),
]


@pytest.mark.parametrize("argv, words", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_is_one_line(capsys, argv, words):
    code = main(["continue", "--model", "simplest-walker", *argv])
    err = capsys.readouterr().err
    assert code == 2, err
    assert words in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_the_kneed_walkers_gait_folds_at_its_least_slope():
    """The kneed walker's stable gait, continued down in slope from Hsu Chen's 0.0504 (the
    start: nyasuto/crane's gait digits, NC26 in tests/test_kneed_walker.py), turns at a fold
    near 0.0318 rad and comes back up as the other gait of the search at 0.0504 (period
    0.484 s, unstable): the fold is passed, not stopped at. At the fold the single-shooting
    Poincaré map has an eigenvalue within 1e-7 of +1."""
    m = load("kneed-walker")
    params = m.parameters({})
    guess = np.array([-0.23859, 0.23859, 0.0, 1.10959, 0.05715, 0.0])
    durations = m.step(params, guess).durations
    options = continuation.Options(switch=False, max_points=80)
    (branch,) = continuation.continue_gaits(
        m, params, "gamma", params[-2], 0.02, guess, durations, options=options
    )
    (fold,) = [s for s in branch.special_points if s.type == "fold"]
    assert 0.030 < fold.parameter < 0.034 and fold.defining <= 1e-9
    at = m.parameters({"gamma": fold.parameter})
    assert min(abs(mu - 1) for mu in m.eigenvalues(at, list(fold.state.values()))) <= 1e-7
    values = [p["parameter"] for p in branch.points]
    turn = int(np.argmin(values))
    assert np.all(np.diff(values[: turn + 1]) < 0) and np.all(np.diff(values[turn:]) > 0)
    assert branch.ended == "back at the start"
    assert values[-1] == pytest.approx(params[-2], abs=1e-12)
    assert branch.points[0]["stable"] and not branch.points[-1]["stable"]
    back = branch.points[-1]
    other = [o for o in m.fixed_points(params) if not o.stable and abs(o.period - 0.484) < 1e-3]
    (other,) = other
    gap = max(abs(back["state"][k] - v) for k, v in other.state.items())
    assert gap <= 1e-8 and back["period_time"] == pytest.approx(other.period, abs=1e-9)


@pytest.mark.slow
def test_the_compass_gaits_flip_curve_against_the_hip_mass():
    """The first flip continued in (gamma, m_h): at a point of the curve far from the start
    the one-parameter continuation in gamma at that m_h (another system: the orbit alone,
    the flip located by the Illinois method) finds the flip at the curve's gamma, and the
    single-shooting Poincaré map has an eigenvalue at -1 there."""
    m = load("compass-gait")
    three, stop_value = math.radians(3.0), math.radians(6.0)
    params = m.parameters({"gamma": three})
    guess, durations = (-0.271, 0.271, 1.09, 0.38), (0.73,)
    options = continuation.Options(switch=False)
    (branch,) = continuation.continue_gaits(
        m, params, "gamma", three, stop_value, guess, durations, options=options
    )
    (flip,) = [s for s in branch.special_points if s.type == "flip"]
    curve = special_curves.continue_special_point(
        m, params, "gamma", three, stop_value, flip, 1, "m_h", 6.0, 16.0,
        options=continuation.Options(max_points=40),
    )  # fmt: skip
    assert curve.ended == ["box", "box"]
    assert all(p["defining_equation"] <= 1e-9 for p in curve.points)
    heavy = max(curve.points, key=lambda p: p["second_parameter"])
    assert heavy["second_parameter"] > 14.0 and heavy["parameter"] < flip.parameter
    at = m.parameters({"gamma": three, "m_h": heavy["second_parameter"]})
    (again,) = continuation.continue_gaits(
        m, at, "gamma", three, stop_value, guess, durations, options=options
    )
    (located,) = [s for s in again.special_points if s.type == "flip"]
    assert abs(located.parameter - heavy["parameter"]) <= 1e-8
    on_curve = m.parameters({"gamma": heavy["parameter"], "m_h": heavy["second_parameter"]})
    mus = m.eigenvalues(on_curve, list(heavy["state"].values()))
    assert min(abs(mu + 1) for mu in mus) <= 1e-8


@pytest.mark.slow
def test_free_draws_the_parameter_plane(capsys, tmp_path):
    plot = tmp_path / "plane.png"
    argv = ["continue", "--model", "vsw-biped", "--param", "beta=0.97", "--param",
            "theta_II=-0.2", "--over", "mu=0.3:0.5", "--free", "theta_II=-0.25:-0.15",
            "--json", "--plot", str(plot)]  # fmt: skip
    assert main(argv) == 0
    data = json.loads(capsys.readouterr().out)
    (curve,) = data["curves"]
    assert curve["type"] == "boundary" and "phase short" in curve["condition"]
    assert data["free"] == "theta_II" and data["free_range"] == [-0.25, -0.15]
    # Along the boundary the short phase has no duration.
    short = [p["name"] for p in load("vsw-biped").phases].index("short")
    assert all(abs(p["phase_durations"][short]) <= 1e-9 for p in curve["points"])
    assert len(curve["points"]) > 5 and plot.stat().st_size > 10_000


def test_a_reported_condition_crossing_zero_is_a_boundary_the_branch_passes(monkeypatch):
    """The location of a reported condition's zero (no model of ours has one on the branches
    tried, so the margin here is made up: gamma - 0.012 on the simplest walker's branch): a
    boundary at 0.012 naming the condition, and the branch goes on to the range's end."""

    def margins(eq, w, eigenvalues):
        return {"made-up": eq.parameter(float(w[-1])) - 0.012}

    monkeypatch.setattr(continuation, "_margins", margins)
    branch = _long_gait_branch(0.014)
    assert branch.ended == "range"
    (boundary,) = branch.special_points
    assert boundary.type == "boundary" and "condition made-up" in boundary.condition
    assert abs(boundary.parameter - 0.012) <= 1e-12 and boundary.defining <= 1e-12


def test_a_complex_pair_crossing_the_unit_circle_is_a_neimark_sacker_point(monkeypatch):
    """The Neimark-Sacker detector and its location (no model of ours shows one on the
    branches tried, so the map's eigenvalues here are made up: a pair r exp(+-i) with
    r = 1 + 50 (gamma - 0.012), and 0.5 and 0)."""

    def eigenvalues(self, jac):
        r = 1.0 + 50.0 * (self.parameter(float(self._w[-1])) - 0.012)
        return [r * complex(math.cos(1.0), math.sin(1.0)),
                r * complex(math.cos(1.0), -math.sin(1.0)), 0.5, 0.0]  # fmt: skip

    original = continuation.Equations.evaluate

    def evaluate(self, w):
        self._w = w  # the point whose eigenvalues are asked next
        return original(self, w)

    monkeypatch.setattr(continuation.Equations, "evaluate", evaluate)
    monkeypatch.setattr(continuation.Equations, "eigenvalues", eigenvalues)
    branch = _long_gait_branch(0.014)
    (ns,) = branch.special_points
    assert ns.type == "neimark-sacker" and abs(ns.parameter - 0.012) <= 1e-12
    assert ns.defining <= 1e-9
