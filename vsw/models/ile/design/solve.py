"""The ILE's design: the problem built, solved from the scan's seeds in every region,
verified and given its status (:func:`design`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from vsw.models.ile.design.forms import IPOPT_INFEASIBLE, REGIONS, numpy_quantities
from vsw.models.ile.design.limit import continue_to_limit
from vsw.models.ile.design.nlp import multistart, verified_solve
from vsw.models.ile.design.problem import Problem, build_problem, normalise_objective
from vsw.models.ile.design.result import (
    DesignResult,
    active_rows,
    conflicts_of,
    not_attained_message,
    simulation_check,
)
from vsw.models.ile.params import RobotScale
from vsw.runtime.errors import VswInputError


def design(
    objective: str | Mapping[str, float] | None = None,
    targets: Mapping[str, float] | None = None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None = None,
    fixed: Mapping[str, float] | None = None,
    min_contact_margin: float = 0.0,
    max_eigenvalue: float | None = None,
    scale: RobotScale | None = None,
    *,
    conditions: str = "exact",
    n_starts: int = 2,
    verify: bool = True,
    explain_infeasible: bool = True,
) -> DesignResult:
    """Design gait parameters (beta, theta_II, phi0) by constrained optimisation.

    Parameters
    ----------
    objective : str or mapping, optional
        ``'speed'`` (maximise), ``'eigenvalue'`` or ``'cost_of_transport'`` (minimise), or
        weights ``{'speed': w1, 'eigenvalue': w2, 'cost_of_transport': w3}`` of the sum
        ``-w1 speed + w2 eigenvalue + w3 cost_of_transport`` that is minimised. Default:
        minimise the eigenvalue when a target is given.
    targets : mapping, optional
        Equality constraints: ``speed`` (sqrt(g r_e)), ``speed_m_s``, ``q_fixed`` (g/r_e),
        ``step_length`` (r_e), ``step_length_m``, ``step_frequency`` (1/sqrt(r_e/g)),
        ``step_frequency_hz``. SI names need ``scale``.
    bounds : mapping, optional
        ``name: (lower, upper)``, either may be None: ``beta``, ``theta_II``, ``phi0``
        (radians), ``step_length``, ``step_frequency`` and their SI names. Closed bounds;
        the parameter table's limits (0 < beta < 1, |theta_II| < pi/2, 0 < phi0 < pi/2) are
        open and kept :data:`TABLE_DISTANCE` away.
    fixed : mapping, optional
        Fixed values of ``beta``, ``theta_II``, ``phi0`` (radians).
    min_contact_margin : float
        Lower bound on the minimum ground normal force over the step, in m g (>= 0 is
        always imposed: the stance foot must stay on the ground).
    max_eigenvalue : float, optional
        Upper bound on the eigenvalue of the stride map (eq. 19).
    scale : RobotScale, optional
        Robot scale for SI targets/bounds and SI outputs.
    conditions : {'exact', 'paper'}
        The existence conditions imposed: every physical condition in its exact form, or in
        addition the paper's (15) (theta_I < 0: the new foot lands ahead of the hip) and
        (17) (theta_II < phi0 / 2) as printed.
    n_starts : int
        IPOPT starts per region of the parameter space (see the package's docstring).
    verify : bool
        Re-check the design by time-domain simulation (``simulation_rel_error``).
    explain_infeasible : bool
        When infeasible, relax each user constraint in turn to name the conflicting ones.

    Returns
    -------
    DesignResult

    Raises
    ------
    VswInputError
        Malformed request (unknown names, empty bounds, SI values without a scale, values
        that overflow in the model's units, ...).
    """
    weights = normalise_objective(objective, bool(targets))
    if not isinstance(n_starts, int) or isinstance(n_starts, bool) or not 1 <= n_starts <= 50:
        raise VswInputError(f"n_starts = {n_starts!r} must be an integer from 1 to 50")
    problem = build_problem(
        weights, targets, bounds, fixed, min_contact_margin, max_eigenvalue, scale, conditions
    )
    best, solves, scan = multistart(problem, n_starts)
    common = {"starts": len(solves), "conditions": conditions}
    if best is None:
        again = (targets, bounds, fixed, min_contact_margin, max_eigenvalue, scale, conditions,
                 n_starts)  # fmt: skip
        return _no_design(problem, solves, scan, common, again, explain_infeasible)
    return _designed(problem, best, solves, scale, verify, common)


def _no_design(problem: Problem, solves: list, scan: Any, common: dict, again: tuple,
               explain_infeasible: bool) -> DesignResult:  # fmt: skip
    """The result where no start gave a verified design: ``infeasible`` on evidence (no
    scanned point and no start's end satisfies the constraints, every start at a local
    minimum of the violation; the conflicting constraints named), or a speed target above
    the fastest gait (``again``: the request's arguments, designed again for the top
    speed), else ``not-converged``."""
    n_starts = again[-1]
    statuses = ", ".join(sorted({s.ipopt_status for s in solves})) or "no start"
    feasible_seen = scan.feasible().any() or any(verified_solve(problem, s).verified
                                                 for s in solves)  # fmt: skip
    # Infeasible is said on evidence: no scanned point satisfies the constraints and
    # every start ended at a (local) minimum of the constraint violation. A start that
    # ran out of iterations proves nothing.
    locally_infeasible = all(s.ipopt_status in IPOPT_INFEASIBLE for s in solves)
    if not feasible_seen and locally_infeasible:
        conflicting = conflicts_of(problem, n_starts) if explain_infeasible else []
        if conflicting:
            detail = "removing any one of these restores feasibility: " + ", ".join(conflicting)
        elif explain_infeasible:
            detail = "no single user constraint's removal restores feasibility"
        else:
            detail = "conflict analysis skipped"
        least = min((s.violation for s in solves), default=math.inf)
        starts = (
            f"each of {len(solves)} IPOPT starts ended at a minimum of the constraint "
            f"violation or in an empty region, least {least:.3g}"
            if solves
            else "none of them is a gait IPOPT could start from"
        )
        message = (
            f"infeasible: no design satisfies the constraints (none of {len(scan.x)} "
            f"scanned designs; {starts}); {detail}"
        )
        return DesignResult("infeasible", conflicting_constraints=tuple(conflicting),
                            message=message, ipopt_status=statuses, **common)  # fmt: skip
    beyond = _speed_beyond_reach(*again)
    if beyond is not None:
        return DesignResult("infeasible", message=f"infeasible: {beyond}",
                            ipopt_status=statuses, **common)  # fmt: skip
    found = "the scan found feasible designs" if feasible_seen else "no feasible design found"
    message = (
        f"not converged: IPOPT reached no verified optimum from {len(solves)} starts "
        f"({statuses}); {found}"
    )
    return DesignResult("not-converged", message=message, ipopt_status=statuses, **common)


def _designed(problem: Problem, best: Any, solves: list, scale: RobotScale | None,
              verify: bool, common: dict) -> DesignResult:  # fmt: skip
    """The result of a verified design: ``optimal``, or ``not-attained`` where the open
    limits it presses against pull it on (:func:`continue_to_limit`), with its analysis,
    its quantities and the simulation's check."""
    from vsw.models.ile.analysis import analyze

    limit = continue_to_limit(problem, best) if best.open_active else None
    if limit is not None and len(limit.path) > 1:
        # The multipliers say the open limits pull; the continuation must agree: no gain
        # beyond rounding when moving closer means the optimum is attained inside.
        gain = limit.path[0]["objective"] - limit.path[-1]["objective"]
        if gain <= 1e-13 * max(1.0, abs(best.objective)):
            limit = None
    open_boundary = best.open_active if limit is not None else ()
    x = best.x
    analysis = analyze(x[0], x[1], x[2], scale)
    qs = numpy_quantities(x[None, :])
    sim_error = simulation_check(analysis) if verify else None
    if limit is None:
        status = "optimal"
        message = (
            f"optimal (local, the best of {len(solves)} IPOPT solves over "
            f"{len(set(s.region for s in solves))} regions; IPOPT {best.ipopt_status})"
        )
    else:
        status = "not-attained"
        message = not_attained_message(problem, limit, best)
    if sim_error is not None and not sim_error <= 1e-6:
        message += f"; WARNING: simulation disagrees (relative error {sim_error:.3g})"
    return DesignResult(
        status=status,
        beta=float(x[0]),
        theta_II=float(x[1]),
        phi0=float(x[2]),
        analysis=analysis,
        objective=best.objective,
        cost_of_transport=float(qs["cost_of_transport"][0]),
        step_frequency=float(qs["step_frequency"][0]),
        active_constraints=tuple(active_rows(problem, best)),
        open_boundary=open_boundary,
        limit=limit,
        simulation_rel_error=sim_error,
        message=message,
        ipopt_status=best.ipopt_status,
        region=REGIONS[best.region].name,
        **common,
    )


def _speed_beyond_reach(
    targets: Mapping[str, float] | None,
    bounds: Mapping[str, tuple[float | None, float | None]] | None,
    fixed: Mapping[str, float] | None,
    min_contact_margin: float,
    max_eigenvalue: float | None,
    scale: RobotScale | None,
    conditions: str,
    n_starts: int,
) -> str | None:
    """Why a speed target is out of reach, when it is: above the largest speed (the
    supremum of ``--maximize speed``) under the request's other constraints."""
    targets = dict(targets or {})
    key = next((k for k in ("speed", "speed_m_s") if k in targets), None)
    if key is None:
        return None
    wanted = targets.pop(key)
    top = design("speed", targets, bounds, fixed, min_contact_margin, max_eigenvalue, scale,
                 conditions=conditions, n_starts=n_starts, verify=False,
                 explain_infeasible=False)  # fmt: skip
    if top.status not in ("optimal", "not-attained") or top.analysis is None:
        return None
    fastest = float(top.to_dict()[key])
    supremum = None
    if top.limit is not None and top.limit.objective is not None:
        supremum = -top.limit.objective  # the objective minimised is -speed
        if key == "speed_m_s" and scale is not None:
            supremum *= math.sqrt(scale.gravity * scale.leg_length)
    reach = max(fastest, supremum or fastest)
    if not wanted > reach * (1 + 1e-6):
        return None
    unit = " m/s" if key == "speed_m_s" else " sqrt(g r_e)"
    limit = (f" (the supremum, {supremum:.6g}{unit}, is not attained)"
             if top.status == "not-attained" and supremum is not None else "")  # fmt: skip
    return (
        f"the target speed {wanted:g}{unit} is above the fastest gait within the other "
        f"constraints, {fastest:.6g}{unit}{limit}"
    )
