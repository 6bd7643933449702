"""RABBIT walking by hybrid zero dynamics (examples/hzd/rabbit_walk.py, ``vsw hzd``),
against routes held out of the project's code:

* the restricted Poincaré map against tests/oracles/rabbit.py (its own mass matrix and
  impact on the extended coordinates) with the zero dynamics computed here: the surface
  solved from the file's controlled functions by numpy, its own impact-invariant first
  Bezier coefficients (Westervelt, Grizzle & Koditschek 2003's rule), ``sigma`` the
  angular momentum about the stance foot, ``d zeta/d theta = I(theta) m g x_cm``
  integrated by SciPy's adaptive quadrature, ``delta`` from the angular momenta before and
  after the oracle's impact;
* the full-order closed loop (computed torque, gains 400, 40) against the restricted map:
  its fixed point and its dominant eigenvalue ``delta^2``;
* the actuators' work per step against the impact's loss.
"""

from __future__ import annotations

import importlib.util
import json
import math
from pathlib import Path

import numpy as np
import pytest

from tests.oracles.rabbit import Rabbit
from vsw.cli import main

pytest.importorskip("casadi")
sympy = pytest.importorskip("sympy")
quad = pytest.importorskip("scipy.integrate").quad

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "hzd" / "rabbit_walk.py"
COORDINATES = ("theta_t", "theta_f", "phi", "psi_f", "psi_t")
SWAP = [4, 3, 2, 1, 0]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """``vsw hzd --json`` on the example (the CLI, in this process)."""
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["hzd", "--model", "rabbit", "--constraints", str(EXAMPLE), "--json"])
    assert code == 0
    return json.loads(out.getvalue())


def _design():
    """The file's phase row, controlled rows, phase range and later Bezier coefficients,
    read from its sympy expressions (affine in the coordinates)."""
    spec = importlib.util.spec_from_file_location("rabbit_walk_under_test", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    c = module.CONSTRAINTS

    def row(expr):
        expr = sympy.sympify(expr)
        by_name = {s.name: s for s in expr.free_symbols}
        return np.array([float(expr.diff(by_name[n])) if n in by_name else 0.0
                         for n in COORDINATES])  # fmt: skip

    rows = np.array([row(a) for a in c.outputs])
    later = np.array([[float(v) for v in h.later] for h in c.outputs.values()])
    return row(c.phase), rows, float(c.theta_plus), float(c.theta_minus), later


class Zero:
    """The zero dynamics of the design on the oracle, computed here."""

    def __init__(self):
        self.walker = Rabbit()
        self.c, self.h, self.lo, self.hi, later = _design()
        self.degree = later.shape[1] + 1
        self.solve = np.linalg.inv(np.vstack([self.h, self.c]))
        self.alphas = np.hstack([np.zeros((len(later), 2)), later])
        q, dq = self.surface(self.hi)  # alpha_0, alpha_1 play no part at theta_minus
        q_plus, rates = self.after(q, dq)
        self.theta_after = float(self.c @ q_plus)
        self.alphas[:, 0] = self.h @ q_plus
        span = self.hi - self.lo
        self.alphas[:, 1] = self.alphas[:, 0] + span / self.degree * (self.h @ rates) / (
            self.c @ rates
        )

    def desired(self, theta):
        """h(theta) and dh/dtheta (Bezier polynomials in s)."""
        span = self.hi - self.lo
        s = (theta - self.lo) / span
        m = self.degree
        k = np.arange(m + 1)
        binom = np.array([math.comb(m, j) for j in k], float)
        basis = binom * s**k * (1 - s) ** (m - k)
        kd = np.arange(m)
        bd = np.array([math.comb(m - 1, j) for j in kd], float) * s**kd * (1 - s) ** (m - 1 - kd)
        return self.alphas @ basis, m * np.diff(self.alphas, axis=1) @ bd / span

    def surface(self, theta):
        value, slope = self.desired(theta)
        return self.solve @ np.append(value, theta), self.solve @ np.append(slope, 1.0)

    def after(self, q, dq):
        """The relabelled configuration and rates after the oracle's impact."""
        _, _, rates = self.walker.impact(q, dq)
        return q[SWAP], rates

    def sigma(self, q, dq):
        """Angular momentum about the stance foot, clockwise positive."""
        return -self.walker.angular_momentum(q, dq, np.zeros(2))

    def kappa(self, theta):
        q, dq = self.surface(theta)
        moment = self.walker.g * self.walker.masses @ self.walker.positions(q)[:, 0]
        return self.sigma(q, dq) * moment  # gravity's moment about the stance foot

    def fixed_point(self):
        v_minus = -quad(self.kappa, self.lo, self.hi, epsabs=1e-13, epsrel=1e-13, limit=200)[0]
        q, dq = self.surface(self.hi)
        q_plus, rates = self.after(q, dq)
        delta = self.sigma(q_plus, rates) / self.sigma(q, dq)
        zeta_star = -v_minus / (1 - delta**2)
        return {"delta_squared": delta**2, "V": v_minus, "zeta_star": zeta_star,
                "theta_dot_minus": math.sqrt(2 * zeta_star) / self.sigma(q, dq)}  # fmt: skip


def _agree(got, expected, tol):
    assert abs(got - expected) <= tol * max(1.0, abs(expected)), (got, expected)


def test_the_gait_is_impact_invariant_and_exists(report):
    mismatch = report["impact_invariance"]["mismatch_per_rate"]
    assert len(mismatch) == 4
    assert max(abs(v) for v in mismatch.values()) < 1e-9
    assert report["delta_squared"] < 1
    assert report["delta_squared"] * report["zeta_star"] > report["V_max"]


def test_the_restricted_map_agrees_with_the_oracle(report):
    zero = Zero()
    _agree(zero.theta_after, zero.lo, 1e-12)  # the design's theta_plus is the impact's
    expected = zero.fixed_point()
    for name in ("delta_squared", "V", "zeta_star", "theta_dot_minus"):
        _agree(report[name], expected[name], 1e-9)


def test_the_full_order_loop_is_the_restricted_map(report):
    loop = report["full_order"]
    assert loop is not None, report["full_order_error"]
    assert report["gains"] == {"kp": 400.0, "kd": 40.0}
    _agree(loop["theta_dot_minus"], report["theta_dot_minus"], 1e-8)
    moduli = sorted((abs(complex(*e)) if isinstance(e, list) else abs(e))
                    for e in loop["eigenvalues"])  # fmt: skip
    assert abs(moduli[-1] - report["delta_squared"]) < 1e-6
    assert moduli[-2] < report["delta_squared"]


def test_the_actuators_work_is_the_impact_loss(report):
    assert abs(report["surface_jump"]) < 1e-9
    _agree(report["work_per_step"], report["impact_loss"], 1e-9)
