"""Walking on rough ground as a Markov chain on a mesh of the Poincaré section: the mean
first-passage time (MFPT) without Monte Carlo (Byl & Tedrake, "Metastable walking
machines", Int. J. Robotics Research 28(8), 2009, Sec. 4).

The chain's states are the nodes of a rectilinear mesh of the section's free components
(the section state less what the step event determines: for the simplest walker theta and
theta_dot, for the compass gait theta, theta_dot and psi_dot) and one absorbing state, the
fall. From each node ``x_i`` one step of the batch simulator is taken on each slope
gamma0 + sigma xi_j of a quadrature of the standard normal (:func:`noise_quadrature`,
weights w_j), all (i, j) in one call (of :data:`CHUNK` nodes at most). The mesh is laid in
whitened coordinates (:func:`linearised_factor`: the linearised step map's covariance made
the identity) over a box that a pilot run sizes (:func:`pilot_box`). A step that fails
goes to the fall with its weight; a step that lands at ``y`` is spread over the corners of
``y``'s mesh cell by multilinear (barycentric on the cell's box) interpolation, so the
chain moves probability as the map moves states to second order in the mesh width. A
landing outside the mesh goes to the fall: the quasi-stationary mass that does so per
step is reported (``escaped``), an error that lowers the MFPTs by about
escaped / (1 - lambda_2) of themselves.

The live states' substochastic matrix ``T`` has a largest eigenvalue lambda_2 (the chain's
second after the fall's 1); its left eigenvector is the quasi-stationary distribution. Two
MFPTs, both counting the steps completed before the failure as :mod:`vsw.studies.rough` does:
``lambda_2 / (1 - lambda_2)``, the walker started in the quasi-stationary distribution
(Byl & Tedrake's 1 / (1 - lambda_2) counts the failing step too), and the expected steps
from the gait itself, ``n - 1`` with ``(I - T) n = 1`` and the first step taken from the
gait's exact state.

The mesh is refined until both MFPTs change by less than :data:`RTOL` on two refinements
in a row: each refinement multiplies the nodes per axis by :data:`GROWTH` and places them where the
chain's mass is, at equal steps of ``(1 - ALPHA) * uniform + ALPHA * marginal`` cumulative
distribution on each axis (the marginal that of the last mesh's quasi-stationary
distribution): the spacing follows the mass and is never wider than 1 / (1 - ALPHA) times
the uniform one.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.dynamics.batch import WALKED, simulator
from vsw.dynamics.hybrid import Orbit
from vsw.gaits.search import free_components, section_states
from vsw.models.base import Model
from vsw.runtime import blas
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.runtime.threads import default_threads
from vsw.studies.rough import linearised_step, slope_index

__all__ = [
    "ALPHA",
    "GROWTH",
    "RTOL",
    "ChainLevel",
    "ChainResult",
    "Mesh",
    "chain_solve",
    "chain_steps",
    "check_chain_inputs",
    "noise_quadrature",
    "rough_chain",
]

RTOL = 0.01
"""Refinement stops when both MFPTs change by less than this (relative) between meshes."""

GROWTH = 1.5
"""Each refinement multiplies the nodes per axis by this."""

ALPHA = 0.5
"""The share of the quasi-stationary marginal in the node placement (the rest uniform)."""

BOX_SD = 6.0
"""The mesh's box reaches at least this many linearised standard deviations each way."""

QUADRATURES = ("gauss-hermite", "quantile")

CHUNK = 4096
"""Mesh nodes stepped in one call of the batch simulator (bounds the memory)."""

MAX_NOISE_NODES = 200
MAX_MESH_NODES = 1_000_000


def check_chain_inputs(noise_nodes: int, max_nodes: int) -> None:
    """One line for a noise node count or a mesh budget out of range."""
    for name, value, low, high in (("noise nodes", noise_nodes, 1, MAX_NOISE_NODES),
                                   ("max nodes", max_nodes, 16, MAX_MESH_NODES)):  # fmt: skip
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise VswInputError(f"{name} = {value!r} must be an integer")
        if not low <= value <= high:
            raise VswInputError(f"{name} = {value} must be from {low} to {high}")


