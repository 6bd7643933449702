"""A model's gaits along one parameter: continuation, and the brute-force diagram.

* :func:`continuation`: at each value the period-one gait solved from the previous value's
  (:meth:`vsw.hybrid.HybridModel.periodic_orbit`), or searched anew where that fails
  (:mod:`vsw.gaits`); where it is unstable or lost, the Poincaré map iterated past a
  transient from where the last iteration ended (the attractor a walk follows: period-k
  orbits and chaos past a flip), as in the classic bifurcation diagram.
* :func:`brute_force`: the same diagram from the batch simulator: at each value the gait by
  Newton on the batch-simulated map, then one batch walk over every value.

Both return the points of ``vsw sweep --json``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from vsw import continuation as arclength
from vsw import stop
from vsw.batch import Runner, simulator
from vsw.errors import ConvergenceError, ModelConditionError, VswInputError
from vsw.gaits import pick
from vsw.hybrid import HybridModel, by_modulus, repeat_period
from vsw.models.base import Model

__all__ = ["NO_GAIT", "brute_force", "continuation", "located_points", "record"]

NO_GAIT = dict.fromkeys(("state", "period", "phase_durations", "eigenvalues",
                         "max_abs_eigenvalue", "stable", "step_length", "speed"))  # fmt: skip
"""The gait's keys of a point where none was found."""


def record(
    model: HybridModel,
    fixed: Mapping[str, float],
    over: str,
    points: list[dict[str, Any]],
    keep: int = 0,
    transient: int = 0,
    method: str | None = None,
) -> dict[str, Any]:
    """A sweep as ``vsw sweep --json`` prints it (after the envelope) and
    :func:`vsw.diagrams.bifurcation_plot` draws it: the swept parameter and its unit, the
    other parameters' values, the points, and the iteration's transient and kept steps."""
    params = model.parameters({**fixed, over: float(points[0][over])})
    data: dict[str, Any] = {
        "model": model.name.replace("_", "-"),
        "parameters": {k: v for k, v in zip(model.spec["parameters"], params) if k != over},
        "over": over,
        "over_unit": next(p.unit for p in model.parameter_table if p.name == over),
    }
    if method:
        data["method"] = method
    data["points"] = points
    if keep:
        data.update(transient=transient, keep=keep)
    return data


