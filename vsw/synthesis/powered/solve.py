"""The powered gait optimised: the NLP solved by IPOPT on N and 2N intervals a phase
(the least squared-input stage first where the cost is the work or the stability), each
start judged by its re-simulation and its mesh, the best kept (:func:`optimize`)."""

from __future__ import annotations

import contextlib
import dataclasses
import io
from collections.abc import Sequence
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.dynamics.quantities import weight as walker_weight
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError
from vsw.synthesis.powered.objectives import named_cost, spectral_radius, works_agree
from vsw.synthesis.powered.problem import Nlp, built
from vsw.synthesis.powered.request import (
    CONSTRAINTS_HELD,
    COST_ZERO,
    MESH_AGREES,
    RESIMULATION_AGREES,
    STABILITY_MARGIN,
    PoweredGait,
    Request,
    checked_parameters,
    continuous_inputs_used,
    input_names,
    ordered_impulses,
    prices_work,
)
from vsw.synthesis.powered.starts import (
    fill_slacks,
    initial_guess,
    kinematic_guess,
    passive_start,
    perturbed_inputs,
    refine,
    transfer,
)
from vsw.synthesis.powered.step import powered_eigenvalues, resimulate
from vsw.synthesis.powered.variables import block

__all__ = ["best_start", "optimize"]


_SUCCESS = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}
_INFEASIBLE = "Infeasible_Problem_Detected"
"""IPOPT's word for a restoration phase that converged to a point of locally least
constraint violation, still violating them: reported as ``infeasible``."""


def optimize(
    model: HybridModel, params: Sequence[float], request: Request, start: Orbit | None = None
) -> PoweredGait:
    """The least-cost periodic step of ``model`` at ``params`` with its inputs (see the
    package's docstring), from ``start`` (default: the model's passive gait at ``params``).

    Solved on ``request.nodes`` intervals a phase and again on twice as many (each from the
    same start): the result is the finer one, with ``mesh_change`` the relative change of
    the cost between them. ``optimal`` needs IPOPT's success on both, the re-simulation
    within :data:`RESIMULATION_AGREES` and ``mesh_change`` within :data:`MESH_AGREES`;
    otherwise ``not-converged`` says which failed (:func:`_judged`). ``cost`` is the named
    cost (the positive work without the regularization the NLP adds;
    ``extra['objective']`` the NLP's). With ``request.starts`` above 1 the second stage
    starts from several points, each solved on both meshes and judged, and the best is
    the result (:func:`_refined_best`).

    Used from Python outside :func:`vsw.runtime.stop.supervised`, a Ctrl-C inside CasADi surfaces
    as a failed solve; with several starts that start is then counted as failed and the
    others go on (under ``supervised``, as the CLI runs, it stops the command)."""
    params = checked_parameters(model, params, request)
    if start is None:
        start = passive_start(model, params)  # None: the model has no passive gait
    fine = _refined_best(model, params, request, _optimize_on_mesh(model, params, request, start))
    if fine.status == "optimal" or (request.minimize == "eigenvalue"
                                    and fine.status == "not-converged"):  # fmt: skip
        try:  # under stability the independent check of the radius, converged or not
            fine.extra["eigenvalues"] = powered_eigenvalues(model, fine.parameters, fine)
        except ConvergenceError as exc:  # a perturbed step that does not end: no map
            stop.check()
            fine.extra["eigenvalues_note"] = str(exc)
    return fine