def chain_steps(dimension: int, noise_nodes: int, max_nodes: int) -> int:
    """The most steps :func:`rough_chain` simulates: the meshes up to ``max_nodes`` (sizes
    growing by GROWTH^dimension), the final one again with twice the noise nodes, and the
    pilot walks."""
    meshes = max_nodes / (1.0 - GROWTH**-dimension)
    return int(meshes * noise_nodes + 2 * max_nodes * noise_nodes + PILOT_STEPS)


def noise_quadrature(nodes: int, kind: str = "gauss-hermite") -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights (summing to 1) for E f(xi), xi standard normal: Gauss-Hermite
    (Golub & Welsch 1969, numpy's ``hermegauss``; exact for polynomials of degree
    2 nodes - 1) or ``quantile``, the midpoint rule in probability (xi_j the normal's
    (j + 1/2)/nodes quantile, weights 1/nodes). A step's failure makes the integrand jump,
    so neither converges spectrally: the error is that of the nodes' weights near the jump
    (:attr:`ChainResult.quadrature_change` measures it with twice the nodes)."""
    if kind not in QUADRATURES:
        raise VswInputError(f"quadrature {kind!r}: choose from {', '.join(QUADRATURES)}")
    if isinstance(nodes, bool) or not isinstance(nodes, (int, np.integer)) or not 1 <= nodes <= 400:
        raise VswInputError(f"noise nodes = {nodes!r} must be an integer from 1 to 400")
    if kind == "gauss-hermite":
        x, w = np.polynomial.hermite_e.hermegauss(int(nodes))
        return x, w / w.sum()
    from scipy.special import ndtri

    return ndtri((np.arange(nodes) + 0.5) / nodes), np.full(nodes, 1.0 / nodes)


@dataclass(frozen=True)
class Mesh:
    """A rectilinear mesh: the node coordinates on each axis (ascending), nodes in C order."""

    axes: tuple[np.ndarray, ...]

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(a) for a in self.axes)

    @property
    def size(self) -> int:
        return int(np.prod(self.shape))

    def nodes(self) -> np.ndarray:
        grids = np.meshgrid(*self.axes, indexing="ij")
        return np.column_stack([g.ravel() for g in grids])

    def interpolation(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Multilinear weights of points ``y`` (M, d) on their cells' 2^d corners:
        ``(corner indices (M, 2^d), weights (M, 2^d), outside (M,))``, a point outside the
        mesh weighted as if moved to its boundary."""
        d = len(self.axes)
        outside = np.zeros(len(y), dtype=bool)
        cells, fracs = [], []
        for k, axis in enumerate(self.axes):
            v = y[:, k]
            outside |= (v < axis[0]) | (v > axis[-1])
            v = np.clip(v, axis[0], axis[-1])
            c = np.clip(np.searchsorted(axis, v, side="right") - 1, 0, len(axis) - 2)
            cells.append(c)
            fracs.append(np.clip((v - axis[c]) / (axis[c + 1] - axis[c]), 0.0, 1.0))
        index = np.zeros((len(y), 2**d), dtype=np.int64)
        weight = np.ones((len(y), 2**d))
        for corner in range(2**d):
            flat = np.zeros(len(y), dtype=np.int64)
            for k in range(d):
                bit = (corner >> (d - 1 - k)) & 1
                flat = flat * len(self.axes[k]) + cells[k] + bit
                weight[:, corner] *= fracs[k] if bit else 1.0 - fracs[k]
            index[:, corner] = flat
        return index, weight, outside

    def refined(self, mass: np.ndarray, growth: float = GROWTH, alpha: float = ALPHA) -> Mesh:
        """A finer mesh on the same box: ``growth`` times the nodes per axis, at equal
        steps of the cumulative ``(1 - alpha) uniform + alpha marginal`` of ``mass`` (on
        the nodes) on each axis, the marginal's density piecewise constant over the
        nodes' dual cells."""
        mass = np.abs(np.asarray(mass, float)).reshape(self.shape)
        mass = mass / mass.sum()
        axes = []
        for k, axis in enumerate(self.axes):
            marginal = mass.sum(axis=tuple(i for i in range(len(self.axes)) if i != k))
            edges = np.concatenate([[axis[0]], (axis[1:] + axis[:-1]) / 2, [axis[-1]]])
            width = axis[-1] - axis[0]
            cdf = np.concatenate([[0.0], np.cumsum(marginal)])
            mixed = (1 - alpha) * (edges - axis[0]) / width + alpha * cdf
            n = max(len(axis) + 1, round(len(axis) * growth))
            new = np.interp(np.linspace(0.0, mixed[-1], n), mixed, edges)
            new[0], new[-1] = axis[0], axis[-1]
            axes.append(new)
        return Mesh(tuple(axes))


