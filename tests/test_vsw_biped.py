"""The compass-like VSW biped: its massless-leg limit is the ILE model, and its energy
restoration balances on a periodic gait.

As ``mu = m / m_H -> 0`` the legs' masses stop acting on the hip: the stance dynamics, the
extension and the heelstrike become the ILE's (the paper's eq. (3)-(6)), while the swing
leg still swings as a pendulum hung from the hip and sets the inter-leg angle ``phi`` at
heelstrike. So the biped's rate**2 just after heelstrike must tend to the ILE's closed-form
fixed point (10) evaluated at ``phi0 = phi``, and the energy its extension adds to the
ILE's (20), both at O(mu).
"""

from __future__ import annotations

import numpy as np
import pytest

import generated.ile as ile
from tests.fast_extension import fast_extension
from vsw.models import load

GAITS = ((0.8, 0.1), (0.85, 0.05))
"""(beta, theta_II) with a period-one gait for small mu (b / l = 0.3, below beta)."""
MUS = (1e-2, 3e-3, 1e-3, 3e-4, 1e-4)


@pytest.fixture(scope="module")
def biped():
    return load("vsw_biped")


def _continued(m, beta: float, theta_II: float, mus) -> list:
    """The gait at each mu, continued from the first (found by the scan) downwards."""
    params = m.parameters({"beta": beta, "theta_II": theta_II, "mu": mus[0]})
    orbits = m.fixed_points(params)
    assert orbits, (beta, theta_II)
    orbit = orbits[0]
    out = [orbit]
    for mu in mus[1:]:
        params = m.parameters({"beta": beta, "theta_II": theta_II, "mu": mu})
        orbit = m.periodic_orbit(params, np.array(list(orbit.state.values())), orbit.durations)
        out.append(orbit)
    return out


@pytest.mark.parametrize(("beta", "theta_II"), GAITS)
def test_massless_legs_give_the_ile_fixed_point_at_the_emergent_angle(biped, beta, theta_II):
    errors = []
    for orbit in _continued(biped, beta, theta_II, MUS):
        s = orbit.state
        phi = s["psi"] - s["theta"]  # the legs swapped at heelstrike
        q_ile = float(ile.q_fixed(beta, theta_II, phi))
        errors.append(abs(s["theta_dot"] ** 2 - q_ile) / q_ile)
        # The section angle is the ILE's theta_I (11) at that angle too.
        assert s["theta"] == pytest.approx(float(ile.theta_I(beta, phi)), abs=1e-12)
    errors = np.array(errors)
    rates = np.diff(np.log(errors)) / np.diff(np.log(MUS))
    assert errors[-1] < 1e-3
    # O(mu): the local log-log slopes tend to 1 (0.87, 0.96, 0.988, 0.996 measured at
    # (0.8, 0.1) from mu = 1e-2 down, the higher orders fading).
    assert abs(rates[-1] - 1.0) < 0.01, rates
    assert np.all(np.diff(np.abs(rates - 1.0)) < 0), rates


@pytest.mark.parametrize(("beta", "theta_II"), GAITS)
def test_energy_the_extension_adds_is_what_heelstrike_dissipates(biped, beta, theta_II):
    """On level ground a periodic gait restores per step exactly what heelstrike loses
    (both phases conserve T + V); as mu -> 0 the extension's input is the ILE's (20)."""
    inputs = []
    for mu, orbit in zip(MUS, _continued(biped, beta, theta_II, MUS)):
        params = biped.parameters({"beta": beta, "theta_II": theta_II, "mu": mu})
        x = np.array(list(orbit.state.values()))
        events = {e.name: e for e in biped.step_events(params, x)}
        added = events["extension"].energy_change
        dissipated = -events["heelstrike"].energy_change
        assert added > 0 and dissipated > 0
        assert added == pytest.approx(dissipated, rel=1e-9)
        phi = orbit.state["psi"] - orbit.state["theta"]
        q = orbit.state["theta_dot"] ** 2
        # The ILE's energy added at its own fixed point, per m g r_e (m = m_H here).
        ile_input = float(ile.energy_complement(beta, theta_II, phi,
                                                float(ile.q_fixed(beta, theta_II, phi)),
                                                1.0, 1.0, 1.0))  # fmt: skip
        inputs.append(abs(added - ile_input) / ile_input)
        assert q > 0
    inputs = np.array(inputs)
    assert inputs[-1] < 1e-3
    rates = np.diff(np.log(inputs)) / np.diff(np.log(MUS))
    assert abs(rates[-1] - 1.0) < 0.01, rates  # O(mu)


