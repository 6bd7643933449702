"""A design's result (:class:`DesignResult`) and what it says: the active constraints,
the simulation check, the constraints in conflict, and the message of a not-attained
optimum."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from vsw.models.ile.design.forms import ACTIVE_TOL, STRICT_MARGIN, TABLE_DISTANCE, numpy_quantities
from vsw.models.ile.design.limit import Limit
from vsw.models.ile.design.nlp import Solve, multistart, scan_box, shifted_bounds
from vsw.models.ile.design.problem import Problem


@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`design`.

    Attributes
    ----------
    status : {'optimal', 'not-attained', 'infeasible', 'not-converged'}
        'optimal': IPOPT converged and the closed forms confirm every constraint; a local
        optimum, the best over the regions and starts, inside every open limit.
        'not-attained': the best design presses against an open limit (see ``limit``).
    beta, theta_II, phi0 : float or None
        The design (radians); None unless a design was found.
    analysis : vsw.models.ile.analysis.Analysis or None
        All outputs of ``vsw analyze`` at the design.
    objective : float or None
        The minimised weighted sum (speed enters with a minus sign).
    cost_of_transport, step_frequency : float or None
        E_c / (m g L) (L the step length) and 1 / step period at the design.
    active_constraints : tuple of str
        Constraints at their bound (targets always).
    open_boundary : tuple of str
        Open limits the optimum presses against (strict conditions, open parameter
        limits); the design keeps STRICT_MARGIN (conditions) and TABLE_DISTANCE (parameter
        limits) away from them.
    limit : Limit or None
        For 'not-attained': the limiting objective value and the path towards it.
    simulation_rel_error : float or None
        Largest relative difference of q^f, step period, step length and speed between the
        closed form and the time-domain simulation started at q^f.
    conflicting_constraints : tuple of str
        When infeasible: user constraints whose removal alone restores feasibility.
    message : str
        One line saying what happened.
    ipopt_status : str
        Return status of the IPOPT solve behind the result.
    starts : int
        Number of IPOPT solves.
    conditions : {'exact', 'paper'}
        The set of existence conditions imposed.
    region : str or None
        The region of the design (where the apex is crossed).
    """

    status: str
    beta: float | None = None
    theta_II: float | None = None
    phi0: float | None = None
    analysis: Any = None
    objective: float | None = None
    cost_of_transport: float | None = None
    step_frequency: float | None = None
    active_constraints: tuple[str, ...] = ()
    open_boundary: tuple[str, ...] = ()
    limit: Limit | None = None
    simulation_rel_error: float | None = None
    conflicting_constraints: tuple[str, ...] = ()
    message: str = ""
    ipopt_status: str = ""
    starts: int = 0
    conditions: str = "exact"
    region: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON contract of ``vsw design --json``: the analysis keys plus the design's."""
        from vsw.models.ile.analysis import FIELDS

        out: dict[str, Any] = {"status": self.status}
        if self.analysis is not None:
            out.update(self.analysis.to_dict())
        else:
            out.update({"beta": None, "theta_II": None, "phi0": None})
            out.update({name: None for name in FIELDS})
            out["conditions"] = []
            out["energy_unit"] = "m g r_e"
        out["status"] = self.status
        if self.analysis is not None and self.analysis.scale is not None:
            out["step_frequency_hz"] = 1.0 / float(self.analysis.step_period_s)
        out.update(
            {
                "condition_set": self.conditions,
                "objective": self.objective,
                "cost_of_transport": self.cost_of_transport,
                "step_frequency": self.step_frequency,
                "active_constraints": list(self.active_constraints),
                "open_boundary": list(self.open_boundary),
                "limit": None if self.limit is None else self.limit.to_dict(),
                "region": self.region,
                "simulation_rel_error": self.simulation_rel_error,
                "conflicting_constraints": list(self.conflicting_constraints),
                "message": self.message,
                "ipopt_status": self.ipopt_status,
                "starts": self.starts,
            }
        )
        return out


