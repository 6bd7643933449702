"""What one- and two-parameter continuation share: a period-``k`` orbit's equations in the
scaled unknowns ``w = (u, nu)`` (:class:`Equations`), the branch's tangent
(:func:`branch_tangent`), the pseudo-arclength corrector (:func:`correct`, Newton of
:mod:`vsw.orbits.newton` bordered by ``normal . (w - anchor) = 0``), the simulated walk's
confirmation of an orbit (:func:`confirm`), how a branch is followed (:class:`Options`)
and a located special point (:class:`SpecialPoint`).

Below both :mod:`vsw.gaits.continuation` (branches in one parameter, their special points and
branch switching) and :mod:`vsw.gaits.special_curves` (a special point continued in two), so
that each imports it and neither the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.orbits import OrbitProblem, newton, phase_sequence
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError

__all__ = [
    "CONFIRM_TOL",
    "MAX_TURN",
    "RESIDUAL_TOL",
    "Equations",
    "Options",
    "SpecialPoint",
    "branch_tangent",
    "confirm",
    "correct",
    "simulated_step",
]

RESIDUAL_TOL = 1e-10
"""The corrector's tolerance on the residual, relative to max(1, |unknowns|)."""

MAX_TURN = 0.3
"""Largest angle (rad) between the tangents of two consecutive points."""

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


class Equations:
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


def branch_tangent(jac: np.ndarray, previous: np.ndarray) -> np.ndarray | None:
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


def correct(
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


def confirm(eq: Equations, w: np.ndarray, eigenvalues: list[complex]) -> tuple[str, list]:
    """The orbit confirmed by the simulated walk: ``period`` steps from x0 with every phase,
    back to x0. Returns ('completed', step lengths) or (why not, [])."""
    model = eq.model
    params = eq.params_at(w[-1])
    x0 = eq.x0(w)
    x = x0.copy()
    lengths: list[float | None] = []
    phases = len(phase_sequence(model))
    for _ in range(eq.period):
        step = simulated_step(model, params, x)
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


def simulated_step(model: HybridModel, params: np.ndarray, x: np.ndarray) -> Any:
    """One simulated step, or why it could not be taken (a solver's failure at extreme
    states is a point the walk does not confirm, not the end of the run)."""
    try:
        return model.step(params, x)
    except (ConvergenceError, OverflowError, ZeroDivisionError, FloatingPointError) as exc:
        stop.check()
        return f"the simulated step failed ({' '.join(str(exc).split())[:80]})"
