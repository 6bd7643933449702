"""Benchmark of gait design: CasADi/IPOPT on the closed forms vs SciPy SLSQP on simulation.

The problem (both sides): the most stable Stepper-2D gait (least eigenvalue) at 0.8 m/s,
with 0.6 <= beta <= 0.95, -20 <= theta_II <= 20 deg, 20 <= phi0 <= 60 deg and the stance
foot on the ground over the whole step.

* IPOPT side: :func:`vsw.models.ile.design.design` as a whole (its scan, one IPOPT start
  in each region the scan finds promising) without the simulation check, timed after
  a warm-up call that builds (and caches) the CasADi solver.
* SLSQP side: what a researcher would write without the closed forms. Every evaluation
  finds the fixed point with
  :func:`vsw.models.ile.simulate.fixed_point_by_simulation`, the eigenvalue as a central
  difference of :func:`vsw.models.ile.simulate.poincare_map`, and speed and the minimum
  normal force from one simulated step; SLSQP differentiates all of it by finite
  differences. Same start point as the IPOPT side.

``compare()`` returns numbers only; case 6 of ``benchmarks/run.py`` formats them
(benchmarks/cases/design.py).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from generated import ile  # noqa: E402
from vsw.models.ile.params import STEPPER_2D  # noqa: E402

TARGET_SPEED_M_S = 0.8
BOUNDS = {
    "beta": (0.6, 0.95),
    "theta_II": (math.radians(-20), math.radians(20)),
    "phi0": (math.radians(20), math.radians(60)),
}


def _ipopt_design(n_starts: int | None = 1, verify: bool = False) -> Any:
    """The design; ``n_starts=None``: as ``vsw design`` runs it (its default starts)."""
    from vsw.models.ile.design import design

    starts = {} if n_starts is None else {"n_starts": n_starts}
    return design(
        targets={"speed_m_s": TARGET_SPEED_M_S},
        bounds=BOUNDS,
        scale=STEPPER_2D,
        verify=verify,
        **starts,
    )


def _start_point() -> np.ndarray:
    """The SLSQP side's start: the design's first IPOPT start (its scan's best seed)."""
    from vsw.models.ile.design.nlp import _seeds
    from vsw.models.ile.design.nlp import scan_box as _scan
    from vsw.models.ile.design.problem import build_problem as _build_problem

    problem = _build_problem(
        {"eigenvalue": 1.0}, {"speed_m_s": TARGET_SPEED_M_S}, BOUNDS, None, 0.0, None,
        STEPPER_2D,
    )  # fmt: skip
    return _seeds(problem, _scan(problem), 1)[0][1]


class _SimulatedGait:
    """Gait quantities from the time-domain simulation only, cached per design."""

    def __init__(self) -> None:
        self.cache: dict[tuple[float, ...], dict[str, float]] = {}
        self.evaluations = 0

    def __call__(self, x: np.ndarray) -> dict[str, float]:
        from vsw.models.ile.simulate import fixed_point_by_simulation, poincare_map, simulate
        from vsw.runtime.errors import ConvergenceError, VswInputError

        key = tuple(float(v) for v in x)
        if key in self.cache:
            return self.cache[key]
        self.evaluations += 1
        beta, theta_II, phi0 = key
        # A design outside the walking region gets large finite values so SLSQP backs off.
        failed = {"eigenvalue": 1.0, "speed": 0.0, "contact": -1.0}
        try:
            q = fixed_point_by_simulation(beta, theta_II, phi0)
            h = 1e-4 * q
            slope = (poincare_map(beta, theta_II, phi0, q + h)
                     - poincare_map(beta, theta_II, phi0, q - h)) / (2 * h)  # fmt: skip
            sim = simulate(beta, theta_II, phi0, q, 1)
        except (ConvergenceError, VswInputError):
            self.cache[key] = failed
            return failed
        if sim.ended != "completed" or not math.isfinite(slope):
            self.cache[key] = failed
            return failed
        legs = np.where(sim.phase == 1, beta, 1.0)
        normal = ile.normal_force(sim.theta, sim.omega, legs)
        out = {
            "eigenvalue": float(slope),
            "speed": float(sim.step_lengths[0] / sim.step_periods[0]),
            "contact": float(np.min(normal)),
        }
        self.cache[key] = out
        return out


def slsqp_design(x0: np.ndarray, maxiter: int = 50) -> dict[str, Any]:
    """The same design problem with SciPy SLSQP on the simulated stride map.

    Returns
    -------
    dict
        ``x`` (beta, theta_II, phi0), ``success``, ``message``, ``evaluations`` (distinct
        designs simulated), ``objective`` (closed-form eigenvalue at ``x``) and
        ``speed_rel_error`` (closed-form speed against the target).
    """
    from scipy.optimize import minimize

    gait = _SimulatedGait()
    target = TARGET_SPEED_M_S / math.sqrt(STEPPER_2D.gravity * STEPPER_2D.leg_length)
    constraints = [
        {"type": "eq", "fun": lambda x: gait(x)["speed"] / target - 1.0},
        {"type": "ineq", "fun": lambda x: gait(x)["contact"]},
    ]
    res = minimize(
        lambda x: gait(x)["eigenvalue"],
        x0,
        method="SLSQP",
        bounds=[BOUNDS[n] for n in ("beta", "theta_II", "phi0")],
        constraints=constraints,
        # Finite-difference step well above the simulation's noise (tolerances 1e-12, a
        # central-difference eigenvalue with step 1e-4 q: noise about 1e-8).
        options={"maxiter": maxiter, "ftol": 1e-10, "eps": 1e-5},
    )
    from vsw.models.ile.analysis import analyze

    a = analyze(*res.x, STEPPER_2D)
    return {
        "x": [float(v) for v in res.x],
        "success": bool(res.success),
        "message": str(res.message),
        "evaluations": gait.evaluations,
        "objective": float(a.eigenvalue),
        "walks": bool(a.walks),
        "speed_rel_error": float(abs(a.speed_m_s / TARGET_SPEED_M_S - 1)),
    }


def _timing(samples: list[float]) -> tuple[float, float, float]:
    return (statistics.median(samples), min(samples), max(samples))


def compare(quick: bool = False) -> dict[str, Any]:
    """Time one IPOPT design solve after set-up and the SLSQP baseline, side by side.

    Parameters
    ----------
    quick : bool
        Fewer repetitions (for smoke tests; the numbers then mean little).

    Returns
    -------
    dict
        ``ipopt_seconds`` and ``slsqp_seconds`` as (median, min, max); ``full_design_seconds``
        (with the simulation check); ``setup_seconds`` (first call, builds the
        solver); ``ratio`` (SLSQP median / IPOPT median); objectives, target errors,
        ``objective_ok`` (IPOPT converged, hits the target to 1e-8 and its eigenvalue is
        no worse than that of an SLSQP point that meets the target to 1e-6) and a
        ``note``.
    """
    from vsw.models.ile.design.nlp import _SOLVERS

    _SOLVERS.clear()
    t0 = time.perf_counter()
    _ipopt_design()
    setup = time.perf_counter() - t0

    reps_ipopt = 5 if quick else 30
    reps_slsqp = 1 if quick else 3
    ipopt_times: list[float] = []
    slsqp_times: list[float] = []
    x0 = _start_point()
    ipopt = slsqp = None
    # Interleaved so that machine load affects both sides alike.
    for i in range(max(reps_ipopt, reps_slsqp)):
        if i < reps_ipopt:
            t0 = time.perf_counter()
            ipopt = _ipopt_design()
            ipopt_times.append(time.perf_counter() - t0)
        if i < reps_slsqp:
            t0 = time.perf_counter()
            slsqp = slsqp_design(x0, maxiter=3 if quick else 50)
            slsqp_times.append(time.perf_counter() - t0)
    full_times = []
    for _ in range(3 if quick else 10):
        t0 = time.perf_counter()
        full = _ipopt_design(n_starts=None, verify=True)
        full_times.append(time.perf_counter() - t0)
    assert ipopt is not None and slsqp is not None
    ipopt_error = (
        abs(float(ipopt.analysis.speed_m_s) / TARGET_SPEED_M_S - 1)
        if ipopt.status == "optimal"
        else math.inf
    )
    # An SLSQP point that misses the target or does not walk is no competitor: a lower
    # eigenvalue bought with a speed error is not a better design.
    slsqp_feasible = slsqp["walks"] and slsqp["speed_rel_error"] <= 1e-6
    objective_ok = (
        ipopt.status == "optimal"
        and ipopt_error <= 1e-8
        and (not slsqp_feasible or float(ipopt.analysis.eigenvalue) <= slsqp["objective"] + 1e-6)
    )
    ipopt_t, slsqp_t = _timing(ipopt_times), _timing(slsqp_times)
    return {
        "ipopt_seconds": ipopt_t,
        "slsqp_seconds": slsqp_t,
        "full_design_seconds": _timing(full_times),
        "setup_seconds": setup,
        "ratio": slsqp_t[0] / ipopt_t[0],
        "ipopt_status": ipopt.status,
        "ipopt_objective": None if ipopt.analysis is None else float(ipopt.analysis.eigenvalue),
        "ipopt_speed_rel_error": ipopt_error,
        "full_design_simulation_rel_error": full.simulation_rel_error,
        "slsqp": slsqp,
        "objective_ok": objective_ok,
        "note": (
            f"least eigenvalue at {TARGET_SPEED_M_S} m/s (Stepper-2D): IPOPT "
            f"{ipopt.analysis.eigenvalue if ipopt.analysis is not None else float('nan'):.6g}"
            f" (speed error {ipopt_error:.1e}), SLSQP {slsqp['objective']:.6g} (speed error "
            f"{slsqp['speed_rel_error']:.1e}, {slsqp['evaluations']} simulated designs, "
            f"{'converged' if slsqp['success'] else 'not converged: ' + slsqp['message']})"
        ),
    }


if __name__ == "__main__":
    import json

    print(json.dumps(compare(quick="--quick" in sys.argv), indent=2, default=str))
