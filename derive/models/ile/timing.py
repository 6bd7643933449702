"""The ILE's step timing: the step length and the durations of the two phases, the time
integral of ``dtheta / omega`` with ``omega`` from the energy integrals of eq. (2), (4) in
Carlson form (:mod:`derive.elliptic`); beyond the paper."""

from __future__ import annotations

import functools

import sympy as sm

from derive.elliptic import pendulum_travel_time
from derive.models.ile.model import beta, q, theta_I, theta_II
from derive.models.ile.phases import eliminate_contact_angles, heelstrike, phase_energy
from derive.models.ile.stride_map import stride


@functools.cache
def step_timing() -> dict[str, sm.Expr]:
    """Step length, phase durations and period (beyond the paper): the phases of eq. (2),
    (4) between theta_I (11), theta_II and theta_IV (5).

    The period is the time integral of ``dtheta / omega`` over both phases, with
    ``omega`` from each phase's energy integral, in Carlson form (:mod:`derive.elliptic`).
    """
    hs = heelstrike()
    st = stride()
    # The foot distance without the cancellation of 1 + beta**2 - 2 beta cos phi0.
    step_length = sm.sqrt(hs["step_length_squared_short"])

    def level(ratio, theta_at, omega_sq_at):
        return eliminate_contact_angles(
            sm.expand(phase_energy(theta_at, omega_sq_at, ratio) / ratio)
        )

    end_I = (hs["sin_theta_I"], hs["cos_theta_I"])
    end_II = (sm.sin(theta_II), sm.cos(theta_II))
    end_IV = (hs["sin_theta_IV"], hs["cos_theta_IV"])
    duration_1 = pendulum_travel_time(end_I, end_II, level(beta, theta_I, q), beta)
    duration_2 = pendulum_travel_time(
        end_II, end_IV, level(1, theta_II, st["omega_III_squared"]), sm.Integer(1)
    )
    return {
        "step_length": step_length,
        "duration_I_II": duration_1,
        "duration_III_IV": duration_2,
    }
