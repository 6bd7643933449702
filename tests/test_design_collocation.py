"""The design's collocated NLP: the Gauss-Legendre scheme's order against exact solutions,
the collocated gait and its eigenvalues against the runtime's (CVODES, variational
equations), and the design's result whether or not collocation finds its start."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq, minimize_scalar

from vsw import models
from vsw.orbits.collocation import legendre_defects, legendre_end, legendre_scheme
from vsw.synthesis import design as gait_design
from vsw.synthesis.design import collocation, solve
from vsw.synthesis.design.problem import Problem


def _collocated_flow(matrix: np.ndarray, x0: np.ndarray, span: float, intervals: int,
                     degree: int) -> np.ndarray:  # fmt: skip
    """x' = A x over ``span`` by the scheme, each interval's linear rows solved."""
    _, c_matrix, d_row = legendre_scheme(degree)
    m, h, x = len(x0), span / intervals, np.array(x0, float)
    for _ in range(intervals):
        system = np.kron(c_matrix[1:, 1:].T, np.eye(m)) - h * np.kron(np.eye(degree), matrix)
        stages = np.linalg.solve(
            system, -np.concatenate([c_matrix[0, j] * x for j in range(1, degree + 1)])
        )
        stages = stages.reshape(degree, m)
        x = legendre_end([x, *stages], d_row)
    return x


@pytest.mark.parametrize("degree", [2, 3])
def test_gauss_legendre_collocation_has_order_twice_its_points(degree):
    # A damped oscillator: exact flow by the matrix exponential.
    matrix = np.array([[0.0, 1.0], [-4.0, -0.3]])
    x0 = np.array([1.0, 0.5])
    exact = expm(matrix * 2.0) @ x0
    errors = [np.max(np.abs(_collocated_flow(matrix, x0, 2.0, n, degree) - exact))
              for n in (8, 16)]  # fmt: skip
    order = np.log2(errors[0] / errors[1])
    assert 2 * degree - 0.3 < order < 2 * degree + 0.5, (errors, order)


def test_the_scheme_s_defects_vanish_on_a_polynomial_of_its_degree():
    _, c_matrix, d_row = legendre_scheme(3)
    roots = legendre_scheme(3)[0]
    h = 0.4

    def cubic(t):
        return 1.0 - 2.0 * t + 0.5 * t**2 + 3.0 * t**3

    def slope(t):
        return -2.0 + t + 9.0 * t**2

    points = [cubic(0.0)] + [cubic(h * r) for r in roots]
    rates = [slope(h * r) for r in roots]
    assert np.allclose(legendre_defects(points, rates, h, c_matrix), 0, atol=1e-13)
    assert legendre_end(points, d_row) == pytest.approx(cubic(h), abs=1e-13)
    # A wrong slope is seen.
    assert not np.allclose(legendre_defects(points, [r + 1e-3 for r in rates], h, c_matrix), 0)


def _compass_problem() -> Problem:
    request = gait_design.DesignRequest(objective={}, targets={"period": 0.75})
    return Problem(models.load("compass-gait"), request)


def _collocated_gap(problem, seeds, intervals):
    """The collocated optimum on ``intervals`` a phase from the stable seed, and how far its
    state and eigenvalue lie from the runtime's gait at its parameters (CVODES at 1e-13,
    the eigenvalues by its variational equations; the collocation's by its own discrete
    map)."""
    model = problem.model
    stable = min(seeds, key=lambda orbit: orbit.max_abs_eigenvalue)
    structure = problem.structure(solve._nontrivial_rank(seeds), problem.objective,
                                  problem.rows, "same")  # fmt: skip
    nlp = collocation.build(model, structure, (intervals,))
    pieces = solve._walk(model, problem.start, stable)
    w0 = collocation.initial_point(model, nlp, np.asarray(problem.start), pieces,
                                   [problem.start[j] for j in problem.free],
                                   1.05 * stable.max_abs_eigenvalue)  # fmt: skip
    bounds = solve._bounds(problem, nlp, problem.request.targets)
    out = nlp.solver(x0=w0, **bounds)
    assert nlp.solver.stats()["return_status"] == "Solve_Succeeded"
    w = np.array(out["x"]).reshape(-1)
    params = solve._parameters_of(problem, nlp, w)
    state = w[nlp.layout["states"]][: 2 * model.n]
    orbit = model.periodic_orbit(params, state, w[nlp.layout["durations"]])
    assert orbit.period == pytest.approx(0.75, abs=1e-6)
    radius = float(w[nlp.layout["rho"]][0])
    state_gap = np.max(np.abs(np.array(list(orbit.state.values())) - state))
    return state_gap, abs(radius / orbit.max_abs_eigenvalue - 1)


def test_the_collocated_optimum_is_the_runtime_s_gait_to_the_mesh_s_error():
    problem = _compass_problem()
    seeds, _, _ = solve._seeds(problem)
    state_gap, eigen_gap = _collocated_gap(problem, seeds, gait_design.INTERVALS)
    assert state_gap < 1e-6
    assert 1e-12 < eigen_gap < 5e-5  # a mesh's error (six intervals: 1.8e-5)
    # Order 6: twice the intervals, about 2^6 times closer (at least 16 asked).
    finer_state_gap, finer_eigen_gap = _collocated_gap(problem, seeds, 2 * gait_design.INTERVALS)
    assert finer_eigen_gap < eigen_gap / 16
    assert finer_state_gap < state_gap / 16


def _runtime_vertex(model, design, period):
    """The slope at which the runtime's gait (its periodic-orbit solver, no NLP) lasts
    ``period``, by brentq from the design's gait, and that gait's max |eigenvalue|."""
    params = list(design.parameters.values())
    k = list(design.parameters).index("gamma")
    state = np.array(list(design.orbit.state.values()))

    def orbit_at(gamma):
        params[k] = gamma
        return model.periodic_orbit(tuple(params), state, design.orbit.durations)

    gamma = brentq(lambda g: orbit_at(g).period - period, params[k] - 1e-4, params[k] + 1e-4,
                   xtol=1e-15, rtol=1e-15)  # fmt: skip
    return gamma, orbit_at(gamma).max_abs_eigenvalue


def test_the_design_at_a_vertex_is_the_runtimes_gait_whichever_nlp_polishes(monkeypatch):
    # One free parameter and one target: the optimum is the slope where the period is
    # 0.75 s. The collocated optimum is carried there by Newton on the orbit (pin.py), with
    # no shooting NLP built; the shooting NLP alone meets the period to IPOPT's tolerance,
    # which moves this eigenvalue about 200 times as much.
    problem_request = gait_design.DesignRequest(objective={}, targets={"period": 0.75})
    model = models.load("compass-gait")
    monkeypatch.setattr(solve, "build", _not_built)
    pinned = gait_design.design(model, problem_request)
    monkeypatch.undo()
    monkeypatch.setattr(solve, "_pinned", lambda *args: None)
    shot = gait_design.design(model, problem_request)
    assert pinned.status == shot.status == "optimal"
    gamma, eigenvalue = _runtime_vertex(model, pinned, 0.75)
    assert pinned.quantities["period"] == pytest.approx(0.75, abs=1e-12)
    assert pinned.parameters["gamma"] == pytest.approx(gamma, rel=1e-10)
    assert pinned.objective == pytest.approx(eigenvalue, rel=1e-9)
    assert shot.parameters["gamma"] == pytest.approx(gamma, rel=1e-8)
    assert shot.objective == pytest.approx(eigenvalue, rel=1e-7)
    # The tutorial's design (docs/tutorials/design.md).
    assert pinned.objective == pytest.approx(0.646696, abs=5e-7)


def test_a_pinned_vertex_is_confirmed_from_the_pins_own_solves(monkeypatch):
    # The pin's Newton solves the orbit at the vertex's parameters; its last solve is
    # confirmed as it stands (a simulated step), so no start asks the orbit solver again,
    # at the collocated parameters or the vertex's.
    monkeypatch.setenv("VSW_THREADS", "1")  # the starts in this process, where they are counted
    model = models.load("compass-gait")
    inside: list[str] = []
    real_collocate, real_orbit = solve._collocate, type(model).periodic_orbit

    def collocate(*args):
        inside.append("start")
        try:
            return real_collocate(*args)
        finally:
            inside.append("end")

    def periodic_orbit(self, *args, **kwargs):
        if inside and inside[-1] == "start":
            inside.append("orbit solve")
        return real_orbit(self, *args, **kwargs)

    monkeypatch.setattr(solve, "_collocate", collocate)
    monkeypatch.setattr(type(model), "periodic_orbit", periodic_orbit)
    monkeypatch.setattr(solve, "build", _not_built)
    result = gait_design.design(
        model, gait_design.DesignRequest(objective={}, targets={"period": 0.75})
    )
    assert result.status == "optimal"
    assert result.quantities["period"] == pytest.approx(0.75, abs=1e-12)
    assert inside.count("start") >= 2
    assert "orbit solve" not in inside


def _not_built(*args, **kwargs):
    raise AssertionError("the shooting NLP was built")


def test_an_active_eigenvalue_bound_is_met_on_the_runtimes_gait(monkeypatch):
    # The simplest walker's fastest gait with max |eigenvalue| <= 0.9: the bound pins the
    # slope; Newton on the orbit meets it to the orbit solver's accuracy.
    model = models.load("simplest-walker")
    request = gait_design.DesignRequest(objective={"speed": 1.0}, max_eigenvalue=0.9)
    monkeypatch.setattr(solve, "build", _not_built)
    result = gait_design.design(model, request)
    assert result.status == "optimal"
    assert result.active_constraints == ("max |eigenvalue|",)
    assert result.quantities["eigenvalue"] == pytest.approx(0.9, abs=1e-10)
    params = list(result.parameters.values())
    k = list(result.parameters).index("gamma")
    state = np.array(list(result.orbit.state.values()))
    for shift, sense in ((-1e-7, -1), (1e-7, 1)):  # the bound is crossed at the slope
        params[k] = result.parameters["gamma"] * (1 + shift)
        moved = model.periodic_orbit(tuple(params), state, result.orbit.durations)
        assert sense * (moved.max_abs_eigenvalue - 0.9) > 0


def test_distinct_gaits_at_the_same_parameters_are_each_polished():
    # The longest step of the compass gait on slopes up to 0.0828 rad: every gait lies at
    # the box's end, the short, the stable and the long one, so the collocated optima
    # share their parameters. The long gait's step by continuation of its branch (the
    # runtime's Newton, no IPOPT; benchmarks/design_every_model.py's reference): 0.722782.
    request = gait_design.DesignRequest(
        objective={"step_length": 1.0}, bounds={"gamma": (0.017642858450295097, 0.0828067842750)}
    )
    result = gait_design.design(models.load("compass-gait"), request)
    assert result.status == "optimal"
    assert result.quantities["step_length"] == pytest.approx(0.7227824373318481, rel=1e-6)


def test_an_interior_optimum_is_not_taken_for_the_box_edge():
    # The simplest walker's least max |eigenvalue| over a slope box whose optimum is
    # interior (0.0138) and close to the box's upper edge (0.01418): IPOPT's multiplier of
    # the inactive edge is its barrier term (about mu / slack, above 1e-8), so an active
    # set read from multipliers alone would pin the slope at the edge (max |eigenvalue|
    # 0.767). The reference minimises the runtime's own gait's eigenvalue (no NLP).
    model = models.load("simplest-walker")
    box = (0.006770117625990786, 0.014177632952357497)
    request = gait_design.DesignRequest(objective={"eigenvalue": 1.0},
                                        bounds={"gamma": box}, max_eigenvalue=1.0)  # fmt: skip
    result = gait_design.design(model, request)
    assert result.status == "optimal"
    assert "gamma bound" not in result.active_constraints
    params = list(result.parameters.values())
    k = list(result.parameters).index("gamma")
    state = np.array(list(result.orbit.state.values()))

    def eigenvalue(gamma):
        params[k] = gamma
        return model.periodic_orbit(tuple(params), state, result.orbit.durations).max_abs_eigenvalue

    reference = minimize_scalar(eigenvalue, bounds=(0.0130, box[1]), method="bounded",
                                options={"xatol": 1e-10})  # fmt: skip
    assert reference.x < box[1] - 1e-4  # interior
    assert result.objective <= reference.fun + 1e-8
    assert result.parameters["gamma"] == pytest.approx(reference.x, abs=1e-6)


def test_a_vertex_past_the_boxs_edge_is_not_taken():
    # The slope of a 0.75 s period on the runtime's gait is 0.07207483; the user's box
    # ends at 0.0720747, and the collocated vertex (0.07207456) lies inside it. Newton on
    # the orbit would step past the edge: that vertex is left to the shooting NLP, which
    # keeps to the box.
    model = models.load("compass-gait")
    request = gait_design.DesignRequest(objective={}, targets={"period": 0.75},
                                        bounds={"gamma": (0.05, 0.0720747)})  # fmt: skip
    result = gait_design.design(model, request)
    if result.found:
        assert result.parameters["gamma"] <= 0.0720747
        assert result.quantities["period"] == pytest.approx(0.75, abs=1e-6)
    else:
        assert result.status in ("infeasible", "not-converged")


def test_only_the_leading_vertex_s_step_is_simulated(monkeypatch):
    # The margins along a simulated step are the verification's dearest part: the measured
    # vertices are simulated best first (the first of equal objectives to 1e-12, in the
    # candidates' order) until one holds; the failed ones go to the shooting NLP, the
    # others cannot win and are left unsimulated.
    simulated = []

    def simulate(problem, measured, targets):
        simulated.append(measured.start)
        measured.failure = "condition fails" if measured.start == 1 else ""
        return measured

    monkeypatch.setattr(solve, "_simulated", simulate)

    def vertex(start, objective):
        empty = np.zeros(1)
        measured = solve._Solve(start, "Solve_Succeeded", empty, empty, empty)
        measured.orbit, measured.objective = object(), objective
        measured.failure = solve._UNSIMULATED
        return measured, f"start {start}"

    items = [vertex(0, 0.3), vertex(1, 0.1), vertex(2, 0.2), vertex(3, 0.2 - 1e-13)]
    best, solves, failed = solve._best_simulated(None, items, {})
    assert simulated == [1, 2]
    assert best.start == 2 and best.verified
    assert failed == ["start 1"]
    assert [s.start for s in solves] == [0, 2, 3]
    assert not any(s.verified for s in solves if s is not best)
