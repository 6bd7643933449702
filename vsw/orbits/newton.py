"""Newton's method on a system of equations, for one start or many at once: the one Newton
of the orbit solvers.

From each start ``w_0`` it iterates

    [J(w_i); b^T] dw = -(R(w_i), b . (w_i - a)),    w_{i+1} = w_i + dw,          (1)

where the optional border ``(b, a)`` adds one linear equation (pseudo-arclength
continuation's ``t . (w - w_pred) = 0``, or a parameter held fixed); without it the system
is ``J dw = -R``. A system (:class:`System`) gives the residual ``R`` of a batch of iterates
(a row of NaN where it cannot be evaluated: the row is dropped) and, for the rows asked, the
Jacobian at the iterates it last evaluated (NaN where not available: dropped too). An
iterate has converged

* without ``step_tol``, as soon as ``max |R(w_i)| <= tol * scale(w_i)`` (no step taken);
* with ``step_tol``, when ``max |R(w_i)| <= tol * s`` and ``max |dw| <= step_tol * s``
  (``s = scale(w_{i+1})``), and the residual at ``w_{i+1}`` is again within ``tol * s``
  with a finite Jacobian there, which the result carries; a step that small whose end
  misses the tolerance is a failure.

``merge``: iterates that round to one point of a grid of spacing ``merge * max(1, the
component's largest |value|)`` go on as one, every member where its first goes (the gait
search's thousands of starts falling into a few gaits). ``max_iterations`` bounds the
steps; with ``step_tol`` the end of the last one is still checked.

Imports: numpy and :mod:`vsw.runtime.stop` (a long solve stops where asked).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from vsw.runtime import stop

__all__ = ["Solution", "System", "solve"]


class System(Protocol):
    """The equations Newton solves (see the module docstring)."""

    def residual(self, w: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """``R`` at each row of ``w`` (rows, size), the iterates of the starts ``rows``:
        (rows, equations); a row of NaN where it cannot be evaluated."""

    def jacobian(self, which: np.ndarray) -> np.ndarray:
        """``J`` at the rows ``which`` of the last :meth:`residual` call: (len(which),
        equations, size); NaN where it is not available."""

    def scale(self, w: np.ndarray) -> np.ndarray:
        """Each row's scale of the tolerances: (rows,)."""


@dataclass
class Solution:
    """Newton's iterates (rows, size), whether each converged, the steps each took, and
    (with ``step_tol``) the Jacobian at each converged iterate (None for the others)."""

    w: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    jacobian: list[np.ndarray | None] | None = None


@dataclass
class _Border:
    normal: np.ndarray
    anchor: np.ndarray


def solve(
    system: System, starts: np.ndarray, *, tol: float, step_tol: float | None = None,
    max_iterations: int = 40, border: tuple[np.ndarray, np.ndarray] | None = None,
    merge: float | None = None,
) -> Solution:  # fmt: skip
    """Newton (1) from every row of ``starts`` (module docstring)."""
    w = np.array(starts, dtype=float)
    count = len(w)
    done = np.zeros(count, dtype=bool)
    alive = np.ones(count, dtype=bool)
    settling = np.zeros(count, dtype=bool)  # took a small step: confirmed at its end
    iterations = np.zeros(count, dtype=int)
    jacobians: list[np.ndarray | None] = [None] * count
    edge = None if border is None else _Border(*(np.asarray(v, float) for v in border))
    for number in range(max_iterations + (step_tol is not None)):
        stop.check()
        open_rows = np.flatnonzero(alive & ~done)
        if open_rows.size == 0:
            break
        rows, group = _groups(w, open_rows, merge)
        base = w[rows]
        r = system.residual(base, rows)
        with np.errstate(invalid="ignore"):
            size = np.max(np.abs(r), axis=1)
        finite = np.all(np.isfinite(r), axis=1)
        if step_tol is None:
            converged = finite & (size <= tol * system.scale(base))
            failed = np.zeros(len(rows), dtype=bool)
        else:
            converged, failed, jac = _settled(system, base, settling[rows], finite, size, tol)
            for row, member in zip(open_rows, group):
                if converged[member]:
                    jacobians[row] = jac[member]
        pending = np.flatnonzero(finite & ~converged & ~failed & ~settling[rows])
        step = np.full_like(base, np.nan)
        if pending.size and number < max_iterations:
            step[pending] = _steps(system, base, r, pending, edge)
        moved = np.all(np.isfinite(step), axis=1)
        new = np.where(moved[:, None], base + step, base)
        if step_tol is not None:
            s = system.scale(new)
            with np.errstate(invalid="ignore"):
                small = (size <= tol * s) & (np.max(np.abs(step), axis=1) <= step_tol * s)
            settling[open_rows] = (moved & small)[group]
        iterations[open_rows] += moved[group]
        done[open_rows] = converged[group]
        alive[open_rows] = (converged | moved)[group]
        w[open_rows] = new[group]
    return Solution(w, done & alive, iterations, jacobians if step_tol is not None else None)


