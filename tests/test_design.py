"""Tests of vsw.models.ile.design: constrained gait design with CasADi/IPOPT on the closed forms."""

from __future__ import annotations

import itertools
import json
import math

import casadi as ca
import numpy as np
import pytest

from generated import ile
from vsw.cli import main
from vsw.models.ile.analysis import analyze, step_period_scipy
from vsw.models.ile.design import design
from vsw.models.ile.design.forms import closed_form_quantities
from vsw.models.ile.params import STEPPER_2D, RobotScale
from vsw.models.ile.simulate import simulate

R = math.radians
BOUNDS = {"beta": (0.6, 0.95), "theta_II": (R(-20), R(20)), "phi0": (R(20), R(60))}
BOUND_ARGS = [
    "--beta-min", "0.6", "--beta-max", "0.95", "--theta-ii-min", "-20", "--theta-ii-max", "20",
    "--phi0-min", "20", "--phi0-max", "60",
]  # fmt: skip


def _grid_quantities(bounds: dict, n: int) -> tuple[np.ndarray, dict, np.ndarray]:
    """Closed-form quantities on an n^3 grid over the bounds (ends included)."""
    from vsw.models.ile.design.forms import numpy_quantities

    axes = [np.linspace(*bounds[name], n) for name in ("beta", "theta_II", "phi0")]
    x = np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=1)
    qs = numpy_quantities(x)
    walks = np.isfinite(qs["speed"])
    for name, _, strict, _, physical, _ in ile.CONDITIONS:
        if physical:
            walks &= qs[name] > 0 if strict else qs[name] >= 0
    return x, qs, walks


# --- the step period inside the NLP ------------------------------------------------------


def _period_function() -> ca.Function:
    """Period and the Jacobian of (period, speed) exactly as the design NLP builds them."""
    x = ca.SX.sym("x", 3)
    qs = closed_form_quantities(x[0], x[1], x[2])
    period, speed = qs["step_period"], qs["speed"]
    return ca.Function("period", [x], [period, ca.jacobian(ca.vertcat(period, speed), x)])


@pytest.mark.parametrize(
    "beta, theta_II, phi0",
    [(0.8, 0.0, R(45)), (0.9, R(-8), R(40)), (0.69, R(20), R(48)), (0.95, R(-5), R(25))],
)
def test_casadi_period_matches_scipy_and_simulation(beta, theta_II, phi0):
    assert bool(analyze(beta, theta_II, phi0).walks)
    period, _ = _period_function()([beta, theta_II, phi0])
    q_fixed = float(ile.q_fixed(beta, theta_II, phi0))
    reference = float(step_period_scipy(beta, theta_II, phi0, q_fixed))
    sim = simulate(beta, theta_II, phi0, q_fixed, 1, record=False)
    assert float(period) == pytest.approx(reference, rel=1e-12)
    assert float(period) == pytest.approx(float(sim.step_periods[0]), rel=1e-9)


@pytest.mark.parametrize("theta_II", [0.0, R(-12), R(12)])
def test_raw_generated_period_derivative_is_right_on_and_off_the_apex(theta_II):
    # The generated period takes sqrt(1 - cos) at each end as +-sin/sqrt(1 + cos) per
    # branch (derive/elliptic.py), never |sin(theta/2)|, whose CasADi derivative at 0 is 0.
    x = ca.SX.sym("x", 3)
    tau = ile.phase_durations(x[0], x[1], x[2], ile.q_fixed(x[0], x[1], x[2]))
    period = ca.Function("p", [x], [tau[0] + tau[1]])
    jac = ca.Function("j", [x], [ca.jacobian(tau[0] + tau[1], x)])
    x0 = np.array([0.8, theta_II, R(45)])
    exact = np.array(jac(x0)).ravel()
    h = 1e-6
    for i in range(3):
        dx = np.zeros(3)
        dx[i] = h
        fd = (float(period(x0 + dx)) - float(period(x0 - dx))) / (2 * h)
        assert exact[i] == pytest.approx(fd, rel=1e-6, abs=1e-8)
    assert abs(exact[1]) > 0.1


