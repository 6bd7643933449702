"""The period-one gaits of a model: a dense scan of its section, then Newton from every dip.

A gait is a fixed point of the Poincaré map ``P`` (section state just after the step event
to the next). The search is complete within a stated box and resolution:

1. **The box.** Each model declares where gaits are looked for: an interval for every
   component of the section state that the section does not determine (``HYBRID["search"]``,
   ``Model.search`` in its model file); the other components follow from those
   (``section_completion``: the step event's geometry and reset). ``box=`` overrides it.
2. **The scan.** A grid over the box (:data:`SCAN_POINTS` along each free component, ends
   included, a rate's zero left out) is stepped once
   by the compiled batch simulator (:mod:`vsw.dynamics.batch`); where the step completes, the
   residual ``P(x) - x`` on the free components.
3. **Newton from every cell that completes its step**, all at once, on ``P(x) - x`` in
   the free components (:func:`vsw.orbits.newton.solve` on :class:`vsw.dynamics.step_map.StepMap`),
   the Jacobian by forward differences of batch steps; a start whose step fails is
   dropped, starts whose iterates meet go on as one. Solutions closer than
   :data:`DISTINCT` are one gait. (Newton only from the cells where ``|P(x) - x|`` dips
   misses gaits: at the biped's (0.8, 0.1, 1e-4, 0.3) the cells that lead to its gait
   with max |eigenvalue| 1394 are none of them dips.)
4. **Each gait confirmed** by the boundary-value solver
   (:meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit`: the periodic-orbit problem of
   :mod:`vsw.orbits`, each phase's start and duration unknown, eigenvalues of its monodromy
   matrix, one simulated step back onto it).

Steps 1-3, and then step 4's gaits, are kept on disk and reused by a later search of the
same model, code and inputs, the gaits only with the same CasADi installation
(:mod:`vsw.gaits.search_cache`; ``VSW_SEARCH_CACHE=0`` turns it off): a command that follows a
gait (``vsw basin``) spent a fifth of its time confirming the same three gaits again. A kept
search returns what a new one would, bit for bit. It is trusted only as far as it is
verified: the file is sealed with its own name and the SHA-256 of its canonical content,
its fields are checked against what a search writes (types, ranges, the grid, the routes
and outcomes), and before its gaits are reported each is stepped once more and must return
to itself as the boundary-value solver's confirmation demands, with every Newton solution
accounted for (:func:`recheck`; reading and checking a kept search took 3 to 9 ms for
the passive walkers' searches at their defaults). A file that
fails any of these is ignored with a one-line :class:`~vsw.runtime.errors.CacheWarning` and the
search is done again. The eigenvalues and the reasons of unconfirmed solutions are not
computed again (that would be the solver's work): the seal vouches for them.

What this misses, by construction: a gait whose set of states that complete one step is
too thin to hold a grid cell near it (a gait with its apex barely passed: max |eigenvalue|
in the hundreds), and gaits outside the box. Against a scan twice as fine, at the biped's
sets where an independent search found gaits an earlier search missed and at the passive
walkers' defaults, no gait with max |eigenvalue| below 100 is missed; of the very unstable
ones the finer scan adds two (|eigenvalue| 778 and 874) to the eleven found here
(benchmarks case 12; tests/test_gaits.py checks the independent search's gaits).
Without a C compiler the scan takes the SciPy route (:func:`vsw.dynamics.batch.reference_walks`)
on a coarse grid (:data:`FALLBACK_CELLS`), and the result says it is not complete.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.batch import FELL, WALKED, BatchSimulator, simulator
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.dynamics.step_map import StepMap
from vsw.gaits import search_cache
from vsw.orbits import newton
from vsw.runtime import limits, stop
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.runtime.threads import default_threads

__all__ = [
    "DISTINCT",
    "FALLBACK_CELLS",
    "SCAN_POINTS",
    "GaitSearch",
    "pick",
    "search",
]

SCAN_POINTS = {1: 4001, 2: 960, 3: 61}
"""Grid points along each free component of the default scan, by their number (more
components: 230,000 cells in all): with 480 in two components the simplest walker's gaits
with |eigenvalue| 930 and 948 (periods 9.4 and 10.2, the swing leg swinging back and
forth) are missed, with 48 in three the compass gait's with 273 (period 1.88 s). At such
gaits the states that complete one step are bands about 0.01 wide in the rates."""

FALLBACK_CELLS = 1_000
"""Cells of the scan on the SciPy route (no compiler): about 300 times slower a step."""

DISTINCT = 1e-7
"""Two Newton solutions are one gait when every component agrees to this times
max(1, |component|)."""

STANDS = 1e-3
"""A Newton solution whose step is shorter than this times the model's length scale (its
largest length parameter, else 1) is no gait, where the step depends on the state: on
level ground a heelstrike's loss falls with the step's size faster than Newton's
tolerance, so the scan finds many near-standing "orbits" (the compass gait's body on
level ground: 449 solutions, 72 distinct, steps of 1e-7 to 5e-5 m). The simplest
walker's gait at its smallest computed slope (1e-8 rad) steps 4e-3."""

