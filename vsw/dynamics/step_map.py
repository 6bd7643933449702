"""The batch simulator's Poincaré map as a system of equations: :class:`StepMap` (``P(y) - y``
with its Jacobian by differences of batch steps) and :func:`fixed_point`, the period-one gait
as its root. The gait search's Newton on the free components of a section state
(:mod:`vsw.gaits.search`) and the sweeps' confirmation of a gait stand on it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from vsw.dynamics.batch import WALKED, BatchResult, BatchSimulator
from vsw.orbits import newton
from vsw.runtime import blas
from vsw.runtime.errors import ConvergenceError

__all__ = ["StepMap", "fixed_point"]


def fixed_point(
    sim: BatchSimulator, params: Sequence[float], guess: Sequence[float], tol: float = 1e-12,
    max_iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The period-one gait near ``guess`` as a fixed point of ``sim``'s
    Poincaré map P: :func:`vsw.orbits.newton.solve` on P(x) - x (:class:`StepMap`, P's
    Jacobian by central differences). On the section the map has an eigenvalue 0 across
    it, so P - I stays invertible on the full state.

    Returns
    -------
    (state, jacobian): the fixed point and P's Jacobian there.

    Raises
    ------
    ConvergenceError
        A walk falls, P - I is singular, or the iteration does not reach
        ``tol * max(1, |x|)``.
    """
    with blas.limited(1):  # its walks run on one thread, its solves too
        system = StepMap(sim, params, difference="central", relative_step=1e-6,
                         threads=1)  # fmt: skip
        found = newton.solve(system, np.array([guess], dtype=float), tol=tol,
                             max_iterations=max_iterations)  # fmt: skip
        x = found.w[0]
        if found.converged[0]:
            return x, system.derivative(np.array([0]))[0]
    if system.failed is not None:
        raise ConvergenceError(
            f"{sim.model.name}: a step near {system.failed[0].tolist()} did not complete "
            f"({system.failed[1]})"
        )
    if found.iterations[0] < max_iterations:  # Newton stopped short: no finite step
        raise ConvergenceError(
            f"{sim.model.name}: the batch map's Jacobian minus I is singular near "
            f"{x.tolist()} (an eigenvalue 1)"
        )
    raise ConvergenceError(
        f"{sim.model.name}: the batch fixed point did not converge in {max_iterations} "
        f"Newton steps (last residual {system.size:.3g})"
    )


class StepMap:
    """``P(y) - y`` for :func:`vsw.orbits.newton.solve`, ``P`` the batch simulator's step
    map and ``y`` some components of section states (the gait search's free components,
    :func:`vsw.gaits.search.search`; all of them, :func:`fixed_point`), so that
    both solve on the one Newton.

    ``complete`` makes section states of rows of ``y`` (default: ``y`` is the state) and
    ``index`` picks ``y``'s components out of a state (default: all). Each residual is a
    batch step of the iterates (a row of NaN where the step fails); the Jacobian is by
    ``difference`` (``forward``: ``d`` steps a row, ``central``: ``2 d``) with the step
    ``relative_step * max(1, |y|)``. ``images``: ``y``'s components of ``P(starts)`` where
    the caller has them (the scan's), used for the first residual. ``failed``: the first
    iterate whose step did not complete, with how it ended; ``size`` the last residual's
    largest component."""

    def __init__(
        self, sim: BatchSimulator, params: Sequence[float], *,
        complete: Callable[[np.ndarray], np.ndarray] | None = None,
        index: Sequence[int] | None = None, images: np.ndarray | None = None,
        difference: str = "forward", relative_step: float = 1e-7, threads: int | None = None,
    ) -> None:  # fmt: skip
        self.sim, self.params, self.threads = sim, params, threads
        self.complete = complete or (lambda y: y)
        self.index = list(range(sim.nx)) if index is None else list(index)
        self.known = None if images is None else np.array(images, dtype=float)
        self.central = {"forward": False, "central": True}[difference]
        self.relative_step = relative_step
        self.base = self.image = np.empty((0, len(self.index)))
        self.failed: tuple[np.ndarray, str] | None = None
        self.size = math.nan

    def _step(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, BatchResult]:
        """The step from each row of ``y``: whether it completed and ``y``'s components of
        its end."""
        result = self.sim.step(self.params, self.complete(y), threads=self.threads)
        walked = result.outcome == WALKED
        if self.failed is None and not np.all(walked):
            first = int(np.argmin(walked))
            self.failed = (y[first], str(sorted(set(result.ended()))))
        return walked, result.final[:, self.index], result

    def residual(self, y: np.ndarray, rows: np.ndarray) -> np.ndarray:
        if self.known is not None:
            image = self.known[rows]
            walked = np.all(np.isfinite(image), axis=1)
            self.known = None
        else:
            walked, image, _ = self._step(y)
        self.base, self.image = y, image
        residual = image - y
        residual[~walked] = np.nan
        with np.errstate(invalid="ignore"):
            self.size = float(np.max(np.abs(residual))) if residual.size else math.nan
        return residual

    def derivative(self, which: np.ndarray) -> np.ndarray:
        """``dP/dy`` at the rows ``which`` of the last residual: (len(which), d, d), NaN
        where a shifted step fails."""
        base, image = self.base[which], self.image[which]
        count, dims = base.shape
        eye = np.eye(dims)
        h = self.relative_step * np.maximum(1.0, np.abs(base))
        shifts = [eye, -eye] if self.central else [eye]
        trial = np.concatenate(
            [(base[:, None, :] + s * h[:, None, :]).reshape(-1, dims) for s in shifts]
        )
        walked, final, _ = self._step(trial)
        walked = walked.reshape(len(shifts), count, dims).all(axis=(0, 2))
        ends = final.reshape(len(shifts), count, dims, dims)
        # out[k, i, j] = dP_i / dy_j
        if self.central:
            out = np.transpose((ends[0] - ends[1]) / (2 * h[:, :, None]), (0, 2, 1))
        else:
            out = np.transpose((ends[0] - image[:, None, :]) / h[:, :, None], (0, 2, 1))
        out[~walked] = np.nan
        return out

    def jacobian(self, which: np.ndarray) -> np.ndarray:
        return self.derivative(which) - np.eye(self.base.shape[1])

    def scale(self, y: np.ndarray) -> np.ndarray:
        return np.maximum(1.0, np.max(np.abs(y), axis=1))
