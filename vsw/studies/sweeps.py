"""A model's gaits along one parameter: continuation, and the brute-force diagram.

* :func:`continuation`: at each value the period-one gait solved from the previous value's
  (:meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit`), or searched anew where that fails
  (:mod:`vsw.gaits.search`); where it is unstable or lost, the Poincaré map iterated past a
  transient from where the last iteration ended (the attractor a walk follows: period-k
  orbits and chaos past a flip), as in the classic bifurcation diagram.
* :func:`brute_force`: the same diagram from the batch simulator: at each value the gait by
  Newton on the batch-simulated map, then the map iterated at every value in one batch.

Both iterate the map with :func:`settle`: past the transient, a block of kept steps at a
time until the kept steps repeat (:func:`settled_period`) or a cap is reached, so a label
names an orbit only once the walk is on it. Both return the points of ``vsw sweep --json``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from vsw.dynamics.batch import APART, BatchSimulator, Runner, simulator
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.dynamics.step_map import fixed_point
from vsw.gaits import continuation as arclength
from vsw.gaits.search import pick
from vsw.models.base import Model
from vsw.orbits import by_modulus
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError, ModelConditionError, VswInputError

__all__ = [
    "MAX_STEPS",
    "NO_GAIT",
    "SETTLE_TOL",
    "brute_force",
    "continuation",
    "located_points",
    "record",
    "settle",
    "settled_period",
]

SETTLE_TOL = 1e-8
"""Relative tolerance of :func:`settled_period`: every component within ``SETTLE_TOL *
max(1, |x|)`` of the state ``p`` steps before. Four orders above the step map's rounding
(a settled orbit of the simplest walker repeats to 1e-14 after 20000 steps), and well
below the spacing of a cascade's orbits near their flips (1e-3 at gamma = 0.01775)."""

MAX_STEPS = 2000
"""Default cap on the steps walked at one value while waiting for the orbit to settle: the
simplest walker's period-2, -4 and -8 orbits settle within 400 steps of its default sweep,
and 2000 compiled steps cost 0.05 s (a chaotic value walks all of them)."""

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
    max_steps: int = MAX_STEPS,
) -> dict[str, Any]:
    """A sweep as ``vsw sweep --json`` prints it (after the envelope) and
    :func:`vsw.plots.diagrams.bifurcation_plot` draws it: the swept parameter and its unit, the
    other parameters' values, the points, and the iteration's transient, kept steps and
    cap (:func:`settle`)."""
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
        data.update(transient=transient, keep=keep, max_steps=max_steps)
    return data