_NEWTON_TOL = 1e-10
_NEWTON_ITERATIONS = 40


@dataclass
class GaitSearch:
    """What :func:`search` found and how.

    ``gaits`` are sorted by period; ``box`` the intervals searched, ``points`` the grid
    points along each; ``outcomes`` counts how the scan's single steps ended (``walked``
    or a failure's name); ``candidates`` the dips Newton started from, ``converged`` how
    many of those converged; ``unconfirmed`` the Newton solutions the boundary-value
    solver did not confirm, with its reason; ``route`` the batch simulator's
    ('compiled', else the SciPy fallback and why); ``complete`` whether the default
    resolution was used on the compiled route; ``standing`` the Newton solutions that
    stand (:data:`STANDS`), left out.
    """

    gaits: list[Orbit]
    box: dict[str, tuple[float, float]]
    points: dict[str, int]
    outcomes: dict[str, int]
    candidates: int
    converged: int
    unconfirmed: list[dict[str, Any]] = field(default_factory=list)
    route: str = "compiled"
    complete: bool = True
    standing: int = 0

    @property
    def cells(self) -> int:
        return math.prod(self.points.values())

    def method(self) -> dict[str, Any]:
        """The search as JSON: box, grid, outcome counts, candidates and route."""
        return {
            "method": "dense scan of the section, Newton from every state that completes a "
            "step, each gait confirmed by the boundary-value solver",
            "box": {k: list(v) for k, v in self.box.items()},
            "points": dict(self.points),
            "cells": self.cells,
            "scan_outcomes": dict(self.outcomes),
            "candidates": self.candidates,
            "newton_converged": self.converged,
            "unconfirmed": list(self.unconfirmed),
            "standing": self.standing,
            "simulator": self.route,
            "complete": self.complete,
        }

    def why_none(self) -> str:
        """One sentence on why no gait was found (the scan's outcomes)."""
        walked = self.outcomes.get("walked", 0)
        ends = ", ".join(f"{n} {k}" for k, n in self.outcomes.items() if k != "walked")
        text = (f"no period-one gait in the search box ({_box_text(self.box)}): of "
                f"{self.cells} scanned section states {walked} complete a step"
                + (f", {ends}" if ends else ""))  # fmt: skip
        if walked and not self.converged:
            text += f"; Newton from those {self.candidates} found no gait"
        if self.unconfirmed:
            text += f"; {len(self.unconfirmed)} Newton solution(s) were no gait when simulated"
        if self.standing:
            text += (f"; {self.standing} Newton solution(s) stand (steps shorter than "
                     f"{STANDS:g} of the length scale)")  # fmt: skip
        return text


def _box_text(box: Mapping[str, tuple[float, float]]) -> str:
    return ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in box.items())


def free_components(model: HybridModel) -> list[str]:
    """The section components the search varies (those the section does not determine)."""
    return list(model.spec["search"])


def check_box(model: HybridModel, box: Mapping[str, tuple[float, float]] | None) -> dict:
    """The search box: the model's, with the intervals ``box`` gives replaced (validated)."""
    out = {k: tuple(float(v) for v in pair) for k, pair in model.spec["search"].items()}
    for name, pair in (box or {}).items():
        if name not in out:
            raise VswInputError(
                f"--search {name}: not a free component of the {model.name} model's section: "
                f"choose from {', '.join(out)}"
            )
        low, high = (float(v) for v in pair)
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise VswInputError(f"--search {name}={low:g}:{high:g}: need finite START < STOP")
        out[name] = (low, high)
    return out


def section_states(model: HybridModel, params: Sequence[float], free: np.ndarray) -> np.ndarray:
    """Full section states from rows of free components (the section's completion)."""
    names = [*model.coordinates, *model.rates]
    columns = free_components(model)
    rows = np.zeros((len(free), len(names)))
    for j, name in enumerate(columns):
        rows[:, names.index(name)] = free[:, j]
    complete = getattr(model.module, "section_completion", None)
    if complete is None or not model.spec["section"]:
        return rows
    with np.errstate(all="ignore"):
        values = complete(*params, *rows.T)
    return np.column_stack([np.broadcast_to(np.asarray(v, float), len(free)) for v in values])