def _settled(
    system: System, base: np.ndarray, settling: np.ndarray, finite: np.ndarray,
    size: np.ndarray, tol: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """With ``step_tol``: the Jacobian of every row, which rows converge at their iterate
    (those that settled there: within ``tol`` again, with a finite Jacobian) and which
    fail (settled there but not within it)."""
    jac = system.jacobian(np.arange(len(base)))
    whole = finite & np.all(np.isfinite(jac), axis=(1, 2))
    within = settling & whole & (size <= tol * system.scale(base))
    return within, settling & ~within, jac


def _steps(
    system: System, base: np.ndarray, r: np.ndarray, pending: np.ndarray, edge: _Border | None
) -> np.ndarray:
    """Newton's steps (1) of the rows ``pending``: NaN where the Jacobian is not finite or
    the system singular."""
    jac = system.jacobian(pending)
    rhs = -r[pending]
    if edge is not None:
        normal = np.broadcast_to(edge.normal, (pending.size, 1, base.shape[1]))
        jac = np.concatenate([jac, normal], axis=1)
        # One dot product a row (a matrix product may sum in another order).
        offsets = [float(edge.normal @ (x - edge.anchor)) for x in base[pending]]
        rhs = np.concatenate([rhs, -np.array(offsets)[:, None]], axis=1)
    return _solve(jac, rhs, np.all(np.isfinite(jac), axis=(1, 2)))


def _solve(matrices: np.ndarray, vectors: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``matrices[k] x = vectors[k]`` where ``rows[k]``, in one batched call; NaN where not
    asked or singular."""
    out = np.full(vectors.shape[:1] + matrices.shape[2:], np.nan)
    chosen = np.flatnonzero(rows)
    if chosen.size == 0:
        return out
    try:
        out[chosen] = np.linalg.solve(matrices[chosen], vectors[chosen][..., None])[..., 0]
    except np.linalg.LinAlgError:  # one singular matrix fails the batch: one at a time
        for k in chosen:
            try:
                out[k] = np.linalg.solve(matrices[k], vectors[k])
            except np.linalg.LinAlgError:
                pass
    return out


def _groups(w: np.ndarray, rows: np.ndarray, merge: float | None) -> tuple[np.ndarray, np.ndarray]:
    """The first of each set of ``rows`` whose iterates agree to ``merge`` (relative to the
    largest component), and for each row the index of its set's first: from there on
    Newton takes them the same way. Every row its own set without ``merge``."""
    if merge is None:
        return rows, np.arange(rows.size)
    resolution = merge * np.maximum(1.0, np.max(np.abs(w[rows]), axis=0))
    keys = np.round(w[rows] / resolution).astype(np.int64, copy=False)
    _, first, group = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return rows[first], group.reshape(-1)