def test_period_gradient_finite_and_continuous_across_theta_II_zero():
    fn = _period_function()
    jacobians = []
    for theta_II in (-1e-7, 0.0, 1e-7):
        _, jac = fn([0.8, theta_II, R(45)])
        jac = np.array(jac)
        assert np.all(np.isfinite(jac))
        jacobians.append(jac)
    # The if_else branches on the sign of theta_II join smoothly: no jump in the gradient.
    np.testing.assert_allclose(jacobians[0], jacobians[2], rtol=1e-5, atol=1e-6)
    # And the exact derivative agrees with a central difference of the closed form.
    h = 1e-6
    x0 = np.array([0.8, 0.0, R(45)])
    for i in range(3):
        dx = np.zeros(3)
        dx[i] = h
        fd = (float(fn(x0 + dx)[0]) - float(fn(x0 - dx)[0])) / (2 * h)
        assert jacobians[1][0, i] == pytest.approx(fd, rel=1e-6, abs=1e-8)


# --- designs -----------------------------------------------------------------------------


def test_design_satisfies_constraints_and_matches_simulation():
    result = design(
        "speed", bounds=BOUNDS, min_contact_margin=0.1, max_eigenvalue=0.4, scale=STEPPER_2D
    )
    assert result.status == "optimal", result.message
    a = result.analysis
    assert bool(a.walks)
    for name, (lo, hi) in BOUNDS.items():
        assert lo - 1e-9 <= getattr(result, name) <= hi + 1e-9
    assert float(a.contact_margin) >= 0.1 - 1e-9
    assert float(a.eigenvalue) <= 0.4 + 1e-9
    assert result.simulation_rel_error < 1e-8
    assert "min_contact_margin" in result.active_constraints
    # Independent check: the fixed point reached by simulating from another start.
    sim = simulate(result.beta, result.theta_II, result.phi0, 0.5 * float(a.q_fixed), 60,
                   record=False)  # fmt: skip
    assert sim.q[-1] == pytest.approx(float(a.q_fixed), rel=1e-8)


def _best_on_grid_near(target_speed: float, margin: float, n: int = 70) -> float:
    """Least eigenvalue over a dense grid of the whole domain among walking gaits within
    0.5 % of a speed with the given contact margin: a bound the optimum must reach."""
    wide = {"beta": (0.2, 0.99), "theta_II": (R(-60), R(70)), "phi0": (R(5), R(85))}
    _, qs, walks = _grid_quantities(wide, n)
    near = walks & (np.abs(qs["speed"] / target_speed - 1) < 5e-3)
    near &= qs["stance_contact"] >= margin
    assert near.any()
    return float(qs["eigenvalue"][near].min())


@pytest.mark.parametrize(
    "request_, speed, margin",
    [
        # The requests of the issue that used to end "not converged" (exit 3).
        ({"objective": "eigenvalue", "targets": {"speed_m_s": 0.8}, "min_contact_margin": 0.1,
          "scale": STEPPER_2D}, 0.8 / math.sqrt(9.81 * 0.25), 0.1),
        ({"targets": {"speed": 0.5}}, 0.5, 0.0),
        ({"targets": {"speed_m_s": 0.8}, "scale": STEPPER_2D}, 0.8 / math.sqrt(9.81 * 0.25), 0.0),
    ],
)  # fmt: skip
def test_feasible_requests_without_a_box_reach_a_verified_optimum(request_, speed, margin):
    result = design(**request_)
    assert result.status == "optimal", result.message
    assert float(result.analysis.speed) == pytest.approx(speed, rel=1e-9)
    assert float(result.analysis.contact_margin) >= margin - 1e-9
    assert bool(result.analysis.walks)
    assert result.simulation_rel_error < 1e-8
    # No gait of a dense grid near that speed is more stable (allowing for the 0.5 % band:
    # the grid's near-target gaits are not exactly at the target).
    assert float(result.analysis.eigenvalue) <= _best_on_grid_near(speed, margin) + 2e-3


