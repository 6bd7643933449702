"""The mean first-passage time over a parameter: the slope's mean or the terrain's noise.

Byl & Tedrake ("Metastable walking machines", IJRR 28(8), 2009, Figs. 6 and 8) print a
walker's MFPT against the terrain's noise on a log scale: the MFPT falls by orders of
magnitude as the noise grows. :func:`rough_sweep` gives that curve at each value of
``gamma0`` (the mean slope; the gait moves with it) or of ``sigma`` (the noise): the
walks' MFPT with its 95 % interval (:func:`vsw.studies.rough.rough_walks`, the same seed at every
value, so every point walks the same draws xi_k: the points differ by the parameter, not
by the sample), the meshed Markov chain's beside it on request
(:func:`vsw.studies.rough_chain.rough_chain`), and the gait's sensitivity norm
(:func:`vsw.studies.rough.gait_sensitivity`, Hobbelen & Wisse 2007). Over ``gamma0`` the gaits
differ, and :func:`spearman` says whether the norm orders them as the MFPT does.

The gait at each ``gamma0`` is continued from the last one (the batch simulator's fixed
point, :func:`vsw.dynamics.step_map.fixed_point`), and searched for afresh only where
that fails, so a sweep costs one gait search, not one per value.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from vsw.dynamics.batch import simulator
from vsw.dynamics.hybrid import Orbit
from vsw.dynamics.step_map import fixed_point
from vsw.models.base import Model
from vsw.plots import plotstyle
from vsw.runtime.errors import ConvergenceError, ModelConditionError, VswInputError
from vsw.studies.rough import TERRAINS, disturbance_index, gait_sensitivity, rough_walks

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["OVER", "RoughSweep", "continued_gait", "parse_over", "rough_sweep", "spearman",
           "sweep_plot", "sweep_units"]  # fmt: skip

OVER = ("gamma0", "sigma")
"""What ``--over`` sweeps: the terrain parameter's mean (its model value) or the noise."""

MAX_POINTS = 200
_OVER_RE = re.compile(r"^\s*([A-Za-z_]\w*)\s*=\s*([^:]+):([^:]+):([^:]+)\s*$")


def parse_over(text: str) -> tuple[str, np.ndarray]:
    """``NAME=a:b:n`` as the name and ``n`` values from ``a`` to ``b`` (both ends), or one
    line saying what is wrong (an unknown name, a malformed or empty range)."""
    match = _OVER_RE.match(text or "")
    if not match:
        raise VswInputError(f"--over {text!r}: write NAME=a:b:n, NAME one of {', '.join(OVER)}")
    name, a, b, n = match.groups()
    if name not in OVER:
        raise VswInputError(f"--over {name}: sweeps one of {', '.join(OVER)}")
    try:
        low, high, count = float(a), float(b), int(n)
    except ValueError:
        raise VswInputError(f"--over {text!r}: a and b numbers, n an integer") from None
    if not (math.isfinite(low) and math.isfinite(high)):
        raise VswInputError(f"--over {text!r}: a and b must be finite")
    if count < 1 or (count == 1 and low != high):
        raise VswInputError(f"--over {text!r}: an empty range (n = {count}; n >= 2, or n = 1 "
                            "with a = b)")  # fmt: skip
    if count > MAX_POINTS:
        raise VswInputError(f"--over {text!r}: at most {MAX_POINTS} values")
    if low == high and count > 1:
        raise VswInputError(f"--over {text!r}: an empty range (a = b with n = {count})")
    # 12 significant digits: 0.007, not linspace's 0.006999999999999999
    return name, np.array([float(f"{v:.12g}") for v in np.linspace(low, high, count)])


def _ranks(x: np.ndarray) -> np.ndarray:
    """Ranks from 1, ties given their mean rank."""
    order = np.argsort(x, kind="stable")
    ranks = np.empty(len(x))
    sorted_x = x[order]
    i = 0
    while i < len(x):
        j = i
        while j + 1 < len(x) and sorted_x[j + 1] == sorted_x[i]:
            j += 1
        ranks[order[i : j + 1]] = 0.5 * (i + j) + 1.0
        i = j + 1
    return ranks


