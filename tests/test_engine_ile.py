"""The ILE through the engine's generic runtime (vsw.dynamics.hybrid) against its own closed forms.

The generic runtime knows nothing of the ILE: it integrates the engine's equations of
motion, detects the engine's guards, applies the engine's resets and solves the periodic
orbit as a boundary-value problem. Its gait must be the paper's fixed point (10), its
eigenvalue (19), and its speed the closed form's (step length over the Carlson period).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from generated import ile
from vsw.models import load
from vsw.models.ile.params import random_parameters

SETS = [(0.8, 0.0, math.pi / 4)] + [
    tuple(float(v[i]) for v in random_parameters(4, seed=31, walking=True).values())
    for i in range(4)
]


@pytest.fixture(scope="module")
def model():
    return load("ile")


@pytest.mark.parametrize("values", SETS)
def test_generic_orbit_is_the_closed_form_fixed_point(model, values):
    params = model.parameters(dict(zip(("beta", "theta_II", "phi0"), values)))
    beta, theta_II, phi0 = params
    q_f = float(ile.q_fixed(beta, theta_II, phi0))
    theta_I = float(ile.theta_I(beta, phi0))
    start = np.array([theta_I, math.sqrt(q_f) * 1.02])  # a perturbed start on the section
    orbit = model.periodic_orbit(params, start, model.step(params, start).durations)
    assert orbit.state["theta"] == pytest.approx(theta_I, abs=1e-12)
    assert orbit.state["theta_dot"] == pytest.approx(math.sqrt(q_f), rel=1e-9)
    eigen = sorted(abs(e) for e in orbit.eigenvalues)
    assert eigen[-1] == pytest.approx(float(ile.eigenvalue(beta, phi0)), rel=1e-8)
    assert eigen[0] < 1e-9  # the section pins theta: one eigenvalue is zero
    tau = ile.phase_durations(beta, theta_II, phi0, q_f)
    assert orbit.period == pytest.approx(float(tau[0] + tau[1]), rel=1e-9)
    assert orbit.step_length == pytest.approx(float(ile.step_length(beta, phi0)), rel=1e-12)


def test_generic_simulation_walks_to_the_fixed_point(model):
    params = model.parameters({"beta": 0.8, "theta_II": 0.0, "phi0": math.pi / 4})
    q_f = float(ile.q_fixed(*params))
    theta_I = float(ile.theta_I(params[0], params[2]))
    walk = model.simulate(params, np.array([theta_I, 0.8]), 40)
    assert walk.ended == "completed" and walk.steps_completed == 40
    assert walk.section[-1][1] ** 2 == pytest.approx(q_f, rel=1e-9)
    # Each step's q follows the paper's stride map (9).
    q = walk.section[:, 1] ** 2
    np.testing.assert_allclose(q[1:], ile.stride_map(*params, q[:-1]), rtol=1e-10)


def test_generic_simulation_reports_the_failures(model):
    params = model.parameters({"beta": 0.8, "theta_II": 0.0, "phi0": math.pi / 4})
    theta_I = float(ile.theta_I(params[0], params[2]))
    q_min = float(ile.q_apex_min(*params))
    q_max = float(ile.q_liftoff_max(*params))
    assert model.step(params, np.array([theta_I, math.sqrt(0.9 * q_min)])).ended == (
        "fell-backward"
    )
    assert model.step(params, np.array([theta_I, math.sqrt(1.1 * q_max)])).ended == "lift-off"
    assert model.step(params, np.array([theta_I, math.sqrt(1.1 * q_min)])).ended == "completed"