def test_target_speed_is_hit():
    result = design(targets={"speed_m_s": 0.8}, bounds=BOUNDS, scale=STEPPER_2D)
    assert result.status == "optimal", result.message
    assert abs(float(result.analysis.speed_m_s) / 0.8 - 1) <= 1e-8
    assert "target_speed" in result.active_constraints
    assert result.simulation_rel_error < 1e-8
    _, qs, walks = _grid_quantities(BOUNDS, 30)
    near = walks & (np.abs(qs["speed"] * math.sqrt(9.81 * 0.25) - 0.8) < 2e-3)
    assert near.any()
    assert float(result.analysis.eigenvalue) <= qs["eigenvalue"][near].min() + 0.02


def test_other_targets_are_hit():
    result = design(targets={"q_fixed": 0.5, "step_length": 0.7}, bounds=BOUNDS)
    assert result.status == "optimal", result.message
    assert float(result.analysis.q_fixed) == pytest.approx(0.5, rel=1e-9)
    assert float(result.analysis.step_length) == pytest.approx(0.7, rel=1e-9)
    result = design("cost_of_transport", targets={"step_frequency_hz": 3.0}, bounds=BOUNDS,
                    scale=STEPPER_2D)  # fmt: skip
    assert result.status == "optimal", result.message
    assert 1 / float(result.analysis.step_period_s) == pytest.approx(3.0, rel=1e-9)


@pytest.mark.parametrize(
    "objective, status",
    [("speed", "optimal"), ("eigenvalue", "optimal"), ("cost_of_transport", "not-attained")],
)
def test_no_grid_point_beats_the_optimiser(objective, status):
    result = design(objective, bounds=BOUNDS, min_contact_margin=0.05)
    assert result.status == status, result.message
    assert bool(result.open_boundary) == (status == "not-attained")
    _, qs, walks = _grid_quantities(BOUNDS, 40)
    walks &= qs["stance_contact"] >= 0.05
    sign = -1.0 if objective == "speed" else 1.0
    values = np.where(walks, sign * qs[objective], np.inf)
    best_grid = values.min()
    # Grid points are feasible, so none may beat a (global) optimum; the optimiser may be
    # better than the grid by at most what one grid cell changes the objective.
    assert best_grid >= result.objective - 1e-9
    assert best_grid - result.objective <= 0.02 * max(1.0, abs(result.objective))


def test_open_boundary_is_not_attained_with_its_limit():
    # The least cost of transport lies where the apex condition (14) becomes an equality:
    # the walker would stall at the apex. The model never reaches it.
    result = design("cost_of_transport", bounds=BOUNDS)
    assert result.status == "not-attained", result.message
    assert "apex" in result.open_boundary and "apex" in result.limit.approached_as
    assert result.analysis.condition("apex").value > 0
    assert bool(result.analysis.walks)
    path = [p["objective"] for p in result.limit.path]
    assert len(path) >= 3 and all(b < a for a, b in itertools.pairwise(path))
    # The limit lies beyond the designs on the path, within its stated uncertainty.
    assert result.limit.objective <= path[-1] + result.limit.uncertainty
    assert path[-1] - result.limit.objective <= 10 * (path[-2] - path[-1])
    assert "not attained" in result.message and "apex" in result.message


def test_degenerate_supremum_says_which_variables_run_to_which_limit():
    # The fastest gait of the model has vanishing steps: beta -> 1 and phi0 -> 0.
    result = design("speed")
    assert result.status == "not-attained", result.message
    assert "beta < 1" in result.limit.approached_as
    assert {"beta -> 1", "phi0 -> 0", "step_length -> 0"} <= set(result.limit.approached_as)
    speeds = [-p["objective"] for p in result.limit.path]
    assert all(b > a for a, b in itertools.pairwise(speeds))
    assert -result.limit.objective >= speeds[-1]
    assert bool(result.analysis.walks)


