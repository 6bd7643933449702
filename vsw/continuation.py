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
  :func:`vsw.conditions.gait_conditions` samples it) changes sign is a boundary too, located
  by the Illinois method on that sampled margin, and the branch goes on past it.

``M`` is the Jacobian of the period-``k`` Poincaré map at the orbit
(:func:`vsw.orbits.monodromy.monodromy`). Every point of a branch is confirmed by the
simulated walk (SciPy's DOP853 with events: ``k`` steps return to ``x0``).

**Branch switching.** At a located flip the period-``2k`` problem's Jacobian is singular
(``M^2`` has the eigenvalue 1); its null vector orthogonal to the doubled period-``k``
branch is the new branch's direction, and a corrector from a small step along it lands on
the period-``2k`` gait, continued like any branch (to its own flip: the cascade).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw import conditions, stop
from vsw.errors import ConvergenceError, VswInputError
from vsw.hybrid import HybridModel, Orbit
from vsw.orbits import OrbitProblem, newton, phase_sequence

__all__ = [
    "LOCATE_TOL",
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

RESIDUAL_TOL = 1e-10
"""The corrector's tolerance on the residual, relative to max(1, |unknowns|)."""

MAX_TURN = 0.3
"""Largest angle (rad) between the tangents of two consecutive points."""

BOUNDARY_NUDGE = 1e-9
"""On a boundary curve, the second parameter's move (a fraction of its range) with which a
point is also confirmed, a hair inside the boundary (:func:`_curve_confirmed`)."""
CONFIRM_TOL = 1e-8
"""The simulated ``k`` steps must return to ``x0`` within this (relative to max(1, |x0|),
times the largest |eigenvalue| on an unstable gait)."""


@dataclass(frozen=True)
class Options:
    """How a branch is followed: steps in the scaled unknowns (the parameter as a fraction
    of its range), the most points per branch, and branch switching."""

    initial_step: float = 0.01
    max_step: float = 0.05
    min_step: float = 1e-7
    max_points: int = 400
    switch: bool = True
    max_period: int = 16


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
class SpecialPoint:
    """A located special point: ``type`` (fold, flip, neimark-sacker, boundary), the
    defining equation's value there (|mu - 1|, |mu + 1|, ||mu| - 1| of the critical
    eigenvalue, the phase duration; for a boundary found by bisection the bracket's width
    in the parameter), for a boundary the condition, and the gait there as a branch point's
    record (parameter, state, eigenvalues, step lengths, ...)."""

    type: str
    defining: float
    condition: str | None
    record: dict[str, Any]
    eigenvalues: list[complex]

    @property
    def parameter(self) -> float:
        return float(self.record["parameter"])

    @property
    def state(self) -> dict[str, float]:
        return dict(self.record["state"])

    @property
    def durations(self) -> list[float]:
        return list(self.record["phase_durations"])

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type,
            "parameter": self.parameter,
            "defining_equation": self.defining,
            "condition": self.condition,
            **{k: v for k, v in self.record.items() if k != "parameter"},
        }


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


class _Equations:
    """The period-``period`` orbit's residual in ``w = (u, nu)``: the periodic-orbit
    problem (:class:`vsw.orbits.OrbitProblem`, ``over`` free) with ``over`` scaled to its
    range, and its Jacobian."""

    def __init__(
        self, model: HybridModel, params: Sequence[float], index: int,
        start: float, stop_value: float, period: int,
    ) -> None:  # fmt: skip
        self.model = model
        self.params = np.asarray(params, dtype=float)
        self.index = index
        self.start = start
        self.width = stop_value - start
        self.period = period
        self.problem = OrbitProblem(model, period, (index,))
        self.n = self.problem.n
        self.sequence = self.problem.sequence
        self.m = self.problem.m

    def parameter(self, nu: float) -> float:
        return self.start + nu * self.width

    def params_at(self, nu: float) -> np.ndarray:
        p = self.params.copy()
        p[self.index] = self.parameter(nu)
        return p

    def x0(self, w: np.ndarray) -> np.ndarray:
        """The section state (the first phase's start)."""
        return self.problem.section_state(w)

    def durations(self, w: np.ndarray) -> np.ndarray:
        return self.problem.durations(w)

    def unknowns(self, x0: np.ndarray, durations: Sequence[float], nu: float) -> np.ndarray:
        """``w`` from the section state and the phase durations (each phase's start by the
        flows and resets from ``x0``)."""
        return np.concatenate([self.problem.unknowns(self.params_at(nu), x0, durations), [nu]])

    def evaluate(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """R(w) and [R_u, R_nu]; RuntimeError where CVODES fails."""
        r, j_u, j_p = self.problem.evaluate(w[:-1], self.params_at(w[-1]))
        return r, np.hstack([j_u, j_p * self.width])

    def eigenvalues(self, jac: np.ndarray) -> list[complex]:
        """The eigenvalues of the period-k Poincaré map at the orbit (its monodromy
        matrix, :mod:`vsw.orbits.monodromy`), from the residual's Jacobian."""
        return self.problem.eigenvalues(jac)

    def state(self, w: np.ndarray) -> dict[str, float]:
        return self.problem.state(w)


class _Corrector:
    """``eq``'s residual (``eq.evaluate``) as :class:`vsw.orbits.newton.System` for one
    iterate; a point CVODES cannot integrate is a row of NaN."""

    def __init__(self, eq: Any) -> None:
        self.eq = eq
        self.last = np.empty((1, 0, 0))

    def residual(self, w: np.ndarray, rows: np.ndarray) -> np.ndarray:
        try:
            r, jac = self.eq.evaluate(w[0])
        except RuntimeError:
            stop.check()  # CasADi turns Ctrl-C and the time limit into this error
            self.last = np.full((1, 1, w.shape[1]), np.nan)
            return np.full((1, 1), np.nan)
        self.last = jac[None]
        return r[None]

    def jacobian(self, which: np.ndarray) -> np.ndarray:
        return self.last[which]

    def scale(self, w: np.ndarray) -> np.ndarray:
        return np.maximum(1.0, np.max(np.abs(w[:, :-1]), axis=1))


def _tangent(jac: np.ndarray, previous: np.ndarray) -> np.ndarray | None:
    """The unit tangent of the branch: [R_w; previous] t = (0, 1), normalised; the sign
    follows ``previous``."""
    system = np.vstack([jac, previous])
    rhs = np.zeros(len(system))
    rhs[-1] = 1.0
    try:
        t = np.linalg.solve(system, rhs)
    except np.linalg.LinAlgError:
        return None
    size = np.linalg.norm(t)
    return t / size if np.isfinite(size) and size > 0 else None


def _correct(
    eq: Any, guess: np.ndarray, normal: np.ndarray, anchor: np.ndarray, max_iterations: int = 12
) -> tuple[np.ndarray, np.ndarray, int] | None:
    """Newton (:func:`vsw.orbits.newton.solve`) on (R(w) = 0, normal . (w - anchor) = 0)
    from ``guess``, to :data:`RESIDUAL_TOL` with a last step below 1e-9 (both relative to
    max(1, |unknowns|)): (w, Jacobian of R at w, iterations), or None where it does not
    converge."""
    found = newton.solve(_Corrector(eq), np.asarray(guess, float)[None], tol=RESIDUAL_TOL,
                         step_tol=1e-9, max_iterations=max_iterations,
                         border=(normal, anchor))  # fmt: skip
    if not found.converged[0]:
        return None
    return found.w[0], found.jacobian[0], int(found.iterations[0])


def _confirm(eq: _Equations, w: np.ndarray, eigenvalues: list[complex]) -> tuple[str, list]:
    """The orbit confirmed by the simulated walk: ``period`` steps from x0 with every phase,
    back to x0. Returns ('completed', step lengths) or (why not, [])."""
    model = eq.model
    params = eq.params_at(w[-1])
    x0 = eq.x0(w)
    x = x0.copy()
    lengths: list[float | None] = []
    phases = len(phase_sequence(model))
    for _ in range(eq.period):
        step = _step(model, params, x)
        if isinstance(step, str):
            return step, []
        if step.ended != "completed":
            return step.ended, []
        if len(step.durations) != phases:
            return "a phase skipped or added (a guard grazed)", []
        lengths.append(step.step_length)
        x = step.state
    largest = max([abs(e) for e in eigenvalues] or [1.0])
    scale = max(1.0, float(np.max(np.abs(x0))))
    gap = float(np.max(np.abs(x - x0)))
    if not gap <= CONFIRM_TOL * scale * max(1.0, largest):
        return f"the simulated walk ends {gap:.3g} away from the orbit", []
    return "completed", lengths


def _step(model: HybridModel, params: np.ndarray, x: np.ndarray) -> Any:
    """One simulated step, or why it could not be taken (a solver's failure at extreme
    states is a point the walk does not confirm, not the end of the run)."""
    try:
        return model.step(params, x)
    except (ConvergenceError, OverflowError, ZeroDivisionError, FloatingPointError) as exc:
        stop.check()
        return f"the simulated step failed ({' '.join(str(exc).split())[:80]})"


def _point(eq: _Equations, w: np.ndarray, jac: np.ndarray, previous: np.ndarray,
           iterations: int) -> _Point | None:  # fmt: skip
    tangent = _tangent(jac, previous)
    if tangent is None:
        return None
    eigenvalues = eq.eigenvalues(jac)
    confirmed, lengths = _confirm(eq, w, eigenvalues)
    margins = _margins(eq, w, eigenvalues) if confirmed == "completed" else {}
    return _Point(w, tangent, eigenvalues, iterations, lengths, confirmed, margins)


def _margins(eq: _Equations, w: np.ndarray, eigenvalues: list[complex]) -> dict[str, float]:
    """The margins of the conditions the model reports without enforcing them
    (``HYBRID["conditions"]``: the kneed walker's stance-knee stop) along a period-one
    orbit, least over the step sampled as :func:`vsw.conditions.gait_conditions` samples
    it; none for other models or periods."""
    if eq.period != 1 or not eq.model.spec.get("conditions"):
        return {}
    durations = tuple(float(v) for v in eq.durations(w))
    orbit = Orbit(eq.state(w), durations, float(sum(durations)), tuple(eigenvalues), None, 0.0)
    found = conditions.gait_conditions(eq.model, eq.params_at(w[-1]), orbit)
    return {c["name"]: c["margin"] for c in found if not c["ends_walk"] and c["margin"] is not None}


# --- test functions ----------------------------------------------------------------------


def _fold(eq: _Equations, p: _Point) -> float:
    return float(p.tangent[-1])


def _flip(eq: _Equations, p: _Point) -> float:
    if not p.eigenvalues:  # undefined (a guard grazing at its phase's end): no sign
        return math.nan
    return float(np.real(np.prod([1.0 + mu for mu in p.eigenvalues])))


def _neimark_sacker(eq: _Equations, p: _Point) -> float:
    mus = p.eigenvalues
    if not mus:
        return math.nan
    product = 1.0 + 0j
    for i in range(len(mus)):
        for j in range(i + 1, len(mus)):
            product *= mus[i] * mus[j] - 1.0
    return float(product.real)


def _duration(eq: _Equations, p: _Point) -> float:
    return float(np.min(eq.durations(p.w)))


TESTS: dict[str, Callable[[_Equations, _Point], float]] = {
    "fold": _fold,
    "flip": _flip,
    "neimark-sacker": _neimark_sacker,
    "boundary": _duration,
}
"""The test functions whose sign changes bracket a special point."""


def _defining(kind: str, eq: _Equations, p: _Point) -> float:
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


def _along(eq: _Equations, a: _Point, s: float) -> _Point | None:
    """The branch's point at arclength ``s`` from ``a`` along ``a``'s tangent (corrected in
    the plane normal to it)."""
    anchor = a.w + s * a.tangent
    solved = _correct(eq, anchor, a.tangent, anchor)
    if solved is None:
        return None
    w, jac, iterations = solved
    return _point(eq, w, jac, a.tangent, iterations)


def _locate_root(
    eq: _Equations, a: _Point, b: _Point, h: float, test: Callable[[_Equations, _Point], float]
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


def _locate_boundary(eq: _Equations, a: _Point, h: float) -> tuple[_Point, _Point, float]:
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


def _special(eq: _Equations, kind: str, p: _Point, condition: str | None = None,
             defining: float | None = None) -> SpecialPoint:  # fmt: skip
    return SpecialPoint(
        type=kind,
        defining=_defining(kind, eq, p) if defining is None else defining,
        condition=condition,
        record=_record(eq, p),
        eigenvalues=p.eigenvalues,
    )


def _record(eq: _Equations, p: _Point) -> dict[str, Any]:
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


def _trace(eq: _Equations, first: _Point, options: Options) -> Branch:
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


def _between(eq: _Equations, a: _Point, b: _Point, h: float) -> tuple[list, tuple | None]:
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
    tests: list[tuple[str, Callable[[_Equations, _Point], float], str | None]] = [
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


def _start(eq: _Equations, state: np.ndarray, durations: Sequence[float]) -> _Point:
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
    solved = _correct(eq, guess, normal, np.zeros_like(guess), max_iterations=40)
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


def _switch(eq: _Equations, flip: SpecialPoint) -> tuple[_Equations, _Point] | None:
    """The period-2k problem and the first point of its branch born at ``flip`` on the
    period-k branch of ``eq`` (module docstring), or None where the corrector does not
    reach it."""
    double = _Equations(eq.model, eq.params, eq.index, eq.start, eq.start + eq.width,
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
    single_t = _tangent(single_jac, np.eye(single_jac.shape[1])[-1])
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
        solved = _correct(double, anchor, across, anchor)
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


def _least_period(eq: _Equations, w: np.ndarray) -> int:
    """The least number of simulated steps, a divisor of ``eq.period``, after which the
    orbit's state returns to x0 (within 1e-7 x max(1, |x0|)); ``eq.period`` where none
    fewer does or a step fails."""
    params = eq.params_at(w[-1])
    x0 = eq.x0(w)
    x = x0.copy()
    for k in range(1, eq.period):
        step = _step(eq.model, params, x)
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
    eq = _Equations(model, params, index, start, stop_value, period)
    first = _start(eq, np.asarray(state, float), durations)
    branches: list[Branch] = []
    queue: list[tuple[_Equations, _Point, float | None]] = [(eq, first, None)]
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


# --- two parameters: the curve of a special point ------------------------------------------


@dataclass
class Curve:
    """A special point continued in two parameters: its ``type`` (and for a boundary its
    condition), the point it started from, and the curve's points, each the gait where the
    defining equation holds: (parameter, second_parameter, state, eigenvalues, defining
    equation's value). ``ended``: how each of its two directions ended (``box``: the range
    of a parameter; ``lost``; ``max points``; or the simulated walk's reason)."""

    type: str
    condition: str | None
    second: str
    start: dict[str, Any]
    points: list[dict[str, Any]]
    ended: list[str]

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type,
            "condition": self.condition,
            "second_parameter_name": self.second,
            "from": self.start,
            "ended": self.ended,
            "points": self.points,
        }


class _CurveEquations:
    """(R(u, lambda, mu) = 0, psi(u, lambda, mu) = 0) in ``W = (u, nu, nu2)``: the orbit and
    the special point's defining function ``psi`` (1 + the eigenvalue nearest -1 at a flip,
    the eigenvalue nearest +1 less 1 at a fold, |mu|^2 - 1 of the complex pair nearest the
    unit circle at a Neimark-Sacker point, the phase's duration at a boundary). R's
    derivatives are CasADi's; psi's by forward differences of the eigenvalues (step 1e-7)."""

    def __init__(self, eq: _Equations, index2: int, start2: float, stop2: float, kind: str,
                 phase: int | None) -> None:  # fmt: skip
        self.eq = eq
        self.model = eq.model
        self.index2 = index2
        self.start2 = start2
        self.width2 = stop2 - start2
        self.kind = kind
        self.phase = phase
        self.n = eq.n
        self.problem = OrbitProblem(eq.model, eq.period, (eq.index, index2))

    def params_at(self, w: np.ndarray) -> np.ndarray:
        p = self.eq.params_at(w[-2])
        p[self.index2] = self.start2 + w[-1] * self.width2
        return p

    def _orbit(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r, j_u, j_1, j_2 = self.problem.evaluate(w[:-2], self.params_at(w))
        return r, np.hstack([j_u, j_1 * self.eq.width, j_2 * self.width2])

    def psi(self, w: np.ndarray, jac: np.ndarray) -> float:
        if self.kind == "boundary":
            return float(self.eq.durations(w[:-1])[self.phase])
        mus = self.eq.eigenvalues(jac[:, :-1])
        if not mus:
            return math.nan
        if self.kind == "flip":
            return float(min(mus, key=lambda mu: abs(mu + 1)).real + 1.0)
        if self.kind == "fold":
            return float(min(mus, key=lambda mu: abs(mu - 1)).real - 1.0)
        pairs = [mu for mu in mus if mu.imag > 1e-9] or mus
        return float(abs(min(pairs, key=lambda mu: abs(abs(mu) - 1))) ** 2 - 1.0)

    def evaluate(self, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        r, jac = self._orbit(w)
        psi = self.psi(w, jac)
        gradient = np.empty(len(w))
        for j in range(len(w)):
            h = 1e-7 * max(1.0, abs(w[j]))
            shifted = w.copy()
            shifted[j] += h
            gradient[j] = (self.psi(shifted, self._orbit(shifted)[1]) - psi) / h
        return np.concatenate([r, [psi]]), np.vstack([jac, gradient])


def _curve_record(ce: _CurveEquations, w: np.ndarray, jac: np.ndarray) -> dict[str, Any]:
    p = ce.params_at(w)
    mus = ce.eq.eigenvalues(jac[:-1, :-1])
    return {
        "parameter": float(p[ce.eq.index]),
        "second_parameter": float(p[ce.index2]),
        "state": ce.eq.state(w),
        "phase_durations": [float(v) for v in ce.eq.durations(w[:-1])],
        "eigenvalues": [[float(e.real), float(e.imag)] for e in mus],
        "defining_equation": abs(float(ce.psi(w, jac[:-1]))),
    }


def _curve_confirmed(ce: _CurveEquations, w: np.ndarray, jac: np.ndarray) -> str:
    """The simulated walk's confirmation of a curve point (:func:`_confirm`).

    On a boundary curve the phase has no duration: the walk from the point starts on its
    failure's threshold (the biped's heelstrike lands on theta_II, where a step "begins
    past theta_II" by the rounding of the solution: +-1e-13), a tie that rounding decides.
    There the walk is also confirmed a hair inside: the second parameter moved by
    BOUNDARY_NUDGE of its range, either way (the orbit moves by as little, far below
    CONFIRM_TOL); the point counts if either walk completes."""
    eigenvalues = ce.eq.eigenvalues(jac[:-1, :-1])
    tries = (
        [w]
        if ce.kind != "boundary"
        else [w, *(w + np.eye(len(w))[-1] * d for d in (BOUNDARY_NUDGE, -BOUNDARY_NUDGE))]
    )
    confirmed = "completed"
    for k, point in enumerate(tries):
        single = _Equations(ce.model, ce.params_at(point), ce.eq.index, ce.eq.start,
                            ce.eq.start + ce.eq.width, ce.eq.period)  # fmt: skip
        outcome = _confirm(single, point[:-1], eigenvalues)[0]
        if outcome == "completed":
            return outcome
        if k == 0:
            confirmed = outcome
    return confirmed


def _trace_curve(ce: _CurveEquations, w0: np.ndarray, direction: np.ndarray,
                 options: Options) -> tuple[list[dict[str, Any]], str]:  # fmt: skip
    """One direction of the curve from ``w0``: its points (without ``w0``) and its end."""
    out: list[dict[str, Any]] = []
    w, t = w0, direction
    h = options.initial_step
    while len(out) < options.max_points:
        stop.check()
        anchor = w + h * t
        solved = _correct(ce, anchor, t, anchor)
        t_new = None if solved is None else _tangent(solved[1], t)
        if t_new is None or t_new @ t < math.cos(MAX_TURN):
            h *= 0.5
            if h < options.min_step:
                return out, "lost"
            continue
        w_new, jac, iterations = solved
        if not (0.0 <= w_new[-2] <= 1.0 and 0.0 <= w_new[-1] <= 1.0):
            return out, "box"
        confirmed = _curve_confirmed(ce, w_new, jac)
        if confirmed != "completed":
            return out, f"the simulated walk: {confirmed}"
        out.append(_curve_record(ce, w_new, jac))
        w, t = w_new, t_new
        if iterations <= 3:
            h = min(1.5 * h, options.max_step)
    return out, "max points"


def continue_special_point(
    model: HybridModel,
    params: Sequence[float],
    over: str,
    start: float,
    stop_value: float,
    special: SpecialPoint,
    period: int,
    second: str,
    second_start: float,
    second_stop: float,
    options: Options | None = None,
) -> Curve:
    """The curve in (``over``, ``second``) along which ``special`` (located on a
    period-``period`` branch continued in ``over`` over [start, stop_value]) persists,
    both ways from it, within both ranges.

    Raises VswInputError for a boundary that no phase duration defines (a failure reached
    on the way: no smooth defining equation), or ``second`` equal to ``over``."""
    options = options or Options()
    names = [p.name for p in model.parameter_table]
    if second not in names:
        raise VswInputError(f"{second!r} is not a parameter of {model.name}: {', '.join(names)}")
    if second == over:
        raise VswInputError(f"--free {second}: the second parameter must differ from --over's")
    eq = _Equations(model, params, names.index(over), start, stop_value, period)
    index2 = names.index(second)
    value2 = float(params[index2])
    if not min(second_start, second_stop) <= value2 <= max(second_start, second_stop):
        raise VswInputError(f"--free {second}={second_start:g}:{second_stop:g} must contain "
                            f"{second}'s value {value2:g}")  # fmt: skip
    phase = None
    if special.type == "boundary":
        if not (special.condition or "").startswith("phase "):
            raise VswInputError(
                f"the boundary at {over} = {special.parameter:g} ({special.condition}) has no "
                "smooth defining equation to continue"
            )
        phase = int(np.argmin(special.durations))
    ce = _CurveEquations(eq, index2, second_start, second_stop, special.type, phase)
    nu = (special.parameter - start) / eq.width
    nu2 = (value2 - second_start) / (second_stop - second_start)
    try:
        u = eq.unknowns(np.array(list(special.state.values())), special.durations, nu)
    except RuntimeError:
        stop.check()
        raise VswInputError(f"the {special.type} point's phases could not be integrated") from None
    w0 = np.concatenate([u[:-1], [nu, nu2]])
    normal = np.zeros_like(w0)
    normal[-1] = 1.0
    solved = _correct(ce, w0, normal, w0, max_iterations=20)
    if solved is None:
        raise VswInputError(
            f"the {special.type} point at {over} = {special.parameter:g} could not be "
            f"continued in {second} (its corrector did not converge)"
        )
    w0, jac, _ = solved
    start_point = _curve_record(ce, w0, jac)
    points, ended = [start_point], []
    for sign in (1.0, -1.0):
        t0 = _tangent(jac, sign * normal)
        if t0 is None:
            ended.append("lost")
            continue
        way, end = _trace_curve(ce, w0, t0, options)
        points = list(reversed(way)) + points if sign < 0 else points + way
        ended.append(end)
    return Curve(special.type, special.condition, second, start_point, points, ended)
