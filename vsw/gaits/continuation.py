"""A model's periodic gaits continued in one parameter, with their special points located.

The period-``k`` gait is the periodic-orbit problem of :mod:`vsw.orbits`
(:class:`~vsw.orbits.OrbitProblem`, the parameter free): unknowns ``u = (x_1..x_m,
T_1..T_m)`` (the start and the duration of each of the ``m`` phases of ``k`` steps),
residual ``R(u, lambda) = (each phase's guard at its end, its reset - the next phase's
start)`` (multiple shooting), with CasADi's derivatives. Continuation follows its solution
curve in ``w = (u, nu)``, ``lambda = start + nu (stop - start)``, by **pseudo-arclength**
(Keller; the vocabulary of AUTO, MatCont and COCO): at a point the tangent ``t`` solves
``[R_w; t_prev] t = (0, 1)``; the predictor is ``w + h t``; the corrector Newton's method
(:func:`vsw.orbits.newton.solve`) on ``(R(w) = 0, t . (w - w_pred) = 0)``, whose Jacobian
stays regular at a fold, so folds are passed, not stopped at. The step ``h`` grows by 1.5
after an easy correction and halves when the corrector fails or the tangent turns by more
than :data:`MAX_TURN`.

**Special points.** Along the branch, test functions whose sign changes between two points
bracket a special point, located by the Illinois method along the arclength (each trial
point corrected onto the branch) until the bracket is below :data:`LOCATE_TOL`:

* ``fold``: the tangent's parameter component (an eigenvalue of the map crosses +1);
* ``flip`` (period doubling): ``det(M + I)`` (an eigenvalue crosses -1);
* ``neimark-sacker``: the bialternate product ``prod_{i<j} (mu_i mu_j - 1)``, kept where a
  complex pair is on the unit circle (a real pair with ``mu_i mu_j = 1``, a neutral saddle,
  is no bifurcation and is not reported);
* ``boundary``: the branch leaves the gaits: a phase duration reaching zero (the event that
  ends it comes at its start: the VSW biped's heelstrike reaching the extension angle), or
  the step simulated from the orbit no longer confirming it (a failure's guard reached on
  the way, a guard grazed: the step ends otherwise), located by bisection; ``condition``
  names it. The branch ends at a boundary. A condition the model reports without enforcing
  it (``HYBRID["conditions"]``) whose margin (least over the step, sampled as
  :func:`vsw.dynamics.conditions.gait_conditions` samples it) changes sign is a boundary too,
  located by the Illinois method on that sampled margin, and the branch goes on past it.

``M`` is the Jacobian of the period-``k`` Poincaré map at the orbit
(:func:`vsw.orbits.monodromy.monodromy`). Every point of a branch is confirmed by the
simulated walk (SciPy's DOP853 with events: ``k`` steps return to ``x0``).

**Branch switching.** At a located flip the period-``2k`` problem's Jacobian is singular
(``M^2`` has the eigenvalue 1); its null vector orthogonal to the doubled period-``k``
branch is the new branch's direction, and a corrector from a small step along it lands on
the period-``2k`` gait, continued like any branch (to its own flip: the cascade).
The orbit's equations, the corrector, the tangent and the walk's confirmation are
:mod:`vsw.gaits.pseudo_arclength`, shared with the two-parameter curves of special points
(``vsw continue --free``, :mod:`vsw.gaits.special_curves`; :func:`continue_special_point` and
:class:`Curve` are read here too).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics import conditions
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.gaits.pseudo_arclength import (
    CONFIRM_TOL,
    MAX_TURN,
    RESIDUAL_TOL,
    Equations,
    Options,
    SpecialPoint,
    branch_tangent,
    confirm,
    correct,
    simulated_step,
)
from vsw.gaits.special_curves import Curve, continue_special_point
from vsw.runtime import stop
from vsw.runtime.errors import VswInputError

__all__ = [
    "CONFIRM_TOL",
    "LOCATE_TOL",
    "RESIDUAL_TOL",
    "Branch",
    "Curve",
    "Options",
    "SpecialPoint",
    "continue_gaits",
    "continue_special_point",
]

LOCATE_TOL = 1e-11
"""A special point is located when its bracket along the arclength is below this (the
arclength in the scaled unknowns: states, durations and the parameter as a fraction of its
range), or its test function is exactly zero."""


@dataclass
class _Point:
    """A point on a branch: the unknowns ``w = (x0, T, nu)``, the tangent there, the map's
    eigenvalues and the confirming simulation's step lengths."""

    w: np.ndarray
    tangent: np.ndarray
    eigenvalues: list[complex]
    iterations: int
    step_lengths: list[float | None] = field(default_factory=list)
    confirmed: str = "completed"  # or why the simulated walk does not confirm the orbit
    margins: dict[str, float] = field(default_factory=dict)  # reported conditions' margins