def continuation(
    model: Model,
    values: Mapping[str, float],
    over: str,
    grid: Sequence[float],
    keep: int = 0,
    transient: int = 100,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """The period-one gait along ``over`` (the other parameters ``values``), each point
    from the previous one (``"from": "continuation"``) or a new search (``"scan"``; where
    it finds none, ``reason`` says why: :meth:`vsw.models.base.Model.analyze`); with
    ``keep`` the map iterated ``transient + keep`` steps where the gait is unstable or
    lost, its last ``keep`` steps kept (``attractor``)."""
    names = list(model.coordinates + model.rates)
    points, previous, walked_to = [], None, None
    for i, value in enumerate(grid):
        params = model.parameters({**values, over: float(value)})
        orbit, source = None, None
        if previous is not None:
            x0 = np.array(list(previous.state.values()))
            try:
                orbit = model.periodic_orbit(params, x0, previous.durations)
                source = "continuation"
            except ConvergenceError:
                stop.check()  # Ctrl-C or the time limit inside CasADi ends the sweep
                orbit = None
        reason = None
        if orbit is None:
            report = model.analyze(params)
            orbit, source, reason = pick(report.gaits), "scan", report.reason
        point = {over: float(value), "found": orbit is not None}
        point.update({"from": source, **orbit.to_dict()} if orbit else {"from": None, **NO_GAIT})
        if orbit is None:
            point["reason"] = reason
        if keep and (orbit is None or not orbit.stable):
            # The attractor followed along the sweep: from where the last iteration ended,
            # else from the previous point's gait (off this point's unstable gait by the
            # parameter step), else from this gait moved by 1e-4: a walk started on an
            # unstable gait stays there for as long as its rounding takes to grow.
            if walked_to is not None:
                start = walked_to
            elif previous is not None:
                start = np.array(list(previous.state.values()))
            elif orbit is not None:
                start = np.array(list(orbit.state.values())) * (1 + 1e-4)
            else:
                start = None
            if start is None:
                point["attractor"] = None
            else:
                attractor = model.attractor(params, start, transient, keep)
                point["attractor"] = attractor.to_dict(names)
                walked_to = attractor.states[-1] if attractor.ended == "completed" else None
        else:
            walked_to = None
            if keep:
                point["attractor"] = None
        points.append(point)
        previous = orbit or previous
        if progress is not None:
            progress(i + 1, len(grid))
    return points


def brute_force(
    model: Model,
    values: Mapping[str, float],
    over: str,
    grid: np.ndarray,
    transient: int,
    keep: int,
    start: Sequence[float] | None = None,
    threads: int | None = None,
    runner: Runner | None = None,
) -> list[dict[str, Any]]:
    """The classic bifurcation diagram by brute force, all from the batch simulator: at
    each value of the parameter ``over`` the period-one gait by Newton on the batch map
    (continued from the previous value; its eigenvalues from the map's Jacobian by central
    differences), then one batch walk over every value, ``transient + keep`` steps each,
    from that value's gait moved by 1e-6 (relative) where it was found, else from the last
    gait found before it (or ``start``; default: the first stable gait of the first value's
    scan), keeping the last ``keep`` steps. Returns the points of ``vsw sweep --json``:
    each with its gait and ``attractor`` (states, step lengths and periods, ``ended``,
    ``period``)."""
    names_p = list(model.spec["parameters"])
    if over not in names_p:
        raise VswInputError(f"{over!r} is not a parameter of {model.name}: {', '.join(names_p)}")
    state_names = [*model.coordinates, *model.rates]
    sim = simulator(model)
    tables = [model.parameters({**values, over: float(v)}) for v in grid]
    if start is None:
        first = model.search_gaits(tables[0]).gaits
        if not first:
            raise ModelConditionError(
                f"{model.name}: no period-one gait at {over} = {grid[0]:g} to start from: "
                "give the start with --state"
            )
        pick = next((o for o in first if o.stable), first[0])
        start = [pick.state[n] for n in state_names]
    start = np.asarray(start, dtype=float)
    points: list[dict[str, Any]] = []
    starts = np.empty((len(grid), len(state_names)))
    previous = start
    for i, (value, params) in enumerate(zip(grid, tables)):
        point: dict[str, Any] = {over: float(value), "from": "batch Newton"}
        try:
            x, jacobian = sim.fixed_point(params, previous)
        except ConvergenceError:
            stop.check()
            x = None
        if x is None or not np.all(np.isfinite(x)):
            point["found"] = False
            for key in ("state", "period", "eigenvalues", "max_abs_eigenvalue", "stable",
                        "step_length", "speed"):  # fmt: skip
                point[key] = None
            starts[i] = previous
        else:
            step = sim.step(params, x[None], threads=1)
            eigenvalues = by_modulus(np.linalg.eigvals(jacobian))
            largest = max(abs(e) for e in eigenvalues)
            length = float(step.kept_lengths[0, 0])
            period = float(step.kept_durations[0, 0])
            length = None if np.isnan(length) else length
            point.update(
                found=True, state=dict(zip(state_names, (float(v) for v in x))), period=period,
                eigenvalues=[[e.real, e.imag] for e in eigenvalues],
                max_abs_eigenvalue=largest, stable=largest < 1.0, step_length=length,
                speed=None if length is None else length / period,
            )  # fmt: skip
            starts[i] = x * (1 + 1e-6)
            previous = x
        points.append(point)
    walks = sim.walk(np.array(tables), starts, transient + keep, converge_tol=0.0,
                     period_tol=0.0, keep=keep, threads=threads, runner=runner)  # fmt: skip
    ended = walks.ended()
    for i, point in enumerate(points):
        walked = int(walks.steps[i])
        # The ring holds the last min(walked, keep) steps, oldest first; of them only those
        # past the transient count (as HybridModel.attractor keeps them).
        held = min(walked, keep)
        after = max(0, min(keep, walked - transient))
        kept = slice(held - after, held)
        kept_rows = walks.kept_states[i][kept]
        lengths = walks.kept_lengths[i][kept]
        durations = walks.kept_durations[i][kept]
        completed = ended[i] == "walked"
        period = repeat_period(kept_rows, 1e-7) if completed and len(kept_rows) > 1 else None
        point["attractor"] = {
            "ended": "completed" if completed else ended[i],
            "steps_walked": walked,
            "period": period,
            "states": [dict(zip(state_names, (float(v) for v in r))) for r in kept_rows],
            "step_lengths": [None if np.isnan(v) else float(v) for v in lengths],
            "step_periods": [float(v) for v in durations],
        }
    return points


def located_points(
    model: Model, values: Mapping[str, float], over: str, points: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """The special points of the period-one branch through the sweep's first gait, located
    by pseudo-arclength continuation over the sweep's range (:mod:`vsw.continuation`, no
    branch switching): what ``vsw sweep --plot`` marks on its grid. Each: ``type``,
    ``parameter``, ``defining_equation``, ``condition``. Empty where no point of the sweep
    has a gait or the continuation cannot start."""
    first = next((p for p in points if p["found"]), None)
    if first is None or len(points) < 2:
        return []
    start, stop_value = float(first[over]), float(points[-1][over])
    if start == stop_value:
        return []
    params = model.parameters({**values, over: start})
    state = list(first["state"].values())
    try:
        branches = arclength.continue_gaits(
            model, params, over, start, stop_value, state, first["phase_durations"],
            options=arclength.Options(switch=False),
        )  # fmt: skip
    except (VswInputError, ConvergenceError):
        stop.check()
        return []
    return [
        {key: s.to_dict()[key] for key in ("type", "parameter", "defining_equation", "condition")}
        for s in branches[0].special_points
    ]
