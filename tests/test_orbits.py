"""The periodic-orbit problem (vsw.orbits): its Newton on systems with known solutions, its
monodromy matrix against routes it does not use (the saltation matrices assembled from
CasADi's own derivatives of the flows, guards and resets; central differences of SciPy's
simulated steps; the Poincaré map's derivative of vsw.dynamics.hybrid), and its quantities."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from vsw.models import load
from vsw.orbits import OrbitProblem, newton, phase_sequence, shooting
from vsw.runtime.errors import ConvergenceError

# Bhounsule et al. 2013: the simplest walker's long gait at gamma = 0.009 (as in
# tests/test_continuation.py), (q1, u1, q2, u2) with q1 = -theta, q2 = -phi.
LONG_GAIT_0009 = (-0.200310900563820, -0.400621801127640, 0.199832473025474, 0.015822999949030)
LONG_PERIOD_0009 = 3.882


class _Quadratic:
    """R(w) = (w_0^2 - a, w_1 - w_0) per row: roots (+-sqrt(a), +-sqrt(a))."""

    def __init__(self, a: float) -> None:
        self.a = a
        self.calls = 0

    def residual(self, w, rows):
        self.calls += 1
        self.w = w
        return np.column_stack([w[:, 0] ** 2 - self.a, w[:, 1] - w[:, 0]])

    def jacobian(self, which):
        w = self.w[which]
        out = np.zeros((len(which), 2, 2))
        out[:, 0, 0] = 2 * w[:, 0]
        out[:, 1, 0], out[:, 1, 1] = -1.0, 1.0
        return out

    def scale(self, w):
        return np.maximum(1.0, np.max(np.abs(w), axis=1))


def test_newton_solves_every_row_and_drops_a_singular_one():
    starts = np.array([[1.0, 0.0], [-3.0, 5.0], [0.0, 1.0], [2.0, 2.0]])
    found = newton.solve(_Quadratic(2.0), starts, tol=1e-14)
    root = np.sqrt(2.0)
    assert list(found.converged) == [True, True, False, True]  # J singular at w_0 = 0
    np.testing.assert_allclose(found.w[[0, 3]], root, rtol=1e-15)
    np.testing.assert_allclose(found.w[1], -root, rtol=1e-15)
    assert found.jacobian is None


def test_newton_with_a_small_last_step_returns_the_jacobian_at_its_end():
    system = _Quadratic(4.0)
    found = newton.solve(system, np.array([[3.0, 0.0]]), tol=1e-12, step_tol=1e-9)
    assert found.converged[0] and np.allclose(found.w[0], 2.0, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(found.jacobian[0], system.jacobian(np.array([0]))[0])
    assert 4 <= found.iterations[0] <= 8  # quadratic convergence from 3


def test_a_border_holds_its_equation():
    """R(w) = w_0^2 + w_1^2 - 1 with w . (1, 1) = 1 bordering it: (1, 0) or (0, 1)."""

    class Circle(_Quadratic):
        def residual(self, w, rows):
            self.w = w
            return (w[:, 0] ** 2 + w[:, 1] ** 2 - 1.0)[:, None]

        def jacobian(self, which):
            return 2 * self.w[which][:, None, :]

    found = newton.solve(Circle(0.0), np.array([[0.9, 0.3]]), tol=1e-13, step_tol=1e-9,
                         border=(np.array([1.0, 1.0]), np.array([1.0, 0.0])))  # fmt: skip
    assert found.converged[0]
    np.testing.assert_allclose(found.w[0], [1.0, 0.0], atol=1e-13)


def test_newton_merges_starts_that_meet():
    system = _Quadratic(9.0)
    starts = np.array([[3.0, 3.0], [3.0, 3.0 + 1e-12], [5.0, 1.0]])
    found = newton.solve(system, starts, tol=1e-13, merge=1e-9)
    assert found.converged.all()
    np.testing.assert_array_equal(found.w[0], found.w[1])


@pytest.fixture(scope="module")
def long_gait():
    """The simplest walker's long gait at gamma = 0.009 solved by the orbit problem."""
    m = load("simplest-walker")
    params = np.array(m.parameters({"gamma": 0.009}))
    problem = OrbitProblem(m)
    guess = problem.unknowns(params, np.array(LONG_GAIT_0009), [LONG_PERIOD_0009])
    solved = problem.solve(params, guess)
    assert solved.converged and solved.residual <= 1e-12
    return m, params, problem, solved


def test_the_orbit_is_the_published_gait(long_gait):
    _, _, problem, solved = long_gait
    np.testing.assert_allclose(problem.section_state(solved.u), LONG_GAIT_0009, atol=1e-12)
    assert problem.durations(solved.u)[0] == pytest.approx(LONG_PERIOD_0009, abs=1e-3)
    assert problem.step_periods(solved.u) == [float(problem.durations(solved.u)[0])]


