"""Tests of vsw.design: constrained gait design with CasADi/IPOPT on the closed forms."""

from __future__ import annotations

import json
import math

import casadi as ca
import numpy as np
import pytest

from generated import ile
from vsw.analysis import analyze, step_period_scipy
from vsw.cli import main
from vsw.design import _CONDITION_ROWS, _quantities, design
from vsw.params import STEPPER_2D
from vsw.simulate import simulate

R = math.radians
BOUNDS = {"beta": (0.6, 0.95), "theta_II": (R(-20), R(20)), "phi0": (R(20), R(60))}
BOUND_ARGS = [
    "--beta-min", "0.6", "--beta-max", "0.95", "--theta-ii-min", "-20", "--theta-ii-max", "20",
    "--phi0-min", "20", "--phi0-max", "60",
]  # fmt: skip


def _grid_quantities(bounds: dict, n: int) -> tuple[np.ndarray, dict, np.ndarray]:
    """Closed-form quantities on an n^3 grid over the bounds (ends included)."""
    from vsw.design import _numpy_quantities

    axes = [np.linspace(*bounds[name], n) for name in ("beta", "theta_II", "phi0")]
    x = np.stack([a.ravel() for a in np.meshgrid(*axes, indexing="ij")], axis=1)
    qs = _numpy_quantities(x)
    walks = np.isfinite(qs["speed"])
    for name in _CONDITION_ROWS:
        walks &= qs[name] > 0 if name != "stance_contact" else qs[name] >= 0
    return x, qs, walks


# --- the step period inside the NLP ------------------------------------------------------


def _period_function() -> ca.Function:
    """Period and the Jacobian of (period, speed) exactly as the design NLP builds them."""
    x = ca.SX.sym("x", 3)
    qs = _quantities(x[0], x[1], x[2])
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


def test_target_speed_is_hit():
    result = design(targets={"speed_m_s": 0.8}, bounds=BOUNDS, scale=STEPPER_2D)
    assert result.status == "optimal", result.message
    assert abs(float(result.analysis.speed_m_s) / 0.8 - 1) <= 1e-8
    assert "target_speed" in result.active_constraints
    assert result.simulation_rel_error < 1e-8
    # With no objective the most stable gait: the eigenvalue is no worse than at any grid
    # point that meets the target to grid accuracy.
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


@pytest.mark.parametrize("objective", ["speed", "eigenvalue", "cost_of_transport"])
def test_no_grid_point_beats_the_optimiser(objective):
    result = design(objective, bounds=BOUNDS, min_contact_margin=0.05)
    assert result.status == "optimal", result.message
    _, qs, walks = _grid_quantities(BOUNDS, 40)
    walks &= qs["stance_contact"] >= 0.05
    sign = -1.0 if objective == "speed" else 1.0
    values = np.where(walks, sign * qs[objective], np.inf)
    best_grid = values.min()
    # Grid points are feasible, so none may beat a (global) optimum; the optimiser may be
    # better than the grid by at most what one grid cell changes the objective.
    assert best_grid >= result.objective - 1e-9
    assert best_grid - result.objective <= 0.02 * max(1.0, abs(result.objective))


def test_open_boundary_is_reported_not_violated():
    # The least cost of transport lies where the apex condition (14) becomes an equality:
    # the walker would stall at the apex. The model never reaches it.
    result = design("cost_of_transport", bounds=BOUNDS)
    assert result.status == "optimal"
    assert "apex" in result.open_boundary
    assert "open boundary" in result.message
    assert result.analysis.condition("apex").value > 0
    assert bool(result.analysis.walks)


def test_stalled_solve_is_labelled_not_converged_or_open_boundary():
    # With theta_II fixed at 0 the fastest gait presses against extension_reached
    # (theta_II > theta_I), where the period has a kink; IPOPT may stall there. Either way
    # the result must say so and the returned point must walk.
    result = design("speed", bounds=BOUNDS, fixed={"theta_II": 0.0})
    assert result.status in ("optimal", "not-converged")
    assert "extension_reached" in result.open_boundary
    assert bool(result.analysis.walks)
    assert result.simulation_rel_error < 1e-8
    if result.status == "not-converged":
        assert "not a certified optimum" in result.message


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
    from vsw.errors import VswInputError

    with pytest.raises(VswInputError):
        design()
    with pytest.raises(VswInputError):
        design("fastest")
    with pytest.raises(VswInputError):
        design(targets={"speed_m_s": 0.8})  # SI without a scale
    with pytest.raises(VswInputError):
        design("speed", bounds={"beta": (0.9, 0.8)})
    with pytest.raises(VswInputError):
        design("speed", fixed={"beta": 1.5})


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


def test_cli_bad_input_exit_2(capsys):
    assert main(["design", "--maximize", "speed", "--max-step-frequency", "3"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--leg-length" in err
    assert main(["design", "--maximize", "speed", "--fix", "gamma=3"]) == 2