def _judged(request: Request, coarse: PoweredGait, fine: PoweredGait) -> PoweredGait:
    """``fine`` (the coarse optimum solved again on twice the intervals, from itself) with
    its ``mesh_change`` and the coarse mesh's cost, and its status as the pair makes it:
    ``optimal`` only where the coarse solve succeeded too and the cost agrees between the
    meshes; an infeasible coarse mesh stays infeasible unless the fine one is optimal."""
    change = abs(fine.cost - coarse.cost) / max(abs(fine.cost), 1e-300)
    fine.extra["mesh_change"] = change
    fine.extra["coarse"] = {"nodes": request.nodes, "cost": coarse.cost,
                            "status": coarse.status}  # fmt: skip
    if "warm_start" in coarse.extra:  # the coarse mesh's first stage
        fine.extra["warm_start"] = coarse.extra["warm_start"]
    agree = change <= MESH_AGREES or abs(fine.cost - coarse.cost) <= COST_ZERO
    if coarse.status == "infeasible" and fine.status != "optimal":
        fine.status, fine.reason = coarse.status, coarse.reason + " (on the coarse mesh)"
    elif fine.status == "optimal" and coarse.ipopt_status not in _SUCCESS:
        fine.status = "not-converged"
        fine.reason = f"IPOPT {coarse.ipopt_status} on the coarse mesh"
    elif fine.status == "optimal" and not agree:
        fine.status = "not-converged"
        fine.reason = (f"the cost changes by {change:.3g} (relative) from {request.nodes} to "
                       f"{2 * request.nodes} intervals a phase: the mesh does not resolve the "
                       "optimum (try more --nodes)")  # fmt: skip
        if prices_work(request):
            fine.reason += ("; the least work may need an impulsive input, which no mesh "
                            "resolves")  # fmt: skip
    return fine


def best_start(results: Sequence[Any]) -> int:
    """The index of the best of several starts' judged results (None: that start failed):
    ``optimal`` first, then IPOPT's success, then the least cost, then the earlier start.
    A lower cost that is not ``optimal`` (a mesh that does not resolve it, a
    re-simulation that disagrees) does not beat an optimal one."""
    ranked = [(r.status != "optimal", r.ipopt_status not in _SUCCESS, r.cost, k)
              for k, r in enumerate(results) if r is not None]  # fmt: skip
    return min(ranked)[3]


def _refined_best(model: HybridModel, params: Sequence[float], request: Request,
                  solved: list[PoweredGait | str]) -> PoweredGait:  # fmt: skip
    """Each coarse optimum (one a start; a string where it failed: why) solved again on
    twice the intervals from itself, so that the change measures the mesh and not another
    local optimum, and judged (:func:`_judged`); the fine result :func:`best_start` picks. With
    several starts, each one's costs, statuses (or why it failed) in ``extra['starts']``
    of the fine result and the chosen one's index in ``best_start``."""
    finer = dataclasses.replace(request, nodes=2 * request.nodes)
    coarse_nlp, fine_nlp = built(model, request), built(model, finer)
    judged: list[PoweredGait | None] = []
    tried: list[dict[str, Any]] = []
    for coarse in solved:
        fine, why = None, coarse if isinstance(coarse, str) else ""
        if not isinstance(coarse, str):
            try:
                guess = refine(model, params, coarse_nlp, coarse.extra["w"], fine_nlp)
                fine = _solve(model, params, finer, fine_nlp, guess,
                              coarse.extra["regularization_scale"])  # fmt: skip
            except ConvergenceError as exc:
                if len(solved) == 1:
                    raise
                why = f"on the fine mesh: {exc}"
        judged.append(None if fine is None else _judged(request, coarse, fine))
        if fine is None:
            tried.append({"coarse": None if isinstance(coarse, str) else coarse.cost,
                          "fine": None, "ipopt_status": None, "status": "failed",
                          "reason": why})  # fmt: skip
        else:
            tried.append({"coarse": coarse.cost, "fine": fine.cost,
                          "ipopt_status": fine.ipopt_status, "status": fine.status,
                          "reason": fine.reason or None})  # fmt: skip
    if all(fine is None for fine in judged):
        raise ConvergenceError(f"{model.name}: every one of {len(solved)} starts failed (the "
                               f"first: {tried[0]['reason']})")  # fmt: skip
    best = best_start(judged)
    fine = judged[best]
    assert fine is not None
    if len(solved) > 1:
        fine.extra["starts"] = tried
        fine.extra["best_start"] = best
    return fine