def test_a_given_solve_is_confirmed_as_periodic_orbit_confirms_its_own(long_gait):
    # HybridModel.confirmed_orbit is periodic_orbit's checks on a solve made elsewhere (the
    # design's pin): the same orbit, bit for bit, from the same solve.
    model, params, problem, solved = long_gait
    own = model.periodic_orbit(params, np.array(LONG_GAIT_0009), [LONG_PERIOD_0009])
    assert model.confirmed_orbit(params, problem, solved) == own
    unsolved = dataclasses.replace(solved, converged=False)
    with pytest.raises(ConvergenceError, match="did not converge"):
        model.confirmed_orbit(params, problem, unsolved)
    backwards = dataclasses.replace(solved, u=np.concatenate([solved.u[:-1], [-1.0]]))
    with pytest.raises(ConvergenceError, match="duration is not positive"):
        model.confirmed_orbit(params, problem, backwards)
    with pytest.raises(ValueError, match="period-one orbit problem of this model"):
        model.confirmed_orbit(params, OrbitProblem(model, period=2), solved)


def _saltation_product(model, params, problem, u):
    """The monodromy matrix assembled phase by phase from CasADi's derivatives of the
    flow, guard and reset: DR (I - f grad g / (grad g . f)) Phi (vsw.orbits.monodromy)."""
    n, out = problem.n, np.eye(problem.n)
    for k, (phase, _) in enumerate(problem.sequence):
        integrator, guard, reset = shooting.flows(model)[phase]
        x0, duration = u[k * n : (k + 1) * n], problem.durations(u)[k]
        x = ca.MX.sym("x", n)
        end = integrator(x0=x, p=ca.vertcat(params, duration))["xf"]
        phi = np.array(ca.Function("phi", [x], [ca.jacobian(end, x)])(x0))
        y = ca.MX.sym("y", n)
        at = np.array(ca.Function("end", [x], [end])(x0)).reshape(-1)
        grad = np.array(ca.Function("dg", [y], [ca.jacobian(guard(params, y), y)])(at))[0]
        d_reset = np.array(ca.Function("dr", [y], [ca.jacobian(reset(params, y), y)])(at))
        f = np.concatenate([at[n // 2 :], model.accelerations(phase, params, at)])
        saltation = np.eye(n) - np.outer(f, grad) / float(grad @ f)
        out = d_reset @ saltation @ phi @ out
    return out


def test_the_monodromy_is_the_product_of_the_saltation_matrices(long_gait):
    m, params, problem, solved = long_gait
    expected = _saltation_product(m, params, problem, solved.u)
    np.testing.assert_allclose(problem.monodromy(solved.jacobian), expected, rtol=0,
                               atol=1e-9 * np.max(np.abs(expected)))  # fmt: skip


def test_the_monodromy_equals_simulated_central_differences(long_gait):
    m, params, problem, solved = long_gait
    x = problem.section_state(solved.u)
    h = 1e-6
    columns = [(m.step(params, x + h * e).state - m.step(params, x - h * e).state) / (2 * h)
               for e in np.eye(len(x))]  # fmt: skip
    np.testing.assert_allclose(problem.monodromy(solved.jacobian), np.array(columns).T,
                               rtol=0, atol=1e-6)  # fmt: skip


def test_the_eigenvalues_equal_the_poincare_maps_derivative(long_gait):
    m, params, problem, solved = long_gait
    ours = problem.eigenvalues(solved.jacobian)
    direct = m.eigenvalues(params, problem.section_state(solved.u))
    # The Poincaré map's end times come from rootfinders stopped at 1e-12.
    np.testing.assert_allclose(np.sort_complex(ours), np.sort_complex(direct), rtol=0,
                               atol=1e-8)  # fmt: skip


def test_two_steps_of_a_period_one_gait_have_the_square_of_its_monodromy(long_gait):
    m, params, problem, solved = long_gait
    double = OrbitProblem(m, period=2)
    durations = np.tile(problem.durations(solved.u), 2)
    u = double.unknowns(params, problem.section_state(solved.u), durations)
    r, jac = double.evaluate(u, params)
    assert np.max(np.abs(r)) <= 1e-12
    single = problem.monodromy(solved.jacobian)
    np.testing.assert_allclose(double.monodromy(jac), single @ single, rtol=0, atol=1e-9)
    assert len(double.section_states(u)) == 2 and double.step_periods(u)[1] == pytest.approx(
        problem.step_periods(solved.u)[0], abs=1e-12
    )


def test_a_free_parameter_adds_its_derivative():
    m = load("compass-gait")
    names = [p.name for p in m.parameter_table]
    index = names.index("gamma")
    problem = OrbitProblem(m, free=(index,))
    params = np.array(m.parameters())
    sequence = phase_sequence(m)
    assert problem.m == len(sequence) and problem.size == (problem.n + 1) * problem.m
    u = problem.unknowns(params, np.array([-0.26, 0.26, 1.2, 0.8]), [0.77])
    _, jac, d_gamma = problem.evaluate(u, params)
    h = 1e-5
    up, down = params.copy(), params.copy()
    up[index] += h
    down[index] -= h
    expected = (problem.evaluate(u, up)[0] - problem.evaluate(u, down)[0]) / (2 * h)
    np.testing.assert_allclose(d_gamma.reshape(-1), expected, rtol=0, atol=1e-6)
    assert jac.shape == (problem.size, problem.size)