@dataclass(frozen=True)
class ChainLevel:
    """One mesh's chain: its size, lambda_2, the two MFPTs and the escaped mass."""

    nodes_per_axis: tuple[int, ...]
    nodes: int
    lambda2: float
    mfpt_qsd: float
    mfpt_gait: float
    escaped: float

    def to_dict(self) -> dict[str, Any]:
        return {"nodes_per_axis": list(self.nodes_per_axis), "nodes": self.nodes,
                "lambda2": self.lambda2, "mfpt_qsd": self.mfpt_qsd,
                "mfpt_gait": self.mfpt_gait, "escaped": self.escaped}  # fmt: skip


def chain_solve(T: Any, first: np.ndarray) -> tuple[float, np.ndarray, float]:
    """``(lambda_2, quasi-stationary distribution, expected steps completed)`` of the live
    states' substochastic matrix ``T`` (sparse, rows: from): lambda_2 its Perron root,
    the distribution its left eigenvector (sum 1), and from a state whose first step
    reaches the live states with the row ``first`` the steps completed before absorption,
    ``first . n`` with ``(I - T) n = 1`` (Kemeny & Snell, "Finite Markov chains", 1960,
    Thm. 3.2.4: ``n`` counts the failing step, so ``first . n`` the steps before it)."""
    from scipy.sparse import csr_matrix, identity
    from scipy.sparse.linalg import eigs, gmres

    size = T.shape[0]
    if size <= 400:
        values, vectors = np.linalg.eig(T.toarray().T)
    else:
        values, vectors = eigs(T.T.tocsr(), k=1, which="LR", v0=np.full(size, 1.0 / size),
                               tol=1e-12)  # fmt: skip
    top = int(np.argmax(values.real))
    pi = np.abs(vectors[:, top].real)
    system = csr_matrix(identity(size) - T)
    guess = np.full(size, 1.0 / max(1.0 - float(values[top].real), 1e-12))
    n, info = gmres(system, np.ones(size), x0=guess, rtol=1e-11, atol=0.0, restart=60,
                    maxiter=2000)  # fmt: skip
    if info:
        raise ConvergenceError(f"the chain's expected steps: GMRES did not converge ({info})")
    return float(values[top].real), pi / pi.sum(), float(first @ n)