def active_rows(problem: Problem, s: Solve) -> list[str]:
    """Names of the constraints at their bound at a solution."""
    qs = numpy_quantities(s.x[None, :])
    active: list[str] = []
    for (i, side), name in sorted(problem.bound_names.items()):
        bound = problem.lbx[i] if side == 0 else problem.ubx[i]  # the user's own
        if name.startswith("fix_"):
            if side == 0:
                active.append(name)
        elif abs(s.x[i] - bound) <= ACTIVE_TOL * max(1.0, abs(bound)):
            active.append(name)
    for c in problem.region_constraints(s.region):
        if c.name == "region":
            continue
        v = float(qs[c.quantity][0])
        for bound in shifted_bounds(c, s.distance):
            near = abs(v - bound) <= ACTIVE_TOL * max(1.0, abs(bound)) + 1e-12
            if math.isfinite(bound) and near and c.name not in active:
                active.append(c.name)
    return active


def simulation_check(analysis: Any) -> float:
    """Relative error of the closed forms against the time-domain simulation at q^f.

    The largest relative difference of q^f (after each of two simulated steps), the step
    period, the step length and the speed; ``inf`` when the simulation does not complete
    the two steps.
    """
    from vsw.models.ile.simulate import simulate

    beta, theta_II, phi0 = (float(v) for v in (analysis.beta, analysis.theta_II, analysis.phi0))
    q_fixed = float(analysis.q_fixed)
    sim = simulate(beta, theta_II, phi0, q_fixed, 2, record=False)
    if sim.ended != "completed":
        return math.inf
    errors = [abs(q - q_fixed) / q_fixed for q in sim.q[1:]]
    for closed, simulated in (
        (float(analysis.step_period), sim.step_periods),
        (float(analysis.step_length), sim.step_lengths),
        (float(analysis.speed), sim.step_lengths / sim.step_periods),
    ):
        errors.extend(abs(s - closed) / abs(closed) for s in simulated)
    return float(max(errors))


def conflicts_of(problem: Problem, per_region: int) -> list[str]:
    """User constraints whose removal alone makes the request feasible."""
    conflicting = []
    for key in problem.user_constraints():
        relaxed = problem.without(key)
        # A scanned point that satisfies everything settles it without a solve.
        scan = scan_box(relaxed)
        if scan.feasible().any() or multistart(relaxed, 1, scan, probe=True)[0] is not None:
            conflicting.append(key)
    return conflicting


def _describe_objective(problem: Problem) -> tuple[str, str]:
    """('supremum' or 'infimum', what) of the request's objective."""
    terms = [t for t, w in problem.weights.items() if w]
    if terms == ["speed"]:
        return "supremum", "speed"
    if len(terms) == 1:
        return "infimum", terms[0].replace("_", " ")
    return "infimum", "weighted objective"


def not_attained_message(problem: Problem, limit: Limit, s: Solve) -> str:
    """The message of a not-attained optimum: the open limits it presses against and the
    limiting value the continuation extrapolates."""
    kind, what = _describe_objective(problem)
    sign = -1.0 if kind == "supremum" else 1.0
    if limit.objective is None:
        value = "not estimated (fewer than three re-solves closer to it converged)"
    elif math.isinf(limit.objective):
        value = "unbounded"
    else:
        value = f"{sign * limit.objective:.8g} (+- {limit.uncertainty:.2g}, extrapolated)"
    last = limit.path[-1]
    return (
        f"not attained: the {kind} of the {what}, {value}, lies on the open boundary "
        f"{', '.join(limit.approached_as)}; the design keeps {TABLE_DISTANCE:g} from open "
        f"parameter limits and {STRICT_MARGIN:g} from strict conditions ({what} "
        f"{sign * s.objective:.8g}; {sign * last['objective']:.8g} at "
        f"{last['distance_scale']:g} of those distances)"
    )