def settled_period(states: np.ndarray, tol: float = SETTLE_TOL) -> int | None:
    """The period of the orbit the kept ``states`` (oldest first) have settled on, or None.

    ``p`` is the smallest lag, at most half the window, at which every kept state is within
    ``tol * max(1, |x|)`` of the state ``p`` steps before: the orbit repeats over at least
    two full cycles. It counts only where every shorter lag ``q < p`` is more than
    :data:`vsw.dynamics.batch.APART` times that away somewhere in the last two cycles (the batch
    simulator's rule): a period-two orbit still converging with multiplier near -1 repeats
    at lag 4 long before lag 2 (the two gaps differ by the factor 1 + mu), and a period-4
    label there would be wrong. None: not settled (a transient not over, a longer period,
    chaos).
    """
    states = np.asarray(states, dtype=float)
    for p in range(1, len(states) // 2 + 1):
        if np.all(_lag_gaps(states, p) <= tol):
            last = states[-2 * p :]
            apart = all(np.max(_lag_gaps(last, q)) > APART * tol for q in range(1, p))
            return p if apart else None
    return None


def _lag_gaps(states: np.ndarray, lag: int) -> np.ndarray:
    """Each state's distance to the one ``lag`` steps later, relative to max(1, |x|)."""
    return np.abs(states[lag:] - states[:-lag]) / np.maximum(1.0, np.abs(states[:-lag]))


def settle(
    sim: BatchSimulator,
    tables: np.ndarray,
    starts: np.ndarray,
    transient: int,
    keep: int,
    max_steps: int = MAX_STEPS,
    tol: float = SETTLE_TOL,
    threads: int | None = None,
    runner: Runner | None = None,
) -> list[dict[str, Any]]:
    """The map iterated from each row of ``starts`` (parameters: the matching row of
    ``tables``) until it has settled: ``transient + keep`` steps, then ``keep`` more at a
    time while :func:`settled_period` finds no period in the last ``keep`` steps, up to
    ``max_steps`` in all. A fixed transient alone labels a slowly converging orbit by the
    wrong period (the simplest walker's period-2 gait at gamma = 0.0175 looks period-4
    after 132 steps); waiting for the repeat costs steps only where the orbit is slow.

    Each record (``attractor`` of ``vsw sweep --json``): ``ended`` (``completed`` or the
    failure), ``steps_walked``, ``settled``, ``period`` (None unless settled), and the
    last ``keep`` steps past the transient: ``states``, ``step_lengths``,
    ``step_periods``."""
    names = [*sim.model.coordinates, *sim.model.rates]
    count = len(starts)
    x = np.array(starts, dtype=float)
    walked = np.zeros(count, dtype=int)
    ended = ["completed"] * count
    period: list[int | None] = [None] * count
    rows = [np.empty((0, x.shape[1]))] * count
    lengths = [np.empty(0)] * count
    durations = [np.empty(0)] * count
    active = np.arange(count)
    block = min(transient + keep, max_steps)
    while active.size:
        stop.check()
        walks = sim.walk(tables[active], x[active], block, converge_tol=0.0, period_tol=0.0,
                         keep=keep, threads=threads, runner=runner)  # fmt: skip
        names_ended = walks.ended()
        still = []
        for j, i in enumerate(active):
            steps = int(walks.steps[j])
            # The ring holds the block's last min(steps, keep) steps, oldest first; of
            # them only those past the transient count.
            held = min(steps, keep)
            fresh = slice(held - min(held, max(0, walked[i] + steps - transient)), held)
            walked[i] += steps
            rows[i] = np.concatenate([rows[i], walks.kept_states[j][fresh]])[-keep:]
            lengths[i] = np.concatenate([lengths[i], walks.kept_lengths[j][fresh]])[-keep:]
            durations[i] = np.concatenate([durations[i], walks.kept_durations[j][fresh]])[-keep:]
            x[i] = walks.final[j]
            if names_ended[j] != "walked":
                ended[i] = names_ended[j]
                continue
            period[i] = settled_period(rows[i], tol) if len(rows[i]) == keep else None
            if period[i] is None and walked[i] < max_steps:
                still.append(i)
        active = np.array(still, dtype=int)
        block = min(keep, max_steps - int(walked[active].max())) if active.size else 0
    return [
        {
            "ended": ended[i],
            "steps_walked": int(walked[i]),
            "settled": period[i] is not None,
            "period": period[i],
            "states": [dict(zip(names, (float(v) for v in r))) for r in rows[i]],
            "step_lengths": [None if np.isnan(v) else float(v) for v in lengths[i]],
            "step_periods": [float(v) for v in durations[i]],
        }
        for i in range(count)
    ]


def continuation(
    model: Model,
    values: Mapping[str, float],
    over: str,
    grid: Sequence[float],
    keep: int = 0,
    transient: int = 100,
    progress: Callable[[int, int], None] | None = None,
    first: tuple[Orbit, str] | None = None,
    max_steps: int = MAX_STEPS,
) -> list[dict[str, Any]]:
    """The period-one gait along ``over`` (the other parameters ``values``), each point
    from the previous one (``"from": "continuation"``) or a new search (``"scan"``; where
    it finds none, ``reason`` says why: :meth:`vsw.models.base.Model.analyze`); with
    ``keep`` the map iterated where the gait is unstable or lost (:func:`settle`, at most
    ``max_steps`` a value), its last ``keep`` steps kept (``attractor``). ``first``: the
    first value's gait and where it came from (``--state``, ``--gait-number K``) instead of
    the search's pick: at a value with two unstable gaits the search's first may be the one
    whose walks fall."""
    sim = simulator(model) if keep else None
    points, previous, walked_to = [], None, None
    for i, value in enumerate(grid):
        params = model.parameters({**values, over: float(value)})
        orbit, source, reason = _gait_at(model, params, previous, first if i == 0 else None)
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
                (attractor,) = settle(sim, np.array([params]), start[None], transient, keep,
                                      max_steps, threads=1)  # fmt: skip
                point["attractor"] = attractor
                completed = attractor["ended"] == "completed" and attractor["states"]
                walked_to = np.array(list(attractor["states"][-1].values())) if completed else None
        else:
            walked_to = None
            if keep:
                point["attractor"] = None
        points.append(point)
        previous = orbit or previous
        if progress is not None:
            progress(i + 1, len(grid))
    return points


def _gait_at(
    model: Model, params: Sequence[float], previous: Orbit | None, first: tuple[Orbit, str] | None
) -> tuple[Orbit | None, str | None, str | None]:
    """One value's period-one gait: ``first`` as given, else continued from ``previous``,
    else the search's pick (with the search's reason where it finds none)."""
    if first is not None:
        return first[0], first[1], None
    if previous is not None:
        x0 = np.array(list(previous.state.values()))
        try:
            return model.periodic_orbit(params, x0, previous.durations), "continuation", None
        except ConvergenceError:
            stop.check()  # Ctrl-C or the time limit inside CasADi ends the sweep
    report = model.analyze(params)
    orbit = pick(report.gaits)
    return orbit, "scan", report.reason


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
    max_steps: int = MAX_STEPS,
) -> list[dict[str, Any]]:
    """The classic bifurcation diagram by brute force, all from the batch simulator: at
    each value of the parameter ``over`` the period-one gait by Newton on the batch map
    (continued from the previous value; its eigenvalues from the map's Jacobian by central
    differences), then the map iterated at every value in one batch (:func:`settle`, at
    most ``max_steps`` a value) from that value's gait moved by 1e-6 (relative) where it
    was found, else from the last gait found before it (or ``start``; default: the first
    stable gait of the first value's scan), keeping the last ``keep`` steps. Returns the
    points of ``vsw sweep --json``: each with its gait and ``attractor``."""
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
        chosen = next((o for o in first if o.stable), first[0])
        start = [chosen.state[n] for n in state_names]
    start = np.asarray(start, dtype=float)
    points: list[dict[str, Any]] = []
    starts = np.empty((len(grid), len(state_names)))
    previous = start
    for i, (value, params) in enumerate(zip(grid, tables)):
        point: dict[str, Any] = {over: float(value), "from": "batch Newton"}
        try:
            x, jacobian = fixed_point(sim, params, previous)
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
            point.update(found=True, **_batch_gait(sim, params, x, jacobian, state_names))
            starts[i] = x * (1 + 1e-6)
            previous = x
        points.append(point)
    attractors = settle(sim, np.array(tables), starts, transient, keep, max_steps,
                        threads=threads, runner=runner)  # fmt: skip
    for point, attractor in zip(points, attractors):
        point["attractor"] = attractor
    return points


