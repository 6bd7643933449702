"""Walking on rough ground: the mean first-passage time (MFPT) of a walker on stochastic
terrain, by Monte Carlo over the batch simulator (:mod:`vsw.dynamics.batch`).

Byl & Tedrake ("Metastable walking machines", Int. J. Robotics Research 28(8), 2009) make
a walker's robustness one number: the expected number of steps it takes on stochastic
terrain before it falls. The terrain here is theirs in its simplest form, a slope drawn
per step: step ``k`` (from 0) is walked on the slope

    gamma_k = gamma0 + sigma * xi_k,  xi_k i.i.d. standard normal,

drawn at the step event that starts step ``k`` and held for the whole step; the state
after an impact is taken as it is into the next step's slope (the impact is the model's,
in the slope's own frame). The slope is the model's parameter :data:`SLOPE`; a model
without one is refused.

The height terrain raises or lowers each step's next foothold instead: step ``k`` ends on
ground ``h_k = h0 + sigma * xi_k`` above its stance foot (along the ground normal), the
model's parameter :data:`HEIGHT`, which its step event's guard must contain (the swing
foot's height minus :data:`HEIGHT`); a model without it is refused in one line. Either
terrain draws xi_k standard normal or uniform on (-sqrt 3, sqrt 3) (:data:`DISTRIBUTIONS`,
standard deviation 1 both).

The draws are counter-based (Philox4x32-10 keyed by the seed, its counter the step and
the walk's index): the slope of step ``k`` of walk ``w`` is a function of ``(seed, w, k)``
alone, so the results are the same for any thread count, block size, or split of the
walks into parts.

A walk ends at its first failure (the model's own: a fall, a lift-off, a stall of the
integration) or after ``max_steps`` steps (censored). :func:`mfpt_estimate` states the
estimator.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from vsw.dynamics.batch import simulator
from vsw.dynamics.hybrid import RTOL, Orbit
from vsw.models.base import Model
from vsw.plots import plotstyle
from vsw.runtime import blas
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.runtime.threads import default_threads

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "DISTRIBUTIONS",
    "HEIGHT",
    "SLOPE",
    "TERRAINS",
    "GaitSensitivity",
    "MfptEstimate",
    "RoughWalks",
    "SlopeTerrain",
    "Terrain",
    "check_inputs",
    "disturbance_index",
    "gait_sensitivity",
    "gait_sensitivity_units",
    "h2_norm",
    "linearised_step",
    "mfpt_estimate",
    "philox4x32",
    "rough_walks",
    "slope_impulse_response",
    "slope_index",
    "survival_plot",
    "terrain_noise",
]

SLOPE = "gamma"
"""The slope parameter's name (radians, downhill positive) in every model that has one."""

HEIGHT = "step_height"
"""The ground-height parameter's name: the height of the next foothold above the stance
foot along the ground normal (the model's length unit, up positive), which a model that
takes the height terrain puts in its step event's guard (the swing foot's height minus
it) with the default 0."""

TERRAINS = {"slope": SLOPE, "height": HEIGHT}
"""Each terrain and the parameter it draws per step."""

DISTRIBUTIONS = ("gaussian", "uniform")
"""The per-step draw xi_k: standard normal, or uniform on (-sqrt 3, sqrt 3); both have mean
0 and standard deviation 1, so sigma is the terrain's standard deviation either way."""

MAX_SEED = 2**63 - 1
MAX_WALKS = 10_000_000
MAX_STEPS = 1_000_000
Z95 = 1.959963984540054
"""The standard normal's 97.5 % quantile: a two-sided 95 % interval."""


def slope_index(model: Model) -> int:
    """The index of the model's slope parameter, or one line saying it has none."""
    names = tuple(model.spec["parameters"])
    if SLOPE not in names:
        raise VswInputError(
            f"{model.cli_name} has no slope parameter {SLOPE} (its parameters: "
            f"{', '.join(names)}): rough ground needs a model on a slope"
        )
    return names.index(SLOPE)


