"""The collocation's price of an input's positive work on one interval (vsw.synthesis.powered): the
state at the quarter points is the scheme's cubic, the five samples fix the power's
quartic, and the Bernstein slack bounds ``max(P, 0)`` on the whole interval, so a power
that changes sign between the samples cannot go unpriced."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsw.models import load
from vsw.orbits.collocation import BERNSTEIN_OF_SAMPLES, SAMPLES, interval_inputs, interval_states
from vsw.synthesis.powered import Request
from vsw.synthesis.powered.dynamics import flow_function, input_rate_function
from vsw.synthesis.powered.problem import _build
from vsw.synthesis.powered.starts import fill_slacks


def _trapezoid(values: np.ndarray, s: np.ndarray) -> float:
    return float(np.sum((values[1:] + values[:-1]) * np.diff(s)) / 2)


def _bernstein(coefficients: np.ndarray, s: np.ndarray) -> np.ndarray:
    n = len(coefficients) - 1
    return sum(c * math.comb(n, j) * s**j * (1 - s) ** (n - j)
               for j, c in enumerate(coefficients))  # fmt: skip


def test_the_quarter_points_are_the_schemes_cubic():
    """A cubic state (and its slopes h x'(0), h x'(1)) at s = 1/4 and 3/4, and a quadratic
    input at the quarter points, exactly."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        a = rng.normal(size=(4, 3))  # x(s) = a0 + a1 s + a2 s^2 + a3 s^3, three components
        x = lambda s, a=a: a[0] + a[1] * s + a[2] * s**2 + a[3] * s**3  # noqa: E731
        slope = lambda s, a=a: a[1] + 2 * a[2] * s + 3 * a[3] * s**2  # noqa: E731
        states = interval_states(x(0.0), x(0.5), x(1.0), slope(0.0), slope(1.0))
        for s, state in zip(SAMPLES, states):
            np.testing.assert_allclose(state, x(s), rtol=0, atol=1e-14)
        b = rng.normal(size=3)
        u = lambda s, b=b: b[0] + b[1] * s + b[2] * s**2  # noqa: E731
        inputs = interval_inputs(u(0.0), u(0.5), u(1.0))
        np.testing.assert_allclose(inputs, [u(s) for s in SAMPLES], rtol=0, atol=1e-14)


def test_the_bernstein_slack_bounds_the_positive_power_on_the_whole_interval():
    """For random quartic powers: the Bernstein coefficients of the five samples give back
    the quartic; their positive parts' mean bounds the integral of ``max(P, 0)`` (by a
    fine quadrature) from above, equals it where the power's coefficients are all of one
    sign, and prices a power that is negative at every sample but positive between them,
    which an epigraph at the samples (as the knots' and midpoint's was) prices at zero."""
    rng = np.random.default_rng(5)
    fine = np.linspace(0.0, 1.0, 200001)
    for _ in range(200):
        quartic = np.polynomial.Polynomial(rng.normal(size=5))
        samples = quartic(np.array(SAMPLES))
        coefficients = BERNSTEIN_OF_SAMPLES @ samples
        np.testing.assert_allclose(_bernstein(coefficients, fine), quartic(fine), atol=1e-12)
        exact = _trapezoid(np.maximum(quartic(fine), 0.0), fine)
        priced = np.mean(np.maximum(coefficients, 0.0))
        assert priced >= exact - 1e-9
        if np.all(coefficients >= 0) or np.all(coefficients <= 0):
            assert priced == pytest.approx(exact, abs=1e-9)
    # Negative at every sample, positive between 0.3 and 0.4.
    hidden = np.polynomial.Polynomial.fromroots([0.3, 0.4]) * -1
    values = hidden(np.array(SAMPLES))
    assert np.all(values < 0)
    exact = _trapezoid(np.maximum(hidden(fine), 0.0), fine)
    assert exact > 1e-4
    assert np.mean(np.maximum(BERNSTEIN_OF_SAMPLES @ values, 0.0)) >= exact


