"""The engine's simplest walker and compass gait against the numbers their sources publish.

Sources, cited beside each number below:

* [G98] M. Garcia, A. Chatterjee, A. Ruina, M. Coleman, "The simplest walking model:
  stability, complexity, and scaling", J. Biomech. Eng. 120(2):281-288, 1998. Abstract:
  two period-one gaits, "one of which is stable when 0 < gamma < 0.015 rad"; "stance angle
  is proportional to gamma^(1/3)".
* [G98code] M. Garcia's simulation code for [G98] (``pointfoot.m``), comments
  "initial conditions gam=0.009 long step to 1e-10" and "... short step to 1e-10": the
  stance angle and rate just after heelstrike of both gaits to 14 digits, the eigenvalues
  of the long-step gait ("loc = -0.19120868949940 +/- 0.55633363687106i") and of the
  short-step gait ("loc = 4.000, 0.459"), and the swing leg's rate after heelstrike,
  ``theta2dot = -theta1dot (1 - cos(2 theta1))``.
* [GTE96] A. Goswami, B. Thuilot, B. Espiau, "Compass-like biped robot part I: stability
  and bifurcation of passive gaits", INRIA RR-2996, 1996: at a = b = 0.5 m, m_h = 10 kg,
  m = 5 kg and a slope of 3 degrees, a stable period-one gait with step period 0.735 s and
  half inter-leg angle 0.271 rad at heelstrike. These two numbers are as quoted by later
  work; the report itself was not at hand: the angle agrees to the 3 digits quoted, the
  period to 1e-3 s (ours 0.73435 s).

[G98] measures both angles the other way round from the engine: its state is minus the
engine's (the engine's ``theta`` is positive with the hip downhill of the stance foot).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsw.hybrid import load

# [G98code], gam = 0.009, "to 1e-10"; in [G98]'s signs (theta1, theta1dot).
GARCIA_LONG = (0.20031090049483, -0.19983247291764)
GARCIA_SHORT = (0.19393736960624, -0.20386692731962)
GARCIA_LONG_EIGENVALUES = (complex(-0.19120868949940, 0.55633363687106),
                           complex(-0.19120868949940, -0.55633363687106))  # fmt: skip
GARCIA_SHORT_EIGENVALUES = (4.000, 0.459)


@pytest.fixture(scope="module")
def walker():
    return load("simplest_walker")


@pytest.fixture(scope="module")
def gaits_0009(walker):
    orbits = walker.fixed_points(walker.parameters({"gamma": 0.009}))
    assert len(orbits) == 2, [o.state for o in orbits]
    short, long = sorted(orbits, key=lambda o: o.state["theta_dot"], reverse=True)
    return short, long


def _jacobian_by_differences(m, params, x, h: float, central: bool = True) -> np.ndarray:
    """The simulated Poincaré map's Jacobian by finite differences of whole steps."""
    base = None if central else m.step(params, x).state
    jac = np.zeros((len(x), len(x)))
    for k in range(len(x)):
        e = np.zeros(len(x))
        e[k] = h
        if central:
            jac[:, k] = (m.step(params, x + e).state - m.step(params, x - e).state) / (2 * h)
        else:
            jac[:, k] = (m.step(params, x + e).state - base) / h
    return jac


def test_both_gaits_at_gamma_0009_are_garcias(gaits_0009):
    """[G98code]'s two gaits to 5e-10: their comment says "to 1e-10" (their integrator's
    tolerance); ours are converged to 1e-13 (the boundary-value residual) and the
    differences measured are 4.6e-11 to 2.0e-10."""
    for orbit, (theta, theta_dot) in zip(gaits_0009, (GARCIA_SHORT, GARCIA_LONG)):
        s = orbit.state
        assert -s["theta"] == pytest.approx(theta, abs=5e-10)
        assert -s["theta_dot"] == pytest.approx(theta_dot, abs=5e-10)
        # Heelstrike leaves the legs symmetric and the swing leg with the rate
        # [G98code] starts it with: (1 - cos(2 theta)) times the stance leg's.
        assert s["phi"] == pytest.approx(2 * s["theta"], abs=1e-12)
        assert s["phi_dot"] == pytest.approx((1 - math.cos(s["phi"])) * s["theta_dot"], rel=1e-10)
    short, long = gaits_0009
    assert long.stable and not short.stable  # [G98]: one of the two is stable
    assert long.period > short.period  # the "long-period" and "short-period" gaits