def _outcome_counts(result: Any) -> dict[str, int]:
    """How the scan's steps ended, counted by code (``walked``, each failure, ``stalled``)."""
    codes, counts = np.unique(np.stack([result.outcome, result.aux]), axis=1, return_counts=True)
    out: dict[str, int] = {}
    for (outcome, aux), count in zip(codes.T, counts):
        if outcome == WALKED:
            name = "walked"
        elif outcome == FELL:
            name = result.failures[aux]
        else:
            name = "stalled"
        out[name] = out.get(name, 0) + int(count)
    return dict(sorted(out.items()))


def _axis(low: float, high: float, count: int, is_rate: bool) -> np.ndarray:
    """``count`` points over [low, high]; a rate's zero is left out (no motion there)."""
    if is_rate and low == 0.0:
        return np.linspace(low, high, count + 1)[1:]
    return np.linspace(low, high, count)


def search_seconds(model: HybridModel, threads: int | None = None) -> float:
    """Estimated run time of :func:`search` at the default scan (for :mod:`vsw.runtime.limits`):
    one batch step per cell at the per-phase cost of :data:`vsw.runtime.limits
    .BATCH_SECONDS_PER_PHASE`, on ``threads`` (default: the usable cores), plus the Newton
    and confirmation part. Measured against it (benchmarks/run.py case 12, 2 threads): the
    compass gait 12.8 s for 13.1 s estimated, the simplest walker 11.5 s for 40.9 s, the
    biped 2.2-6.0 s for 22.2 s. Far from the defaults it can be off by more (a stiff swing leg
    costs many integrator steps a cell): the limit is also enforced while the search runs.
    """
    dims = len(model.spec["search"])
    cells = _scan_points(dims, None) ** dims
    threads = default_threads() if threads is None else threads
    per_step = limits.BATCH_SECONDS_PER_PHASE * len(model.phases) * model.n
    return cells * per_step / threads + limits.SEARCH_SECONDS_FIXED


def _scan_points(dims: int, cells: int | None) -> int:
    if cells is None:
        return SCAN_POINTS.get(dims, max(3, math.floor(230_000 ** (1.0 / dims))))
    return max(3, math.floor(cells ** (1.0 / dims) + 1e-9))


def _distinct(solutions: np.ndarray) -> list[np.ndarray]:
    """The solutions in order, each dropped that lies within ``DISTINCT * max(1, |x|)`` of
    one kept before it in every component (compared with all kept at once: a scan that
    converges thousands of starts keeps hundreds)."""
    solutions = np.asarray(solutions, dtype=float)
    kept = np.empty_like(solutions)
    count = 0
    for x in solutions:
        scale = DISTINCT * np.maximum(1.0, np.abs(x))
        if np.all(np.any(np.abs(x - kept[:count]) > scale, axis=1)):
            kept[count] = x
            count += 1
    return list(kept[:count])


