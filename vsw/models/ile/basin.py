"""Basin of attraction of the ILE gait over a grid of theta_II (the paper's Fig. 9).

The basin is computed by iterating the generated stride map from a grid of initial q with
the failure checks of every step (fall backward: q <= q_apex_min; lift-off: the contact
margin of the step is negative), then refining each edge by bisection on the same test.
The closed-form interval (q_apex_min, q_liftoff_max] is *not* used to compute it; the
tests compare the two, and :func:`check_edges_by_simulation` checks edges with the
time-domain simulation.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from generated import ile
from vsw.models.ile.analysis import analyze, jsonable
from vsw.models.ile.params import check_parameter
from vsw.models.ile.simulate import simulate, simulate_cost
from vsw.runtime import limits
from vsw.runtime.errors import VswInputError
from vsw.runtime.threads import default_threads
from vsw.runtime.vectorize import CHUNK, run_blocks

__all__ = [
    "Basin",
    "EdgeCheck",
    "basin",
    "basin_cost",
    "check_edges_by_simulation",
    "converges",
    "edge_check_cost",
]

Progress = Callable[[int, int], None]

# Conditions checked step by step on q; the other physical conditions depend only on the
# parameters and decide whether a gait can exist at all.
_STEPWISE_CONDITIONS = frozenset({"q_positive", "apex", "stance_contact"})

DEFAULT_THETA_II_DEG = np.linspace(-30.0, 40.0, 141)

_BISECTIONS = 60  # bisection steps per basin edge: 2^-60 of a grid spacing, below round-off


_FIELD_NOTES = {
    "beta": "length shorten ratio r_s/r_e",
    "phi0": "rad: inter-leg angle at heelstrike",
    "theta_II": "rad: leg extension angle of each row",
    "q_min": "g/r_e: lower basin edge; the basin is q_min < q0 <= q_max, q = omega_I^2",
    "q_max": "g/r_e: upper basin edge (the stance foot lifts off above it)",
    "q_fixed": "g/r_e: fixed point of the stride map, eq. (10)",
    "omega_min": "sqrt(g/r_e): sqrt(q_min)",
    "omega_max": "sqrt(g/r_e): sqrt(q_max)",
    "n_steps": "stride-map steps each initial q is walked before it counts as converged: "
    "until eigenvalue^n_steps * (1.5/beta) < 1e-12",
}


@dataclass(frozen=True)
class Basin:
    """Basin of attraction per theta_II for fixed beta and phi0.

    Attributes
    ----------
    beta, phi0 : float
    theta_II : numpy.ndarray, shape (n,)
        Grid (rad).
    q_min, q_max : numpy.ndarray, shape (n,)
        The basin is q_min < q0 <= q_max (q = omega_I^2); NaN where no gait exists.
    q_fixed : numpy.ndarray, shape (n,)
        Fixed point (NaN where no gait exists).
    n_steps : int
        Stride-map iterations each initial q is walked before it counts as converged:
        enough for eigenvalue^n_steps x (1.5 / beta) < 1e-12 (at most ``max_steps``).
    """

    beta: float
    phi0: float
    theta_II: np.ndarray
    q_min: np.ndarray
    q_max: np.ndarray
    q_fixed: np.ndarray
    n_steps: int

    @property
    def omega_min(self) -> np.ndarray:
        """Lower edge as omega_I = sqrt(q_min), shape (n,)."""
        return np.sqrt(self.q_min)

    @property
    def omega_max(self) -> np.ndarray:
        """Upper edge as omega_I = sqrt(q_max), shape (n,)."""
        return np.sqrt(self.q_max)

    def to_dict(self) -> dict[str, Any]:
        """JSON contract of ``vsw basin --json`` (equal-length lists, None for NaN).

        ``fields`` maps every other key to its unit and meaning (``n_steps`` included).
        """
        return {
            "beta": self.beta,
            "phi0": self.phi0,
            "theta_II": jsonable(self.theta_II),
            "q_min": jsonable(self.q_min),
            "q_max": jsonable(self.q_max),
            "q_fixed": jsonable(self.q_fixed),
            "omega_min": jsonable(self.omega_min),
            "omega_max": jsonable(self.omega_max),
            "n_steps": self.n_steps,
            "fields": dict(_FIELD_NOTES),
        }


def _steps_to_converge(eigenvalue: float, spread: float, tol: float, cap: int) -> int:
    """Iterations after which lambda^n * spread < tol for the linear map (at least 2)."""
    if not (0 < eigenvalue < 1 and math.isfinite(spread)):
        return cap
    n = math.ceil(math.log(tol / max(spread, tol)) / math.log(eigenvalue)) + 1
    return int(min(max(n, 2), cap))


def _tiling(shape: tuple[int, int]) -> tuple[int, int]:
    """Rows and columns of the blocks of a (theta_II, q) grid: at most CHUNK elements each.

    Whole rows while a row fits in a block; longer rows are split into columns as well, so
    the temporaries of a block stay in cache and bounded, however long the q grid is.
    """
    cols = max(1, min(shape[1], CHUNK))
    return max(1, CHUNK // cols), cols


def _tile_count(shape: tuple[int, int]) -> int:
    rows, cols = _tiling(shape)
    return -(-shape[0] // rows) * -(-shape[1] // cols)


def converges(
    beta: float,
    theta_II: np.ndarray,
    phi0: float,
    q0: np.ndarray,
    n_steps: int,
    q_fixed: np.ndarray,
    gait_exists: np.ndarray,
    tol: float = 1e-8,
    progress: Progress | None = None,
) -> np.ndarray:
    """Whether walking from q0 survives ``n_steps`` steps and ends at the fixed point.

    Parameters
    ----------
    beta, phi0 : float
    theta_II, q_fixed, gait_exists : numpy.ndarray
        Broadcastable against ``q0`` (e.g. shape (n, 1) against (n, m)).
    q0 : numpy.ndarray
        Initial q = omega_I^2.
    n_steps : int
    tol : float
        Relative distance to q_fixed accepted at the end.
    progress : callable, optional
        ``progress(done, total)`` in blocks after each block (from one thread at a time).

    Returns
    -------
    numpy.ndarray of bool
        Broadcast shape of the inputs.
    """
    q = np.asarray(q0, dtype=float)
    shape = np.broadcast_shapes(
        q.shape, np.shape(theta_II), np.shape(q_fixed), np.shape(gait_exists)
    )
    if len(shape) != 2 or math.prod(shape) <= CHUNK:
        out = _converges_block(beta, theta_II, phi0, q, n_steps, q_fixed, gait_exists, tol)
        if progress is not None:
            progress(1, 1)
        return out
    # Blocks of about CHUNK elements, every step of a block while it is in cache, blocks
    # on the shared thread pool: numpy releases the GIL (case 5 of benchmarks/run.py).
    # Broadcast along rows only: a (n, 1) column stays one column, so per-theta_II terms
    # are computed once per row, not once per q.
    full = []
    for a in (theta_II, q, q_fixed, gait_exists):
        a = np.asarray(a)
        a = a.reshape((1,) * (2 - a.ndim) + a.shape)
        full.append(np.broadcast_to(a, (shape[0], a.shape[1])))
    rows, cols = _tiling(shape)
    tiles = [(r, c) for r in range(0, shape[0], rows) for c in range(0, shape[1], cols)]
    out = np.empty(shape, dtype=bool)
    lock = threading.Lock()
    done = 0

    def block(i: int) -> None:
        nonlocal done
        r, c = tiles[i]
        part = [a[r : r + rows, c : c + cols] if a.shape[1] > 1 else a[r : r + rows] for a in full]
        out[r : r + rows, c : c + cols] = _converges_block(
            beta, part[0], phi0, part[1], n_steps, part[2], part[3], tol
        )
        if progress is not None:
            with lock:
                done += 1
                progress(done, len(tiles))

    run_blocks(block, range(len(tiles)), default_threads())
    return out


def _converges_block(beta, theta_II, phi0, q, n_steps, q_fixed, gait_exists, tol) -> np.ndarray:
    alive = np.broadcast_to(gait_exists, np.broadcast_shapes(q.shape, np.shape(gait_exists)))
    alive = alive.copy()
    # NaN and overflow are expected where no gait exists (they fail the tests below).
    with np.errstate(all="ignore"):
        q_apex = ile.q_apex_min(beta, theta_II, phi0)
        for _ in range(n_steps):
            # Every step: over the apex (eq. 14 exact) and foot on the ground all step.
            alive &= q > q_apex
            alive &= ile.contact_margin(beta, theta_II, phi0, q) >= 0
            q = np.where(alive, ile.stride_map(beta, theta_II, phi0, q), np.nan)
        alive &= np.abs(q - q_fixed) <= tol * (1 + np.abs(q_fixed))
    return alive


def _map_steps(beta: float, phi0: float, max_steps: int) -> int:
    """Map iterations per test of :func:`basin`: until lambda^n (1.5/beta) < 1e-12."""
    return _steps_to_converge(float(ile.eigenvalue(beta, phi0)), 1.5 / beta, 1e-12, max_steps)


def basin_cost(
    beta: float,
    phi0: float,
    n_theta: int,
    n_q: int,
    *,
    max_steps: int = 5000,
    refine: bool = True,
    threads: int | None = None,
) -> limits.Cost:
    """Estimated run time and peak memory of :func:`basin` (see :mod:`vsw.runtime.limits`).

    From the arrays it allocates: the boolean grid result and the copy that finding each
    row's last basin point makes (2 bytes a grid point), the q grid (8 bytes a q), the
    temporaries of the blocks running at once (about 90 bytes an element, measured with
    tracemalloc on 10^6-element blocks), and per theta_II the analysis, the bisection
    brackets and the output (below 1 kB). The time: ``n_steps`` map steps over every grid
    point and over every row of each of the 2 x 60 bisection tests.

    Parameters
    ----------
    beta, phi0 : float
        Validated parameters (rad).
    n_theta, n_q : int
        Grid size.
    max_steps, refine : as for :func:`basin`
    threads : int, optional
        Default :func:`vsw.runtime.threads.default_threads`.

    Returns
    -------
    vsw.runtime.limits.Cost
    """
    threads = default_threads() if threads is None else threads
    n_steps = _map_steps(beta, phi0, max_steps)
    shape = (n_theta, max(n_q - 1, 0))
    cells = shape[0] * shape[1]
    if cells <= CHUNK:
        blocks, block_size = 1, cells
    else:
        blocks, block_size = _tile_count(shape), math.prod(_tiling(shape))
    parallel = max(1, min(threads, blocks))
    per_block = limits.BASIN_SECONDS_PER_BLOCK_STEP
    per_element = limits.BASIN_SECONDS_PER_ELEMENT_STEP
    seconds = n_steps * (blocks * per_block + cells * per_element) / parallel
    if refine:  # 2 tests per bisection step, each one block over the rows
        seconds += 2 * _BISECTIONS * n_steps * (per_block + n_theta * per_element)
    nbytes = 2 * cells + 8 * n_q + parallel * block_size * 90 + 1000 * n_theta
    return limits.Cost(seconds, nbytes)


def basin(
    beta: float,
    phi0: float,
    theta_II_grid: Any = None,
    *,
    n_q: int = 2001,
    refine: bool = True,
    max_steps: int = 5000,
    progress: Progress | None = None,
) -> Basin:
    """Basin of attraction of the fixed point for each theta_II of a grid.

    Parameters
    ----------
    beta, phi0 : float
        Model parameters (phi0 in rad).
    theta_II_grid : array_like, shape (n,), optional
        theta_II values (rad); default -30 deg to 40 deg in 0.5 deg steps.
    n_q : int
        Number of initial q on the grid 0 < q <= 1.5 / beta. The stance foot lifts off at
        instant I itself once q > cos(theta_I) / beta <= 1 / beta, so the grid reaches past
        every upper edge.
    refine : bool
        Bisect each edge between its grid neighbours to full precision.
    max_steps : int
        Cap on map iterations per test.
    progress : callable, optional
        ``progress(done, total)`` after each block of the grid and each bisection step.

    Returns
    -------
    Basin
        NaN edges where no gait exists (some physical condition independent of q fails, or
        no grid q converges).

    Raises
    ------
    VswInputError
        Invalid parameters or grid, or a grid whose estimated time or memory exceeds the
        limits of :mod:`vsw.runtime.limits` (see :func:`basin_cost`).
    """
    beta = float(check_parameter("beta", beta))
    phi0 = float(check_parameter("phi0", phi0))
    theta_II = _checked_grid(beta, phi0, theta_II_grid, n_q, max_steps, refine)
    gait_exists, q_fixed = _gait_exists(beta, theta_II, phi0)
    q_top = 1.5 / beta
    with np.errstate(all="ignore"):  # beta below 1e-308: q_top = inf, a grid of NaN
        q_grid = np.linspace(0.0, q_top, n_q)[1:]
    test = _BasinTest(beta, phi0, theta_II, q_fixed, gait_exists,
                      _map_steps(beta, phi0, max_steps))  # fmt: skip
    q_min, q_max, any_inside = _edges(test, q_grid, q_top, refine, progress)
    return Basin(
        beta=beta,
        phi0=phi0,
        theta_II=theta_II,
        q_min=q_min,
        q_max=q_max,
        q_fixed=np.where(any_inside, q_fixed, np.nan),
        n_steps=test.n_steps,
    )


def _edges(
    test: _BasinTest, q_grid: np.ndarray, q_top: float, refine: bool, progress: Progress | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each row's basin edges: its first and last converging q of ``q_grid``, with
    ``refine`` bisected to full precision (NaN where no grid q converges), and whether
    any grid q converges."""
    grid_blocks = _tile_count((test.theta_II.size, q_grid.size))
    total = grid_blocks + (_BISECTIONS if refine else 0)

    def grid_progress(done: int, _blocks: int) -> None:
        if progress is not None:
            progress(done * grid_blocks // _blocks, total)

    q0 = np.broadcast_to(q_grid, (test.theta_II.size, q_grid.size))
    inside = test(q0, report=grid_progress)
    any_inside = inside.any(axis=1)
    first = np.argmax(inside, axis=1)
    last = q_grid.size - 1 - np.argmax(inside[:, ::-1], axis=1)
    if progress is not None and not (refine and any_inside.any()):
        progress(total, total)
    q_min = np.where(any_inside, q_grid[first], np.nan)
    q_max = np.where(any_inside, q_grid[last], np.nan)
    if refine and any_inside.any():
        rows = np.flatnonzero(any_inside)

        def step_done(i: int) -> None:
            if progress is not None:
                progress(grid_blocks + i + 1, total)

        q_min[rows], q_max[rows] = _bisect_edges(test, rows, q_grid, first[rows], last[rows],
                                                 q_top, step_done)  # fmt: skip
    return q_min, q_max, any_inside


def _checked_grid(
    beta: float, phi0: float, theta_II_grid: Any, n_q: int, max_steps: int, refine: bool
) -> np.ndarray:
    """The theta_II grid of :func:`basin` (rad), checked with ``n_q`` and the basin's
    estimated cost against :mod:`vsw.runtime.limits`."""
    theta_II = np.radians(DEFAULT_THETA_II_DEG) if theta_II_grid is None else theta_II_grid
    theta_II = check_parameter("theta_II", np.atleast_1d(theta_II)).astype(float)
    if theta_II.ndim != 1:
        raise VswInputError(f"theta_II_grid must be one-dimensional, got shape {theta_II.shape}")
    if isinstance(n_q, bool) or not isinstance(n_q, (int, np.integer)) or n_q < 3:
        raise VswInputError(f"n_q = {n_q!r} must be an integer of at least 3 grid points")
    limits.check(
        f"a basin of {theta_II.size} theta_II x {n_q} q values",
        basin_cost(beta, phi0, theta_II.size, n_q, max_steps=max_steps, refine=refine),
        "use fewer theta_II or q values",
    )
    return theta_II


def _gait_exists(beta: float, theta_II: np.ndarray, phi0: float) -> tuple[np.ndarray, np.ndarray]:
    """Per theta_II, whether the physical conditions that do not depend on q hold, and
    the fixed point there (NaN where they do not)."""
    analysis = analyze(beta, theta_II, phi0, timing=False)
    gait_exists = np.ones(theta_II.shape, dtype=bool)
    for c in analysis.conditions:
        if c.physical and c.name not in _STEPWISE_CONDITIONS:
            gait_exists &= np.asarray(c.holds)
    return gait_exists, np.where(gait_exists, analysis.q_fixed, np.nan)


@dataclass(frozen=True)
class _BasinTest:
    """Whether initial q converge (:func:`converges`) on rows of a basin's theta_II grid."""

    beta: float
    phi0: float
    theta_II: np.ndarray
    q_fixed: np.ndarray
    gait_exists: np.ndarray
    n_steps: int

    def __call__(
        self, q0: np.ndarray, rows: Any = slice(None), report: Progress | None = None
    ) -> np.ndarray:
        """``q0`` tested on ``rows``: one q per row, or a (rows, q) grid."""
        th = self.theta_II[rows]
        qf = self.q_fixed[rows]
        ok = self.gait_exists[rows]
        if q0.ndim == 2:
            th, qf, ok = th[:, None], qf[:, None], ok[:, None]
        return converges(self.beta, th, self.phi0, q0, self.n_steps, qf, ok, progress=report)


def _bisect_edges(
    test: _BasinTest,
    rows: np.ndarray,
    q_grid: np.ndarray,
    first: np.ndarray,
    last: np.ndarray,
    q_top: float,
    step_done: Callable[[int], None],
) -> tuple[np.ndarray, np.ndarray]:
    """Each row's lower and upper basin edge, bisected from its first and last converging
    grid q and their failing neighbours."""
    # Lower edge: bracket (fail, converge); q = 0 (standing still) never converges.
    low_fail = np.where(first > 0, q_grid[np.maximum(first - 1, 0)], 0.0)
    low_ok = q_grid[first]
    # Upper edge: bracket (converge, fail); past the grid end counts as failing.
    high_ok = q_grid[last]
    high_fail = np.where(
        last < q_grid.size - 1, q_grid[np.minimum(last + 1, q_grid.size - 1)], q_top
    )
    for i in range(_BISECTIONS):
        mid = 0.5 * (low_fail + low_ok)
        good = test(mid, rows)
        low_ok = np.where(good, mid, low_ok)
        low_fail = np.where(good, low_fail, mid)
        mid = 0.5 * (high_ok + high_fail)
        good = test(mid, rows)
        high_ok = np.where(good, mid, high_ok)
        high_fail = np.where(good, high_fail, mid)
        step_done(i)
    return low_ok, high_ok


@dataclass(frozen=True)
class EdgeCheck:
    """One simulation run next to a basin edge.

    Attributes
    ----------
    theta_II : float
    edge : {'q_min', 'q_max'}
    side : {'inside', 'outside'}
    q0 : float
    expected, ended : str
        Expected and actual end of the simulation ('completed' means it also reached the
        fixed point).
    q_last : float
        q after the last simulated heelstrike (NaN if it never got there).
    ok : bool
    """

    theta_II: float
    edge: str
    side: str
    q0: float
    expected: str
    ended: str
    q_last: float
    ok: bool


def _edge_check_steps(beta: float, phi0: float) -> int:
    """Simulated steps of an inside edge check: until lambda^n < 1e-9 (at most 200)."""
    return _steps_to_converge(float(ile.eigenvalue(beta, phi0)), 1.0, 1e-9, 200)


def edge_check_cost(
    beta: float, phi0: float, n_samples: int, steps: int | None = None
) -> limits.Cost:
    """Estimated time and memory of :func:`check_edges_by_simulation` on ``n_samples`` rows.

    Each row simulates both edges from inside for ``steps`` steps (default as there) and
    from outside for 2 steps (see :mod:`vsw.runtime.limits` for the cost of a step).
    """
    steps = _edge_check_steps(beta, phi0) if steps is None else steps
    return simulate_cost(n_samples * (2 * steps + 4), record=False)


def check_edges_by_simulation(
    result: Basin,
    n_samples: int = 5,
    rel: float = 1e-3,
    steps: int | None = None,
    progress: Progress | None = None,
) -> list[EdgeCheck]:
    """Check sampled basin edges with the time-domain simulation (``vsw.models.ile.simulate``).

    Just inside each edge the simulation must complete and reach q_fixed; just outside the
    lower edge it must fall backward and outside the upper edge the foot must lift off.

    Parameters
    ----------
    result : Basin
    n_samples : int
        Number of theta_II values, evenly spread over those with a gait.
    rel : float
        Offset from the edge as a fraction of the basin width.
    steps : int, optional
        Simulated steps for the inside runs; default enough for lambda^steps < 1e-9.
    progress : callable, optional
        ``progress(done, total)`` after each simulation.

    Returns
    -------
    list of EdgeCheck
    """
    rows = np.flatnonzero(np.isfinite(result.q_min) & np.isfinite(result.q_max))
    if rows.size == 0:
        return []
    if steps is None:
        steps = _edge_check_steps(result.beta, result.phi0)
    # More samples than rows with a basin pick every row once: the plan is the same.
    n_picks = min(max(n_samples, 1), rows.size)
    limits.check(
        f"{n_picks} edge checks by simulation",
        edge_check_cost(result.beta, result.phi0, n_picks, steps),
        "check fewer edges",
    )
    picks = rows[np.unique(np.linspace(0, rows.size - 1, n_picks).round().astype(int))]
    plan: list[tuple[int, str, str, float, str]] = []
    for i in picks:
        width = result.q_max[i] - result.q_min[i]
        delta = rel * width
        plan.append((i, "q_min", "inside", result.q_min[i] + delta, "completed"))
        if result.q_min[i] - delta > 0:
            plan.append((i, "q_min", "outside", result.q_min[i] - delta, "fell-backward"))
        plan.append((i, "q_max", "inside", result.q_max[i] - delta, "completed"))
        plan.append((i, "q_max", "outside", result.q_max[i] + delta, "lift-off"))
    checks: list[EdgeCheck] = []
    for done, (i, edge, side, q0, expected) in enumerate(plan, start=1):
        run_steps = steps if side == "inside" else 2
        sim = simulate(
            result.beta, float(result.theta_II[i]), result.phi0, float(q0), run_steps, record=False
        )
        q_last = float(sim.q[-1]) if len(sim.q) else math.nan
        ok = sim.ended == expected
        if ok and expected == "completed":
            q_fixed = float(result.q_fixed[i])
            ok = abs(q_last - q_fixed) <= 1e-6 * (1 + abs(q_fixed))
        checks.append(
            EdgeCheck(
                float(result.theta_II[i]), edge, side, float(q0), expected, sim.ended, q_last, ok
            )
        )
        if progress is not None:
            progress(done, len(plan))
    return checks
