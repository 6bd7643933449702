"""The VSW biped whose swing leg a hip actuator catches and holds at phi0
(derive/models/vsw_biped_phi0.py): the ILE's assumption with a massive swing leg.

As ``mu -> 0`` it must be the ILE itself at ``phi0``: the fixed point (10), the eigenvalue
(19) and the energy input (20) are the paper's closed forms (generated/ile, derived
separately). The catch and the extension must keep the angular momentum about the stance
foot, computed here from the bodies' positions and velocities (complex-step derivatives
of the generated positions), not from the resets' derivation.
"""

from __future__ import annotations

import numpy as np
import pytest

import generated.ile as ile
import generated.vsw_biped_phi0 as gen
from tests.conftest import committed_gaits
from tests.fast_extension import fast_extension
from vsw.models import load

MUS = (1e-2, 1e-3, 1e-4)


@pytest.fixture(scope="module")
def model():
    return load("vsw_biped_phi0")


@pytest.fixture(scope="module")
def gait(model):
    """The one gait the search finds at the defaults (mu = 0.1)."""
    _, params, orbits = committed_gaits("vsw_biped_phi0")  # kept and confirmed: no search
    (orbit,) = orbits
    return params, orbit


def _continued(model, orbit, mus):
    out = []
    for mu in mus:
        params = model.parameters({"mu": mu})
        orbit = model.periodic_orbit(params, np.array(list(orbit.state.values())), orbit.durations)
        out.append((params, orbit))
    return out


def test_massless_legs_give_the_ile_at_phi0(model, gait):
    """The rate**2 after heelstrike tends to the ILE's q^f (10), the gait's eigenvalue to
    the ILE's (19) and the extension's input to the ILE's (20), each at O(mu) (measured at
    the defaults beta = 0.9, theta_II = 0.43, phi0 = 0.4: q 2.6e-3, 2.6e-4, 2.6e-5 relative;
    eigenvalue 3.7e-4, 3.8e-5, 3.8e-6; energy 2.1e-3, 2.1e-4, 2.1e-5: the legs' masses,
    2 mu m_H, rise with the hip)."""
    beta, theta_II, phi0 = model.parameters({})[:3]  # the defaults
    q_ile = float(ile.q_fixed(beta, theta_II, phi0))
    eigenvalue = float(ile.eigenvalue(beta, phi0))
    energy_ile = float(ile.energy_complement(beta, theta_II, phi0, q_ile, 1.0, 1.0, 1.0))
    errors = []
    for params, orbit in _continued(model, gait[1], MUS):
        assert orbit.state["theta"] == pytest.approx(float(ile.theta_I(beta, phi0)), abs=1e-12)
        added = next(e for e in model.step_events(params, np.array(list(orbit.state.values())))
                     if e.name == "extension").energy_change  # fmt: skip
        errors.append((abs(orbit.state["theta_dot"] ** 2 - q_ile) / q_ile,
                       abs(orbit.max_abs_eigenvalue - eigenvalue),
                       abs(added - energy_ile) / energy_ile))  # fmt: skip
    errors = np.array(errors)
    assert np.all(errors[-1] < 3e-4), errors
    slopes = np.diff(np.log(errors), axis=0) / np.diff(np.log(MUS))[:, None]
    assert np.all(np.abs(slopes - 1.0) < 0.02), slopes


def _angular_momentum(phase: str, params, state: np.ndarray) -> float:
    """About the stance foot, from the bodies' positions and their complex-step rates."""
    positions = getattr(gen, f"{phase}_positions")
    inertias = np.array(getattr(gen, f"{phase}_inertias")(*params, *state), float)
    n = len(state) // 2
    h = 1e-30
    moved = state.astype(complex)
    moved[:n] += 1j * h * state[n:]  # a displacement along the rates
    values = np.array(positions(*params, *moved), complex).reshape(-1, 3)
    xy = values[:, :2].real
    velocity = values[:, :2].imag / h
    masses = inertias.reshape(-1, 2)[:, 0]
    return float(np.sum(masses * (xy[:, 0] * velocity[:, 1] - xy[:, 1] * velocity[:, 0])))


def test_catch_and_extension_keep_the_angular_momentum_about_the_foot(model, gait):
    """The hip's impulse at the catch is internal and the leg's at the extension passes
    through the stance foot: the walker's angular momentum about the foot is the same on
    both sides of each (1e-12), while the energy changes (the catch dissipates, the
    extension adds); over the step the extension adds what the catch and heelstrike take
    (1e-9)."""
    params, orbit = gait
    events = {e.name: e for e in model.step_events(params, np.array(list(orbit.state.values())))}
    for name, before, after in (("catch", "swing", "caught_short"),
                                ("extension", "caught_short", "caught_long")):  # fmt: skip
        e = events[name]
        h_before = _angular_momentum(before, params, e.state_before)
        h_after = _angular_momentum(after, params, e.state_after)
        assert h_after == pytest.approx(h_before, abs=1e-12)
    assert events["catch"].energy_change < 0 < events["extension"].energy_change
    lost = -events["catch"].energy_change - events["heelstrike"].energy_change
    assert events["extension"].energy_change == pytest.approx(lost, rel=1e-9)


EPS = (1e-3, 1e-4, 1e-5)


def test_the_extension_is_the_limit_of_a_fast_one_with_the_hip_held(model, gait):
    """The model's instantaneous extension (``Jump(limit=True)``) against a fast one
    integrated from the state before it, with equations written in the tests
    (tests/fast_extension.py, the hip locked):
    the error falls as eps (theta 7.6e-4, 7.6e-5, 7.6e-6 at eps = 1e-3, 1e-4, 1e-5 on the
    default gait: the walker's own motion in that time), and the Richardson extrapolation
    of the last two is the reset's state to 2e-10 (theta) and 3.6e-10 (theta'). The walker
    turns by 1.83e-4 rad through the extension: the leg's push drags the swing leg's mass,
    which is off the stance leg's line, about the foot. An extension that kept theta
    (``Jump()``, this model's rule before) is off the limit by that turn."""
    params, orbit = gait
    (extension,) = (e for e in model.step_events(params, np.array(list(orbit.state.values())))
                    if e.name == "extension")  # fmt: skip
    theta, _, theta_dot, _ = extension.state_before  # the hip held: phi = phi0, phi' = 0
    after = extension.state_after[[0, 2]]
    beta, _, phi0, mu, b = params
    # In the swing leg's own angle psi = theta - phi0, turning with the stance leg.
    start = (theta, theta - phi0, theta_dot, theta_dot)
    ends = np.array([fast_extension(beta, mu, b, start, eps)[:2] for eps in EPS])
    errors = np.abs(ends - after)
    limit = (10 * ends[-1] - ends[-2]) / 9  # Richardson: the O(eps) terms cancel
    turn = after[0] - theta
    assert np.all(np.abs(errors[:-1] / errors[1:] - 10) < 0.1), errors
    assert np.all(np.abs(limit - after) < 1e-8), limit - after
    assert 1e-4 < abs(turn) < 3e-4