@dataclass
class Branch:
    """A branch of period-``period`` gaits: its points and located special points, and how
    it ended (``range``: the range's end; ``back at the start``: the range's start, which a
    branch reaches past a fold, or a period-doubled one running towards it; ``boundary``: a
    boundary point; ``lost``: the corrector failed at the smallest step; ``max points``)."""

    period: int
    points: list[dict[str, Any]]
    special_points: list[SpecialPoint]
    ended: str
    from_flip: float | None = None

    def to_dict(self) -> dict[str, Any]:
        return {
            "period": self.period,
            "from_flip": self.from_flip,
            "ended": self.ended,
            "points": self.points,
            "special_points": [s.to_dict() for s in self.special_points],
        }


def _point(eq: Equations, w: np.ndarray, jac: np.ndarray, previous: np.ndarray,
           iterations: int) -> _Point | None:  # fmt: skip
    tangent = branch_tangent(jac, previous)
    if tangent is None:
        return None
    eigenvalues = eq.eigenvalues(jac)
    confirmed, lengths = confirm(eq, w, eigenvalues)
    margins = _margins(eq, w, eigenvalues) if confirmed == "completed" else {}
    return _Point(w, tangent, eigenvalues, iterations, lengths, confirmed, margins)


def _margins(eq: Equations, w: np.ndarray, eigenvalues: list[complex]) -> dict[str, float]:
    """The margins of the conditions the model reports without enforcing them
    (``HYBRID["conditions"]``: the kneed walker's stance-knee stop) along a period-one
    orbit, least over the step sampled as :func:`vsw.dynamics.conditions.gait_conditions` samples
    it; none for other models or periods."""
    if eq.period != 1 or not eq.model.spec.get("conditions"):
        return {}
    durations = tuple(float(v) for v in eq.durations(w))
    orbit = Orbit(eq.state(w), durations, float(sum(durations)), tuple(eigenvalues), None, 0.0)
    found = conditions.gait_conditions(eq.model, eq.params_at(w[-1]), orbit)
    return {c["name"]: c["margin"] for c in found if not c["ends_walk"] and c["margin"] is not None}


# --- test functions ----------------------------------------------------------------------


def _fold(eq: Equations, p: _Point) -> float:
    return float(p.tangent[-1])


def _flip(eq: Equations, p: _Point) -> float:
    if not p.eigenvalues:  # undefined (a guard grazing at its phase's end): no sign
        return math.nan
    return float(np.real(np.prod([1.0 + mu for mu in p.eigenvalues])))


def _neimark_sacker(eq: Equations, p: _Point) -> float:
    mus = p.eigenvalues
    if not mus:
        return math.nan
    product = 1.0 + 0j
    for i in range(len(mus)):
        for j in range(i + 1, len(mus)):
            product *= mus[i] * mus[j] - 1.0
    return float(product.real)


def _duration(eq: Equations, p: _Point) -> float:
    return float(np.min(eq.durations(p.w)))


TESTS: dict[str, Callable[[Equations, _Point], float]] = {
    "fold": _fold,
    "flip": _flip,
    "neimark-sacker": _neimark_sacker,
    "boundary": _duration,
}
"""The test functions whose sign changes bracket a special point."""