def test_a_stable_gait_near_beta_1_attracts_a_simulated_walk(biped):
    """The search of paper_check.walkers finds stable gaits as beta nears 1: at beta = 0.97,
    theta_II = -0.2, mu = 0.3, b / l = 0.3 the least unstable gait has max |lambda| 0.387
    (< 1), and a walk simulated from it with every rate 1 % off comes back to 1e-9 within
    60 steps (the eigenvalues' verdict checked by the time-domain simulation alone); at
    mu = 1e-4 the same branch is more stable still (0.150)."""
    values = {"beta": 0.97, "theta_II": -0.2, "mu": 0.3, "b_over_l": 0.3}
    params = biped.parameters(values)
    orbit = min(biped.fixed_points(params), key=lambda o: o.max_abs_eigenvalue)
    assert orbit.max_abs_eigenvalue == pytest.approx(0.387, abs=1e-3)
    x = np.array(list(orbit.state.values()))
    walk = biped.simulate(params, np.concatenate([x[:2], 1.01 * x[2:]]), 60)
    assert walk.ended == "completed"
    assert np.max(np.abs(walk.section[-1] - x)) < 1e-9
    for mu in (0.1, 0.01, 1e-3, 1e-4):
        params = biped.parameters({**values, "mu": mu})
        orbit = biped.periodic_orbit(params, np.array(list(orbit.state.values())),
                                     orbit.durations)  # fmt: skip
    assert orbit.max_abs_eigenvalue == pytest.approx(0.150, abs=1e-3)


def test_a_step_that_begins_past_theta_II_ends_the_walk_by_name(biped):
    """Heelstrike past the extension angle: the model has no rule for that step
    (the ILE's theta_I < theta_II), so the walk ends with ``extension-missed`` at once, in
    the SciPy route and the C batch simulator alike; 0.01 rad before theta_II the extension
    comes (the short phase lasts)."""
    from vsw.dynamics.batch import FELL, simulator

    params = biped.parameters({"beta": 0.97, "theta_II": -0.2, "mu": 0.3})
    states = []
    for theta in (-0.19, -0.21):  # past theta_II = -0.2, and before it
        psi = float(np.arccos(0.97 * np.cos(theta)))  # both feet on the ground
        states.append([theta, psi, 1.0, -1.0])
    past, before = biped.step(params, np.array(states[0])), biped.step(params, np.array(states[1]))
    assert past.ended == "extension-missed" and past.durations == (0.0,)
    assert before.ended != "extension-missed" and before.durations[0] > 0
    sim = simulator(biped)
    assert sim.library() is not None, sim.build_error
    batch = sim.step(params, np.array(states))
    assert batch.outcome[0] == FELL and batch.ended()[0] == "extension-missed"
    assert batch.ended()[1] == before.ended  # lift-off in the long phase, the same in both


def test_the_extension_missed_margin_vanishes_where_the_branch_ends(biped):
    """The stable branch at (0.97, -0.2) ends where continuation finds the short phase's
    duration reaching zero (mu = 0.36344); the failure's margin, theta_II less the stance
    angle where the step begins (a different quantity: the section state, not a duration),
    falls to zero there, linearly in the distance to it."""
    from vsw.dynamics.conditions import gait_conditions
    from vsw.gaits.continuation import Options as ContinuationOptions
    from vsw.gaits.continuation import continue_gaits

    values = {"beta": 0.97, "theta_II": -0.2}
    params = biped.parameters(values | {"mu": 0.3})
    orbit = min(biped.fixed_points(params), key=lambda o: o.max_abs_eigenvalue)
    start = np.array(list(orbit.state.values()))
    (branch,) = continue_gaits(biped, params, "mu", 0.3, 0.5, start, orbit.durations,
                               options=ContinuationOptions(switch=False))  # fmt: skip
    assert branch.ended == "boundary"
    end = branch.special_points[-1].parameter
    assert 0.3634 < end < 0.3635
    margins = []
    for gap in (2e-3, 1e-3):
        p = biped.parameters(values | {"mu": end - gap})
        gait = biped.periodic_orbit(p, start, orbit.durations)
        start = np.array(list(gait.state.values()))
        margin = {c["name"]: c["margin"] for c in gait_conditions(biped, p, gait)}
        assert margin["extension-missed"] == pytest.approx(-0.2 - gait.state["theta"], abs=1e-12)
        margins.append(margin["extension-missed"])
    assert 0 < margins[1] < margins[0] < 0.01
    assert margins[0] / margins[1] == pytest.approx(2.0, rel=0.02)