@pytest.mark.slow
def test_fixed_theta_II_on_the_region_boundary():
    # theta_II = 0 is the boundary between two regions of the apex crossing. The fastest
    # gait there presses against extension_reached (theta_I < theta_II = 0): the speed
    # grows as theta_I rises towards 0.
    result = design("speed", bounds=BOUNDS, fixed={"theta_II": 0.0})
    assert result.status == "not-attained", result.message
    assert result.open_boundary == ("extension_reached",)
    assert result.theta_II == 0.0 and bool(result.analysis.walks)
    assert result.simulation_rel_error < 1e-8
    # Not the open limit of theta_II: a region bound is no table limit.
    assert not any(name.startswith("theta_II") for name in result.limit.approached_as)
    path = [p["objective"] for p in result.limit.path]
    assert all(b < a for a, b in itertools.pairwise(path))
    # The brute-force check of the limit: theta_I -> 0 means beta -> cos phi0 from above;
    # the grid's fastest walking gait at theta_II = 0 is no faster than the limit.
    grid = {"beta": (0.6, 0.95), "theta_II": (0.0, 0.0), "phi0": (R(20), R(60))}
    _, qs, walks = _grid_quantities(grid, 200)
    assert qs["speed"][walks].max() <= -result.limit.objective + 1e-9


def test_paper_conditions_keep_the_design_inside_the_papers_region():
    # Unconstrained by (15) and (17), this request is best answered by a gait with the new
    # foot landing behind the hip (theta_I > 0) and a late extension.
    request = {"targets": {"speed": 0.5}}
    exact = design(**request)
    paper = design(**request, conditions="paper")
    assert exact.conditions == "exact" and paper.conditions == "paper"
    for result in (exact, paper):
        assert result.status in ("optimal", "not-attained"), result.message
        assert bool(result.analysis.walks)
    for name in ("theta_I_negative", "extension_before_symmetric_contact"):
        assert paper.analysis.condition(name).value > 0, name
    assert not (
        exact.analysis.condition("theta_I_negative").holds
        and exact.analysis.condition("extension_before_symmetric_contact").holds
    )
    # A smaller feasible set cannot give a better optimum.
    assert paper.objective >= exact.objective - 1e-12
    assert paper.to_dict()["condition_set"] == "paper"


def test_paper_conditions_never_use_the_region_where_theta_I_is_positive():
    from vsw.models.ile.design.forms import REGIONS
    from vsw.models.ile.design.problem import build_problem

    problem = build_problem({"speed": 1.0}, None, None, None, 0.0, None, None, "paper")
    assert all(REGIONS[r].theta_I_sign >= 0 for r in problem.regions)
    result = design("speed", conditions="paper")
    assert result.analysis.condition("theta_I_negative").value > 0


def test_target_on_the_objectives_own_quantity():
    # Maximising the speed at a fixed speed: every feasible design is optimal.
    result = design("speed", targets={"speed": 0.5})
    assert result.status == "optimal", result.message
    assert float(result.analysis.speed) == pytest.approx(0.5, rel=1e-9)
    assert result.objective == pytest.approx(-0.5, rel=1e-9)


def test_weighted_objective_is_no_worse_than_its_terms_at_their_own_optima():
    weights = {"speed": 1.0, "eigenvalue": 2.0}
    mixed = design(weights, bounds=BOUNDS, min_contact_margin=0.05)
    assert mixed.status in ("optimal", "not-attained"), mixed.message
    value = -float(mixed.analysis.speed) + 2 * float(mixed.analysis.eigenvalue)
    assert mixed.objective == pytest.approx(value, rel=1e-12)
    for single in ("speed", "eigenvalue"):
        other = design(single, bounds=BOUNDS, min_contact_margin=0.05)
        at_other = -float(other.analysis.speed) + 2 * float(other.analysis.eigenvalue)
        assert mixed.objective <= at_other + 1e-9


