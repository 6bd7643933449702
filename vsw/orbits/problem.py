"""The periodic-orbit problem: a hybrid period-``p`` orbit of a model, with some of its
parameters free, as one object: its unknowns, residual and exact Jacobian (the shooting
discretisation, :mod:`vsw.orbits.shooting`), its monodromy matrix
(:mod:`vsw.orbits.monodromy`), its quantities, and its solution by the one Newton
(:mod:`vsw.orbits.newton`).

The unknowns are ``u = (x_1..x_m, T_1..T_m)``: the start of each of the ``m`` phases of
``p`` steps and its duration; ``x_1`` is the section state (just after the step event).
The residual is (2) of :mod:`vsw.orbits.shooting`; its Jacobian in ``u`` and its derivative
in each free parameter are CasADi's, exact to the integrator's tolerance.

Imports: numpy, :mod:`vsw.orbits.shooting`, :mod:`vsw.orbits.monodromy`,
:mod:`vsw.orbits.newton`, ``vsw.runtime.stop``. A model is taken by its interface
(:class:`vsw.dynamics.hybrid.HybridModel`'s), never by importing :mod:`vsw.dynamics.hybrid`.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.orbits import monodromy, newton, shooting
from vsw.runtime import stop

__all__ = ["SOLVE_ITERATIONS", "SOLVE_STEP_TOL", "SOLVE_TOL", "OrbitProblem", "Solved"]

SOLVE_TOL = 1e-10
""":meth:`OrbitProblem.solve`'s tolerance on the residual, relative to max(1, |u|)."""

SOLVE_STEP_TOL = 1e-9
"""And on Newton's last step: one more step is taken from there, and its end checked."""

SOLVE_ITERATIONS = 40
"""Newton's steps at most in :meth:`OrbitProblem.solve`."""


@dataclass(frozen=True)
class Solved:
    """:meth:`OrbitProblem.solve`'s result: the unknowns Newton ended at, whether they
    solve the orbit, the residual's largest entry there (inf where it cannot be
    evaluated), its Jacobian in ``u`` (where converged), and CVODES' complaint where an
    integration failed on the way."""

    u: np.ndarray
    converged: bool
    residual: float
    jacobian: np.ndarray | None
    error: str | None = None


