"""A collocated optimum carried onto the runtime's exact gait by the constraints that pin it:
:func:`pinned_gait`.

At a vertex of the design (as many active constraints as free parameters: a target, a
quantity's bound, the eigenvalue bound, a parameter's box), the optimum is the solution of
those constraints alone, whatever the objective. The collocated NLP finds the vertex and its
active set to the mesh's error; here the active rows are solved again on the periodic orbit
the runtime's solver gives (:class:`vsw.orbits.OrbitProblem`, CVODES), by Newton in the free
parameters with a finite-difference Jacobian kept up to date by Broyden's update:

    c_A(p) = b_A,                                                                      (1)

``c_A`` the active quantities of the orbit at ``p``, ``b_A`` their targets or bounds. The
collocated point is within the mesh's error of the root, so one or two steps reach the
orbit solver's own accuracy. Where an active row is not one Newton on the orbit solves (a
condition's margin or a guard's ``when``, the least eigenvalue's radius at its bound),
:func:`pinning_rows` says so with None; where the active set does not pin the parameters
(an interior optimum), a quantity needs the step simulated, Newton fails, or its root lies
past a box's edge or on another gait, :func:`pinned_gait` does. The design then polishes
on the multiple-shooting NLP instead (:mod:`vsw.synthesis.design.shooting`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from vsw.dynamics.batch import simulator
from vsw.dynamics.hybrid import Orbit
from vsw.dynamics.quantities import report
from vsw.dynamics.quantities import weight as walker_weight
from vsw.orbits import OrbitProblem, Solved, shooting
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError
from vsw.synthesis.design.problem import Problem

__all__ = ["ACTIVE", "Pinning", "pinned_gait", "pinning_rows", "pressed_bound"]

ACTIVE = 1e-8
"""A constraint is active where its multiplier's magnitude exceeds this and its value is at
its bound (:func:`pressed_bound`)."""

_ITERATIONS = 8
_SOLVED = 1e-12  # max |c_A - b_A| / max(1, |b_A|) at which Newton stops
_ACCEPTED = 1e-9  # and the largest it may end at
_FD_STEP = 1e-6  # of the box's width
_AT_BOUND = 1e-6  # an active row's distance from its bound, relative
_MOVE = 1e-4  # the farthest a pinned parameter may move from the collocated one, of the width


Pinning = tuple[dict[str, float], dict[int, float]]
"""The equations (1): each pinned quantity's value; each free parameter held at its box's
bound (index -> the bound)."""


def pinning_rows(problem: Problem, nlp: Any, solve: Any, bounds: Mapping[str, np.ndarray],
                 targets: Mapping[str, float],
                 structure_eigen: str | None) -> Pinning | None:  # fmt: skip
    """The equations (1) of a collocated optimum: each active row's quantity at its bound
    (a target's value), and each free parameter pressed against its box (index -> the
    bound); None where an active row is not of a kind Newton on the orbit can solve.
    Active: its multiplier above :data:`ACTIVE` and its value at the bound (an inactive
    bound's multiplier is IPOPT's barrier term, small but not zero)."""
    g = np.array(nlp.solver.get_function("nlp_g")(solve.w, bounds["p"])).reshape(-1)
    equations = {name: float(value) for name, value in targets.items()}
    for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
        if kind == "equality" or name in equations:
            continue  # a target is an equation whatever its multiplier
        bound = pressed_bound(g[i], solve.lam_g[i], bounds["lbg"][i], bounds["ubg"][i], 1.0)
        if bound is None:
            continue
        if kind == "quantity":
            equations[name] = bound
        elif kind == "jury":
            if structure_eigen == "bound":
                equations["eigenvalue"] = float(problem.request.max_eigenvalue)
            # else the radius is the objective's unknown, not a constraint on p
        else:
            return None  # a margin or a guard's when: the shooting NLP polishes those
    rho = nlp.layout["rho"]
    if rho.stop > rho.start:
        radius = (solve.w[rho][0], solve.lam_x[rho][0], bounds["lbx"][rho][0],
                  bounds["ubx"][rho][0], 1.0)  # fmt: skip
        if pressed_bound(*radius) is not None:
            return None  # the least eigenvalue held at the eigenvalue bound
    pressed = {}
    free = nlp.layout["free"]
    for i, j in enumerate(problem.free):
        low, high = problem.box[j]
        bound = pressed_bound(solve.w[free][i], solve.lam_x[free][i], low, high, high - low)
        if bound is not None:
            pressed[j] = bound
    return equations, pressed


def pressed_bound(value: float, multiplier: float, low: float, high: float,
             scale: float) -> float | None:  # fmt: skip
    """The bound an active constraint presses against, or None where it is inactive."""
    if not abs(multiplier) > ACTIVE:
        return None
    # CasADi's sign: negative where the lower bound holds, positive where the upper does.
    for bound in (low, high) if multiplier < 0 else (high, low):
        if np.isfinite(bound) and abs(value - bound) <= _AT_BOUND * max(scale, abs(bound)):
            return float(bound)
    return None


def pinned_gait(problem: Problem, params: Sequence[float], state: np.ndarray,
                durations: np.ndarray, rows: Pinning) -> tuple[tuple, Orbit] | None:  # fmt: skip
    """The parameters and confirmed gait that solve (1) from a collocated optimum (its
    parameters, section state and phase durations), or None where Newton does not reach
    them (the design then polishes on the shooting NLP). The first orbit solve, at the
    collocated parameters, finds the exact gait the collocated one approximates; the last
    is confirmed by a simulated step (:meth:`~vsw.dynamics.hybrid.HybridModel.confirmed_orbit`)."""
    equations, pressed = rows
    unknown = [j for j in problem.free if j not in pressed]
    if len(equations) != len(unknown) or not _computable(equations):
        return None
    p = np.array(params, dtype=float)
    for j, value in pressed.items():
        p[j] = value
    names = sorted(equations)
    goal = np.array([equations[n] for n in names])
    scale = np.maximum(1.0, np.abs(goal))
    width = np.array([problem.box[j][1] - problem.box[j][0] for j in unknown])
    orbits = _Orbits(problem, state, durations, bool({"step_length", "speed"} & set(names)))

    def residual(at: np.ndarray) -> np.ndarray | None:
        quantities = orbits.quantities(at)
        return (
            None
            if quantities is None
            else (np.array([quantities[n] for n in names]) - goal) / scale
        )

    r = residual(p)
    if r is None:
        return None
    first = orbits.state
    if unknown:
        r = _newton(residual, p, r, unknown, width)
    if r is None or not np.max(np.abs(r), initial=0.0) <= _ACCEPTED:
        return None
    moved = np.abs(p[unknown] - np.asarray(params)[unknown])
    if np.any(moved > _MOVE * np.maximum(width, 1e-12)):
        return None
    if any(not problem.box[j][0] <= p[j] <= problem.box[j][1] for j in unknown):
        return None  # the vertex lies past a box's edge: the shooting NLP keeps to the box
    if not np.array_equal(orbits.at, p) and orbits.quantities(p) is None:
        return None  # (Newton's last solve was a difference quotient's)
    if not _same_state(orbits.state, first):
        return None  # another gait
    step = simulator(problem.model).step_phases
    try:
        confirmed = problem.model.confirmed_orbit(tuple(p), orbits.problem, orbits.solved, step)
    except ConvergenceError:
        return None
    return tuple(float(v) for v in p), confirmed


def _same_state(x: np.ndarray, y: np.ndarray) -> bool:
    """Whether two gaits' section states at nearly the same parameters are one gait's:
    within :data:`_MOVE` of their scale."""
    return bool(np.max(np.abs(x - y)) <= _MOVE * max(1.0, float(np.max(np.abs(y)))))


def _newton(residual: Any, p: np.ndarray, r: np.ndarray, unknown: list[int],
            width: np.ndarray) -> np.ndarray | None:  # fmt: skip
    """Newton on (1) in the parameters ``unknown`` from ``p`` (updated in place), its
    Jacobian by forward differences once, then Broyden's update: the last residual."""
    if np.max(np.abs(r)) <= _SOLVED:
        return r
    jacobian = np.empty((len(r), len(unknown)))
    for k, j in enumerate(unknown):
        h = _FD_STEP * max(width[k], 1e-9)
        shifted = p.copy()
        shifted[j] += h
        r_h = residual(shifted)
        if r_h is None:
            return None
        jacobian[:, k] = (r_h - r) / h
    for _ in range(_ITERATIONS):
        if np.max(np.abs(r)) <= _SOLVED:
            break
        try:
            step = np.linalg.solve(jacobian, -r)
        except np.linalg.LinAlgError:
            return None
        if not np.any(step):
            break
        p[unknown] += step
        r_new = residual(p)
        if r_new is None:
            return None
        jacobian += np.outer(r_new - r - jacobian @ step, step) / float(step @ step)
        r = r_new
    return r