def _batch_gait(
    sim: BatchSimulator,
    params: Sequence[float],
    x: np.ndarray,
    jacobian: np.ndarray,
    state_names: Sequence[str],
) -> dict[str, Any]:
    """A gait's keys of a brute-force point: one batch step from the fixed point ``x`` and
    the eigenvalues of the map's ``jacobian``."""
    step = sim.step(params, x[None], threads=1)
    eigenvalues = by_modulus(np.linalg.eigvals(jacobian))
    largest = max(abs(e) for e in eigenvalues)
    length = float(step.kept_lengths[0, 0])
    period = float(step.kept_durations[0, 0])
    length = None if np.isnan(length) else length
    return dict(
        state=dict(zip(state_names, (float(v) for v in x))), period=period,
        eigenvalues=[[e.real, e.imag] for e in eigenvalues], max_abs_eigenvalue=largest,
        stable=largest < 1.0, step_length=length,
        speed=None if length is None else length / period,
    )  # fmt: skip


def located_points(
    model: Model, values: Mapping[str, float], over: str, points: list[dict[str, Any]]
) -> list[dict[str, Any]]:
    """The special points of the period-one branch through the sweep's first gait, located
    by pseudo-arclength continuation over the sweep's range (:mod:`vsw.gaits.continuation`, no
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