def _optimize_on_mesh(model: HybridModel, params: Sequence[float], request: Request,
                      start: Orbit | None) -> list[PoweredGait | str]:  # fmt: skip
    """The optimum on the coarse mesh from each start (for a start after the first that
    failed, why): the first stage from the passive gait or the kinematic guess, then the
    second from its optimum (:func:`_second_stage`)."""
    stage = request
    if request.minimize != "torque2" and continuous_inputs_used(model, request):
        # Positive work is flat wherever no input does work and not smooth where one
        # starts to: from the passive gait IPOPT wanders (to steps of no duration);
        # from the least squared-input step that meets the targets it converges. (With
        # every continuous input held at zero that stage has nothing to move the walker
        # with, and more equations than unknowns: the work stage starts directly.)
        stage = dataclasses.replace(request, minimize="torque2")
    nlp = built(model, stage)
    if start is None:
        guess = kinematic_guess(model, params, nlp, request)
    else:
        guess = initial_guess(model, params, start, nlp, request.nodes)
    nlp.choose(params, guess)
    nlp.start_radius(params, guess)
    if stage is request and prices_work(request):
        fill_slacks(model, params, nlp, guess)
    result = _solve(model, params, stage, nlp, guess)
    if stage is request:
        return [result]
    staged = built(model, request)
    scale = 1.0
    if request.minimize == "work" and result.step_length is not None:
        scale = walker_weight(model, result.parameters) * result.step_length
    if result.cost > COST_ZERO:  # the squared inputs' integral of the first stage
        # Under stability near a passive gait that integral is almost zero and the weight
        # large (4 % of the objective at the compass gait's passive speed; the share is
        # reported). A weight fixed by the walker's weight squared times the period was
        # tried: the stability test's solve then ran over 12 CPU minutes (24 s with this
        # one) and was stopped; why was not found.
        scale /= result.cost
    first = transfer(model, params, nlp, result.extra["w"], staged)
    solved = _second_stage(model, params, request, staged, first, scale)
    for final in solved:
        if not isinstance(final, str):
            final.extra["warm_start"] = {"minimize": "torque2", "status": result.status,
                                         "cost": result.cost,
                                         "parameters": result.parameters}  # fmt: skip
    return solved


def _second_stage(model: HybridModel, params: Sequence[float], request: Request, nlp: Nlp,
                  first: np.ndarray, scale: float) -> list[PoweredGait | str]:  # fmt: skip
    """The second stage solved from ``first`` and from ``request.starts - 1`` perturbations
    of its inputs (for one of those that failed, why). The perturbations are relative to
    ``first``'s inputs: where those are nearly zero (a passive gait meets the targets, the
    inputs only the mesh's error) every start is nearly ``first``, and the starts' equal
    costs in ``extra['starts']`` show it."""
    solved: list[PoweredGait | str] = [_solve(model, params, request, nlp, first, scale)]
    for k in range(1, request.starts):
        try:
            guess = perturbed_inputs(model, params, nlp, first, k)
            solved.append(_solve(model, params, request, nlp, guess, scale))
        except ConvergenceError as exc:
            solved.append(str(exc))
    return solved


def _ground_impulses(nlp: Nlp, w: np.ndarray, arguments: np.ndarray
                    ) -> dict[str, tuple[float, float]]:  # fmt: skip
    values = np.array(nlp.ground(w, arguments), dtype=float).reshape(-1, 2)
    return {key: (float(t), float(n)) for key, (t, n) in zip(nlp.ground_keys, values)}


def _check_finite_start(model: HybridModel, nlp: Nlp, guess: np.ndarray,
                        arguments: np.ndarray) -> None:  # fmt: skip
    """IPOPT is not started from a point where the NLP's cost or constraints are not
    finite: it would report a NaN at every trial point and wander to its iteration limit
    (or fail in restoration); the run ends at once with the reason."""
    with np.errstate(all="ignore"), _solver_output_dropped():
        values = nlp.solver.oracle().call({"x": guess, "p": arguments})
    for name, what in (("f", "cost"), ("g", "constraints")):
        value = np.array(values[name], dtype=float).reshape(-1)
        bad = np.flatnonzero(~np.isfinite(value))
        if len(bad):
            where = f" (row {bad[0]} of {len(value)})" if len(value) > 1 else ""
            raise ConvergenceError(f"{model.name}: the NLP's {what} are not finite at its "
                                   f"start{where}: the targets or parameters are beyond what "
                                   "this model's step can be; IPOPT was not started")  # fmt: skip