class OrbitProblem:
    """The period-``period`` orbit of ``model`` with the parameters ``free`` (indices into
    its parameter vector) differentiated: see the module docstring."""

    def __init__(self, model: Any, period: int = 1, free: Sequence[int] = ()) -> None:
        self.model = model
        self.period = period
        self.free = tuple(free)
        self.sequence = shooting.phase_sequence(model) * period
        self.n = 2 * model.n
        self.m = len(self.sequence)
        self.size = (self.n + 1) * self.m
        # Looked up on the module: a test may stand in for the CasADi function.
        self.function = shooting.multiple_shooting(model, period, self.free)

    # --- the unknowns ------------------------------------------------------------------

    def unknowns(
        self, params: Sequence[float], x0: np.ndarray, durations: Sequence[float]
    ) -> np.ndarray:
        """``u`` from the section state and the phase durations: each phase's start by the
        flows and resets (RuntimeError where CVODES fails)."""
        starts = shooting.starts_of(self.model, self.period, params, x0, durations)
        return np.concatenate([starts, np.asarray(durations, float)])

    def section_state(self, u: np.ndarray) -> np.ndarray:
        """``x_1``: the state just after the step event."""
        return u[: self.n]

    def durations(self, u: np.ndarray) -> np.ndarray:
        return u[self.n * self.m : self.n * self.m + self.m]

    def state(self, u: np.ndarray) -> dict[str, float]:
        """The section state by name (coordinates, then rates)."""
        names = [*self.model.coordinates, *self.model.rates]
        return dict(zip(names, (float(v) for v in self.section_state(u))))

    # --- its quantities ----------------------------------------------------------------

    def section_states(self, u: np.ndarray) -> list[np.ndarray]:
        """The state just after each of the ``period`` step events (the first is x_1)."""
        per_step = self.m // self.period
        return [u[j * per_step * self.n : (j * per_step + 1) * self.n] for j in range(self.period)]

    def step_periods(self, u: np.ndarray) -> list[float]:
        """Each step's duration: the sum of its phases'."""
        durations = self.durations(u)
        per_step = self.m // self.period
        return [
            float(np.sum(durations[j * per_step : (j + 1) * per_step])) for j in range(self.period)
        ]

    # --- residual, Jacobian, monodromy -------------------------------------------------

    def evaluate(self, u: np.ndarray, params: Sequence[float]) -> tuple[np.ndarray, ...]:
        """The residual at ``u``, its Jacobian in ``u`` and its derivative in each free
        parameter (numpy; RuntimeError where CVODES fails)."""
        with contextlib.redirect_stderr(io.StringIO()):
            out = self.function(u, *params)
        out = out if isinstance(out, tuple) else (out,)
        return (np.array(out[0], dtype=float).reshape(-1),
                *(np.array(v, dtype=float) for v in out[1:]))  # fmt: skip

    def monodromy(self, jacobian: np.ndarray) -> np.ndarray:
        """The monodromy matrix from the residual's Jacobian in ``u``
        (:func:`vsw.orbits.monodromy.monodromy`)."""
        return monodromy.monodromy(jacobian, self.n, self.m)

    def eigenvalues(self, jacobian: np.ndarray) -> list[complex]:
        """Its eigenvalues, largest first; none where it is not finite."""
        return monodromy.eigenvalues(jacobian, self.n, self.m)

    # --- the orbit at fixed parameters -------------------------------------------------

    def solve(self, params: Sequence[float], guess: np.ndarray) -> Solved:
        """Newton (:func:`vsw.orbits.newton.solve`) on the residual at ``params`` from the
        unknowns ``guess``, to :data:`SOLVE_TOL` and :data:`SOLVE_STEP_TOL`."""
        system = _Fixed(self, params)
        found = newton.solve(system, np.asarray(guess, float)[None], tol=SOLVE_TOL,
                             step_tol=SOLVE_STEP_TOL, max_iterations=SOLVE_ITERATIONS)  # fmt: skip
        u = found.w[0]
        if found.converged[0]:
            return Solved(u, True, system.size, found.jacobian[0])
        try:
            r = self.evaluate(u, params)[0]
        except RuntimeError:
            stop.check()
            r = np.array([np.inf])
        size = float(np.max(np.abs(r))) if np.all(np.isfinite(r)) else np.inf
        return Solved(u, False, size, None, system.error)


class _Fixed:
    """The residual at fixed parameters as :class:`vsw.orbits.newton.System` (one row)."""

    def __init__(self, problem: OrbitProblem, params: Sequence[float]) -> None:
        self.problem = problem
        self.params = np.asarray(params, dtype=float)
        self.error: str | None = None
        self.size = np.inf  # the largest residual entry at the last iterate
        self.last = np.empty((1, problem.size, problem.size))

    def residual(self, w: np.ndarray, rows: np.ndarray) -> np.ndarray:
        try:
            r, jac = self.problem.evaluate(w[0], self.params)[:2]
        except RuntimeError as exc:  # CVODES gave up (an iterate far from any orbit)
            stop.check()  # or CasADi turned Ctrl-C or the time limit into this error
            self.error = " ".join(str(exc).split())
            return np.full((1, self.problem.size), np.nan)
        self.last = jac[None]
        self.size = float(np.max(np.abs(r))) if np.all(np.isfinite(r)) else np.inf
        return r[None]

    def jacobian(self, which: np.ndarray) -> np.ndarray:
        return self.last[which]

    def scale(self, w: np.ndarray) -> np.ndarray:
        return np.maximum(1.0, np.max(np.abs(w), axis=1))