def search(
    model: HybridModel,
    params: Sequence[float],
    *,
    box: Mapping[str, tuple[float, float]] | None = None,
    cells: int | None = None,
) -> GaitSearch:
    """The period-one gaits at ``params`` within the search box (module docstring).

    The scan and Newton's solutions, then the confirmed gaits, are kept in the cache
    directory (:func:`vsw.gaits.search_cache.cache_file`) and reused by any later search of the
    same model, code and inputs (the gaits only with the same CasADi installation); a
    reused search returns what a new one would, bit for bit (the floats written by
    ``repr``, which reads back exactly; an orbit's phase states are not kept, and a search
    with any keeps no gaits).
    Outside :func:`vsw.runtime.stop.supervised` a search with a solution the solver did not confirm
    keeps no gaits: there a Ctrl-C inside CasADi looks like a failed solve.

    Parameters
    ----------
    model : HybridModel
    params : sequence of float
        The parameter vector (``model.parameters(...)``).
    box : mapping of str to (low, high), optional
        Intervals replacing the model's for some free components.
    cells : int, optional
        Grid cells of the scan (default :data:`SCAN_POINTS` per axis, or
        :data:`FALLBACK_CELLS` on the SciPy route).
    """
    params = tuple(float(v) for v in params)
    box = check_box(model, box)
    sim = simulator(model)
    compiled = sim.library() is not None
    path = search_cache.cache_file(model, sim, params, box, cells) if compiled else None
    scanned = search_cache.read(path, model, sim, box, _scan_points(len(box), cells))
    names = [*model.coordinates, *model.rates]
    kept = None if scanned is None else search_cache.kept_gaits(scanned.get("confirmed"), names)
    if kept is not None:
        problem = recheck(model, sim, params, scanned["found"], *kept)
        if problem is not None:
            search_cache.note(
                f"the kept search {path} is no longer trusted ({problem}): searching again"
            )
            scanned, kept = None, None
    if scanned is None:
        scanned = _scan(model, sim, params, box, cells, compiled)
        search_cache.write(path, scanned)  # kept before confirming: an interrupt loses no scan
    if kept is not None:
        gaits, unconfirmed, standing = kept
    else:
        gaits, unconfirmed, standing = _confirm(model, sim, params, scanned["found"])
        # Outside stop.supervised (vsw as a library) a Ctrl-C inside CasADi comes back as a
        # failed solve, indistinguishable from a real one: such a result is not kept.
        record = search_cache.confirmed_record(gaits, unconfirmed, standing)
        if record is not None and (stop.supervising() or not unconfirmed):
            search_cache.write(path, {**scanned, "confirmed": record})
    return GaitSearch(
        gaits=gaits,
        box=box,
        points=scanned["points"],
        outcomes=scanned["outcomes"],
        candidates=scanned["candidates"],
        converged=scanned["converged"],
        unconfirmed=unconfirmed,
        route=scanned["route"],
        complete=compiled and cells is None,
        standing=standing,
    )


def _scan(
    model: HybridModel, sim: BatchSimulator, params: tuple[float, ...],
    box: dict[str, tuple[float, float]], cells: int | None, compiled: bool,
) -> dict[str, Any]:  # fmt: skip
    """The scan of the box and Newton from every cell that completes its step: the
    distinct solutions (free components) and how they were found."""
    names = [*model.coordinates, *model.rates]
    free = list(box)
    free_index = [names.index(n) for n in free]
    per_axis = _scan_points(len(free), cells if cells or compiled else FALLBACK_CELLS)
    axes = [_axis(*box[n], per_axis, n in model.rates) for n in free]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(free))
    states = section_states(model, params, grid)
    result = sim.step(params, states)
    walked = result.outcome == WALKED
    with np.errstate(invalid="ignore"):
        gap = np.max(np.abs(result.final[:, free_index] - grid), axis=1)
    residual = np.where(walked & np.isfinite(gap), gap, np.inf)
    starts = np.flatnonzero(np.isfinite(residual))
    # Newton on P(y) - y from every start at once; a start whose step fails is dropped,
    # starts whose iterates meet (to 1e-9) go on as one.
    system = StepMap(sim, params, complete=lambda y: section_states(model, params, y),
                     index=free_index, images=result.final[starts][:, free_index])  # fmt: skip
    found = newton.solve(system, grid[starts], tol=_NEWTON_TOL,
                         max_iterations=_NEWTON_ITERATIONS, merge=1e-9)  # fmt: skip
    solutions, ok = found.w, found.converged
    return {
        "found": [[float(v) for v in y] for y in _distinct(solutions[ok])],
        "points": {n: len(a) for n, a in zip(free, axes)},
        "outcomes": _outcome_counts(result),
        "candidates": int(starts.size),
        "converged": int(np.count_nonzero(ok)),
        "route": result.route,
    }


def _confirm(
    model: HybridModel, sim: BatchSimulator, params: tuple[float, ...], found: list
) -> tuple[list[Orbit], list[dict[str, Any]], int]:
    """Each Newton solution confirmed by the boundary-value solver: the distinct gaits by
    period, the solutions it did not confirm with its reason, and how many solutions stood
    (a step shorter than :data:`STANDS` of the length scale: not passed to the solver)."""
    names = [*model.coordinates, *model.rates]
    gaits, unconfirmed, standing = [], [], 0
    shortest = _shortest_step(model, params)
    for y in found:
        kind, state, step = _classify(model, sim, params, y, shortest)
        if kind == "stands":
            standing += 1
            continue
        if kind == "no step":
            continue  # a step of no duration (legs together at the event): no gait
        period = float(sum(step.durations))  # the durations are the solver's guess
        try:
            gaits.append(model.periodic_orbit(params, state, step.durations,
                                              step=sim.step_phases))  # fmt: skip
        except ConvergenceError as exc:
            stop.check()  # Ctrl-C or the time limit inside CasADi is no failed start
            unconfirmed.append(
                {
                    "state": dict(zip(names, (float(v) for v in state))),
                    "period": period,
                    "reason": str(exc).split(": ", 1)[-1],
                }
            )
    distinct: list[Orbit] = []
    for orbit in sorted(gaits, key=lambda o: o.period):
        x = np.array(list(orbit.state.values()))
        if all(np.any(np.abs(x - np.array(list(o.state.values())))
                      > DISTINCT * np.maximum(1.0, np.abs(x))) for o in distinct):  # fmt: skip
            distinct.append(orbit)
    return distinct, unconfirmed, standing