@dataclass
class ChainResult:
    """The meshed chain's MFPT on each mesh (:func:`rough_chain`)."""

    components: list[str]
    sigma: float
    quadrature: str
    noise_nodes: int
    levels: list[ChainLevel]
    converged: bool
    qsd: np.ndarray
    mesh: Mesh
    gait_failure: float
    quadrature_change: float | None = None
    steps: int = 0

    @property
    def final(self) -> ChainLevel:
        return self.levels[-1]

    def qsd_summary(self) -> dict[str, Any]:
        """The quasi-stationary distribution's mean and standard deviation per component."""
        x = self.mesh.nodes()
        mean = self.qsd @ x
        sd = np.sqrt(np.maximum(self.qsd @ (x - mean) ** 2, 0.0))
        return {"mean": dict(zip(self.components, mean.tolist())),
                "sd": dict(zip(self.components, sd.tolist()))}  # fmt: skip

    def to_dict(self) -> dict[str, Any]:
        f = self.final
        return {
            "method": "meshed Markov chain",
            "components": list(self.components),
            "quadrature": self.quadrature,
            "noise_nodes": self.noise_nodes,
            "interpolation": "multilinear on the mesh cell's corners",
            "lambda2": f.lambda2,
            "mfpt_qsd": f.mfpt_qsd,
            "mfpt_gait": f.mfpt_gait,
            "byl_tedrake": 1.0 / (1.0 - f.lambda2) if f.lambda2 < 1 else None,
            "nodes": f.nodes,
            "nodes_per_axis": list(f.nodes_per_axis),
            "escaped": f.escaped,
            "converged": self.converged,
            "refinements": len(self.levels) - 1,
            "levels": [level.to_dict() for level in self.levels],
            "quadrature_change": self.quadrature_change,
            "gait_failure": self.gait_failure,
            "quasi_stationary": self.qsd_summary(),
            "steps_simulated": self.steps,
        }


class _Steps:
    """One step of the batch simulator from rows of free components on every slope
    gamma0 + sigma xi_j of the quadrature: the transition rows to the mesh's nodes."""

    def __init__(self, model: Model, params: Sequence[float], sigma: float, xi: np.ndarray,
                 w: np.ndarray, threads: int | None) -> None:  # fmt: skip
        names = [*model.coordinates, *model.rates]
        self.model, self.params = model, np.asarray(params, dtype=float)
        self.index, self.sigma, self.xi, self.w = slope_index(model), sigma, xi, w
        self.free = [names.index(c) for c in free_components(model)]
        self.threads, self.count = threads, 0
        self.centre, self.L = np.zeros(len(self.free)), np.eye(len(self.free))

    def to_section(self, z: np.ndarray) -> np.ndarray:
        """Free components from whitened coordinates: centre + L z."""
        return self.centre + z @ self.L.T

    def to_mesh(self, y: np.ndarray) -> np.ndarray:
        """Whitened coordinates of free components: L^-1 (y - centre)."""
        from scipy.linalg import solve_triangular

        return solve_triangular(self.L, (y - self.centre).T, lower=True).T

    def rows(self, mesh: Mesh, starts: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray]:
        """``(M, escaped, failure)``: M (sparse, len(starts) x mesh.size) the probability
        of reaching each node in one step, escaped the probability per start of a landing
        outside the mesh (taken as a fall), failure that of a fall of the walker (per
        start); :data:`CHUNK` starts a call."""
        from scipy.sparse import vstack

        parts = [self._rows(mesh, starts[i : i + CHUNK]) for i in range(0, len(starts), CHUNK)]
        return (vstack([p[0] for p in parts]).tocsr(), np.concatenate([p[1] for p in parts]),
                np.concatenate([p[2] for p in parts]))  # fmt: skip

    def _rows(self, mesh: Mesh, starts: np.ndarray) -> tuple[Any, np.ndarray, np.ndarray]:
        from scipy.sparse import csr_matrix

        J, N = len(self.xi), len(starts)
        rows = np.tile(self.params, (N * J, 1))
        rows[:, self.index] = self.params[self.index] + self.sigma * np.tile(self.xi, N)
        sections = section_states(self.model, self.params, self.to_section(starts))
        full = np.repeat(sections, J, axis=0)
        result = simulator(self.model).step(rows, full, threads=self.threads)
        self.count += N * J
        walked = result.outcome == WALKED
        y = np.where(walked[:, None], self.to_mesh(result.final[:, self.free]), starts[0])
        index, weight, outside = mesh.interpolation(y)
        p = np.tile(self.w, N) * walked
        escaped_p = p * outside
        p = p * ~outside  # a landing outside the mesh is taken as a fall (an error mass)
        start = np.repeat(np.arange(N), J)
        M = csr_matrix(((p[:, None] * weight).ravel(), (np.repeat(start, weight.shape[1]),
                        index.ravel())), shape=(N, mesh.size))  # fmt: skip
        escaped = np.bincount(start, escaped_p, minlength=N)
        failure = 1.0 - np.bincount(start, p, minlength=N) - escaped
        return M, escaped, failure


