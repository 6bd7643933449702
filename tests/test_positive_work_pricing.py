"""The collocation's price of an input's positive work on one interval (vsw.powered): the
state at the quarter points is the scheme's cubic, the five samples fix the power's
quartic, and the Bernstein slack bounds ``max(P, 0)`` on the whole interval, so a power
that changes sign between the samples cannot go unpriced."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsw.powered import BERNSTEIN_OF_SAMPLES, SAMPLES, interval_inputs, interval_states


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
        exact = np.trapezoid(np.maximum(quartic(fine), 0.0), fine)
        priced = np.mean(np.maximum(coefficients, 0.0))
        assert priced >= exact - 1e-9
        if np.all(coefficients >= 0) or np.all(coefficients <= 0):
            assert priced == pytest.approx(exact, abs=1e-9)
    # Negative at every sample, positive between 0.3 and 0.4.
    hidden = np.polynomial.Polynomial.fromroots([0.3, 0.4]) * -1
    values = hidden(np.array(SAMPLES))
    assert np.all(values < 0)
    exact = np.trapezoid(np.maximum(hidden(fine), 0.0), fine)
    assert exact > 1e-4
    assert np.mean(np.maximum(BERNSTEIN_OF_SAMPLES @ values, 0.0)) >= exact