@contextlib.contextmanager
def _solver_output_dropped():
    """CasADi's and IPOPT's own messages through Python's streams (warnings of an
    evaluation, ``KeyboardInterruptException`` when a stop lands in IPOPT) go nowhere:
    what the user reads is the run's one line (the status and its reason, or the stop)."""
    sink = io.StringIO()
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
        yield


def _phases(nlp: Nlp, w: np.ndarray, durations: tuple[float, ...], nodes: int) -> tuple:
    """Each phase of ``w`` on its knots: times, states, inputs at knots and midpoints in
    time order, and their times."""
    times, states, inputs, input_times = [], [], [], []
    for k, entry in enumerate(nlp.layout):
        t0 = sum(durations[:k])
        states.append(block(w, entry["knots"]))
        times.append(t0 + durations[k] * np.arange(nodes + 1) / nodes)
        at_knots, at_middles = block(w, entry["u_knots"]), block(w, entry["u_middles"])
        merged = np.empty((2 * nodes + 1, at_knots.shape[1]))
        merged[0::2], merged[1::2] = at_knots, at_middles
        inputs.append(merged)
        input_times.append(t0 + durations[k] * np.arange(2 * nodes + 1) / (2 * nodes))
    return times, states, inputs, input_times


def _ledger(model: HybridModel, nlp: Nlp, w: np.ndarray,
            arguments: np.ndarray) -> tuple[dict, dict]:  # fmt: skip
    """Each input's and impulse's positive and negative work on the mesh, and each
    impulse's value, by ``<phase or event>.<name>``."""
    work_values = np.array(nlp.work(w, arguments), dtype=float).reshape(-1)
    keys, impulses = [], {}
    for (phase, event), entry in zip(model.phase_sequence(), nlp.layout):  # the NLP's order
        keys += [f"{phase}.{name}" for name in input_names(model)[phase]]
        names = [f"{event['name']}.{name}" for name in ordered_impulses(model, event)]
        keys += names
        impulses |= dict(zip(names, (float(v) for v in block(w, entry["impulses"])[0])))
    work = {key: {"positive": float(work_values[j]), "negative": float(work_values[len(keys) + j])}
            for j, key in enumerate(keys)}  # fmt: skip
    return work, impulses


def _reason(status: str, violation: float, resimulated: str, error: float) -> str:
    """Why IPOPT's point is not an optimal gait ('' where nothing says so yet): IPOPT's
    status, a violated constraint, a re-simulation that fails or ends away from the last
    knot."""
    if status == _INFEASIBLE:
        return (f"IPOPT found the constraints locally infeasible (violated by {violation:.3g} "
                "where it stopped): no gait meets the targets, bounds and parameters near "
                "this start; a local result, not a proof")  # fmt: skip
    if status == "Invalid_Number_Detected":
        return ("IPOPT stopped: the NLP evaluated to NaN or inf at its iterate (the targets "
                "or parameters beyond what this model's step can be?)")  # fmt: skip
    if status not in _SUCCESS:
        return f"IPOPT {status}"
    if not violation <= CONSTRAINTS_HELD:
        return f"IPOPT's point violates a constraint by {violation:.3g}"
    if resimulated:
        return f"the re-simulation {resimulated}"
    if not error <= RESIMULATION_AGREES:
        return f"the re-simulation ends {error:.3g} from the last knot (relative)"
    return ""