def _level(steps: _Steps, mesh: Mesh, gait: np.ndarray) -> tuple[ChainLevel, np.ndarray, float]:
    """The chain on ``mesh``: its level, quasi-stationary distribution, and the gait's
    probability of failing its first step."""
    M, escaped, failure = steps.rows(mesh, np.vstack([mesh.nodes(), gait[None]]))
    T, first = M[:-1], M[-1].toarray().ravel()
    lam, pi, from_gait = chain_solve(T, first)
    mfpt_qsd = lam / (1 - lam) if lam < 1 else math.inf
    level = ChainLevel(mesh.shape, mesh.size, lam, mfpt_qsd, from_gait,
                       float(pi @ escaped[:-1]))  # fmt: skip
    return level, pi, float(failure[-1])


def linearised_factor(model: Model, params: Sequence[float], gait: Orbit, sigma: float
                      ) -> np.ndarray:  # fmt: skip
    """The Cholesky factor L (W = L L^T) of the free section components' covariance about
    the gait under the linearised step map x' = A x + B sigma xi: W = A W A^T +
    sigma^2 B B^T (the discrete Lyapunov equation), restricted to the free components."""
    from scipy.linalg import solve_discrete_lyapunov

    names = [*model.coordinates, *model.rates]
    A, B, _, _ = linearised_step(model, params, [gait.state[n] for n in names])
    if not np.max(np.abs(np.linalg.eigvals(A))) < 1:
        raise VswInputError("the chain needs a stable gait (|eigenvalues| < 1)")
    W = solve_discrete_lyapunov(A, sigma**2 * np.outer(B, B))
    free = [names.index(c) for c in free_components(model)]
    Wf = W[np.ix_(free, free)]
    scale = np.sqrt(np.maximum(np.diag(Wf), 1e-30))
    corr = Wf / np.outer(scale, scale) + 1e-9 * np.eye(len(free))
    return scale[:, None] * np.linalg.cholesky(corr)


PILOT_WALKS = 256
"""Walks of the pilot run that sizes the mesh's box."""

PILOT_STEPS = 100_000
"""The pilot's budget of steps (its walks stop when they are spent)."""

MARGIN = 0.1
"""The box's margin beyond the pilot's states, as a share of their range on each axis."""