def _defining(kind: str, eq: Equations, p: _Point) -> float:
    """The defining equation's value at a located point (0 at the exact point)."""
    mus = p.eigenvalues or [complex(math.nan)]
    if kind == "fold":
        return min(abs(mu - 1.0) for mu in mus)
    if kind == "flip":
        return min(abs(mu + 1.0) for mu in mus)
    if kind == "neimark-sacker":
        pairs = [mu for mu in mus if mu.imag > 1e-9]
        return min((abs(abs(mu) - 1.0) for mu in pairs), default=math.inf)
    return abs(_duration(eq, p))


def _along(eq: Equations, a: _Point, s: float) -> _Point | None:
    """The branch's point at arclength ``s`` from ``a`` along ``a``'s tangent (corrected in
    the plane normal to it)."""
    anchor = a.w + s * a.tangent
    solved = correct(eq, anchor, a.tangent, anchor)
    if solved is None:
        return None
    w, jac, iterations = solved
    return _point(eq, w, jac, a.tangent, iterations)


def _locate_root(
    eq: Equations, a: _Point, b: _Point, h: float, test: Callable[[Equations, _Point], float]
) -> tuple[_Point, float] | None:  # fmt: skip
    """The point between ``a`` (s = 0) and ``b`` (s = h) where ``test`` vanishes (Illinois
    method), with its s; None where a trial point cannot be corrected."""
    lo, hi = 0.0, h
    f_lo, f_hi = test(eq, a), test(eq, b)
    best = (b, h) if abs(f_hi) < abs(f_lo) else (a, 0.0)
    side = 0
    for _ in range(100):
        if abs(hi - lo) <= LOCATE_TOL:
            break
        s = hi - f_hi * (hi - lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (lo + hi)
        if not (min(lo, hi) < s < max(lo, hi)):
            s = 0.5 * (lo + hi)
        p = _along(eq, a, s)
        if p is None:
            return None
        f = test(eq, p)
        best = (p, s)
        if f == 0.0:
            break
        if (f > 0) == (f_hi > 0):
            hi, f_hi = s, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            lo, f_lo = s, f
            if side == -1:
                f_hi *= 0.5
            side = -1
    return best


def _locate_boundary(eq: Equations, a: _Point, h: float) -> tuple[_Point, _Point, float]:
    """Bisection on the simulated walk's confirmation between ``a`` (confirmed, s = 0) and
    s = ``h`` (not): the last confirmed point, the first unconfirmed and the bracket."""
    lo, hi = 0.0, h
    good, bad = a, None
    while hi - lo > LOCATE_TOL:
        s = 0.5 * (lo + hi)
        p = _along(eq, a, s)
        if p is None:
            break
        if p.confirmed == "completed":
            lo, good = s, p
        else:
            hi, bad = s, p
    return good, bad, hi - lo


def _special(eq: Equations, kind: str, p: _Point, condition: str | None = None,
             defining: float | None = None) -> SpecialPoint:  # fmt: skip
    return SpecialPoint(
        type=kind,
        defining=_defining(kind, eq, p) if defining is None else defining,
        condition=condition,
        record=_record(eq, p),
        eigenvalues=p.eigenvalues,
    )


def _record(eq: Equations, p: _Point) -> dict[str, Any]:
    """A branch point as JSON: ``vsw continue --json``'s ``points``."""
    durations = eq.durations(p.w)
    period = float(np.sum(durations))
    largest = max([abs(mu) for mu in p.eigenvalues] or [math.nan])
    lengths = p.step_lengths
    known = [v for v in lengths if v is not None]
    length = float(np.mean(known)) if known and len(known) == len(lengths) else None
    names = [*eq.model.coordinates, *eq.model.rates]
    starts = eq.problem.section_states(p.w)
    return {
        "parameter": eq.parameter(float(p.w[-1])),
        "state": eq.state(p.w),
        "section_states": [dict(zip(names, (float(v) for v in x))) for x in starts],
        "step_periods": eq.problem.step_periods(p.w),
        "period_time": period,
        "phase_durations": [float(v) for v in durations],
        "eigenvalues": [[float(e.real), float(e.imag)] for e in p.eigenvalues],
        "max_abs_eigenvalue": largest,
        "stable": bool(largest < 1.0),
        "step_length": length,
        "step_lengths": lengths,
        "speed": None if length is None else float(sum(known)) / period,
        **({"condition_margins": dict(p.margins)} if p.margins else {}),
    }


def _neutral_saddle(p: _Point) -> bool:
    """A Neimark-Sacker test zero without a complex pair on the unit circle."""
    return not any(mu.imag > 1e-9 and abs(abs(mu) - 1.0) < 1e-6 for mu in p.eigenvalues)


def _trace(eq: Equations, first: _Point, options: Options) -> Branch:
    """Follow the branch from ``first`` in its tangent's direction to the range's end, a
    boundary, or until it is lost."""
    points, specials = [first], []
    h = options.initial_step
    ended = "max points"
    while len(points) < options.max_points:
        stop.check()
        a = points[-1]
        b = _along(eq, a, h)
        if b is not None and (b.tangent @ a.tangent < math.cos(MAX_TURN)):
            b = None  # turned too far: another branch, or a fold taken too fast
        if b is None:
            h *= 0.5
            if h < options.min_step:
                ended = "lost"
                break
            continue
        nu_b = float(b.w[-1])
        leaving = nu_b > 1.0 or nu_b < 0.0
        if leaving:
            # Land on the range's end: the point where nu reaches it (a root of nu - end).
            end = 1.0 if nu_b > 1.0 else 0.0
            found = _locate_root(eq, a, b, h, lambda _eq, p, end=end: float(p.w[-1]) - end)
            if found is None:
                ended = "lost"
                break
            b, h = found
        found_specials, boundary = _between(eq, a, b, h)
        specials.extend(found_specials)
        if boundary is not None:
            last, special = boundary
            specials.append(special)
            if last is not a and last.confirmed == "completed":
                points.append(last)
            ended = "boundary"
            break
        points.append(b)
        if leaving:
            ended = "range" if nu_b > 1.0 else "back at the start"
            break
        if b.iterations <= 3:
            h = min(1.5 * h, options.max_step)
    return Branch(eq.period, [_record(eq, p) for p in points], specials, ended)


def _between(eq: Equations, a: _Point, b: _Point, h: float) -> tuple[list, tuple | None]:
    """The special points between consecutive points ``a`` and ``b`` (``h`` apart), in
    order, and the boundary that ends the branch there, if any: (last gait, its point)."""
    found: list[tuple[float, SpecialPoint]] = []
    boundary: tuple[float, _Point, SpecialPoint] | None = None
    if _duration(eq, b) <= 0.0 < _duration(eq, a):
        located = _locate_root(eq, a, b, h, _duration)
        if located is not None:
            p, s = located
            phase = eq.sequence[int(np.argmin(eq.durations(p.w)))][0]
            record = eq.model.phases[eq.model.phase_index[phase]]
            # A failure the phase checks where it begins is the model's word for a step
            # whose event has already passed (the VSW bipeds' extension-missed).
            named = [f[0] for f in record.get("start_failures", ())]
            special = _special(eq, "boundary", p, f"phase {phase} of no duration (the event "
                               "that ends it comes at its start)"
                               + (f"; past it the walk ends: {', '.join(named)}" if named
                                  else ""))  # fmt: skip
            boundary = (s, p, special)
    if boundary is None and b.confirmed != "completed":
        good, bad, _ = _locate_boundary(eq, a, h)
        why = bad.confirmed if bad is not None else b.confirmed
        gap = abs(float((bad if bad is not None else b).w[-1] - good.w[-1]))
        special = _special(eq, "boundary", good, f"the simulated walk: {why}",
                           defining=abs(eq.width) * gap)  # fmt: skip
        boundary = (float(a.tangent @ (good.w - a.w)), good, special)
    limit = boundary[0] if boundary is not None else h
    # (type, test function, condition): the bifurcations, then each reported condition.
    tests: list[tuple[str, Callable[[Equations, _Point], float], str | None]] = [
        (kind, TESTS[kind], None) for kind in ("fold", "flip", "neimark-sacker")
    ]
    for name in sorted(set(a.margins) & set(b.margins)):
        tests.append((
            "boundary",
            lambda _eq, p, name=name: p.margins.get(name, math.nan),
            f"condition {name} (reported, not enforced): its margin reaches 0",
        ))  # fmt: skip
    for kind, test, condition in tests:
        f_a, f_b = test(eq, a), test(eq, b)
        if not (np.isfinite(f_a) and np.isfinite(f_b)) or (f_a > 0) == (f_b > 0) or f_a == 0:
            continue
        located = _locate_root(eq, a, b, h, test)
        if located is None or not math.isfinite(test(eq, located[0])):
            continue
        p, s = located
        if s > limit or (kind == "neimark-sacker" and _neutral_saddle(p)):
            continue
        defining = None if condition is None else abs(test(eq, p))
        found.append((s, _special(eq, kind, p, condition, defining)))
    found.sort(key=lambda item: item[0])
    out = [special for _, special in found]
    return out, (None if boundary is None else (boundary[1], boundary[2]))


def _start(eq: Equations, state: np.ndarray, durations: Sequence[float]) -> _Point:
    """The first point: the orbit at the range's start from a guess (nu fixed at 0);
    VswInputError where the guess leads to no gait."""
    where = f"at {eq.parameter(0.0):g}"
    try:
        guess = eq.unknowns(state, durations, 0.0)
    except RuntimeError:
        stop.check()
        raise VswInputError(
            f"{eq.model.name}: the start's phases could not be integrated"
        ) from None
    normal = np.zeros_like(guess)
    normal[-1] = 1.0
    solved = correct(eq, guess, normal, np.zeros_like(guess), max_iterations=40)
    if solved is None:
        raise VswInputError(f"{eq.model.name}: no period-{eq.period} gait {where} near the start "
                            "(the orbit's corrector did not converge from it)")  # fmt: skip
    w, jac, iterations = solved
    if np.any(eq.durations(w) <= 0):
        raise VswInputError(f"{eq.model.name}: no gait {where} near the start (the corrector "
                            "converged to a phase of no positive duration)")  # fmt: skip
    p = _point(eq, w, jac, normal, iterations)
    if p is None or abs(p.tangent[-1]) < 1e-9:
        raise VswInputError(f"{eq.model.name}: the start is at a fold of the branch: start the "
                            "range elsewhere")  # fmt: skip
    if p.confirmed != "completed":
        raise VswInputError(f"{eq.model.name}: no gait {where} near the start: {p.confirmed}")
    shorter = _least_period(eq, w)
    if shorter < eq.period:
        raise VswInputError(f"{eq.model.name}: the start leads to a period-{shorter} gait {where}, "
                            f"not period {eq.period}: give a point of a period-{eq.period} "
                            "gait")  # fmt: skip
    return p  # its tangent points to larger nu: [R_w; e_nu] t = (0, 1)


def _switch(eq: Equations, flip: SpecialPoint) -> tuple[Equations, _Point] | None:
    """The period-2k problem and the first point of its branch born at ``flip`` on the
    period-k branch of ``eq`` (module docstring), or None where the corrector does not
    reach it."""
    double = Equations(eq.model, eq.params, eq.index, eq.start, eq.start + eq.width,
                        2 * eq.period)  # fmt: skip
    nu = (flip.parameter - eq.start) / eq.width
    try:
        single_w = eq.unknowns(np.array(list(flip.state.values())), flip.durations, nu)
        _, single_jac = eq.evaluate(single_w)
        cut = eq.n * eq.m
        w0 = np.concatenate([single_w[:cut], single_w[:cut], single_w[cut:-1],
                             single_w[cut:-1], [nu]])  # fmt: skip
        _, jac = double.evaluate(w0)
    except RuntimeError:
        stop.check()
        return None
    single_t = branch_tangent(single_jac, np.eye(single_jac.shape[1])[-1])
    if single_t is None or not np.all(np.isfinite(jac)):
        return None
    # The null space of R_w is two-dimensional at a period doubling: the doubled period-k
    # branch's own direction and the new branch's. Project the null basis off the first.
    starts, times = single_t[:cut], single_t[cut:-1]
    along = np.concatenate([starts, starts, times, times, single_t[-1:]])
    along /= np.linalg.norm(along)
    try:
        null = np.linalg.svd(jac)[2][-2:]
    except np.linalg.LinAlgError:
        return None
    across = max((v - (v @ along) * along for v in null), key=np.linalg.norm)
    across /= np.linalg.norm(across)
    for h in (1e-3, 3e-3, 1e-2, 3e-2):
        anchor = w0 + h * across
        solved = correct(double, anchor, across, anchor)
        if solved is None:
            continue
        w, jac2, iterations = solved
        if _least_period(double, w) < double.period:
            continue  # back on the period-k gait
        p = _point(double, w, jac2, across, iterations)
        if p is None or p.confirmed != "completed":
            continue
        if p.tangent @ (w - w0) < 0:
            p.tangent = -p.tangent
        return double, p
    return None


def _least_period(eq: Equations, w: np.ndarray) -> int:
    """The least number of simulated steps, a divisor of ``eq.period``, after which the
    orbit's state returns to x0 (within 1e-7 x max(1, |x0|)); ``eq.period`` where none
    fewer does or a step fails."""
    params = eq.params_at(w[-1])
    x0 = eq.x0(w)
    x = x0.copy()
    for k in range(1, eq.period):
        step = simulated_step(eq.model, params, x)
        if isinstance(step, str) or step.ended != "completed":
            return eq.period
        x = step.state
        if eq.period % k == 0 and np.max(np.abs(x - x0)) <= 1e-7 * max(1.0, np.max(np.abs(x0))):
            return k
    return eq.period


def continue_gaits(
    model: HybridModel,
    params: Sequence[float],
    over: str,
    start: float,
    stop_value: float,
    state: Sequence[float],
    durations: Sequence[float],
    period: int = 1,
    options: Options | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[Branch]:
    """The branch of period-``period`` gaits through ``state`` (at ``over = start``; its
    phase durations ``durations`` are the guess) continued to ``over = stop_value``, and,
    with ``options.switch``, the period-doubled branches born at each flip it locates (up
    to ``options.max_period``), in the order found.

    Parameters
    ----------
    model : HybridModel
    params : sequence of float
        The parameter vector (``over``'s own value is replaced along the branch).
    over : str
        The parameter continued in.
    start, stop_value : float
        The range.
    state, durations : sequence of float
        A guess of the gait at ``start``: its section state and each phase's duration
        over ``period`` steps.
    """
    options = options or Options()
    names = [p.name for p in model.parameter_table]
    if over not in names:
        raise VswInputError(f"{over!r} is not a parameter of {model.name}: {', '.join(names)}")
    if not start != stop_value:
        raise VswInputError(f"the range of {over} is empty: give START != STOP")
    index = names.index(over)
    eq = Equations(model, params, index, start, stop_value, period)
    first = _start(eq, np.asarray(state, float), durations)
    branches: list[Branch] = []
    queue: list[tuple[Equations, _Point, float | None]] = [(eq, first, None)]
    while queue:
        current, point, born = queue.pop(0)
        branch = _trace(current, point, options)
        branch.from_flip = born
        branches.append(branch)
        if progress is not None:
            progress(len(branches), len(branches) + len(queue))
        if not options.switch or 2 * current.period > options.max_period:
            continue
        for special in branch.special_points:
            if special.type != "flip":
                continue
            child = _switch(current, special)
            if child is not None:
                queue.append((*child, special.parameter))
    return branches