def test_the_nlps_slacks_fill_its_layout_and_are_priced_at_their_mean():
    """On the point-mass biped's NLP (two inputs, three intervals) at a random point: the
    slacks :func:`fill_slacks` writes satisfy the NLP's own slack rows (CasADi's
    column-major reshape against numpy's layout; the same values in another order violate
    them), tightly where a coefficient is positive, and the cost prices them at ``h / 5``
    times their sum, which equals the positive parts of the Bernstein coefficients of the
    power at the five samples computed here from the Hermite cubic written out."""
    model = load("point_mass_biped")
    params = np.asarray(model.parameters(), dtype=float)
    nlp = _build(model, Request("work", target_speed=0.3, nodes=3))
    (entry,) = nlp.layout
    rng = np.random.default_rng(11)
    w = rng.uniform(-0.3, 0.3, nlp.size)
    w[0] = 1.2  # the phase's duration
    for key in ("knots", "middles"):  # the hip above its foot: rates well defined
        first, parts, width = entry[key]
        w[first + 1 : first + parts * width : width] += 0.9
    first, parts, width = entry["impulses"]
    w[first : first + parts * width] = 0.0  # only the continuous inputs priced
    fill_slacks(model, params, nlp, w)

    g = nlp.solver.get_function("nlp_g")
    arguments = np.append(params, 0.0)  # the regularization's scale 0: the cost is the work
    first, parts, width = entry["s_intervals"]
    shifted = w.copy()
    shifted[first : first + parts * width] += 1.0
    g0 = np.array(g(w, arguments)).ravel()
    rows = np.flatnonzero(np.abs(np.array(g(shifted, arguments)).ravel() - g0 - 1.0) < 1e-12)
    assert rows.size == parts * width == 3 * 5 * 2
    assert g0[rows].min() >= -1e-12
    assert np.sum(np.abs(g0[rows]) <= 1e-12) >= 5  # tight where the coefficient is positive
    reordered = w.copy()
    reordered[first : first + parts * width] = w[first : first + parts * width][::-1]
    assert np.array(g(reordered, arguments)).ravel()[rows].min() < -1e-6

    h = w[0] / 3
    flow, rates = flow_function(model, "stance"), input_rate_function(model, "stance")
    x = w[entry["knots"][0] :][: 4 * 4].reshape(4, 4)
    xc = w[entry["middles"][0] :][: 3 * 4].reshape(3, 4)
    u = w[entry["u_knots"][0] :][: 4 * 2].reshape(4, 2)
    uc = w[entry["u_middles"][0] :][: 3 * 2].reshape(3, 2)
    basis = np.array([[math.comb(4, j) * s**j * (1 - s) ** (4 - j) for j in range(5)]
                      for s in SAMPLES])  # fmt: skip
    expected = 0.0
    for i in range(3):
        f0, f1 = (np.array(flow(params, x[k], u[k]), float).ravel() for k in (i, i + 1))
        powers = []
        for s in SAMPLES:
            cubic = ((2 * s**3 - 3 * s**2 + 1) * x[i] + (s**3 - 2 * s**2 + s) * h * f0
                     + (-2 * s**3 + 3 * s**2) * x[i + 1] + (s**3 - s**2) * h * f1)  # fmt: skip
            state = xc[i] if s == 0.5 else cubic
            lagrange = (2 * (s - 0.5) * (s - 1), -4 * s * (s - 1), 2 * s * (s - 0.5))
            inputs = lagrange[0] * u[i] + lagrange[1] * uc[i] + lagrange[2] * u[i + 1]
            powers.append(inputs * np.array(rates(params, state), float).ravel())
        coefficients = np.linalg.solve(basis, np.array(powers))  # (coefficient, input)
        expected += h / 5 * np.maximum(coefficients, 0.0).sum()
    assert float(nlp.cost(w, arguments)) == pytest.approx(expected, rel=1e-12)
