"""Design for every model (vsw.synthesis.design): the NLP on the periodic orbit, checked against
physics and closed forms it does not use.

* the Jury / Schur–Cohn rows against numpy's roots;
* the rimless wheel's design against its closed-form gait (Tedrake, Underactuated Robotics,
  "Simple models of walking": the fixed point just after collision
  ``omega* = cot(2 alpha) sqrt(4 (g / l) sin(alpha) sin(gamma))`` and the map's slope
  ``cos^2(2 alpha)`` there);
* a passive walker's cost of transport is sin(gamma) on every periodic gait (the energy the
  impacts dissipate per step is gravity's work down the slope; the design computes it from
  the impacts' kinetic energy, not from the slope);
* the ILE: the generic route reproduces the closed-form design (vsw.models.ile.design);
* statuses, exit codes and one-line errors of ``vsw design --model NAME``.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from vsw import models
from vsw.cli import main
from vsw.models.ile.design import design as ile_design
from vsw.orbits.monodromy import characteristic_coefficients, jury_rows
from vsw.runtime.errors import VswInputError
from vsw.synthesis.design import DesignRequest, design


@pytest.fixture
def run_cli(capsys):
    def run(argv):
        code = main(argv)
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


@pytest.mark.parametrize("degree", [1, 2, 3, 4, 5])
def test_jury_rows_say_whether_every_root_is_in_the_unit_disc(degree):
    rng = np.random.default_rng(degree)
    checked = 0
    for _ in range(400):
        roots = rng.uniform(0.2, 1.3, degree) * np.exp(1j * rng.uniform(-np.pi, np.pi, degree))
        # Real coefficients: pair complex roots with their conjugates.
        if degree >= 2:
            roots[1] = np.conj(roots[0])
        if degree >= 4:
            roots[3] = np.conj(roots[2])
        if degree % 2:
            roots[-1] = roots[-1].real
        radius = np.max(np.abs(roots))
        if abs(radius - 1) < 1e-3:
            continue
        coefficients = np.real(np.poly(roots))[1:]
        rows = jury_rows(list(coefficients))
        assert (min(rows) >= 0) == (radius < 1), (roots, rows)
        checked += 1
    assert checked > 300


def test_characteristic_coefficients_are_numpys():
    rng = np.random.default_rng(1)
    matrix = rng.normal(size=(5, 5))
    got = [float(c) for c in characteristic_coefficients(ca.DM(matrix), 5)]
    np.testing.assert_allclose(got, np.poly(matrix)[1:], rtol=1e-12, atol=1e-12)


def test_rimless_wheel_design_is_its_closed_form_gait():
    model = models.load("rimless_wheel")
    result = design(model, DesignRequest(objective={"eigenvalue": 1.0},
                                         bounds={"alpha": (0.2, 0.5)},
                                         fixed={"gamma": 0.2}))  # fmt: skip
    assert result.status == "optimal"
    alpha, gamma = result.parameters["alpha"], result.parameters["gamma"]
    # The slope cos^2(2 alpha) falls as alpha grows to pi/4: the least is at the bound.
    assert alpha == pytest.approx(0.5, abs=1e-9)
    assert result.quantities["eigenvalue"] == pytest.approx(math.cos(2 * alpha) ** 2, rel=1e-8)
    omega = 1 / math.tan(2 * alpha) * math.sqrt(4 * 9.81 * math.sin(alpha) * math.sin(gamma))
    assert result.orbit.state["theta_dot"] == pytest.approx(omega, rel=1e-8)
    assert result.simulation_rel_error < 1e-9


def test_rimless_wheel_fastest_gait_rolls_at_the_lift_off_limit():
    model = models.load("rimless_wheel")
    result = design(model, DesignRequest(objective={"speed": 1.0}, fixed={"gamma": 0.05}))
    assert result.found
    # The stance foot stays down while g cos(theta) >= l omega^2 (the wheel's centripetal
    # demand at the top of the arc, theta = 0): the fastest gait sits on it.
    omega_top = math.sqrt(9.81 * 1.0)
    rates = result.orbit.state["theta_dot"]
    assert rates < omega_top
    lift_off = next(c for c in result.margins if c["name"] == "lift-off")
    assert 0 <= lift_off["margin"] < 1e-5
    assert "lift-off" in result.active_constraints


def test_a_passive_walkers_cost_of_transport_is_the_slope():
    model = models.load("rimless_wheel")
    result = design(model, DesignRequest(objective={"energy_per_step": 1.0},
                                         bounds={"gamma": (0.03, 0.12)}))  # fmt: skip
    assert result.found
    gamma = result.parameters["gamma"]
    assert result.quantities["cost_of_transport"] == pytest.approx(math.sin(gamma), rel=1e-8)


@pytest.mark.parametrize(
    ("generic", "closed"),
    [
        ({"targets": {"speed": 0.5}}, {"targets": {"speed": 0.5}}),
        ({"objective": {"eigenvalue": 1.0}, "fixed": {"phi0": math.radians(40)}},
         {"objective": "eigenvalue", "fixed": {"phi0": math.radians(40)}}),
        ({"objective": {"speed": 1.0}, "max_eigenvalue": 0.5, "bounds": {"phi0": (0.3, 0.9)}},
         {"objective": "speed", "max_eigenvalue": 0.5, "bounds": {"phi0": (0.3, 0.9)}}),
    ],
)  # fmt: skip
def test_the_generic_route_reproduces_the_ile_closed_form_design(generic, closed):
    ours = design(models.load("ile"), DesignRequest(**generic))
    theirs = ile_design(**closed)
    assert ours.status == theirs.status == "optimal"
    # The closed forms keep the normal force >= 1e-9 m g, the NLP >= 1e-7 m g (its nodes
    # are integrated to 1e-10): the designs differ by that much.
    np.testing.assert_allclose(
        [ours.parameters[k] for k in ("beta", "theta_II", "phi0")],
        [theirs.beta, theirs.theta_II, theirs.phi0], rtol=0, atol=2e-6,
    )  # fmt: skip
    assert ours.quantities["eigenvalue"] == pytest.approx(theirs.to_dict()["eigenvalue"],
                                                          abs=2e-6)  # fmt: skip
    assert ours.quantities["speed"] == pytest.approx(theirs.to_dict()["speed"], abs=2e-6)


def test_a_speed_beyond_reach_is_infeasible_with_the_fastest_gait():
    model = models.load("rimless_wheel")
    result = design(model, DesignRequest(targets={"speed": 10.0}, fixed={"gamma": 0.05}))
    assert result.status == "infeasible"
    assert "largest speed" in result.message
    fastest = float(result.message.split("constraints, ")[1].split(" ")[0])
    # Below the speed at which the wheel would leave the ground at the top of its arc,
    # sqrt(g l) (= 3.13 m/s), and close to it: the lift-off limit is what stops it.
    assert 3.0 < fastest < math.sqrt(9.81)


def test_an_infeasible_target_is_proven_before_the_seeds_are_shot(monkeypatch):
    # The compass gait has no walking gait with a 3 s period: the extremes the collocated
    # starts reach prove it, so the seeds' shooting solves (seconds each) are not run.
    from vsw.synthesis.design import solve

    def not_shot(*args, **kwargs):
        raise AssertionError("the seeds were shot")

    monkeypatch.setattr(solve, "_shot_seeds", not_shot)
    result = design(models.load("compass-gait"), DesignRequest(targets={"period": 3.0}))
    assert result.status == "infeasible"
    assert "largest period" in result.message


def test_the_eigenvalue_bound_holds_on_the_verified_gait():
    result = design(models.load("ile"), DesignRequest(objective={"speed": 1.0},
                                                      max_eigenvalue=0.3))  # fmt: skip
    assert result.found
    assert result.quantities["eigenvalue"] <= 0.3 * (1 + 1e-6)
    assert result.orbit.max_abs_eigenvalue == result.quantities["eigenvalue"]


@pytest.mark.parametrize(
    ("request_", "words"),
    [
        ({"fixed": {"nope": 1.0}, "objective": {"speed": 1.0}}, "not a parameter"),
        ({"bounds": {"gamma": (2.0, 3.0)}, "objective": {"speed": 1.0}}, "open interval"),
        ({"fixed": {"gamma": 0.05}, "bounds": {"gamma": (0.06, 0.07)},
          "objective": {"speed": 1.0}}, "contradicts"),
        ({"targets": {"speed": 1.0, "period": 1.0}, "fixed": {"gamma": 0.05}}, "target(s)"),
        ({"targets": {"speed": 1.0}, "bounds": {"speed": (2.0, 3.0)}}, "contradicts"),
        ({"objective": {"speed": 1.0}, "fixed": {"alpha": 0.3, "gamma": 0.05}}, "nothing to"),
        ({}, "give an objective"),
        ({"objective": {"speed": 1.0}, "start": {"nope": 0.3}}, "not a parameter"),
        ({"objective": {"speed": 1.0}, "fixed": {"gamma": 0.05}, "start": {"gamma": 0.06}},
         "a fixed parameter has no start"),
        ({"objective": {"speed": 1.0}, "bounds": {"alpha": (0.2, 0.5)},
          "start": {"alpha": 0.6}}, "outside its design interval"),
        ({"objective": {"speed": 1.0}, "start": {"g": 9.0}}, "not designed"),
    ],
)  # fmt: skip
def test_malformed_requests_are_refused_before_any_search(request_, words):
    with pytest.raises(VswInputError, match=None) as info:
        design(models.load("rimless_wheel"), DesignRequest(**request_))
    assert words in str(info.value)
    assert "\n" not in str(info.value)


def test_a_design_searches_for_its_first_gaits_at_the_start_given(monkeypatch):
    model = models.load("rimless_wheel")
    searched = []
    search = model.search_gaits
    monkeypatch.setattr(model, "search_gaits", lambda params: searched.append(params) or
                        search(params))  # fmt: skip
    result = design(model, DesignRequest(objective={"eigenvalue": 1.0},
                                         bounds={"alpha": (0.2, 0.5)}, fixed={"gamma": 0.2},
                                         start={"alpha": 0.45}))  # fmt: skip
    names = [p.name for p in model.parameter_table]
    assert searched[0][names.index("alpha")] == 0.45
    assert searched[0][names.index("gamma")] == 0.2
    # The same design as from the default start: cos^2(2 alpha) least at the bound.
    assert result.status == "optimal"
    assert result.parameters["alpha"] == pytest.approx(0.5, abs=1e-9)


def test_cli_design_of_a_model_prints_the_envelope_and_the_gait(run_cli):
    code, out, err = run_cli(["design", "--model", "rimless-wheel", "--minimize",
                              "eigenvalue", "--bound", "alpha=0.2:0.5", "--fix", "gamma=0.2",
                              "--json"])  # fmt: skip
    assert code == 0, err
    data = json.loads(out)
    assert list(data)[:4] == ["model", "parameters", "units", "provenance"]
    assert data["status"] == "optimal"
    assert data["parameters"]["gamma"] == 0.2
    assert data["gait"]["max_abs_eigenvalue"] == pytest.approx(math.cos(1.0) ** 2, rel=1e-8)
    assert data["units"]["quantities"]["speed"] == "m/s"


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--model", "compass-gait", "--beta-min", "0.5", "--maximize", "speed"], "ILE's"),
        # 0 is a value, not an absent option.
        (["--model", "compass-gait", "--gravity", "0", "--maximize", "speed"], "ILE's"),
        (["--model", "ile", "--maximize", "step-length"], "speed only"),
        (["--model", "ile", "--target-period", "2"], "not an option"),
        (["--model", "compass-gait", "--bound", "gamma=1"], "expected NAME=A:B"),
        (["--model", "compass-gait", "--bound", "gamma=0.1:0.05", "--maximize", "speed"],
         "exceeds"),
        (["--model", "compass-gait", "--fix", "gamma=x", "--maximize", "speed"], "gamma"),
        (["--model", "compass-gait", "--max-eigenvalue", "-1", "--maximize", "speed"],
         "positive"),
        (["--model", "ile", "--target-speed", "0.5", "--start", "beta=0.5"], "not an option"),
        (["--model", "compass-gait", "--start", "nope=1", "--maximize", "speed"],
         "not a parameter"),
        (["--model", "compass-gait", "--start", "gamma=0.1", "--start", "gamma=0.2",
          "--maximize", "speed"], "given twice"),
    ],
)  # fmt: skip
def test_cli_bad_design_requests_exit_2_with_one_line(run_cli, argv, words):
    code, _, err = run_cli(["design", *argv])
    assert code == 2
    assert words in err
    assert len(err.strip().splitlines()) == 1


def test_cli_ile_speed_target_beyond_the_robot_is_infeasible(run_cli):
    code, out, err = run_cli(["design", "--stepper-2d", "--target-speed", "5"])
    assert code == 3
    assert out.startswith("status           infeasible")
    assert "above the fastest gait" in err and "1.68" in err


@pytest.mark.slow
def test_the_suite_runs_and_the_rimless_wheel_meets_its_references():
    """The suite of benchmarks/design_every_model.py in miniature: its reference (gait
    branches by continuation, no IPOPT) and the design agree on every problem."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
    import design_every_model

    report = design_every_model.run(6, 7, ["rimless_wheel"], slsqp=1)
    wheel = report["models"]["rimless_wheel"]
    assert wheel["problems"] == 6
    assert wheel["success"] == 6, [r for r in wheel["records"] if not r["success"]]
    assert wheel["feasible_reported_infeasible"] == 0
    assert len(wheel["slsqp_pairs"]) == 1


def test_cli_ile_bound_on_the_step_frequency_in_its_own_units(run_cli):
    code, out, err = run_cli(["design", "--maximize", "speed", "--bound",
                              "step_frequency=:0.5", "--json"])  # fmt: skip
    assert code == 0, err
    data = json.loads(out)
    assert 1 / data["step_period"] <= 0.5 * (1 + 1e-9)