def disturbance_index(model: Model, terrain: str) -> int:
    """The index of the parameter ``terrain`` draws per step (:data:`TERRAINS`), or one
    line saying what the model would need to take it."""
    if terrain not in TERRAINS:
        raise VswInputError(f"terrain {terrain!r}: one of {', '.join(TERRAINS)}")
    if terrain == "slope":
        return slope_index(model)
    names = tuple(model.spec["parameters"])
    if HEIGHT not in names:
        raise VswInputError(
            f"{model.cli_name} cannot take a height terrain: it has no parameter {HEIGHT} "
            "(the next foothold's height above the stance foot, in its step event's guard: "
            f"the swing foot's height minus {HEIGHT}); its parameters: {', '.join(names)}"
        )
    return names.index(HEIGHT)


def check_inputs(sigma: float, walks: int, max_steps: int, seed: int) -> None:
    """One line for a noise level, walk count, step count or seed out of range."""
    if not math.isfinite(sigma) or sigma < 0:
        raise VswInputError(f"sigma = {sigma:g} must be a finite number >= 0")
    for name, value, most in (("walks", walks, MAX_WALKS), ("max_steps", max_steps, MAX_STEPS)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise VswInputError(f"{name} = {value!r} must be an integer")
        if not 1 <= value <= most:
            raise VswInputError(f"{name} = {value} must be from 1 to {most}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise VswInputError(f"seed = {seed!r} must be an integer")
    if not 0 <= seed <= MAX_SEED:
        raise VswInputError(f"seed = {seed} must be from 0 to {MAX_SEED}")


_MASK32 = np.uint64(0xFFFFFFFF)
_PHILOX_M = (np.uint64(0xD2511F53), np.uint64(0xCD9E8D57))
_PHILOX_W = (0x9E3779B9, 0xBB67AE85)


def philox4x32(counter: Sequence[np.ndarray], key: Sequence[int]) -> tuple[np.ndarray, ...]:
    """Philox4x32-10 (Salmon, Moraes, Dror & Shaw, "Parallel random numbers: as easy as
    1, 2, 3", SC 2011), vectorised over the counters: four words of 32 bits (arrays that
    broadcast) and a key of two, to four words of 32 bits (uint64 arrays). Random123's
    known answers are in the tests."""
    c0, c1, c2, c3 = (np.asarray(c, dtype=np.uint64) & _MASK32 for c in counter)
    k0, k1 = int(key[0]) & 0xFFFFFFFF, int(key[1]) & 0xFFFFFFFF
    for r in range(10):
        if r:
            k0, k1 = (k0 + _PHILOX_W[0]) & 0xFFFFFFFF, (k1 + _PHILOX_W[1]) & 0xFFFFFFFF
        p0, p1 = _PHILOX_M[0] * c0, _PHILOX_M[1] * c2
        c0, c1, c2, c3 = ((p1 >> np.uint64(32)) ^ c1 ^ np.uint64(k0), p1 & _MASK32,
                          (p0 >> np.uint64(32)) ^ c3 ^ np.uint64(k1), p0 & _MASK32)  # fmt: skip
    return c0, c1, c2, c3


def _uniform(high: np.ndarray, low: np.ndarray) -> np.ndarray:
    """A uniform double in (0, 1) from two words: 27 + 26 bits, half a unit offset."""
    bits = (high >> np.uint64(5)) << np.uint64(26) | (low >> np.uint64(6))
    return (bits.astype(np.float64) + 0.5) * 2.0**-53


def terrain_noise(seed: int, walks: Sequence[int] | np.ndarray, steps: int | np.ndarray,
                  distribution: str = "gaussian") -> np.ndarray:  # fmt: skip
    """The draw xi of each step ``steps`` of each walk ``walks`` (global indices; arrays
    that broadcast): Philox4x32-10 with the key ``seed`` (its two 32-bit halves) on the
    counter (step, walk's low and high 32 bits, 0), its four words two uniforms u1, u2;
    ``gaussian``: xi = sqrt(-2 ln u1) cos(2 pi u2) (Box & Muller 1958), ``uniform``:
    xi = sqrt(3) (2 u1 - 1). A draw is a function of (seed, walk, step) alone."""
    if distribution not in DISTRIBUTIONS:
        raise VswInputError(f"distribution {distribution!r}: one of {', '.join(DISTRIBUTIONS)}")
    walks = np.asarray(walks, dtype=np.uint64)
    steps = np.asarray(steps, dtype=np.uint64)
    x0, x1, x2, x3 = philox4x32(
        (steps, walks & _MASK32, walks >> np.uint64(32), np.zeros_like(walks)),
        (int(seed) & 0xFFFFFFFF, int(seed) >> 32),
    )
    u1 = _uniform(x0, x1)
    if distribution == "uniform":
        return math.sqrt(3.0) * (2.0 * u1 - 1.0)
    u2 = _uniform(x2, x3)
    return np.sqrt(-2.0 * np.log(u1)) * np.cos(2.0 * np.pi * u2)


class Terrain:
    """The per-step parameter rows of walks on a random terrain, for
    :meth:`vsw.dynamics.batch.BatchSimulator.walk_varying`: ``terrain(rows, k)`` is the parameter
    rows of step ``k`` of the walks ``first_walk + rows``, the parameter ``index`` (the
    slope, or the next foothold's height) drawn as its value + sigma xi."""

    def __init__(
        self, params: Sequence[float], index: int, sigma: float, seed: int, first_walk: int = 0,
        distribution: str = "gaussian",
    ) -> None:  # fmt: skip
        self.params = np.asarray(params, dtype=float)
        self.index, self.sigma, self.seed, self.first_walk = index, sigma, seed, first_walk
        self.distribution = distribution

    def slopes(self, rows: np.ndarray, k: int) -> np.ndarray:
        """The drawn parameter (a slope or a height) of step ``k`` of the walks
        ``first_walk + rows``."""
        walks = self.first_walk + np.asarray(rows, dtype=np.int64)
        xi = terrain_noise(self.seed, walks, k, self.distribution)
        return self.params[self.index] + self.sigma * xi

    def __call__(self, rows: np.ndarray, k: int) -> np.ndarray:
        out = np.tile(self.params, (len(rows), 1))
        out[:, self.index] = self.slopes(rows, k)
        return out

    def of_steps(self, rows: np.ndarray, first: int, count: int) -> np.ndarray:
        """The parameter rows of steps ``first .. first + count - 1`` of the walks
        ``first_walk + rows``: (len(rows), count, parameters), each row the one of
        ``self(rows, k)`` (one draw of the counters of every step at once)."""
        walks = self.first_walk + np.asarray(rows, dtype=np.int64)
        xi = terrain_noise(self.seed, walks[:, None], np.arange(first, first + count)[None, :],
                           self.distribution)  # fmt: skip
        out = np.empty((len(walks), count, len(self.params)))
        out[:] = self.params
        out[:, :, self.index] = self.params[self.index] + self.sigma * xi
        return out


SlopeTerrain = Terrain
"""The slope terrain: :class:`Terrain` on the slope parameter's index."""


@dataclass(frozen=True)
class MfptEstimate:
    """The MFPT (steps completed before the first failure) with its standard error and a
    95 % interval (``high`` None: unbounded above); ``mfpt`` None where no walk failed."""

    mfpt: float | None
    se: float | None
    low: float
    high: float | None
    estimator: str
    walks: int
    failures: int
    censored: int
    total_steps: int


def mfpt_estimate(steps: np.ndarray, failed: np.ndarray) -> MfptEstimate:
    """The MFPT from walks that completed ``steps`` steps each, ``failed`` where a failure
    ended them (else censored: they walked every step).

    Every walk's step is a trial that fails with probability p (Byl & Tedrake 2009: far
    from the start, a metastable walker's first passage is geometric, p = 1 - lambda_2).
    With S steps completed over all walks and F failures the likelihood is
    p^F (1 - p)^S, so the maximum-likelihood MFPT is (1 - p)/p = S / F, the censored walks
    counted by their steps. Nothing censored, S / F is the sample mean, given with the
    sample's standard error and the normal 95 % interval. With censored walks the standard
    error is the Fisher information's, S/F sqrt((S + F)/(S F)), and the interval is
    symmetric in log MFPT. No failure: no estimate, and the 95 % lower bound
    (1 - p_max)/p_max with p_max = 1 - 0.05^(1/S)."""
    steps = np.asarray(steps, dtype=np.int64)
    failed = np.asarray(failed, dtype=bool)
    walks, total = len(steps), int(steps.sum())
    fails, censored = int(failed.sum()), int((~failed).sum())
    if fails == 0:
        p_max = -math.expm1(math.log(0.05) / total) if total else 1.0
        return MfptEstimate(None, None, (1 - p_max) / p_max, None,
                            "no failure: the 95 % lower bound of a geometric first passage",
                            walks, 0, censored, total)  # fmt: skip
    mfpt = total / fails
    if censored == 0:
        se = float(np.std(steps, ddof=1)) / math.sqrt(walks) if walks > 1 else math.inf
        return MfptEstimate(mfpt, se, max(0.0, mfpt - Z95 * se), mfpt + Z95 * se,
                            "sample mean (no walk censored)", walks, fails, 0, total)  # fmt: skip
    spread = math.sqrt((total + fails) / (total * fails))
    return MfptEstimate(mfpt, mfpt * spread, mfpt * math.exp(-Z95 * spread),
                        mfpt * math.exp(Z95 * spread),
                        "geometric maximum likelihood, censored walks counted by their steps",
                        walks, fails, censored, total)  # fmt: skip


@dataclass
class RoughWalks:
    """Walks on a random slope from one start (see :func:`rough_walks`)."""

    model: str
    parameters: dict[str, float]
    sigma: float
    seed: int
    max_steps: int
    start: dict[str, float]
    gait: Orbit | None
    steps: np.ndarray
    ended: list[str]
    route: str = "compiled"
    terrain: str = "slope"
    distribution: str = "gaussian"

    @property
    def failed(self) -> np.ndarray:
        return np.array([e != "walked" for e in self.ended], dtype=bool)

    def estimate(self) -> MfptEstimate:
        return mfpt_estimate(self.steps, self.failed)

    def failures_by_kind(self) -> dict[str, int]:
        kinds = [e for e in self.ended if e != "walked"]
        return {kind: kinds.count(kind) for kind in sorted(set(kinds))}

    def survival(self) -> tuple[np.ndarray, np.ndarray]:
        """The survival curve: the fraction of walks that completed at least ``k`` steps,
        at ``k`` = 0, each step count where it drops, and ``max_steps``."""
        ks = np.unique(np.concatenate([[0, self.max_steps], self.steps[self.failed] + 1]))
        ks = ks[ks <= self.max_steps]
        fraction = (self.steps[None, :] >= ks[:, None]).mean(axis=1)
        return ks, fraction

    def to_dict(self) -> dict[str, Any]:
        e = self.estimate()
        ks, fraction = self.survival()
        mfpt = {"value": e.mfpt, "se": e.se, "low": e.low, "high": e.high}
        return {
            "model": self.model,
            "parameters": self.parameters,
            "terrain": self.terrain,
            "distribution": self.distribution,
            "sigma": self.sigma,
            "seed": self.seed,
            "walks": e.walks,
            "max_steps": self.max_steps,
            "start": self.start,
            "gait": None if self.gait is None else self.gait.to_dict(),
            "mfpt": mfpt,
            "estimator": e.estimator,
            "failures": e.failures,
            "censored": e.censored,
            "steps_walked": e.total_steps,
            "failures_by_kind": self.failures_by_kind(),
            "survival": {"steps": ks.tolist(), "fraction": fraction.tolist()},
            "simulator": self.route,
            "fields": {
                "sigma": f"standard deviation of the {TERRAINS[self.terrain]} drawn per step",
                "mfpt": "steps completed before the first failure: value, standard error, "
                "95 % interval (low, high; high null: unbounded)",
                "censored": "walks that completed max_steps steps without failing",
                "survival": "fraction of walks that completed at least each number of steps",
            },
        }


def rough_walks(
    model: Model,
    params: Sequence[float],
    sigma: float,
    walks: int = 1000,
    max_steps: int = 1000,
    seed: int = 0,
    *,
    start: Sequence[float] | None = None,
    gait: Orbit | None = None,
    threads: int | None = None,
    terrain: str = "slope",
    distribution: str = "gaussian",
    scheduler: str | None = None,
) -> RoughWalks:
    """``walks`` walks of at most ``max_steps`` steps on the slope gamma0 + sigma xi_k
    (gamma0 the parameter's value in ``params``; ``terrain`` ``height``: the next
    foothold's height instead), each from ``start`` (a section state) or else from the
    stable period-one gait at ``params``. Byl & Tedrake (2009), Sec. 3. ``scheduler``: a
    Dask scheduler's address to run parts of the walks on
    (:func:`vsw.studies.cluster.rough_on_cluster`), with this process's results: each walk's terrain
    is its own."""
    index = disturbance_index(model, terrain)
    check_inputs(sigma, walks, max_steps, seed)
    terrain_noise(seed, 0, 0, distribution)  # an unknown distribution: one line, before the walks
    names = (*model.coordinates, *model.rates)
    with blas.limited(default_threads() if threads is None else threads):
        if start is None:
            gait = gait or model.stable_gait(params, "no gait to start the walks from")
            start = [gait.state[n] for n in names]
        x0 = np.asarray(start, dtype=float)
        if x0.shape != (len(names),) or not np.all(np.isfinite(x0)):
            raise VswInputError(f"start must be {len(names)} finite values ({', '.join(names)})")
        rows = Terrain(params, index, sigma, seed, distribution=distribution)
        states = np.tile(x0, (walks, 1))
        if scheduler:
            from vsw.studies.cluster import rough_on_cluster

            result = rough_on_cluster(scheduler, model.name, rows, states, max_steps)
        else:
            result = simulator(model).walk_varying(rows, states, max_steps, threads=threads)
    return RoughWalks(
        model=model.name,
        parameters=dict(zip(model.spec["parameters"], (float(p) for p in params))),
        sigma=float(sigma),
        seed=int(seed),
        max_steps=int(max_steps),
        start=dict(zip(names, (float(v) for v in x0))),
        gait=gait,
        steps=result.steps.copy(),
        ended=result.ended(),
        route=result.route,
        terrain=terrain,
        distribution=distribution,
    )


def survival_plot(data: Mapping[str, Any], title: str | None = None) -> Figure:
    """The survival curve of a :meth:`RoughWalks.to_dict` record (a step function, log
    scale) with the geometric law of the estimate, (MFPT/(MFPT + 1))^k, dashed."""
    with plotstyle.context():
        fig, ax = plotstyle.new_figure()
        ks = np.asarray(data["survival"]["steps"], dtype=float)
        fraction = np.asarray(data["survival"]["fraction"], dtype=float)
        shown = fraction > 0
        ax.step(ks[shown], fraction[shown], where="post", color=plotstyle.COLORS["blue"],
                label="walks (Monte Carlo)")  # fmt: skip
        mfpt = data["mfpt"]["value"]
        if mfpt is not None and mfpt > 0:
            k = np.linspace(0.0, float(data["max_steps"]), 200)
            ax.plot(k, (mfpt / (mfpt + 1.0)) ** k, "--", color=plotstyle.COLORS["vermillion"],
                    label=f"geometric, MFPT {mfpt:.4g}")  # fmt: skip
        ax.set_yscale("log")
        ax.set_xlabel("steps $k$")
        ax.set_ylabel("walks still walking after $k$ steps")
        ax.set_xlim(0, float(data["max_steps"]))
        ax.legend(loc="lower left")
        if title:
            ax.set_title(title)
    return fig


# --- the gait sensitivity norm ------------------------------------------------------------------

INDICATORS = ("step_time", "step_length")
"""The gait indicators of the gait sensitivity norm: each step's duration and length."""

GSN_STEP = 1e-6
"""Central differences of the step map: this times max(1, |value|) each way."""

GSN_TOLERANCE = 1e-13
"""The compiled integrator's rtol = atol for the differences (the SciPy route, without a
compiler, integrates at its own 1e-12)."""


@dataclass(frozen=True)
class GaitSensitivity:
    """The linearised step-to-step response of a gait to its slope (Hobbelen & Wisse,
    "A disturbance rejection measure for limit cycle walkers: the gait sensitivity norm",
    IEEE T-RO 23(6), 2007): ``x_{k+1} = A x_k + B e_k``, ``y_k = C x_k + D e_k`` with ``x``
    the section state's deviation, ``e_k`` the deviation of step ``k``'s slope and ``y_k``
    that step's :data:`INDICATORS`; ``gsn`` the H2 norm from ``e`` to ``y`` (each
    indicator's own in ``by_indicator``)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    gsn: float
    by_indicator: dict[str, float]
    disturbance: str = SLOPE

    def to_dict(self) -> dict[str, Any]:
        return {
            "gsn": self.gsn,
            "gsn_by_indicator": dict(self.by_indicator),
            "indicators": list(INDICATORS),
            "disturbance": self.disturbance,
            "A": self.A.tolist(),
            "B": self.B.tolist(),
            "C": self.C.tolist(),
            "D": self.D.tolist(),
        }


def gait_sensitivity_units(model: Any, terrain: str = "slope") -> dict[str, str]:
    """The units of :meth:`GaitSensitivity.to_dict`'s numbers, for
    :func:`vsw.cli.output.with_units` (``vsw rough`` and ``vsw analyze``): per radian of
    slope, or per unit length of foothold height."""
    time, length = model.units.get("time", ""), model.units.get("length", "")
    per = "rad" if terrain == "slope" else length
    return {"gsn": f"{time}/{per} and {length}/{per} together",
            "gsn_by_indicator.step_time": f"{time}/{per}",
            "gsn_by_indicator.step_length": f"{length}/{per}", "A": "state/state",
            "B": f"state/{per}", "C": "indicator/state", "D": f"indicator/{per}"}  # fmt: skip


def _tolerance(sim: Any) -> float:
    """:data:`GSN_TOLERANCE` on the compiled simulator, the SciPy route's own without it."""
    return GSN_TOLERANCE if sim.library() is not None else RTOL


def linearised_step(
    model: Model, params: Sequence[float], state: Sequence[float], terrain: str = "slope"
) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D)`` of the step map at ``state`` by central differences of the batch
    simulator's steps (:data:`GSN_STEP`, :data:`GSN_TOLERANCE`): in each state component
    and in the terrain's parameter (the slope, or the next foothold's height); C, D rows of
    :data:`INDICATORS`. The state's full Jacobian: on a section with determined components
    its extra eigenvalues are 0."""
    index = disturbance_index(model, terrain)
    x = np.asarray(state, dtype=float)
    p = np.asarray(params, dtype=float)
    n = len(x)
    h = GSN_STEP * np.maximum(1.0, np.abs(np.append(x, p[index])))
    offsets = np.zeros((2 * (n + 1), n + 1))
    for i in range(n + 1):
        offsets[2 * i, i], offsets[2 * i + 1, i] = h[i], -h[i]
    rows = np.tile(p, (len(offsets), 1))
    rows[:, index] += offsets[:, n]
    sim = simulator(model)
    result = sim.step(rows, x + offsets[:, :n], threads=1, tolerance=_tolerance(sim))
    if np.any(result.outcome != 0):
        raise ConvergenceError(f"{model.cli_name}: a step near the gait did not complete "
                               f"({sorted(set(result.ended()))})")  # fmt: skip
    out = np.column_stack([result.final, result.kept_durations[:, 0], result.kept_lengths[:, 0]])
    derivative = (out[0::2] - out[1::2]) / (2 * h[:, None])  # row i: d/d(variable i)
    A, C = derivative[:n, :n].T, derivative[:n, n:].T
    B, D = derivative[n, :n], derivative[n, n:]
    return A, B, C, D


def h2_norm(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> float:
    """The H2 norm of ``x_{k+1} = A x_k + B e_k``, ``y_k = C x_k + D e_k`` (one input):
    sqrt(|D|^2 + trace(C W C^T)) with W = A W A^T + B B^T, the response to a unit impulse
    summed over the steps (Hobbelen & Wisse 2007, eq. 4). A must be stable."""
    from scipy.linalg import solve_discrete_lyapunov

    if not np.max(np.abs(np.linalg.eigvals(A))) < 1:
        raise VswInputError("the gait sensitivity norm needs a stable gait (|eigenvalues| < 1)")
    B, C, D = np.atleast_1d(B), np.atleast_2d(C), np.atleast_1d(D)
    W = solve_discrete_lyapunov(A, np.outer(B, B))
    return math.sqrt(float(D @ D) + float(np.trace(C @ W @ C.T)))


def gait_sensitivity(
    model: Model, params: Sequence[float], gait: Orbit, terrain: str = "slope"
) -> GaitSensitivity:
    """The gait sensitivity norm of ``gait`` to its slope (``terrain`` ``height``: to the
    next foothold's height), step time and step length (Hobbelen & Wisse 2007); the
    indicators a model does not report (NaN step length) are left out."""
    names = (*model.coordinates, *model.rates)
    A, B, C, D = linearised_step(model, params, [gait.state[n] for n in names], terrain)
    kept = [i for i in range(len(INDICATORS)) if np.all(np.isfinite(C[i])) and np.isfinite(D[i])]
    C, D = C[kept], D[kept]
    by = {INDICATORS[i]: h2_norm(A, B, C[j], D[j : j + 1]) for j, i in enumerate(kept)}
    return GaitSensitivity(A, B, C, D, h2_norm(A, B, C, D), by, TERRAINS[terrain])


def slope_impulse_response(
    model: Model, params: Sequence[float], state: Sequence[float], steps: int, eps: float
) -> np.ndarray:
    """The indicators' response to the slope of step 0 alone, by central differences of
    the nonlinear step map walked ``steps`` steps from ``state`` with that slope
    ``gamma +- eps`` (shape (steps, 2), per unit slope): the impulse response whose
    2-norm is the gait sensitivity norm, without linearising."""
    index = slope_index(model)
    sim = simulator(model)
    x = np.tile(np.asarray(state, dtype=float), (2, 1))
    out = np.zeros((steps, len(INDICATORS)))
    for k in range(steps):
        rows = np.tile(np.asarray(params, dtype=float), (2, 1))
        if k == 0:
            rows[:, index] += (eps, -eps)
        result = sim.step(rows, x, threads=1, tolerance=_tolerance(sim))
        if np.any(result.outcome != 0):
            raise ConvergenceError(f"{model.cli_name}: a step of the response did not complete")
        y = np.column_stack([result.kept_durations[:, 0], result.kept_lengths[:, 0]])
        out[k] = (y[0] - y[1]) / (2 * eps)
        x = result.final
    return out
