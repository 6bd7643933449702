"""Tests of vsw.models.ile.params and vsw.models.ile.analysis against independent computations.

Expected values come from the paper's equations written out here, SciPy quadrature,
brute-force minima and the time-domain simulation, never from the code under test.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from generated import ile
from vsw.models.ile.analysis import analyze, phase_durations_scipy, step_period_scipy
from vsw.models.ile.params import STEPPER_2D, GaitParameters, RobotScale, validate
from vsw.runtime.errors import VswInputError

FIG8 = (0.8, 0.0, math.radians(45.0))


def paper_theta_I(beta, phi0):
    return -np.arctan((beta - np.cos(phi0)) / np.sin(phi0))  # eq. (11)


def paper_q_fixed(beta, theta_II, phi0):
    theta_I = paper_theta_I(beta, phi0)
    c2 = np.cos(phi0) ** 2
    numerator = 2 * c2 * (np.cos(theta_II) * (1 - beta**3) - np.cos(theta_I) * (beta - beta**3))
    return numerator / (beta**2 * (1 - c2 * beta**2))  # eq. (10)


def quad_phase_times(beta, theta_II, phi0, q):
    """Phase durations as integrals of dtheta / omega(theta) from the energy integrals."""
    from scipy.integrate import quad

    theta_I = paper_theta_I(beta, phi0)
    theta_IV = theta_I + phi0

    def omega_1(theta):
        return math.sqrt(q + (2 / beta) * (math.cos(theta_I) - math.cos(theta)))

    omega_II = omega_1(theta_II)
    omega_III = beta**2 * omega_II

    def omega_2(theta):
        return math.sqrt(omega_III**2 + 2 * (math.cos(theta_II) - math.cos(theta)))

    tau_1 = quad(lambda th: 1 / omega_1(th), theta_I, theta_II, epsabs=1e-14, epsrel=1e-13)[0]
    tau_2 = quad(lambda th: 1 / omega_2(th), theta_II, theta_IV, epsabs=1e-14, epsrel=1e-13)[0]
    return tau_1, tau_2


# --- parameters --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "fragments"),
    [
        ({"beta": 1.2}, ["beta = 1.2", "0 < beta < 1"]),
        ({"beta": 0.0}, ["beta = 0", "0 < beta < 1"]),
        ({"phi0": math.radians(95)}, ["phi0 =", "95 deg", "eq. (16)"]),
        ({"phi0": float("nan")}, ["phi0 = nan", "finite", "eq. (16)"]),
        ({"theta_II": float("inf")}, ["theta_II = inf", "finite", "pi/2"]),
        ({"theta_II": -2.0}, ["theta_II", "pi/2"]),
        ({"beta": "0.8"}, ["beta = '0.8'", "not a real number"]),
        ({"beta": None}, ["beta = None", "not a real number"]),
        ({"beta": True}, ["beta = True", "not a real number"]),
    ],
)
def test_gait_parameters_reject_bad_values_with_one_line(kwargs, fragments):
    values = {"beta": 0.8, "theta_II": 0.0, "phi0": 0.7} | kwargs
    with pytest.raises(VswInputError) as info:
        GaitParameters(**values)
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message


def test_validate_arrays_names_the_offending_element():
    beta = np.array([0.5, 0.9, 1.5])
    with pytest.raises(VswInputError, match=r"beta\[2\] = 1.5"):
        validate(beta, 0.0, 0.7)
    out = validate(np.array([0.5, 0.9]), np.zeros((3, 1)), 0.7)
    assert all(a.shape == (3, 2) for a in out)
    with pytest.raises(VswInputError, match="broadcast"):
        validate(np.array([0.5, 0.9]), np.zeros(3), 0.7)


@pytest.mark.parametrize("which", ["beta", "theta_II", "phi0"])
def test_masked_arrays_with_masked_values_are_rejected(which):
    """np.asarray drops a mask: the masked (hidden) values would be analysed as if valid.
    Here they are even outside the domain, and nothing would have said so."""
    args = {"beta": np.full(3, 0.8), "theta_II": np.zeros(3), "phi0": np.full(3, 0.7)}
    hidden = {"beta": 5.0, "theta_II": 9.0, "phi0": -1.0}[which]
    args[which] = np.ma.array([args[which][0], args[which][1], hidden], mask=[0, 0, 1])
    with pytest.raises(VswInputError) as info:
        analyze(args["beta"], args["theta_II"], args["phi0"], timing=False)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"{which} is a masked array with 1 masked")
    assert f"{which}.compressed()" in message


def test_masked_arrays_without_masked_values_are_plain_arrays():
    plain = analyze(np.array([0.8, 0.75]), 0.0, 0.7, timing=False)
    masked = analyze(np.ma.array([0.8, 0.75], mask=False), 0.0, 0.7, timing=False)
    np.testing.assert_array_equal(masked.q_fixed, plain.q_fixed)
    assert not isinstance(masked.q_fixed, np.ma.MaskedArray)


def test_masked_values_are_rejected_by_the_other_validators_too():
    from vsw.models.ile.params import check_positive

    with pytest.raises(VswInputError, match="q0 is a masked array with 1 masked"):
        check_positive("q0", np.ma.masked_invalid([0.3, np.nan]), "reason")


def test_gait_parameters_frozen_and_from_degrees():
    p = GaitParameters.from_degrees(0.8, 0, 45)
    assert p.astuple() == pytest.approx(FIG8)
    with pytest.raises(AttributeError):
        p.beta = 0.7  # type: ignore[misc]


@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), float("inf"), "x"])
def test_robot_scale_rejects_non_positive(bad):
    with pytest.raises(VswInputError, match="leg_length"):
        RobotScale(bad, 1.0)
    with pytest.raises(VswInputError, match="mass"):
        RobotScale(1.0, bad)


# --- fixed point, geometry, energies -----------------------------------------------------


def test_fixed_point_matches_paper_equations_and_energy_integrals():
    beta, theta_II, phi0 = np.meshgrid(
        [0.6, 0.8, 0.95], np.radians([-10, 0, 15]), np.radians([45, 60]), indexing="ij"
    )
    a = analyze(beta, theta_II, phi0)
    np.testing.assert_allclose(a.q_fixed, paper_q_fixed(beta, theta_II, phi0), rtol=1e-12)
    np.testing.assert_allclose(a.theta_I, paper_theta_I(beta, phi0), rtol=1e-12)
    np.testing.assert_allclose(a.theta_IV, a.theta_I + phi0, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(a.eigenvalue, beta**2 * np.cos(phi0) ** 2, rtol=1e-12)
    # One step with the energy integrals and resets (3), (6) returns q_fixed.
    q = a.q_fixed
    omega_II_sq = q + (2 / beta) * (np.cos(a.theta_I) - np.cos(theta_II))
    omega_IV_sq = beta**4 * omega_II_sq + 2 * (np.cos(theta_II) - np.cos(a.theta_IV))
    q_next = (np.cos(phi0) / beta) ** 2 * omega_IV_sq
    np.testing.assert_allclose(q_next, q, rtol=1e-11)
    # Step length: the two feet and the hip form a triangle with legs r_e and beta r_e.
    step = np.hypot(np.sin(a.theta_IV) + beta * np.sin(-a.theta_I), 0.0)
    np.testing.assert_allclose(a.step_length, step, rtol=1e-12)


def test_energies_from_mechanical_energy_before_and_after_each_jump():
    beta, theta_II, phi0 = 0.85, math.radians(-5), math.radians(50)
    a = analyze(beta, theta_II, phi0)
    q = a.q_fixed
    theta_I, theta_IV = a.theta_I, a.theta_IV
    omega_II_sq = q + (2 / beta) * (math.cos(theta_I) - math.cos(theta_II))
    before_ext = beta * math.cos(theta_II) + beta**2 * omega_II_sq / 2  # leg beta r_e
    omega_III_sq = beta**4 * omega_II_sq
    after_ext = math.cos(theta_II) + omega_III_sq / 2
    omega_IV_sq = omega_III_sq + 2 * (math.cos(theta_II) - math.cos(theta_IV))
    before_hs = math.cos(theta_IV) + omega_IV_sq / 2
    after_hs = beta * math.cos(theta_I) + beta**2 * q / 2  # the new stance leg is short
    assert a.energy_added == pytest.approx(after_ext - before_ext, rel=1e-12)
    assert a.energy_lost == pytest.approx(before_hs - after_hs, rel=1e-12)
    si = analyze(beta, theta_II, phi0, STEPPER_2D)
    mgr = STEPPER_2D.mass * STEPPER_2D.gravity * STEPPER_2D.leg_length
    # A scale adds the SI values under keys of their own; energy_added keeps its unit.
    assert si.energy_added == a.energy_added
    assert si.energy_added_J == pytest.approx(mgr * (after_ext - before_ext), rel=1e-12)
    assert si.energy_lost_J == pytest.approx(mgr * (before_hs - after_hs), rel=1e-12)


def test_contact_margin_is_brute_force_minimum_of_normal_force():
    for beta, theta_II, phi0 in [FIG8, (0.9, math.radians(-8), math.radians(40))]:
        a = analyze(beta, theta_II, phi0)
        q = a.q_fixed
        th1 = np.linspace(a.theta_I, theta_II, 20001)
        w1 = q + (2 / beta) * (np.cos(a.theta_I) - np.cos(th1))
        omega_III_sq = beta**4 * w1[-1]
        th2 = np.linspace(theta_II, a.theta_IV, 20001)
        w2 = omega_III_sq + 2 * (np.cos(theta_II) - np.cos(th2))
        normal = np.concatenate(
            [(np.cos(th1) - beta * w1) * np.cos(th1), (np.cos(th2) - w2) * np.cos(th2)]
        )
        assert a.contact_margin == pytest.approx(normal.min(), abs=1e-7)


# --- step period: generated Carlson vs SciPy closed form vs quadrature ---------------------


@pytest.mark.parametrize(
    ("beta", "theta_II_deg", "phi0_deg"),
    [(0.8, 0, 45), (0.8, -6, 45), (0.8, 15, 45), (0.9, -3, 30), (0.75, 5, 50), (0.9, 12, 40)],
)
def test_phase_durations_three_ways(beta, theta_II_deg, phi0_deg):
    theta_II, phi0 = math.radians(theta_II_deg), math.radians(phi0_deg)
    a = analyze(beta, theta_II, phi0)
    assert a.walks
    q = float(a.q_fixed)
    generated = ile.phase_durations(beta, theta_II, phi0, q)
    scipy_closed = phase_durations_scipy(beta, theta_II, phi0, q)
    quad = quad_phase_times(beta, theta_II, phi0, q)
    for g, s, qd in zip(generated, scipy_closed, quad):
        assert float(s) == pytest.approx(qd, rel=1e-10)
        assert float(g) == pytest.approx(qd, rel=1e-10)
    assert a.step_period == pytest.approx(sum(quad), rel=1e-10)
    assert float(step_period_scipy(beta, theta_II, phi0, q)) == pytest.approx(sum(quad), rel=1e-10)
    assert a.speed == pytest.approx(a.step_length / sum(quad), rel=1e-10)


def test_scipy_step_period_below_apex_energy_both_sides():
    # q off the fixed point so that phase I-II stays below the apex energy (E < 1) or not.
    beta, theta_II, phi0 = 0.8, math.radians(-4), math.radians(45)
    for q in [0.05, 0.2, 0.6]:
        expected = quad_phase_times(beta, theta_II, phi0, q)
        got = phase_durations_scipy(beta, theta_II, phi0, q)
        np.testing.assert_allclose(np.array(got, dtype=float), expected, rtol=1e-10)


# --- vectorisation, warnings, JSON -------------------------------------------------------


def test_vectorised_equals_elementwise_and_no_warnings():
    rng = np.random.default_rng(3)
    beta = rng.uniform(0.05, 0.999, 40000)  # many sets do not walk
    theta_II = rng.uniform(-1.5, 1.5, 40000)
    phi0 = rng.uniform(0.01, 1.56, 40000)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = analyze(beta, theta_II, phi0, STEPPER_2D)
    assert a.q_fixed.shape == (40000,)
    assert 0 < a.walks.mean() < 1
    assert np.all(np.isnan(a.step_period[~a.walks]))
    assert np.all(np.isfinite(a.step_period[a.walks]))
    for i in [0, 1, 17, 39999]:
        one = analyze(beta[i], theta_II[i], phi0[i])
        assert one.walks == a.walks[i]
        assert one.q_fixed == pytest.approx(a.q_fixed[i], rel=1e-12)
        np.testing.assert_allclose(one.step_period, a.step_period[i], rtol=1e-12)


def test_walks_is_feasible_interval_and_geometry():
    rng = np.random.default_rng(5)
    beta = rng.uniform(0.3, 0.999, 20000)
    theta_II = rng.uniform(-0.6, 0.8, 20000)
    phi0 = rng.uniform(0.1, 1.5, 20000)
    a = analyze(beta, theta_II, phi0)
    expected = (
        (a.q_fixed > 0)
        & (a.q_apex_min < a.q_fixed)
        & (a.q_fixed <= a.q_liftoff_max)
        & (a.theta_I < theta_II)
        & (theta_II < a.theta_IV)
    )
    # Exclude sets within rounding of a boundary.
    margin = np.minimum.reduce(
        [
            np.abs(a.q_fixed - a.q_apex_min),
            np.abs(a.q_fixed - a.q_liftoff_max),
            np.abs(theta_II - a.theta_I),
            np.abs(theta_II - a.theta_IV),
        ]
    )
    clear = margin > 1e-9
    assert np.array_equal(a.walks[clear], expected[clear])


def test_to_dict_is_strict_json_with_null_for_nan():
    a = analyze(np.array([0.8, 0.3]), 0.0, math.radians(45), STEPPER_2D)
    assert not a.walks[1]  # beta < cos(phi0): no gait
    d = a.to_dict()
    text = json.dumps(d, allow_nan=False)
    back = json.loads(text)
    assert back["step_period"][1] is None
    assert back["walks"] == [True, False]
    one = analyze(*FIG8, STEPPER_2D).to_dict()
    required = {
        "q_fixed", "omega_I", "eigenvalue", "theta_I", "theta_IV", "step_length",
        "step_period", "speed", "contact_margin", "walks", "conditions", "energy_added",
        "energy_lost", "q_apex_min", "q_liftoff_max", "speed_m_s", "speed_leg_s",
        "step_period_s", "step_length_m",
    }  # fmt: skip
    assert required <= one.keys()
    json.dumps(one, allow_nan=False)
    names = [c["name"] for c in one["conditions"]]
    assert names == [c[0] for c in ile.CONDITIONS]
    for c in one["conditions"]:
        assert {"name", "equation", "value", "holds", "status", "physical", "meaning"} <= c.keys()
        assert isinstance(c["holds"], bool)


def test_si_units_by_dimensional_analysis():
    a = analyze(*FIG8)
    s = analyze(*FIG8, RobotScale(0.25, 0.78, 9.81))
    t_unit = math.sqrt(0.25 / 9.81)
    assert s.step_period_s == pytest.approx(a.step_period * t_unit, rel=1e-14)
    assert s.step_length_m == pytest.approx(a.step_length * 0.25, rel=1e-14)
    assert s.speed_m_s == pytest.approx(a.speed * math.sqrt(9.81 * 0.25), rel=1e-14)
    assert s.speed_leg_s == pytest.approx(s.speed_m_s / 0.25, rel=1e-14)


# --- against the time-domain simulation --------------------------------------------------


def test_fig8_matches_simulation_to_1e_9():
    simulate = pytest.importorskip("vsw.models.ile.simulate").simulate
    a = analyze(*FIG8)
    result = simulate(*FIG8, q0=float(a.q_fixed), steps=3)
    assert result.ended == "completed"
    np.testing.assert_allclose(result.q, a.q_fixed, rtol=1e-9)
    np.testing.assert_allclose(result.step_periods, a.step_period, rtol=1e-9)
    np.testing.assert_allclose(result.step_lengths, a.step_length, rtol=1e-9)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    beta=st.floats(0.55, 0.97),
    theta_II_deg=st.floats(-15, 25),
    phi0_deg=st.floats(25, 65),
    offset=st.floats(-0.9, 0.9),
)
def test_simulation_follows_the_analysis(beta, theta_II_deg, phi0_deg, offset):
    simulate = pytest.importorskip("vsw.models.ile.simulate").simulate
    theta_II, phi0 = math.radians(theta_II_deg), math.radians(phi0_deg)
    a = analyze(beta, theta_II, phi0)
    assume(a.walks and a.contact_margin > 1e-3 and a.q_fixed - a.q_apex_min > 1e-3)
    # Start anywhere well inside the feasible interval: the gait converges to q_fixed.
    low, high = float(a.q_apex_min), float(a.q_liftoff_max)
    q0 = a.q_fixed + offset * (high - a.q_fixed if offset > 0 else a.q_fixed - low)
    result = simulate(beta, theta_II, phi0, q0=float(q0), steps=25, record=False)
    assert result.ended == "completed"
    # |q_n - q^f| = lambda^n |q0 - q^f| for the linear map (eq. 19), checked by integration.
    expected = a.q_fixed + a.eigenvalue ** np.arange(26) * (q0 - a.q_fixed)
    np.testing.assert_allclose(result.q, expected, rtol=1e-7, atol=1e-9)
    # Just outside the interval it fails in the predicted way in the first step.
    q_below = low - 1e-3 * (high - low)
    if q_below > 0:  # q_apex_min can be 0 (theta_I = 0): then nothing falls backward
        below = simulate(beta, theta_II, phi0, q0=q_below, steps=2, record=False)
        assert below.ended == "fell-backward"
    above = simulate(beta, theta_II, phi0, q0=high + 1e-3 * (high - low), steps=2, record=False)
    assert above.ended == "lift-off"


def test_thread_count_does_not_change_analyze(monkeypatch):
    rng = np.random.default_rng(8)
    args = (
        rng.uniform(0.05, 0.999, 50000),
        rng.uniform(-1.5, 1.5, 50000),
        rng.uniform(0.01, 1.56, 50000),
    )
    monkeypatch.setenv("VSW_THREADS", "1")
    one = analyze(*args)
    monkeypatch.setenv("VSW_THREADS", "2")
    two = analyze(*args)
    for name in ("q_fixed", "eigenvalue", "step_period", "contact_margin", "walks"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    for c1, c2 in zip(one.conditions, two.conditions):
        np.testing.assert_array_equal(c1.value, c2.value)
    monkeypatch.setenv("VSW_THREADS", "zero")
    with pytest.raises(VswInputError, match="VSW_THREADS must be a positive integer"):
        analyze(*args)


def test_apex_and_contact_margins_against_brute_force_over_the_step():
    """The apex margin (min omega**2 per phase over its slope in q) and the contact margin
    (min N) of the fused and explicit generated code against dense sampling of the step."""
    from tests.conftest import random_walking_parameters

    p = random_walking_parameters(30, seed=21)
    names = [c[0] for c in ile.CONDITIONS]
    for beta, theta_II, phi0 in zip(p["beta"], p["theta_II"], p["phi0"]):
        a = analyze(beta, theta_II, phi0)
        q = float(a.q_fixed)
        th1 = np.linspace(float(a.theta_I), theta_II, 40001)
        w1 = q + (2 / beta) * (np.cos(a.theta_I) - np.cos(th1))
        omega_III_sq = beta**4 * w1[-1]
        th2 = np.linspace(theta_II, float(a.theta_IV), 40001)
        w2 = omega_III_sq + 2 * (np.cos(theta_II) - np.cos(th2))
        apex = min(w1.min(), w2.min() / beta**4)
        normal = min(
            ((np.cos(th1) - beta * w1) * np.cos(th1)).min(),
            ((np.cos(th2) - w2) * np.cos(th2)).min(),
        )
        fused = dict(zip(names, ile.fixed_point_conditions(beta, theta_II, phi0)[2:]))
        explicit = dict(zip(names, ile.condition_margins(beta, theta_II, phi0)))
        for margins in (fused, explicit):
            assert float(margins["apex"]) == pytest.approx(apex, rel=1e-6, abs=1e-6)
            assert float(margins["stance_contact"]) == pytest.approx(normal, abs=1e-7)