def test_extrapolation_of_known_sequences():
    from vsw.models.ile.design.limit import _STEP, _extrapolate

    d = np.array([1.0, _STEP, _STEP**2, _STEP**3])
    limit, uncertainty = _extrapolate(list(2.0 + 3.0 * d))  # linear in the distance
    assert limit == pytest.approx(2.0, abs=1e-12) and uncertainty < 1e-9
    limit, uncertainty = _extrapolate(list(1.0 - np.sqrt(d)))  # like sqrt(distance)
    assert abs(limit - 1.0) <= uncertainty + 1e-12
    assert _extrapolate([1.0, 2.0]) == (None, None)  # two values decide nothing
    assert _extrapolate([0.0, -1.0, -3.0, -7.0]) == (-math.inf, None)  # growing steps
    assert _extrapolate([0.0, -1.0, -3.0])[0] is None  # two growing steps are not enough


def test_impossible_eigenvalue_bound_is_infeasible_and_named():
    # eigenvalue = beta^2 cos^2 phi0 >= 0.81 cos^2 40 deg = 0.475 > 0.2.
    result = design(
        "eigenvalue", fixed={"beta": 0.9}, bounds={"phi0": (None, R(40))}, max_eigenvalue=0.2
    )
    assert result.status == "infeasible"
    # Relaxing beta needs beta <= 0.58 with phi0 <= 40 deg, relaxing phi0 needs phi0 >= 60
    # deg with beta = 0.9: neither walks (brute force below), so only the bound conflicts.
    assert result.conflicting_constraints == ("max_eigenvalue",)
    for bounds in (
        {"beta": (1e-3, 0.999), "theta_II": (-1.57, 1.57), "phi0": (1e-3, R(40))},
        {"beta": (0.9, 0.9), "theta_II": (-1.57, 1.57), "phi0": (R(40), 1.5697)},
    ):
        _, qs, walks = _grid_quantities(bounds, 60)
        assert not np.any(walks & (qs["eigenvalue"] <= 0.2))


def test_impossible_target_speed_names_the_conflicting_constraints():
    result = design(targets={"speed": 0.9}, bounds=BOUNDS)
    assert result.status == "infeasible"
    assert set(result.conflicting_constraints) == {"target_speed", "phi0_min"}
    # Brute force: dropping phi0 >= 20 deg reaches 0.9; dropping any other bound does not.
    wide = {"beta": (1e-3, 0.999), "theta_II": (-1.57, 1.57), "phi0": (1e-3, 1.5697)}
    for name, side, reaches in [
        ("phi0", 0, True), ("phi0", 1, False), ("theta_II", 0, False), ("theta_II", 1, False),
        ("beta", 0, False), ("beta", 1, False),
    ]:  # fmt: skip
        bounds = dict(BOUNDS)
        pair = list(bounds[name])
        pair[side] = wide[name][side]
        bounds[name] = tuple(pair)
        _, qs, walks = _grid_quantities(bounds, 30)
        assert bool(np.any(walks & (qs["speed"] >= 0.9))) == reaches, (name, side)


def test_bad_requests_raise():
    from vsw.runtime.errors import VswInputError

    bad = [
        {},
        {"objective": "fastest"},
        {"targets": {"speed_m_s": 0.8}},  # SI without a scale
        {"objective": "speed", "bounds": {"beta": (0.9, 0.8)}},
        {"objective": "speed", "fixed": {"beta": 1.5}},
        {"objective": "speed", "conditions": "strict"},
        {"objective": "speed", "n_starts": 0},
        {"objective": "speed", "min_contact_margin": -0.1},
        # A closed bound inside the distance kept from an open limit cannot be honoured.
        {"objective": "speed", "bounds": {"beta": (None, 0.9995)}},
        # A target outside its own bounds, and one on q^f below the kept margin of (12).
        {"targets": {"step_length": 0.5}, "bounds": {"step_length": (None, 0.4)}},
        {"targets": {"q_fixed": 1e-7}},
        # Values that overflow once made dimensionless.
        {"objective": "speed", "bounds": {"step_length_m": (1e308, None)},
         "scale": RobotScale(1e-3, 1.0)},
        {"targets": {"speed_m_s": 1e300}, "scale": RobotScale(1e-300, 1.0)},
    ]  # fmt: skip
    for kwargs in bad:
        with pytest.raises(VswInputError):
            design(**kwargs)