def _shortest_step(model: HybridModel, params: Sequence[float]) -> float:
    """The step below which a Newton solution stands (:data:`STANDS`; 0 where the step
    length does not depend on the state)."""
    return STANDS * _length_scale(model, params) if _steps_vary(model, params) else 0.0


def _classify(
    model: HybridModel, sim: BatchSimulator, params: Sequence[float], y: Sequence[float],
    shortest: float,
) -> tuple[str, np.ndarray, Any]:  # fmt: skip
    """What a Newton solution ``y`` (free components) is before the boundary-value solver
    sees it: ``stands`` (a step shorter than ``shortest``), ``no step`` (its step does not
    complete, or takes no time: legs together at the event) or ``candidate``; with its
    section state and (but where it stands) its step by ``sim.step_phases``."""
    state = section_states(model, params, np.array([y], dtype=float))[0]
    length = model.step_length(params, state)
    if length is not None and abs(length) < shortest:
        return "stands", state, None
    step = sim.step_phases(params, state)
    if step.ended != "completed" or not float(sum(step.durations)) > 1e-9:
        return "no step", state, step
    return "candidate", state, step


def probed_step_lengths(model: HybridModel, params: Sequence[float]) -> set[float | None]:
    """The step length at two states with every coordinate different: one value where the
    parameters fix it (the rimless wheel's spokes, the Kuo walker's d), two where it depends
    on the state ({None} without a step length). Not states with all coordinates equal: they
    put a compass gait's legs together, where its step is zero whatever the state."""
    size = 2 * model.n
    states = (np.linspace(0.1, 0.7, size), np.linspace(-0.3, 0.2, size)[::-1])
    return {model.step_length(params, state) for state in states}


def _steps_vary(model: HybridModel, params: Sequence[float]) -> bool:
    """Whether the step length depends on the state: only then can a solution stand."""
    lengths = probed_step_lengths(model, params)
    return None not in lengths and len(lengths) > 1


def _length_scale(model: HybridModel, params: Sequence[float]) -> float:
    """The model's largest parameter in its unit of length, else 1 (scaled units)."""
    unit = model.spec["units"].get("length")
    lengths = [abs(float(v)) for p, v in zip(model.parameter_table, params) if p.unit == unit]
    return max(lengths, default=1.0) or 1.0


_MATCH = 1e-5
"""A Newton solution is the kept gait it led to when every component agrees to this times
max(1, |component|): the boundary-value solver moves a solution of Newton's tolerance by
far less (at most 1.2e-10 relative, measured at the defaults of the nine passive walkers
with gaits), and distinct gaits of a search lie further apart."""


