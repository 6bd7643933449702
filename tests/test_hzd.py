"""Walking by hybrid zero dynamics (vsw.synthesis.hzd, derive/hzd.py, vsw hzd) on the three-link
biped, against routes held out of the project's code:

* the restricted Poincaré map of both shipped designs against tests/oracles/
  three_link_biped.py: its own mass matrix, Coriolis and gravity terms, its own impact,
  its zero dynamics from the unactuated row of the equations of motion (not the angular
  momentum) integrated by SciPy's adaptive quadrature, and its own impact-invariant Bezier
  coefficients (Westervelt, Grizzle & Koditschek 2003's rule);
* the full-order closed loop (the runtime's orbit solver on the computed-torque loop) on
  the impact-invariant design against the restricted map: an invariant surface carries the
  fixed point, and the map's eigenvalue delta^2 is the loop's dominant one;
* the actuators' work per step (a quadrature of the torques' power) against the impact's
  loss (two energies);
* bad constraints: one line, exit 2.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from tests.oracles import three_link_biped as oracle
from vsw.models import key, load
from vsw.synthesis import hzd

pytest.importorskip("casadi")

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "hzd"
MIRROR = EXAMPLES / "three_link_mirror.py"
INVARIANT = EXAMPLES / "three_link_mirror_invariant.py"
END = math.pi / 8


@pytest.fixture(scope="module")
def walker():
    return load("three-link-biped")


@pytest.fixture(scope="module")
def mirror(walker):
    return hzd.analyze(walker, key("three-link-biped"), MIRROR)


@pytest.fixture(scope="module")
def invariant(walker):
    return hzd.analyze(walker, key("three-link-biped"), INVARIANT)


@pytest.fixture(scope="module")
def oracle_alphas():
    return oracle.invariant_bezier(oracle.mirror_bezier(6), -END, END)


def _agree(got: float, expected: float, tol: float) -> None:
    assert abs(got - expected) <= tol * max(1.0, abs(expected)), (got, expected)


def test_mirror_restricted_map_is_the_oracles(mirror):
    expected = oracle.restricted_map(oracle.mirror_surface())
    z = mirror.zero
    _agree(z.delta_squared, expected.slope, 1e-9)
    _agree(z.theta_dot_minus, expected.theta_dot_minus, 1e-9)
    _agree(z.theta_dot_plus, expected.theta_dot_plus, 1e-9)
    _agree(z.zeta_star, expected.zeta_star, 1e-9)


def test_invariant_restricted_map_is_the_oracles(invariant, oracle_alphas):
    expected = oracle.restricted_map(oracle.bezier_surface(oracle_alphas, -END, END))
    z = invariant.zero
    _agree(z.delta_squared, expected.slope, 1e-9)
    _agree(z.theta_dot_minus, expected.theta_dot_minus, 1e-9)
    _agree(z.theta_dot_plus, expected.theta_dot_plus, 1e-9)
    _agree(z.zeta_star, expected.zeta_star, 1e-9)


def test_invariant_coefficients_are_the_oracles(invariant, oracle_alphas):
    alphas = np.array(invariant.samples["surface"].alphas).reshape(2, 7)
    assert np.allclose(alphas, oracle_alphas, rtol=0, atol=1e-12)


def test_same_pre_impact_geometry_same_delta(mirror, invariant):
    """delta depends only on the configuration and the surface's direction at theta_minus,
    which the invariant design keeps; so do the step's length and the phase's end."""
    _agree(invariant.zero.delta, mirror.zero.delta, 1e-12)
    assert mirror.step_length == pytest.approx(2 * math.sin(END), rel=1e-14)
    assert invariant.step_length == pytest.approx(2 * math.sin(END), rel=1e-14)


def test_impact_invariance(mirror, invariant):
    """The mismatch of y_dot after the impact per unit theta_dot before: zero for the
    invariant design; for the mirror, the oracle's impact and h'(theta_plus) = (-1 -
    pi/8, 0)."""
    assert max(abs(v) for v in invariant.mismatch) < 1e-12
    _q_plus, qd_plus = oracle.impact(
        oracle.mirror_surface().q(END), oracle.mirror_surface().dq(END)
    )
    slope = np.array([-1.0 - END, 0.0])
    expected = qd_plus[1:] - slope * qd_plus[0]
    assert np.allclose(mirror.mismatch, expected, rtol=0, atol=1e-12)
    assert min(abs(v) for v in mirror.mismatch) > 0.1


def test_full_order_loop_carries_the_restricted_gait(invariant):
    full = invariant.full_order
    assert full is not None, invariant.full_order_error
    _agree(invariant.samples["full_theta_dot_minus"], invariant.zero.theta_dot_minus, 1e-8)
    _agree(full.period, invariant.zero.period, 1e-8)
    assert abs(full.eigenvalues[0] - invariant.zero.delta_squared) <= 1e-6
    # The transverse dynamics (double pole at -20/s over a step of 0.87 s) are far inside.
    assert all(abs(e) < 1e-4 for e in full.eigenvalues[1:])


def test_work_per_step_is_the_impact_loss(mirror, invariant):
    _agree(invariant.work_per_step, invariant.impact_loss, 1e-9)
    assert invariant.surface_jump == pytest.approx(0.0, abs=1e-9)
    # Off an invariant surface the ideal controller also restores the rates at impact.
    _agree(mirror.work_per_step, mirror.impact_loss - mirror.surface_jump, 1e-9)
    assert mirror.impact_loss > 1.0


def test_quadrature_error_is_round_off(mirror):
    assert mirror.zero.quadrature_error < 1e-9 * abs(mirror.zero.v_minus)


def test_feed_forward_torques_hold_the_model_on_the_surface(walker, invariant):
    """Along the gait the torques give accelerations that keep y'' = 0: checked by the
    model's own equations and the oracle's."""
    s = invariant.samples
    p = walker.parameters()
    surface = s["surface"]
    for x, u in zip(s["states"][::40], s["torques"][::40]):
        qdd = oracle.accelerations(x[:3], x[3:], u)
        theta, theta_dot = x[0], x[3]
        _q, dq, ddq = surface.at(theta)
        theta_ddot = qdd[0]
        assert np.allclose(qdd, ddq * theta_dot**2 + dq * theta_ddot, atol=1e-9)
    assert p == walker.parameters()


def test_plot_is_deterministic(invariant, tmp_path):
    from vsw.synthesis.hzd.plot import save_hzd_plot

    a, b = tmp_path / "a.png", tmp_path / "b.png"
    for path in (a, b):
        save_hzd_plot(invariant, invariant.samples["surface"], "theta1", "s", path)
    assert a.read_bytes() == b.read_bytes()


@pytest.mark.parametrize("changes", [{"m_t": 8.0, "l": 0.6}, {"m": 4.0, "m_h": 20.0, "r": 0.9}])
def test_other_parameters_agree_with_the_oracle(walker, changes):
    """The impact-invariant coefficients are set at the given parameters (the impact map
    depends on them): the restricted map still agrees with the oracle's, built afresh."""
    params = {**oracle.DEFAULTS, **changes}
    report = hzd.analyze(walker, key("three-link-biped"), INVARIANT, changes, full_order=False)
    alphas = oracle.invariant_bezier(oracle.mirror_bezier(6), -END, END, params)
    expected = oracle.restricted_map(oracle.bezier_surface(alphas, -END, END), params)
    _agree(report.zero.delta_squared, expected.slope, 1e-9)
    _agree(report.zero.theta_dot_minus, expected.theta_dot_minus, 1e-9)
    assert max(abs(v) for v in report.mismatch) < 1e-12
    _agree(report.work_per_step, report.impact_loss, 1e-9)