def spearman(x: Sequence[float], y: Sequence[float]) -> float | None:
    """Spearman's rank correlation (Spearman 1904): the Pearson correlation of the ranks,
    ties at their mean rank; None with fewer than 3 pairs or a constant variable."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) < 3 or len(x) != len(y):
        return None
    rx, ry = _ranks(x) - (len(x) + 1) / 2, _ranks(y) - (len(y) + 1) / 2
    denominator = math.sqrt(float(rx @ rx) * float(ry @ ry))
    return None if denominator == 0 else float(rx @ ry) / denominator


def continued_gait(model: Model, params: Sequence[float], guess: dict[str, float] | None
                   ) -> Orbit:  # fmt: skip
    """The period-one gait at ``params`` by Newton on the batch simulator's step map from
    ``guess`` (the last value's gait), its eigenvalues the map's Jacobian's; without a
    guess, or where Newton fails or lands on an unstable gait, the model's gait search
    (:meth:`vsw.models.base.Model.stable_gait`)."""
    names = (*model.coordinates, *model.rates)
    if guess is not None:
        sim = simulator(model)
        try:
            x, jacobian = fixed_point(sim, params, [guess[n] for n in names])
            step = sim.step_phases(params, x)
            if step.ended == "completed":
                residual = float(np.max(np.abs(np.asarray(step.state) - x)))
                orbit = Orbit(dict(zip(names, (float(v) for v in x))), step.durations,
                              float(sum(step.durations)),
                              tuple(complex(e) for e in np.linalg.eigvals(jacobian)),
                              step.step_length, residual)  # fmt: skip
                if orbit.stable:
                    return orbit
        except ConvergenceError:
            pass
    return model.stable_gait(params, "no stable gait to start the walks from")


@dataclass
class RoughSweep:
    """The MFPT at each value of ``over`` (see :func:`rough_sweep`)."""

    over: str
    parameter: str
    terrain: str
    distribution: str
    values: list[float]
    points: list[dict[str, Any]] = field(default_factory=list)

    def correlation(self) -> dict[str, Any]:
        """Spearman's rank correlation of the gait sensitivity norm with the MFPT over the
        points that have both (the walks' MFPT; the chain's too where it ran)."""
        out: dict[str, Any] = {}
        picks = (
            ("walks", lambda p: (p.get("mfpt") or {}).get("value")),
            ("chain", lambda p: (p.get("chain") or {}).get("mfpt_gait")),
        )
        for key, pick in picks:
            pairs = [(p["gsn"], pick(p)) for p in self.points
                     if p.get("gsn") is not None and pick(p) is not None]  # fmt: skip
            if pairs and any(pick(p) is not None for p in self.points):
                gsn, mfpt = zip(*pairs)
                out[key] = {"rho": spearman(gsn, mfpt), "points": len(pairs)}
        return out

    def to_dict(self) -> dict[str, Any]:
        return {
            "over": self.over,
            "swept_parameter": self.parameter,
            "terrain": self.terrain,
            "distribution": self.distribution,
            "values": list(self.values),
            "points": self.points,
            "spearman_gsn_mfpt": self.correlation(),
        }


def _point_keys(walks: Any) -> dict[str, Any]:
    """The walks' keys a sweep's point keeps (not their survival curve or start)."""
    d = walks.to_dict()
    return {k: d[k] for k in ("mfpt", "estimator", "failures", "censored", "steps_walked",
                              "failures_by_kind", "simulator")}  # fmt: skip


def rough_sweep(
    model: Model,
    params: Sequence[float],
    sigma: float,
    over: str,
    values: Sequence[float],
    *,
    walks: int = 1000,
    max_steps: int = 1000,
    seed: int = 0,
    terrain: str = "slope",
    distribution: str = "gaussian",
    monte_carlo: bool = True,
    chain: Mapping[str, Any] | None = None,
    scheduler: str | None = None,
) -> RoughSweep:
    """The MFPT of walks on ``terrain`` at each of ``values`` of ``over`` (``gamma0``: the
    terrain parameter's mean, ``sigma``: the noise), the other held at ``params``' value
    and ``sigma``; ``chain``: :func:`vsw.studies.rough_chain.rough_chain`'s keyword arguments to run
    it too (slope, Gaussian), None not to. A value without a stable gait is kept with its
    reason and no MFPT."""
    if over not in OVER:
        raise VswInputError(f"--over {over}: sweeps one of {', '.join(OVER)}")
    index = disturbance_index(model, terrain)
    name = model.spec["parameters"][index]
    sweep = RoughSweep(
        over,
        name if over == "gamma0" else "sigma",
        terrain,
        distribution,
        [float(v) for v in values],
    )
    guess: dict[str, float] | None = None
    gait: Orbit | None = None
    for value in sweep.values:
        p = np.array(params, dtype=float)
        s = sigma
        if over == "gamma0":
            p = np.array(model.parameters({**dict(zip(model.spec["parameters"], p)),
                                           name: value}), dtype=float)  # fmt: skip
        else:
            s = value
        point: dict[str, Any] = {over: value, "sigma": s, name: float(p[index])}
        if gait is None or over == "gamma0":
            try:
                gait = continued_gait(model, p, guess)
            except ModelConditionError as exc:
                point.update({"gait": None, "reason": str(exc), "gsn": None})
                sweep.points.append(point)
                gait = None
                continue
            guess = dict(gait.state)
            gsn = gait_sensitivity(model, p, gait, terrain)
        point["gait"] = {"state": dict(gait.state), "max_abs_eigenvalue": gait.max_abs_eigenvalue}
        point["gsn"] = gsn.gsn
        if monte_carlo:
            found = rough_walks(model, p, s, walks, max_steps, seed, gait=gait, terrain=terrain,
                                distribution=distribution, scheduler=scheduler)  # fmt: skip
            point.update(_point_keys(found))
        if chain is not None:
            from vsw.studies.rough_chain import rough_chain

            result = rough_chain(model, p, s, gait=gait, **chain).to_dict()
            point["chain"] = {k: result[k] for k in ("mfpt_gait", "mfpt_qsd", "lambda2",
                                                     "nodes", "converged")}  # fmt: skip
        sweep.points.append(point)
    return sweep


def sweep_plot(data: Mapping[str, Any], xlabel: str, title: str | None = None) -> Figure:
    """MFPT against the swept value on a log scale (Byl & Tedrake 2009's figure): the
    walks' MFPT with its 95 % interval, a value where no walk fell as its lower bound (an
    up triangle), the chain's MFPT from the gait as open circles; over ``gamma0`` a second
    panel with the gait sensitivity norm."""
    points = data["points"]
    over = data["over"]
    with_gsn = over == "gamma0" and any(p.get("gsn") is not None for p in points)
    from matplotlib.ticker import FuncFormatter, MaxNLocator

    with plotstyle.context():
        fig, axes = plotstyle.new_figure(nrows=2 if with_gsn else 1,
                                         height=4.2 if with_gsn else None)  # fmt: skip
        axes = np.atleast_1d(axes)
        ax = axes[0]
        walks = [p for p in points if (p.get("mfpt") or {}).get("value") is not None]
        if walks:
            x = np.array([p[over] for p in walks])
            y = np.array([p["mfpt"]["value"] for p in walks])
            high = np.array([p["mfpt"]["high"] if p["mfpt"]["high"] is not None else v
                             for p, v in zip(walks, y)])  # fmt: skip
            low = np.array([p["mfpt"]["low"] for p in walks])
            ax.errorbar(x, y, yerr=[y - low, high - y], fmt="o-", ms=3, capsize=2,
                        color=plotstyle.COLORS["blue"], label="walks, 95 % interval")  # fmt: skip
        bounds = [p for p in points if p.get("mfpt") and p["mfpt"]["value"] is None]
        if bounds:
            ax.plot([p[over] for p in bounds], [p["mfpt"]["low"] for p in bounds], "^",
                    color=plotstyle.COLORS["blue"], label="no fall: lower bound")  # fmt: skip
        chain = [p for p in points if (p.get("chain") or {}).get("mfpt_gait") is not None]
        if chain:
            ax.plot([p[over] for p in chain], [p["chain"]["mfpt_gait"] for p in chain], "o",
                    mfc="none", color=plotstyle.COLORS["vermillion"],
                    label="meshed Markov chain")  # fmt: skip
        ax.set_yscale("log")
        ax.set_ylabel("MFPT [steps]")
        ax.legend(loc="best")
        if title:
            ax.set_title(title)
        if with_gsn:
            gx = [p[over] for p in points if p.get("gsn") is not None]
            gy = [p["gsn"] for p in points if p.get("gsn") is not None]
            axes[1].plot(gx, gy, "s-", ms=3, color=plotstyle.COLORS["black"])
            axes[1].set_yscale("log")
            axes[1].set_ylabel("gait sensitivity norm")
        axes[-1].set_xlabel(xlabel)
        plain = FuncFormatter(lambda v, _: f"{v:g}")
        for a in axes:  # a noise of 0.00075 rad is six characters: five ticks fit
            a.xaxis.set_major_locator(MaxNLocator(5, steps=[1, 2, 2.5, 5, 10]))
            low, high = a.get_ylim()
            if high < 10 * low:  # within a decade the log axis labels its minor ticks
                a.yaxis.set_major_formatter(plain)
                a.yaxis.set_minor_formatter(plain)
    return fig


def sweep_units(model: Any, terrain: str) -> dict[str, str]:
    """The units of :meth:`RoughSweep.to_dict`'s numbers, for
    :func:`vsw.cli.output.with_units`."""
    unit = "rad" if terrain == "slope" else model.units.get("length", "")
    time, length = model.units.get("time", ""), model.units.get("length", "")
    return {"values": unit, "gamma0": unit, "sigma": unit, TERRAINS[terrain]: unit,
            "mfpt": "steps", "failures": "1", "censored": "1", "steps_walked": "steps",
            "failures_by_kind": "1", "gsn": f"{time}/{unit} and {length}/{unit} together",
            "gait.max_abs_eigenvalue": "1", "chain.mfpt_gait": "steps",
            "chain.mfpt_qsd": "steps", "chain.lambda2": "1", "chain.nodes": "1",
            "rho": "1", "points": "1"}  # fmt: skip
