"""CasADi fixed-point solvers (closed-form and integrated maps) against the closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from oracles import ile_fixed_point as fp

from generated import ile
from vsw.runtime.errors import ConvergenceError, VswInputError

FIG8 = (0.8, 0.0, math.radians(45.0))
REL = 1e-10
PHYSICAL = np.array([c[4] for c in ile.CONDITIONS])
STRICT = np.array([c[2] for c in ile.CONDITIONS])


def walking_mask(beta, theta_II, phi0) -> np.ndarray:
    margins = np.array(ile.condition_margins(beta, theta_II, phi0), dtype=float)
    margins = margins.reshape(len(ile.CONDITIONS), -1)
    holds = np.where(STRICT[:, None], margins > 0, margins >= 0)
    return np.all(holds[PHYSICAL], axis=0)


def seeded_walking_sets(n: int, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    beta = rng.uniform(0.3, 0.999, 40 * n)
    phi0 = rng.uniform(0.02, 1.55, 40 * n)
    theta_II = rng.uniform(-1.2, 1.2, 40 * n)
    keep = walking_mask(beta, theta_II, phi0)
    return beta[keep][:n], theta_II[keep][:n], phi0[keep][:n]


@pytest.mark.parametrize("method", fp.METHODS)
def test_fig8_fixed_point(method):
    res = fp.solve_fixed_point(*FIG8, method=method)
    q_f = float(ile.q_fixed(*FIG8))
    assert res.converged and res.method == method
    assert abs(res.q_fixed / q_f - 1) <= REL
    assert abs(res.residual) <= 1e-12
    assert 1 <= res.iterations <= 5  # the map is linear in q: Newton needs one real step
    assert res.stats["success"]


def test_integrated_map_and_durations_match_closed_form_at_fig8():
    q_f = float(ile.q_fixed(*FIG8))
    q_next, tau_1, tau_2 = fp.integrated_stride_map(*FIG8, q_f)
    assert abs(q_next / float(ile.stride_map(*FIG8, q_f)) - 1) <= 1e-13
    closed_1, closed_2 = (float(v) for v in ile.phase_durations(*FIG8, q_f))
    assert abs(tau_1 / closed_1 - 1) <= 1e-12
    assert abs(tau_2 / closed_2 - 1) <= 1e-12


@settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow],
)
@given(beta=st.floats(0.3, 0.999), phi0=st.floats(0.02, 1.55), frac=st.floats(0.0, 1.0))
def test_both_methods_agree_with_closed_form_on_walking_sets(beta, phi0, frac):
    # theta_II between theta_I and theta_IV, where walking gaits can exist.
    th_I, th_IV = float(ile.theta_I(beta, phi0)), float(ile.theta_IV(beta, phi0))
    theta_II = th_I + frac * (th_IV - th_I)
    assume(bool(walking_mask(beta, theta_II, phi0)[0]))
    q_f = float(ile.q_fixed(beta, theta_II, phi0))
    for method in fp.METHODS:
        res = fp.solve_fixed_point(beta, theta_II, phi0, method=method)
        assert abs(res.q_fixed - q_f) <= REL * abs(q_f), method


@pytest.mark.parametrize("method", fp.METHODS)
def test_batch_agrees_with_closed_form(method):
    beta, theta_II, phi0 = seeded_walking_sets(300)
    assert beta.size == 300
    res = fp.solve_fixed_point_batch(beta, theta_II, phi0, method=method)
    q_f = ile.q_fixed(beta, theta_II, phi0)
    assert res.converged.all()
    assert np.all(np.abs(res.q_fixed - q_f) <= REL * np.abs(q_f))


def test_batch_threads_and_broadcasting():
    theta_II = np.linspace(-0.3, 0.3, 7)
    res = fp.solve_fixed_point_batch(0.8, theta_II, math.radians(45), parallelization="thread")
    assert res.q_fixed.shape == (7,) and res.converged.all()
    assert np.allclose(res.q_fixed, ile.q_fixed(0.8, theta_II, math.radians(45)), rtol=1e-12)


# A walker whose fixed point lies below the apex bound: the integrated map is undefined
# there (omega would have to pass through zero), so Newton cannot converge.
FALLING = (0.9, -0.4, 1.2)


def test_falling_case_is_really_falling():
    assert float(ile.q_fixed(*FALLING)) < float(ile.q_apex_min(*FALLING))


def test_integrated_non_convergence_raises():
    with pytest.raises(ConvergenceError, match="did not converge") as info:
        fp.solve_fixed_point(*FALLING, method="integrated")
    assert "\n" not in str(info.value)


def test_integrated_non_convergence_in_batch_is_reported():
    res = fp.solve_fixed_point_batch(
        [FIG8[0], FALLING[0]], [FIG8[1], FALLING[1]], [FIG8[2], FALLING[2]], method="integrated"
    )
    assert res.converged.tolist() == [True, False]
    assert math.isnan(res.q_fixed[1]) and math.isfinite(res.q_fixed[0])


def test_nan_reported_as_success_is_caught(monkeypatch):
    """CasADi's newton may return NaN with success=True; the residual check must catch it."""

    class NanSolver:
        def __call__(self, *args):
            return math.nan

        def stats(self):
            return {"success": True, "return_status": "success", "iter_count": 1}

    _, residual = fp._rootfinder("closed-form", 50)
    monkeypatch.setattr(fp, "_rootfinder", lambda method, max_iter: (NanSolver(), residual))
    with pytest.raises(ConvergenceError):
        fp.solve_fixed_point(*FIG8)


def test_iteration_limit_reports_non_convergence():
    # One Newton iteration from far away on the integrated map leaves a large residual
    # (the map is linear only up to integration error, so iteration 1 is not exact).
    with pytest.raises(ConvergenceError):
        fp.solve_fixed_point(*FIG8, method="integrated", q0=1e6, max_iter=0)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"beta": 1.0}, "beta"),
        ({"phi0": -0.1}, "phi0"),
        ({"theta_II": float("nan")}, "theta_II"),
        ({"method": "magic"}, "method"),
        ({"q0": float("inf")}, "q0"),
    ],
)
def test_bad_input(kwargs, match):
    args = dict(zip(("beta", "theta_II", "phi0"), FIG8)) | kwargs
    with pytest.raises(VswInputError, match=match):
        fp.solve_fixed_point(**args)


def test_empty_batch():
    res = fp.solve_fixed_point_batch([], [], [])
    assert res.q_fixed.shape == (0,) and res.converged.shape == (0,)