def test_the_held_hip_extension_is_no_limit_of_a_fast_one_with_a_hip_servo(biped):
    """Issue 26 (a): is the held-hip rule (theta and psi kept, both momenta conserved) the
    limit of a fast extension whose hip a stiff servo keeps on its course? Not on the
    stable gait at (0.97, -0.2), mu = 0.3: integrated from the state before the rule's
    extension (tests/fast_extension.py: its own Lagrangian) for eps = 1e-3, 1e-4, 1e-5, the
    hip servo's work grows as 1 / eps (-1.76e-3, -1.52e-2, -1.49e-1 m_H g l, against the
    0.041 the rule's extension adds: no finite limit, so the rule's work cannot be split
    into leg and hip), and the walker turns by -1.05e-3 rad (Richardson's extrapolation),
    where the rule keeps theta: the leg's push drags the swing leg's mass about the foot.
    (theta' tends to 0.34131 where the rule gives 0.34071.)"""
    params = biped.parameters({"beta": 0.97, "theta_II": -0.2, "mu": 0.3, "b_over_l": 0.3})
    orbit = min(biped.fixed_points(params), key=lambda o: o.max_abs_eigenvalue)
    (extension,) = (e for e in biped.step_events(params, np.array(list(orbit.state.values())))
                    if e.name == "extension")  # fmt: skip
    beta, _, mu, b = params
    runs = np.array([fast_extension(beta, mu, b, extension.state_before, eps)
                     for eps in (1e-3, 1e-4, 1e-5)])  # fmt: skip
    work = runs[:, 2]
    assert np.all(np.abs(work[:-1] / work[1:] - 0.1) < 0.03), work
    assert abs(work[-1]) > 3 * extension.energy_change
    theta_limit, rate_limit = (10 * runs[-1, :2] - runs[-2, :2]) / 9
    turn = theta_limit - extension.state_after[0]
    assert -1.1e-3 < turn < -1.0e-3, turn
    assert rate_limit == pytest.approx(0.34131, abs=1e-5)
    assert extension.state_after[2] == pytest.approx(0.34071, abs=1e-5)


def test_the_stable_gait_flips_as_the_legs_mass_moves_down(biped):
    """docs/models/vsw_biped.md, b / l swept: continuation locates the first flip of the
    stable gait at (0.97, -0.2), mu = 0.3, at b / l = 0.53364. Checked here without it: the
    gait followed by Newton in steps of b / l from 0.3 has its eigenvalues inside the unit
    circle 1e-3 before, and one real eigenvalue below -1 1e-3 after (the flip's)."""
    values = {"beta": 0.97, "theta_II": -0.2, "mu": 0.3}
    orbit = min(biped.fixed_points(biped.parameters(values)), key=lambda o: o.max_abs_eigenvalue)
    for b in (*np.arange(0.32, 0.53, 0.02), 0.53264, 0.53464):
        params = biped.parameters(values | {"b_over_l": b})
        start = np.array(list(orbit.state.values()))
        orbit = biped.periodic_orbit(params, start, orbit.durations)
        if b == 0.53264:
            assert orbit.max_abs_eigenvalue < 1
    eigenvalues = np.asarray(orbit.eigenvalues)
    (flip,) = eigenvalues[np.abs(eigenvalues) > 1]
    assert abs(flip.imag) < 1e-12 and -1.05 < flip.real < -1
