"""The time-domain simulation against the closed-form analysis of the generated code."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from generated import ile
from vsw.models.ile.simulate import (
    SimulationResult,
    fixed_point_by_simulation,
    poincare_map,
    poincare_step,
    simulate,
)
from vsw.runtime.errors import ConvergenceError, VswInputError

FIG8 = (0.8, 0.0, math.radians(45.0))  # beta, theta_II, phi0 of the paper's Fig. 8
REL = 1e-9
PHYSICAL = [c[4] for c in ile.CONDITIONS]
STRICT = [c[2] for c in ile.CONDITIONS]


def walks(beta: float, theta_II: float, phi0: float) -> bool:
    """All physical existence conditions hold (closed-form margins from generated code)."""
    margins = np.array(ile.condition_margins(beta, theta_II, phi0), dtype=float)
    holds = np.where(STRICT, margins > 0, margins >= 0)
    return bool(np.all(holds[PHYSICAL]))


def rel_err(a, b):
    return np.abs(np.asarray(a) / np.asarray(b) - 1)


# ---- the paper's Fig. 8 gait ----------------------------------------------------------


@pytest.fixture(scope="module")
def fig8_run() -> tuple[SimulationResult, float]:
    q_f = float(ile.q_fixed(*FIG8))
    # Start perturbed; with eigenvalue 0.32 forty steps reach the fixed point to ~1e-20.
    return simulate(*FIG8, 1.5 * q_f, 40), q_f


def test_fig8_fixed_point_step_period_and_length(fig8_run):
    res, q_f = fig8_run
    assert res.ended == "completed"
    assert res.q.size == 41 and res.step_periods.size == 40
    assert rel_err(res.q[-1], q_f) <= REL
    # Step metrics of the converged steps against the closed form at q_fixed.
    period = float(sum(ile.phase_durations(*FIG8, q_f)))
    assert np.all(rel_err(res.step_periods[-5:], period) <= REL)
    assert np.all(rel_err(res.step_lengths, ile.step_length(FIG8[0], FIG8[2])) <= REL)


def test_fig8_simulated_fixed_point_by_brentq():
    q_f = float(ile.q_fixed(*FIG8))
    assert rel_err(fixed_point_by_simulation(*FIG8), q_f) <= REL
    assert rel_err(poincare_map(*FIG8, q_f), q_f) <= REL


def test_fig8_events_follow_the_instants(fig8_run):
    res, _ = fig8_run
    kinds = [e[0] for e in res.events]
    assert kinds[:5] == ["I", "II", "III", "IV", "I"]
    assert kinds.count("IV") == 40
    beta, theta_II, phi0 = FIG8
    for kind, _t, theta, _omega in res.events:
        if kind in ("II", "III"):
            assert theta == theta_II
        elif kind == "IV":
            assert abs(theta - ile.theta_IV(beta, phi0)) <= 1e-12
        else:
            assert abs(theta - ile.theta_I(beta, phi0)) <= 1e-12
    times = [e[1] for e in res.events]
    assert np.all(np.diff(times) >= 0)
    assert np.all(np.diff(res.t) >= 0)


def test_energy_constant_along_each_swing_phase(fig8_run):
    res, _ = fig8_run
    beta = FIG8[0]
    for step in (0, 1, 39):
        for phase, rho in ((1, beta), (2, 1.0)):
            sel = (res.step == step) & (res.phase == phase)
            energy = ile.phase_energy(res.theta[sel], res.omega[sel], rho)
            assert sel.sum() > 3
            assert np.ptp(energy) <= 1e-10 * abs(energy[0])


def _hip(theta: float, rho: float) -> np.ndarray:
    """Hip position relative to the stance foot; theta is measured from the vertical."""
    return rho * np.array([math.sin(theta), math.cos(theta), 0.0])


def _hip_velocity(theta: float, omega: float, rho: float) -> np.ndarray:
    return rho * omega * np.array([math.cos(theta), -math.sin(theta), 0.0])


def test_angular_momentum_conserved_across_extension_and_heelstrike(fig8_run):
    res, _ = fig8_run
    beta, _theta_II, phi0 = FIG8
    events = res.events
    for i, (kind, t, theta, omega) in enumerate(events):
        if kind == "II":
            # Extension: about the stance foot (origin), leg beta -> 1 at the same angle.
            k3, t3, th3, w3 = events[i + 1]
            assert k3 == "III" and t3 == t and th3 == theta
            before = np.cross(_hip(theta, beta), _hip_velocity(theta, omega, beta))
            after = np.cross(_hip(th3, 1.0), _hip_velocity(th3, w3, 1.0))
            assert abs(after[2] / before[2] - 1) <= 1e-14
        if kind == "IV" and i + 1 < len(events):
            # Heelstrike: about the swing foot, which lands at hip + beta (sin, -cos)(phi0 - th).
            k1, _t1, th1, w1 = events[i + 1]
            assert k1 == "I"
            hip = _hip(theta, 1.0)
            foot = hip + beta * np.array([math.sin(phi0 - theta), -math.cos(phi0 - theta), 0.0])
            assert abs(foot[1]) <= 1e-12  # the swing foot is on the ground
            before = np.cross(hip - foot, _hip_velocity(theta, omega, 1.0))
            # After the swap: new stance leg of length beta from the foot, at angle th1.
            assert np.allclose(foot + _hip(th1, beta), hip, atol=1e-12)
            after = np.cross(_hip(th1, beta), _hip_velocity(th1, w1, beta))
            assert abs(after[2] / before[2] - 1) <= 1e-12


def test_record_false_keeps_events_only():
    res = simulate(*FIG8, 0.5, 3, record=False)
    assert res.ended == "completed" and res.q.size == 4
    assert res.t.size == len(res.events)


def test_progress_callback():
    calls = []
    simulate(*FIG8, 0.5, 4, progress=lambda i, n: calls.append((i, n)))
    assert calls == [(0, 4), (1, 4), (2, 4), (3, 4)]


# ---- failures and edge cases ---------------------------------------------------------


def test_fall_back_in_phase_one_before_extension():
    beta, _, phi0 = FIG8
    res = simulate(beta, 0.1, phi0, 1e-3, 5)  # too slow to reach the apex at theta = 0
    assert res.ended == "fell-backward"
    assert [e[0] for e in res.events] == ["I"]
    assert res.phase[-1] == 1 and abs(res.omega[-1]) <= 1e-12 and res.theta[-1] < 0
    assert res.q.size == 1
    assert math.isnan(poincare_map(beta, 0.1, phi0, 1e-3))
    assert poincare_step(beta, 0.1, phi0, 1e-3).ended == "fell-backward"


def test_lift_off_at_the_start():
    q_max = float(ile.q_liftoff_max(*FIG8))
    res = simulate(*FIG8, 3 * q_max, 2)
    assert res.ended == "lift-off" and res.q.size == 1


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((1.2, 0.0, 0.7, 0.5, 3), "beta"),
        ((0.8, float("nan"), 0.7, 0.5, 3), "theta_II"),
        ((0.8, 0.0, 1.6, 0.5, 3), "phi0"),
        ((0.8, 0.0, 0.7, -0.5, 3), "q0"),
        ((0.8, 0.0, 0.7, float("inf"), 3), "q0"),
        ((0.8, 0.0, 0.7, 0.5, 0), "steps"),
        ((0.8, 0.0, 0.7, 0.5, 2.5), "steps"),
        ((0.8, -0.5, math.radians(45), 0.5, 3), "extension_reached"),
        ((0.8, 0.7, math.radians(45), 0.5, 3), "extension_before_heelstrike"),
    ],
)
def test_bad_input_is_one_line_error(args, match):
    with pytest.raises(VswInputError, match=match) as info:
        simulate(*args)
    assert "\n" not in str(info.value)


def test_theta_II_equal_to_theta_I_is_rejected():
    beta, _, phi0 = FIG8
    with pytest.raises(VswInputError, match="extension_reached"):
        simulate(beta, float(ile.theta_I(beta, phi0)), phi0, 0.5, 1)


# ---- properties over random valid parameters -----------------------------------------


@st.composite
def model_parameters(draw):
    """beta, phi0 in their domains; theta_II strictly between theta_I and theta_IV."""
    beta = draw(st.floats(0.3, 0.99))
    phi0 = draw(st.floats(0.05, 1.5))
    th_I, th_IV = float(ile.theta_I(beta, phi0)), float(ile.theta_IV(beta, phi0))
    theta_II = th_I + draw(st.floats(0.02, 0.98)) * (th_IV - th_I)
    return beta, theta_II, phi0


PROPERTY = settings(
    max_examples=30,
    deadline=None,
    suppress_health_check=[HealthCheck.filter_too_much, HealthCheck.too_slow],
)


@PROPERTY
@given(params=model_parameters(), start=st.floats(-0.9, 0.9))
def test_walking_gaits_converge_to_the_fixed_point(params, start):
    assume(walks(*params))
    q_f = float(ile.q_fixed(*params))
    q_lo, q_hi = float(ile.q_apex_min(*params)), float(ile.q_liftoff_max(*params))
    # Keep a relative margin from the feasibility edges, where a step grazes the apex or
    # the normal force touches zero and the outcome is decided by round-off.
    assume(q_f > q_lo * (1 + 1e-6) and q_f < q_hi * (1 - 1e-6))
    q0 = q_f + abs(start) * ((q_hi if start > 0 else q_lo) - q_f)
    steps = 12
    res = simulate(*params, q0, steps, record=False)
    assert res.ended == "completed"
    lam = float(ile.eigenvalue(params[0], params[2]))
    # The iterates approach q_f geometrically with ratio lambda (the map is linear).
    predicted = q_f + lam ** np.arange(steps + 1) * (q0 - q_f)
    assert np.all(np.abs(res.q - predicted) <= REL * max(q_f, abs(q0)))
    if abs(q0 - q_f) * lam**steps <= 1e-12 * q_f:
        assert rel_err(res.q[-1], q_f) <= REL


@PROPERTY
@given(params=model_parameters(), below=st.floats(0.01, 0.99))
def test_start_below_apex_bound_falls_backward(params, below):
    q_lo, q_hi = float(ile.q_apex_min(*params)), float(ile.q_liftoff_max(*params))
    assume(q_lo > 1e-6)
    q0 = q_lo * (1 - below)
    assume(q0 < q_hi)  # otherwise the foot may lift off before the fall
    res = simulate(*params, q0, 3)
    assert res.ended == "fell-backward"
    assert res.q.size == 1


@PROPERTY
@given(params=model_parameters(), above=st.floats(0.01, 2.0))
def test_start_above_liftoff_bound_lifts_off(params, above):
    q_lo, q_hi = float(ile.q_apex_min(*params)), float(ile.q_liftoff_max(*params))
    assume(q_hi > q_lo and q_hi > 1e-6)
    res = simulate(*params, q_hi * (1 + above), 3)
    assert res.ended == "lift-off"
    assert res.q.size == 1


@PROPERTY
@given(params=model_parameters())
def test_apex_failure_at_the_fixed_point_ends_in_a_fall(params):
    """When q_f lies below the apex bound, a gait started inside the feasible interval
    decays towards q_f and falls back once q crosses q_apex_min."""
    q_f = float(ile.q_fixed(*params))
    q_lo, q_hi = float(ile.q_apex_min(*params)), float(ile.q_liftoff_max(*params))
    assume(q_f < q_lo * (1 - 1e-3) and q_hi > q_lo * (1 + 1e-3) and q_lo > 1e-6)
    q0 = 0.5 * (q_lo + q_hi)
    lam = float(ile.eigenvalue(params[0], params[2]))
    # Steps until the geometric decay crosses q_apex_min, with some slack.
    n_cross = math.log((q_lo - q_f) / (q0 - q_f)) / math.log(lam)
    assume(n_cross < 25)
    res = simulate(*params, q0, math.ceil(n_cross) + 3, record=False)
    assert res.ended == "fell-backward"
    # Every step that completed started above the bound; the one that fell started below.
    assert np.all(res.q[:-1] >= q_lo * (1 - 1e-9)) and res.q[-1] < q_lo * (1 + 1e-9)


@settings(max_examples=10, deadline=None, suppress_health_check=list(HealthCheck))
@given(params=model_parameters())
def test_simulated_fixed_point_by_brentq_matches_closed_form(params):
    assume(walks(*params))
    q_f = float(ile.q_fixed(*params))
    q_lo, q_hi = float(ile.q_apex_min(*params)), float(ile.q_liftoff_max(*params))
    assume(q_lo * (1 + 1e-6) < q_f < q_hi * (1 - 1e-6))
    assert rel_err(fixed_point_by_simulation(*params), q_f) <= REL


def test_simulated_fixed_point_reports_a_falling_gait():
    falling = (0.9, -0.4, 1.2)  # q_fixed < q_apex_min: every gait decays into a fall
    assert float(ile.q_fixed(*falling)) < float(ile.q_apex_min(*falling))
    with pytest.raises(ConvergenceError):
        fixed_point_by_simulation(*falling)