def test_eigenvalues_are_the_simulated_maps_and_garcias_are_off_by_1e_3(walker, gaits_0009):
    """The engine's eigenvalues (CasADi sensitivities through CVODES) equal those of
    central differences of the simulated map (DOP853, event location, step 1e-6) to 1e-6,
    and one-sided differences converge to them at O(h) (steps 1e-3 to 1e-5). [G98code]'s
    lie 1e-3 beyond ours, on the other side from where one-sided differences come from
    (-0.19121 + 0.55633i against our -0.19010 + 0.55760i; 4.000 against 4.0039): our
    converged values stand; the source's error is of that size and its cause unknown."""
    params = walker.parameters({"gamma": 0.009})
    for orbit, published in zip(gaits_0009, (GARCIA_SHORT_EIGENVALUES, GARCIA_LONG_EIGENVALUES)):
        x = np.array(list(orbit.state.values()))
        ours = np.array(orbit.eigenvalues)
        central = np.linalg.eigvals(_jacobian_by_differences(walker, params, x, 1e-6))
        leading = sorted(central, key=lambda v: -abs(v))[:2]
        np.testing.assert_allclose(sorted(ours[:2], key=lambda v: v.imag),
                                   sorted(leading, key=lambda v: v.imag), atol=1e-6)  # fmt: skip
        gaps = []
        for h in (1e-3, 1e-4, 1e-5):
            forward = np.linalg.eigvals(_jacobian_by_differences(walker, params, x, h, False))
            forward = sorted(forward, key=lambda v: -abs(v))[:2]
            gaps.append(max(abs(abs(a) - abs(b)) for a, b in zip(forward, ours[:2])))
        assert gaps[0] > 5 * gaps[1] > 25 * gaps[2]  # O(h) convergence to ours
        # The two nonzero eigenvalues; the section's constraints (phi = 2 theta, the swing
        # rate set by the impact) give the other two as zeros.
        assert np.all(np.abs(ours[2:]) < 1e-9)
        published = np.array(published, dtype=complex)
        gap = np.max(np.abs(np.sort_complex(ours[:2]) - np.sort_complex(published)))
        assert 5e-4 < gap < 5e-3, gap


def test_the_long_gait_loses_stability_at_0015(walker):
    """[G98]: stable for 0 < gamma < 0.015 (two digits). Continued from 0.009 and bisected
    on max |eigenvalue| = 1."""

    def largest(gamma: float, guess) -> tuple[float, object]:
        params = walker.parameters({"gamma": gamma})
        orbit = walker.periodic_orbit(params, np.array(list(guess.state.values())),
                                      guess.durations)  # fmt: skip
        return orbit.max_abs_eigenvalue, orbit

    orbit = max(walker.fixed_points(walker.parameters({"gamma": 0.009})), key=lambda o: o.period)
    for gamma in np.linspace(0.009, 0.0145, 12)[1:]:
        value, orbit = largest(float(gamma), orbit)
    assert value < 1.0
    low, high, guess = 0.0145, 0.0160, orbit
    value, _ = largest(high, guess)
    assert value > 1.0
    while high - low > 1e-5:
        mid = 0.5 * (low + high)
        value, candidate = largest(mid, guess)
        if value < 1.0:
            low, guess = mid, candidate
        else:
            high = mid
    assert round(low, 3) == 0.015, low


def test_step_angle_scales_with_the_cube_root_of_the_slope(walker):
    """[G98]: the stance angle is proportional to gamma^(1/3). The long gait continued down
    to gamma = 1e-7: the log-log slope tends to 1/3 and theta / gamma^(1/3) to a constant
    (ours: printed by docs/models/passive_walkers.md's numbers, checked here to converge)."""
    orbit = max(walker.fixed_points(walker.parameters({"gamma": 0.009})), key=lambda o: o.period)
    gammas = np.geomspace(0.009, 1e-7, 40)
    thetas = []
    for gamma in gammas:
        params = walker.parameters({"gamma": float(gamma)})
        orbit = walker.periodic_orbit(params, np.array(list(orbit.state.values())),
                                      orbit.durations)  # fmt: skip
        thetas.append(-orbit.state["theta"])
    thetas = np.array(thetas)
    slopes = np.diff(np.log(thetas)) / np.diff(np.log(gammas))
    assert abs(slopes[-1] - 1 / 3) < 2e-3, slopes[-5:]
    assert abs(slopes[-1] - 1 / 3) < abs(slopes[0] - 1 / 3) / 10
    ratio = thetas / gammas ** (1 / 3)
    # Converging: the last ratios change by less and less.
    assert abs(ratio[-1] - ratio[-2]) < abs(ratio[1] - ratio[0]) / 10


# --- the compass gait ------------------------------------------------------------------------


def test_compass_gait_at_3_degrees_is_goswamis():
    """[GTE96] (as quoted, 3 digits): step period 0.735 s, half inter-leg angle 0.271 rad."""
    m = load("compass_gait")
    params = m.parameters({"gamma": math.radians(3.0)})
    stable = [o for o in m.fixed_points(params) if o.stable]
    assert len(stable) == 1
    (orbit,) = stable
    # Ours: 0.73435 s; the quoted 0.735 is 0.07 % above (its rounding unknown).
    assert abs(orbit.period - 0.735) < 1e-3, orbit.period
    assert round(-orbit.state["theta"], 3) == 0.271
    # Symmetric at heelstrike: the legs swap at equal angles.
    assert orbit.state["psi"] == pytest.approx(-orbit.state["theta"], abs=1e-12)


def test_compass_gait_at_drakes_defaults_walks_stably():
    """Drake's CompassGaitParams (the defaults): one stable and one unstable gait."""
    m = load("compass_gait")
    orbits = m.fixed_points(m.parameters({}))
    assert sorted(o.stable for o in orbits) == [False, True]