def pilot_box(steps: _Steps, gait: np.ndarray, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """The mesh's box in whitened coordinates: the range of the states that
    :data:`PILOT_WALKS` walks from the gait visit (slopes from
    :func:`vsw.studies.rough.terrain_noise` with ``seed``, walks far beyond the Monte Carlo's
    indices) until they fall or spend
    :data:`PILOT_STEPS` steps, widened by :data:`MARGIN` each side and to at least
    +- :data:`BOX_SD` (the linearised spread)."""
    from vsw.studies.rough import terrain_noise

    sim = simulator(steps.model)
    x = np.tile(section_states(steps.model, steps.params, steps.to_section(gait[None]))[0],
                (PILOT_WALKS, 1))  # fmt: skip
    low, high = np.full(len(gait), -BOX_SD), np.full(len(gait), BOX_SD)
    alive, k, spent = np.arange(PILOT_WALKS), 0, 0
    while alive.size and spent < PILOT_STEPS:
        rows = np.tile(steps.params, (alive.size, 1))
        rows[:, steps.index] += steps.sigma * terrain_noise(seed, alive + 2**40, k)
        result = sim.step(rows, x[alive], threads=steps.threads)
        walked = result.outcome == WALKED
        z = steps.to_mesh(result.final[walked][:, steps.free])
        if len(z):
            low, high = np.minimum(low, z.min(axis=0)), np.maximum(high, z.max(axis=0))
        x[alive] = result.final
        alive, k, spent = alive[walked], k + 1, spent + alive.size
    steps.count += spent
    width = high - low
    return low - MARGIN * width, high + MARGIN * width


def rough_chain(
    model: Model,
    params: Sequence[float],
    sigma: float,
    *,
    gait: Orbit | None = None,
    nodes: int | None = None,
    noise_nodes: int = 24,
    quadrature: str = "gauss-hermite",
    max_nodes: int = 100_000,
    max_levels: int = 8,
    check_quadrature: bool = True,
    threads: int | None = None,
) -> ChainResult:
    """The meshed Markov chain's MFPT on the slope gamma0 + sigma xi_k (module docstring):
    a mesh of ``nodes`` per axis (32 on a 2-D section, 12 on a 3-D one) in whitened
    coordinates (:func:`linearised_factor`) over :func:`pilot_box`, refined
    (:meth:`Mesh.refined`) until both MFPTs change by less than :data:`RTOL`, at most
    ``max_levels`` meshes of at most ``max_nodes`` nodes; ``check_quadrature``: the final
    mesh again with twice the noise nodes, the relative change of the gait's MFPT in
    ``quadrature_change``."""
    slope_index(model)
    if not math.isfinite(sigma) or sigma <= 0:
        raise VswInputError(f"sigma = {sigma:g}: the chain needs a finite sigma > 0")
    xi, w = noise_quadrature(noise_nodes, quadrature)
    with blas.limited(default_threads() if threads is None else threads):
        gait = gait or model.stable_gait(params, "no gait for the chain to mesh around")
        components = free_components(model)
        steps = _Steps(model, params, sigma, xi, w, threads)
        steps.centre = np.array([gait.state[c] for c in components])
        steps.L = linearised_factor(model, params, gait, sigma)
        origin = np.zeros(len(components))
        low, high = pilot_box(steps, origin)
        n0 = nodes or (32 if len(components) <= 2 else 12)
        mesh = Mesh(tuple(np.linspace(a, b, n0) for a, b in zip(low, high)))
        levels, converged = [], False
        while True:
            level, pi, gait_failure = _level(steps, mesh, origin)
            levels.append(level)
            if len(levels) > 2 and _settled(*levels[-3:]):
                converged = True
                break
            finer = mesh.refined(pi)
            if finer.size > max_nodes or len(levels) >= max_levels:
                break
            mesh = finer
        change = None
        if check_quadrature:
            again = _Steps(model, params, sigma, *noise_quadrature(2 * noise_nodes, quadrature),
                           threads)  # fmt: skip
            again.centre, again.L = steps.centre, steps.L
            level2, _, _ = _level(again, mesh, origin)
            steps.count += again.count
            change = abs(level2.mfpt_gait - level.mfpt_gait) / level.mfpt_gait
    return ChainResult(components, float(sigma), quadrature, int(noise_nodes), levels,
                       converged, pi, mesh, gait_failure, change, steps.count)  # fmt: skip


def _settled(*levels: ChainLevel) -> bool:
    """Both MFPTs within :data:`RTOL` of the next mesh's, on each refinement of
    ``levels`` (two in a row: one alone can pause on the way)."""
    pairs = itertools.pairwise(levels)
    return all(abs(b.mfpt_qsd - a.mfpt_qsd) <= RTOL * abs(a.mfpt_qsd)
               and abs(b.mfpt_gait - a.mfpt_gait) <= RTOL * abs(a.mfpt_gait)
               for b, a in pairs)  # fmt: skip