def recheck(
    model: HybridModel, sim: BatchSimulator, params: tuple[float, ...], found: list,
    gaits: list[Orbit], unconfirmed: list[dict[str, Any]], standing: int,
) -> str | None:  # fmt: skip
    """Why kept confirmed gaits are not what confirming ``found`` would give, or None.

    Cheap (compiled steps: 2 d + 1 per gait and one per Newton solution, no solver): each
    gait's largest |eigenvalue| must agree with a finite-difference estimate
    (:data:`_EIGENVALUE_CHECK`), its step must return to it as
    :meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit` demands of a new one, with the phases,
    durations and step length kept; and every Newton solution
    must be accounted for as a new confirmation would (one that stands, whose step does
    not complete, that is an unconfirmed solution kept, or that is near a kept gait), the
    counts agreeing. The digest already guards the file against damage: this catches a
    kept gait that is no gait, or a gait left out, whoever wrote the file."""
    names = [*model.coordinates, *model.rates]
    for number, orbit in enumerate(gaits, 1):
        x = np.array([orbit.state[n] for n in names])
        # The eigenvalue first: it widens the tolerance of the return below.
        estimate = _largest_eigenvalue(model, sim, params, orbit)
        if estimate is not None and not (
            abs(estimate - orbit.max_abs_eigenvalue) <= _EIGENVALUE_CHECK * max(1.0, estimate)
        ):
            return f"kept gait {number}: its largest |eigenvalue| is about {estimate:.4g}"
        problem = _returns(orbit, x, sim.step_phases(params, x))
        if problem is not None:
            return f"kept gait {number}: {problem}"
    shortest = _shortest_step(model, params)
    kept_states = [np.array([o.state[n] for n in names]) for o in gaits]
    left = [np.array([u["state"][n] for n in names]) for u in unconfirmed]
    stood = 0
    for y in found:
        kind, state, _ = _classify(model, sim, params, y, shortest)
        if kind == "stands":
            stood += 1
            continue
        if kind == "no step":
            continue
        scale = np.maximum(1.0, np.abs(state))
        same = [k for k, u in enumerate(left) if np.all(np.abs(u - state) <= 1e-12 * scale)]
        if same:
            left.pop(same[0])
            continue
        if not any(np.all(np.abs(g - state) <= _MATCH * scale) for g in kept_states):
            return "a Newton solution that steps is neither a kept gait nor an unconfirmed one"
    if stood != standing:
        return f"{stood} Newton solution(s) stand, not {standing}"
    if left:
        return "an unconfirmed solution kept is none of the search's"
    return None


_EIGENVALUE_CHECK = 2e-2
"""A kept gait's largest |eigenvalue| must agree with a finite-difference estimate to this
times max(1, |eigenvalue|). Measured at the passive walkers' default gaits: agreement to
1e-8 on the stable ones and 2e-3 at worst (the simplest walker's |eigenvalue| 948, whose
band of states that complete a step is about 0.01 wide)."""


def _largest_eigenvalue(
    model: HybridModel, sim: BatchSimulator, params: tuple[float, ...], orbit: Orbit
) -> float | None:
    """The largest |eigenvalue| of the step map at a gait, by central differences of batch
    steps in the free components (2 d steps, one call), or None where a shifted state does
    not complete its step. The map on the section's free components has the nonzero
    eigenvalues of the full state's monodromy (the reset puts every state on the
    section)."""
    free = free_components(model)
    names = [*model.coordinates, *model.rates]
    index = [names.index(n) for n in free]
    y = np.array([orbit.state[n] for n in free])
    h = 1e-6 * np.maximum(1.0, np.abs(y))
    shifts = np.eye(len(y)) * h
    rows = np.concatenate([y + shifts, y - shifts])
    result = sim.step(params, section_states(model, params, rows))
    if not np.all(result.outcome == WALKED):
        return None
    final = result.final[:, index]
    jacobian = ((final[: len(y)] - final[len(y) :]) / (2 * h[:, None])).T
    with np.errstate(all="ignore"):
        values = np.linalg.eigvals(jacobian) if np.all(np.isfinite(jacobian)) else None
    return None if values is None else float(np.max(np.abs(values)))


def _returns(orbit: Orbit, x: np.ndarray, simulated: Any) -> str | None:
    """Why the step ``simulated`` from the gait ``orbit`` (state ``x``) shows it is no
    gait, or None: the test :meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit` confirms an
    orbit with (back within 1e-9 of max(1, |state|) times max(1, |eigenvalue|)), and the
    step's phases, durations and length those kept."""
    if simulated.ended != "completed":
        return f"the step from it ends {simulated.ended}"
    if len(simulated.durations) != len(orbit.durations):
        return "the step from it passes other phases"
    scale = max(1.0, float(np.max(np.abs(x))))
    gap = float(np.max(np.abs(simulated.state - x)))
    if not gap <= 1e-9 * scale * max(1.0, orbit.max_abs_eigenvalue):
        return f"the step from it ends {gap:.3g} away"
    # The solver's durations against the simulated step's: both to about 1e-9.
    if not np.allclose(simulated.durations, orbit.durations, rtol=0, atol=1e-7 * orbit.period):
        return "its phase durations are not its step's"
    length, kept = simulated.step_length, orbit.step_length
    if (length is None) != (kept is None) or (
        kept is not None and not abs(length - kept) <= 1e-9 * max(1.0, abs(kept))
    ):
        return "its step length is not its step's"
    return None


def pick(gaits: Sequence[Orbit]) -> Orbit | None:
    """The gait the commands follow: the first stable one (by period), else the first."""
    stable = [o for o in gaits if o.stable]
    return (stable or list(gaits) or [None])[0]
