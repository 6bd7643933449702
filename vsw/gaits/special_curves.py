"""A special point of a branch continued in two parameters: the curve in the parameter
plane along which a fold, flip, Neimark-Sacker point or boundary persists
(``vsw continue --free``).

The unknowns are the branch's (:class:`vsw.gaits.pseudo_arclength.Equations`: the orbit's ``u`` and
the first parameter's ``nu``) and ``nu2``, the second parameter as a fraction of its range;
the equations the orbit's residual and the point's defining function ``psi`` (for a flip
``1 +`` the eigenvalue nearest -1, for a fold the eigenvalue nearest +1 less 1, for a
Neimark-Sacker point ``|mu|^2 - 1`` of the complex pair nearest the unit circle, for a
boundary the duration of the phase that vanishes). The curve is followed by the branch's
pseudo-arclength steps (:func:`vsw.gaits.pseudo_arclength.correct`,
:func:`vsw.gaits.pseudo_arclength.branch_tangent`) and every point confirmed by the simulated walk
(:func:`vsw.gaits.pseudo_arclength.confirm`). Kept apart from :mod:`vsw.gaits.continuation`, which
follows branches in one parameter, so that each module stays one subject.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.gaits.pseudo_arclength import (
    MAX_TURN,
    Equations,
    Options,
    SpecialPoint,
    branch_tangent,
    confirm,
    correct,
)
from vsw.orbits import OrbitProblem
from vsw.runtime import stop
from vsw.runtime.errors import VswInputError

__all__ = ["BOUNDARY_NUDGE", "Curve", "continue_special_point"]

BOUNDARY_NUDGE = 1e-9
"""On a boundary curve, the second parameter's move (a fraction of its range) with which a
point is also confirmed, a hair inside the boundary (:func:`_curve_confirmed`)."""


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

    def __init__(self, eq: Equations, index2: int, start2: float, stop2: float, kind: str,
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
    """The simulated walk's confirmation of a curve point
    (:func:`vsw.gaits.pseudo_arclength.confirm`).

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
        single = Equations(ce.model, ce.params_at(point), ce.eq.index, ce.eq.start,
                            ce.eq.start + ce.eq.width, ce.eq.period)  # fmt: skip
        outcome = confirm(single, point[:-1], eigenvalues)[0]
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
        solved = correct(ce, anchor, t, anchor)
        t_new = None if solved is None else branch_tangent(solved[1], t)
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
    eq = Equations(model, params, names.index(over), start, stop_value, period)
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
    solved = correct(ce, w0, normal, w0, max_iterations=20)
    if solved is None:
        raise VswInputError(
            f"the {special.type} point at {over} = {special.parameter:g} could not be "
            f"continued in {second} (its corrector did not converge)"
        )
    w0, jac, _ = solved
    start_point = _curve_record(ce, w0, jac)
    points, ended = [start_point], []
    for sign in (1.0, -1.0):
        t0 = branch_tangent(jac, sign * normal)
        if t0 is None:
            ended.append("lost")
            continue
        way, end = _trace_curve(ce, w0, t0, options)
        points = list(reversed(way)) + points if sign < 0 else points + way
        ended.append(end)
    return Curve(special.type, special.condition, second, start_point, points, ended)