def test_derivation_refuses_an_input_with_a_moment_about_the_foot():
    """An input along the stance leg's absolute angle (an ankle) acts on the angular
    momentum about the foot: the zero dynamics here need one degree of underactuation
    there, and the derivation says so."""
    import dataclasses

    import sympy as sm

    from derive.hzd import Constraints, ConstraintsError, coordinates, derivation
    from derive.models import three_link_biped as model_file

    theta1, theta2, theta3 = coordinates("theta1", "theta2", "theta3")
    phase = model_file.STANCE
    ankle = dataclasses.replace(phase.inputs[0], along=model_file.theta1)
    model = dataclasses.replace(
        model_file.MODEL,
        phases=(dataclasses.replace(phase, inputs=(ankle, phase.inputs[1])),),
    )
    constraints = Constraints(
        phase=theta1, theta_plus=-END, theta_minus=END, outputs={theta2: 0, theta3: sm.pi / 6}
    )
    with pytest.raises(ConstraintsError, match="torque about the stance foot"):
        derivation(model, constraints, "test")
    # The model as it is derives.
    assert "zero_dynamics" in derivation(model_file.MODEL, constraints, "test").quantities


def test_bezier_of_is_exact():
    import sympy as sm

    from derive.hzd import S, bezier_of

    poly = 3 - 2 * S + 5 * S**2
    alpha = bezier_of(poly, 6)
    bernstein = sum(a * sm.binomial(6, k) * S**k * (1 - S) ** (6 - k) for k, a in enumerate(alpha))
    assert sm.expand(bernstein - poly) == 0


def test_simulated_closed_loop_returns_at_the_rate_delta_squared(walker, invariant):
    """The runtime's simulation (DOP853 with the model's events) of the closed loop from a
    state off the gait (every rate 5 % high, off the surface): each step's deviation of
    theta1_dot just after the impact shrinks by a factor that tends to delta^2."""
    from vsw.synthesis.hzd.loop import ClosedLoop

    loop = ClosedLoop(walker, invariant.samples["surface"], 400.0, 40.0)
    closed = loop.hybrid()
    p = walker.parameters()
    fixed = np.array(list(invariant.full_order.state.values()))
    x = fixed.copy()
    x[3:] *= 1.05
    deviations = []
    for _ in range(6):
        result = closed.step(p, x)
        assert result.ended == "completed"
        x = result.state
        deviations.append(x[3] - fixed[3])
    ratios = np.array(deviations[1:]) / np.array(deviations[:-1])
    assert np.all(np.diff(np.abs(ratios - invariant.zero.delta_squared)) < 0)
    assert abs(ratios[-1] - invariant.zero.delta_squared) < 1e-3