_CHEAP = {"period", "step_frequency", "eigenvalue", "step_length", "speed", "weight"}


def _computable(equations: Mapping[str, float]) -> bool:
    """Whether the quantities of (1) follow from the orbit solver's unknowns alone (no
    simulated step: the energy an impact dissipates needs the state before it)."""
    return set(equations) <= _CHEAP


class _Orbits:
    """The orbit solver at parameter sets near a collocated gait, each from the last; the
    last solve kept (:attr:`solved`)."""

    def __init__(self, problem: Problem, state: np.ndarray, durations: np.ndarray,
                 lengths: bool) -> None:  # fmt: skip
        self.model = problem.model
        self.lengths = lengths  # whether the step's length is asked
        self.problem = OrbitProblem(self.model)
        self.state = np.asarray(state, float)
        self.durations = np.asarray(durations, float)
        self.guess: np.ndarray | None = None
        self.solved: Solved | None = None
        self.at: np.ndarray | None = None  # the parameters of the last solve

    def quantities(self, params: np.ndarray) -> dict[str, Any] | None:
        try:
            if self.guess is None:
                self.guess = self.problem.unknowns(params, self.state, self.durations)
            solved = self.problem.solve(params, self.guess)
        except RuntimeError:  # CVODES failed, or CasADi turned a stop into this error
            stop.check()
            return None
        if not solved.converged:
            return None
        self.solved, self.guess, self.at = solved, solved.u, params.copy()
        self.state = self.problem.section_state(solved.u)
        self.durations = self.problem.durations(solved.u)
        eigenvalues = self.problem.eigenvalues(solved.jacobian)
        if not eigenvalues:
            return None
        facts = {
            "period": float(np.sum(self.durations)),
            "eigenvalue": abs(eigenvalues[0]),
            "weight": walker_weight(self.model, params),
        }
        if self.lengths:
            # The step's length is the model's of the state just before the step event.
            m, n = self.problem.m, self.problem.n
            phase = self.problem.sequence[-1][0]
            start = solved.u[(m - 1) * n : m * n]
            try:
                end = shooting.phase_flow(self.model, phase, params, start, self.durations[-1])
            except RuntimeError:
                stop.check()
                return None
            length = self.model.step_length(params, end)
            if length is None:
                return None
            facts["step_length"] = length
        return report(facts)
