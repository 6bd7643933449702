"""Time-domain simulation evidence for the audit (thin wrappers over
:mod:`vsw.models.ile.simulate`).

Every run is deterministic (no randomness inside the integrator); sample selection is
seeded by the caller. A run that the model cannot define (the stance leg never reaches
``theta_II``, or would extend after heelstrike) is reported as ``'undefined'``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from generated import ile

__all__ = ["Run", "energy_at", "run", "step_events"]

RTOL = 1e-10
ATOL = 1e-12


@dataclass(frozen=True)
class Run:
    """Outcome of one simulation.

    Attributes
    ----------
    ended : {'completed', 'fell-backward', 'lift-off', 'undefined'}
    q : numpy.ndarray
        q just after each heelstrike, starting with q0.
    events : list of tuple
        ``(name, t, theta, omega)`` for the instants I, II, III, IV of every step.
    """

    ended: str
    q: np.ndarray
    events: list


def run(beta: float, theta_II: float, phi0: float, q0: float, steps: int) -> Run:
    """Simulate ``steps`` steps from ``q0`` (``q = omega_I**2``) with the hybrid simulator.

    Returns
    -------
    Run
        ``ended='undefined'`` when :func:`vsw.models.ile.simulate.simulate` refuses the parameters
        (``theta_II`` outside ``(theta_I, theta_IV)``).
    """
    from vsw.models.ile.simulate import simulate
    from vsw.runtime.errors import VswInputError

    try:
        res = simulate(
            float(beta),
            float(theta_II),
            float(phi0),
            float(q0),
            int(steps),
            rtol=RTOL,
            atol=ATOL,
            record=False,
        )
    except VswInputError:
        return Run("undefined", np.array([q0]), [])
    return Run(res.ended, np.asarray(res.q, float), list(res.events))


def step_events(events: list, step: int) -> dict[str, tuple[float, float]]:
    """``{'I': (theta, omega), 'II': ..., 'III': ..., 'IV': ..., 'I+': ...}`` of one step."""
    starts = [i for i, e in enumerate(events) if e[0] == "I"]
    i0 = starts[step]
    out = {}
    for name, _t, theta, omega in events[i0 : i0 + 4]:
        out[name] = (theta, omega)
    nxt = events[i0 + 4]
    out["I+"] = (nxt[2], nxt[3])
    return out


def energy_at(theta: float, omega: float, leg_ratio: float) -> float:
    """Mechanical energy (units m g r_e) of the hip on a leg of length ``leg_ratio r_e``."""
    return float(ile.phase_energy(theta, omega, leg_ratio))


def converged(result: Run, q_fixed: float, tol: float = 1e-6) -> bool:
    """Whether a completed run ends within ``tol`` (relative) of ``q_fixed``."""
    if result.ended != "completed" or not math.isfinite(q_fixed):
        return False
    return abs(float(result.q[-1]) - q_fixed) <= tol * (1.0 + abs(q_fixed))
