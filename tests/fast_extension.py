"""A fast extension of the VSW bipeds, integrated from equations written here (not the
engine's): what the instantaneous extension rules are checked against as its time eps
goes to zero (tests/test_vsw_biped.py, tests/test_vsw_biped_phi0.py)."""

from __future__ import annotations

import functools

import sympy as sm
from scipy.integrate import solve_ivp


@functools.cache
def _equations():
    """The biped through a fast extension with a hip servo, from a Lagrangian written here
    (not the engine's): coordinates theta, the hip's angle phi = theta - psi and the stance
    leg's length r; hip at r (sin theta, cos theta), each leg's mass b below the hip along
    its leg; masses 1, mu, mu; g = 1. With r(t) and phi(t) prescribed, theta's equation has
    no generalised force (the leg's force acts on r, the hip's torque on phi), and the hip
    torque is phi's generalised force. Returns (theta'', hip torque) as functions of
    (theta, phi, r, theta', phi', r', r'', mu, b) with phi'' = 0."""
    t = sm.Symbol("t")
    mu, b = sm.symbols("mu b", positive=True)
    theta, phi, r = (sm.Function(n)(t) for n in ("theta", "phi", "r"))
    unit = lambda a: sm.Matrix([sm.sin(a), sm.cos(a)])  # noqa: E731
    bodies = ((1, r * unit(theta)), (mu, (r - b) * unit(theta)),
              (mu, r * unit(theta) - b * unit(theta - phi)))  # fmt: skip
    lagrangian = sum(m * (x.diff(t).dot(x.diff(t)) / 2 - x[1]) for m, x in bodies)
    force = [lagrangian.diff(q.diff(t)).diff(t) - lagrangian.diff(q) for q in (theta, phi)]
    symbols = sm.symbols("theta phi r theta_d phi_d r_d theta_dd phi_dd r_dd")
    plain = {q.diff(t, 2): s_dd for q, s_dd in zip((theta, phi, r), symbols[6:])}
    plain |= {q.diff(t): s_d for q, s_d in zip((theta, phi, r), symbols[3:6])}
    plain |= dict(zip((theta, phi, r), symbols[:3]))
    force = [f.subs(plain).subs(symbols[7], 0) for f in force]
    (acceleration,) = sm.solve(force[0], symbols[6])
    args = (*symbols[:6], symbols[8], mu, b)
    return (sm.lambdify(args, acceleration),
            sm.lambdify((*args, symbols[6]), force[1]))  # fmt: skip


def fast_extension(beta: float, mu: float, b: float, state, eps: float) -> tuple[float, ...]:
    """From ``state`` (theta, psi, theta', psi') the stance leg extends from beta to 1 along
    the quintic smoothstep in a time ``eps`` while a stiff hip servo keeps the hip's angle
    on its course (its rate constant; zero: the hip locked, as the caught biped's). Returns
    theta and theta' at the end and the hip's work."""
    accelerate, torque = _equations()
    theta, psi, theta_dot, psi_dot = state
    phi, phi_dot = theta - psi, theta_dot - psi_dot

    def length(t):
        u = min(max(t / eps, 0.0), 1.0)
        return (beta + (1 - beta) * u**3 * (10 - 15 * u + 6 * u**2),
                (1 - beta) * 30 * u**2 * (1 - u) ** 2 / eps,
                (1 - beta) * 60 * u * (1 - u) * (1 - 2 * u) / eps**2)  # fmt: skip

    def rates(t, y):
        r, r_dot, r_ddot = length(t)
        args = (y[0], phi + phi_dot * t, r, y[1], phi_dot, r_dot, r_ddot, mu, b)
        theta_ddot = accelerate(*args)
        return [y[1], theta_ddot, torque(*args, theta_ddot) * phi_dot]

    end = solve_ivp(rates, (0.0, eps), [theta, theta_dot, 0.0], method="DOP853",
                    rtol=1e-12, atol=1e-14).y[:, -1]  # fmt: skip
    return float(end[0]), float(end[1]), float(end[2])