def _ipopt(model: HybridModel, params: Sequence[float], request: Request, nlp: Nlp,
           guess: np.ndarray, arguments: np.ndarray) -> tuple[dict, tuple]:  # fmt: skip
    """IPOPT's result from ``guess`` (refused where the NLP is not finite there:
    :func:`_check_finite_start`) and the bounds it was given; a stop (Ctrl-C, the time
    limit) that lands in it raised."""
    lbx, ubx, lbg, ubg = nlp.bounds
    if nlp.chosen and not prices_work(request):
        # The squared inputs' integral and the stability price no impulse (they are held at
        # zero), so not where one acts either: the chosen parameters stay at their values.
        lbx, ubx = lbx.copy(), ubx.copy()
        nlp.choose(params, lbx)
        nlp.choose(params, ubx)
    _check_finite_start(model, nlp, guess, arguments)
    try:
        with _solver_output_dropped():
            result = nlp.solver(x0=guess, p=arguments, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    except RuntimeError as exc:  # a NaN in the model's functions at IPOPT's trial point
        stop.check()  # or CasADi turned Ctrl-C or the time limit into this error
        raise ConvergenceError(f"{model.name}: IPOPT failed ({' '.join(str(exc).split())[:80]})"
                               ) from None  # fmt: skip
    stop.check()  # IPOPT stopped by Ctrl-C or the time limit is no solution
    return result, (lbx, ubx, lbg, ubg)


def _solve(model: HybridModel, params: Sequence[float], request: Request, nlp: Nlp,
           guess: np.ndarray, regularization_scale: float = 1.0) -> PoweredGait:  # fmt: skip
    arguments = np.append(np.asarray(params, dtype=float), regularization_scale)
    result, (lbx, ubx, lbg, ubg) = _ipopt(model, params, request, nlp, guess, arguments)
    stats = nlp.solver.stats()
    status = str(stats.get("return_status", "unknown"))
    w = np.array(result["x"], dtype=float).reshape(-1)
    p = nlp.parameters(params, w)
    sequence = model.phase_sequence()
    durations = tuple(float(v) for v in w[: len(sequence)])
    times, states, inputs, input_times = _phases(nlp, w, durations, request.nodes)
    work, impulses = _ledger(model, nlp, w, arguments)
    along = {} if prices_work(request) else None
    error, guard, resimulated = resimulate(model, p, durations, states, inputs, along)
    moved = None  # the positive work along the re-simulated motion, the impulses' as the mesh's
    if along is not None:
        moved = sum(v["positive"] for v in along.values()) + sum(
            v["positive"] for key, v in work.items() if key not in along
        )
    g = np.array(result["g"], dtype=float).reshape(-1)
    violation = float(max(np.max(lbg - g, initial=0.0), np.max(g - ubg, initial=0.0),
                          np.max(lbx - w, initial=0.0), np.max(w - ubx, initial=0.0)))  # fmt: skip
    step_length = None
    if model.spec["step_length"]:
        step_length = float(model.step_length(p, states[-1][-1]))
    period = sum(durations)
    scale = max(1.0, float(max(np.max(np.abs(s)) for s in states)))
    reason = _reason(status, violation, resimulated, error)
    if (
        not reason
        and moved is not None
        and not works_agree(
            moved,
            mesh := sum(v["positive"] for v in work.values()),
            walker_weight(model, p) * (step_length or 1.0),
        )
    ):
        reason = (f"the positive work along the re-simulated step, {moved:.6g}, is not the "
                  f"mesh's, {mesh:.6g}: the mesh does not resolve the power")  # fmt: skip
    objective = float(nlp.cost(w, arguments))
    named, radius = objective, {}
    if nlp.radius is not None:  # the cost is the radius measured, the unknown beside it
        jacobian = nlp.step_jacobian(params, w)
        named = spectral_radius(jacobian)
        radius = {"radius_unknown": float(w[nlp.radius]), "step_jacobian": jacobian}
        if not reason and w[nlp.radius] <= STABILITY_MARGIN * (1 + 1e-6):
            reason = (f"the radius reached its floor, {STABILITY_MARGIN:g}: the least is below "
                      "it (not attained at the floor)")  # fmt: skip
    return PoweredGait(
        status="infeasible" if status == _INFEASIBLE else "not-converged" if reason else "optimal",
        reason=reason,
        cost=named_cost(model, p, request, work, step_length, named),
        durations=durations,
        times=times,
        states=states,
        inputs=inputs,
        input_times=input_times,
        work=work,
        step_length=step_length,
        speed=None if step_length is None else step_length / period,
        resimulation_error=error,
        guard_at_end=guard,
        ipopt_status=status,
        iterations=int(stats.get("iter_count", -1)),
        impulses=impulses,
        ground_impulses=_ground_impulses(nlp, w, arguments),
        parameters=tuple(float(v) for v in p),
        extra={
            "resimulated_work": moved,
            "state_scale": scale,
            "w": w,
            "constraint_violation": violation,
            "objective": objective,
            **radius,
            "regularization_scale": regularization_scale,
        },
    )
