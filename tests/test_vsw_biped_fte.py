"""The VSW biped with a finite-time extension and a free hip (derive/models/vsw_biped_fte.py).

Two checks the derivation does not contain: as ``mu -> 0`` the gait is the TLE's, whose
stride map is a closed form of a separate derivation (derive/models/tle.py); and what the
free hip does to the extension as ``delta -> 0``, integrated here with SciPy from the state
at which the held-hip biped (derive/models/vsw_biped.py) extends, measured against
asymptotic laws rather than against the model's own numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import generated.tle as tle
import generated.vsw_biped_fte as fte
from vsw.models import load

MUS = (1e-2, 1e-3, 1e-4)


@pytest.fixture(scope="module")
def model():
    return load("vsw_biped_fte")


def test_massless_legs_give_the_tle_fixed_point_at_the_emergent_angle(model):
    """As mu -> 0 the legs stop acting on the hip (the swing leg still swings, and sets
    the inter-leg angle phi at heelstrike): the rate**2 after heelstrike tends to the TLE's
    closed-form fixed point at phi0 = phi, at O(mu) (measured 1.2e-2, 1.2e-3, 1.2e-4 on the
    least unstable gait at (0.93, -0.1), delta = 0.1), and
    the section angle is the TLE's (the ILE's (11)) at phi."""
    beta, theta_II, delta = 0.93, -0.1, 0.1
    params = model.parameters({"beta": beta, "theta_II": theta_II, "mu": MUS[0], "delta": delta})
    orbit = min(model.fixed_points(params), key=lambda o: o.max_abs_eigenvalue)
    errors = []
    for mu in MUS:
        params = model.parameters({"beta": beta, "theta_II": theta_II, "mu": mu, "delta": delta})
        orbit = model.periodic_orbit(params, np.array(list(orbit.state.values())), orbit.durations)
        s = orbit.state
        phi = s["psi"] - s["theta"]  # the legs swapped at heelstrike
        q_tle = float(tle.q_fixed(beta, theta_II, phi, delta))
        errors.append(abs(s["theta_dot"] ** 2 - q_tle) / q_tle)
        assert s["theta"] == pytest.approx(float(tle.theta_I(beta, phi)), abs=1e-12)
    slopes = np.diff(np.log(errors)) / np.diff(np.log(MUS))
    assert errors[-1] < 2e-4, errors
    assert np.all(np.abs(slopes - 1.0) < 0.02), (errors, slopes)


def _extension(delta: float, state: np.ndarray, values: dict) -> dict:
    """The extension phase alone, from ``state`` at theta_II to theta_II + delta."""
    p = (values["beta"], values["theta_II"], values["mu"], 0.3, delta)

    def rhs(_t, x):
        return np.r_[x[2:], fte.extension_accelerations(*p, *x)]

    def ends(_t, x):
        return x[0] - values["theta_II"] - delta

    ends.terminal, ends.direction = True, 1
    sol = solve_ivp(rhs, (0, 1), state, method="DOP853", rtol=1e-12, atol=1e-12, events=ends,
                    dense_output=True)  # fmt: skip
    end = sol.y_events[0][0]
    t = np.linspace(0, sol.t_events[0][0], 4001)
    normal = fte.extension_normal_force(*p, *sol.sol(t))
    return {
        "duration": sol.t_events[0][0],
        "end": end,
        "added": fte.extension_energy(*p, *end) - fte.extension_energy(*p, *state),
        "least_normal_force": float(np.min(normal)),
    }


def test_a_free_hip_extension_has_no_instantaneous_limit_along_the_stance_angle():
    """From the state at which the held-hip biped extends (its stable gait at (0.97, -0.2),
    mu = 0.3), the free-hip extension over delta = 4e-4 and 2e-4 rad of stance angle:
    the hip's outward push moves it across the swing leg, whose mass then pulls on the
    stance leg's rotation, so the stance leg stalls and the extension takes a finite time
    (0.0103 and 0.0098 sqrt(l/g), tending to about 0.0092 linearly in delta), not a time
    that vanishes with delta; the swing leg turns by a finite angle (-0.0598, -0.0597 rad)
    where the held-hip rule keeps it; and to start the push the foot must be held down by
    a pull that grows as 1/delta**2 (least normal force -1.8e5 and -7.0e5 m_H g)."""
    biped = load("vsw_biped")
    values = {"beta": 0.97, "theta_II": -0.2, "mu": 0.3}
    params = biped.parameters(values)
    orbit = min(biped.fixed_points(params), key=lambda o: o.max_abs_eigenvalue)
    events = biped.step_events(params, np.array(list(orbit.state.values())))
    held = next(e for e in events if e.name == "extension")
    coarse, fine = (_extension(d, held.state_before, values) for d in (4e-4, 2e-4))
    # Finite duration: halving delta shortens it by a twentieth, not by half.
    assert 0.009 < fine["duration"] < coarse["duration"] < 0.011
    assert coarse["duration"] - fine["duration"] < 0.06 * fine["duration"]
    # The swing leg turns (held hip: not at all) by an angle that settles.
    turn = [r["end"][1] - held.state_before[1] for r in (coarse, fine)]
    assert turn[1] == pytest.approx(-0.0597, abs=5e-4)
    assert abs(turn[0] - turn[1]) < 2e-4
    # The push's start: the foot's normal force as 1/delta**2 (slope -2 in log-log).
    ratio = coarse["least_normal_force"] / fine["least_normal_force"]
    assert fine["least_normal_force"] < -1e5
    assert ratio == pytest.approx(0.25, rel=0.03)
    # The stance leg barely turns while it extends: its mean rate is delta / duration.
    assert 2e-4 / fine["duration"] < 0.03 < held.state_before[2]