# --- command line ------------------------------------------------------------------------


def test_cli_json_contract(capsys):
    code = main(["design", "--target-speed", "0.8", "--stepper-2d", *BOUND_ARGS, "--json"])
    out = capsys.readouterr()
    assert code == 0
    data = json.loads(out.out)
    assert out.err == ""
    reference = analyze(data["beta"], data["theta_II"], data["phi0"], STEPPER_2D).to_dict()
    assert set(reference) <= set(data)
    for key in ("status", "active_constraints", "simulation_rel_error"):
        assert key in data
    assert data["status"] == "optimal"
    assert abs(data["speed_m_s"] / 0.8 - 1) <= 1e-8
    assert data["speed"] == pytest.approx(reference["speed"], rel=1e-12)


def test_cli_infeasible_exit_3(capsys):
    code = main(["design", "--minimize", "eigenvalue", "--fix", "beta=0.9", "--phi0-max", "40",
                 "--max-eigenvalue", "0.2", "--json"])  # fmt: skip
    out = capsys.readouterr()
    assert code == 3
    data = json.loads(out.out)
    assert data["status"] == "infeasible"
    assert data["conflicting_constraints"] == ["max_eigenvalue"]
    assert "Ipopt" not in out.out + out.err and "EXIT" not in out.out + out.err
    # With --json a failure also says why, in one line on stderr.
    assert out.err.count("\n") == 1 and out.err.startswith("vsw design: infeasible")


def test_cli_not_attained_exits_0_with_the_limit(capsys):
    code = main(["design", "--maximize", "speed", "--json"])
    out = capsys.readouterr()
    assert code == 0 and out.err == ""
    data = json.loads(out.out)
    assert data["status"] == "not-attained"
    assert "beta -> 1" in data["limit"]["approached_as"]
    assert data["limit"]["objective"] is not None


def test_readme_example_without_a_box(capsys):
    code = main(["design", "--stepper-2d", "--target-speed", "0.8", "--min-contact-margin",
                 "0.05"])  # fmt: skip
    out = capsys.readouterr()
    assert code == 0, out.err
    assert out.out.startswith("status           optimal")
    # The numbers the README quotes.
    rows = dict(line.split(None, 1) for line in out.out.splitlines() if line.strip())
    assert rows["beta"].split()[0] == "0.56887876"
    assert rows["theta_II"].split()[0] == "42.301613"
    assert rows["phi0"].split()[0] == "63.283386"
    assert rows["eigenvalue"].startswith("0.0654108")


def test_cli_bad_input_exit_2(capsys):
    assert main(["design", "--maximize", "speed", "--max-step-frequency", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--leg-length" in err
    assert main(["design", "--maximize", "speed", "--fix", "gamma=3"]) == 2
    capsys.readouterr()
    for argv in (
        ["--fix", "beta=0.7", "--fix", "beta=0.8", "--target-speed", "0.5"],
        ["--maximize", "speed", "--min-step-length", "1e308", "--leg-length", "1e-3"],
        ["--leg-length", "1e-300", "--target-speed", "1e300"],
        ["--maximize", "speed", "--theta-ii-max", "1e999"],
        ["--maximize", "speed", "--conditions", "strict"],
        ["--target-step-length", "0.5", "--max-step-length", "0.4"],
        ["--maximize", "speed", "--beta-max", "0.9995"],
    ):
        assert main(["design", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err, (argv, err)
