"""Basins of attraction of any engine model over a slice of its section (one or two of its
free components), by the batch simulator (:mod:`vsw.dynamics.batch`).

A basin cell is a section state (just after the step event): the period-one gait's, with
the two gridded components replaced and, where the model declares its section
(``HYBRID["section"]``: e.g. the simplest walker's phi = 2 theta and the swing rate the
impact gives), the components the section determines recomputed from them. Each cell is
walked until it converges to the gait (every component within ``tol * max(1, |gait|)``),
repeats with a period 2..8 (to the same tolerance), falls, stalls, or has walked
``steps`` steps (``other``). Schwab & Wisse (2001, "Basin of attraction of the simplest
walking model", Proc. ASME DETC) drew the simplest walker's this way, by cell mapping.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from vsw.dynamics.batch import Runner, simulator
from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.models.base import Model
from vsw.plots import plotstyle
from vsw.runtime import blas
from vsw.runtime.errors import VswInputError
from vsw.runtime.threads import default_threads

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "LABEL_ORDER",
    "basin_plot",
    "check_grid_names",
    "grid_basin",
    "grid_states",
]

LABEL_ORDER = ("converged", "fell", "other")
"""Classes of a basin cell; ``period-K`` between converged and fell."""


def grid_states(
    model: HybridModel,
    params: Sequence[float],
    base: Sequence[float],
    x_name: str,
    x: np.ndarray,
    y_name: str | None = None,
    y: np.ndarray | None = None,
) -> np.ndarray:
    """The section states of a grid: ``base`` with ``x_name`` (and ``y_name``) set (rows:
    y, columns: x) and the components the section determines recomputed. Shape
    (len(y) * len(x), 2 n), row-major over (y, x); one row without ``y_name``."""
    check_grid_names(model, x_name, y_name)
    names = (*model.coordinates, *model.rates)
    determined = model.spec.get("section", ())
    y_values = np.zeros(1) if y_name is None else np.asarray(y, float)
    yy, xx = np.meshgrid(y_values, np.asarray(x, float), indexing="ij")
    states = np.tile(np.asarray(base, dtype=float), (xx.size, 1))
    states[:, names.index(x_name)] = xx.ravel()
    if y_name is not None:
        states[:, names.index(y_name)] = yy.ravel()
    if determined:
        completed = model.module.section_completion(*params, *states.T)
        states = np.column_stack([np.broadcast_to(c, len(states)) for c in completed])
    return np.ascontiguousarray(states, dtype=float)


def check_grid_names(model: HybridModel, x_name: str, y_name: str | None = None) -> None:
    """One line for a grid over components that are not the model's or that its section
    determines, or over one component of a section that has more."""
    names = (*model.coordinates, *model.rates)
    shown = model.name.replace("_", "-")  # as the command line names it
    free = [n for n in names if n not in model.spec.get("section", ())]
    if y_name is None and len(free) > 1:
        raise VswInputError(
            f"--grid given once: the section of {shown} has {len(free)} free components "
            f"({', '.join(free)}): give --grid twice (x, then y)"
        )
    gridded = (x_name,) if y_name is None else (x_name, y_name)
    for name in gridded:
        if name not in names:
            raise VswInputError(
                f"--grid {name}: not a coordinate or rate of {shown}: choose from "
                f"{', '.join(names)}"
            )
    if x_name == y_name:
        raise VswInputError(f"--grid {x_name} given twice: grid over two different components")
    determined = model.spec.get("section", ())
    for name in gridded:
        if name in determined:
            raise VswInputError(
                f"--grid {name}: on the section of {shown} {name} follows from "
                f"{', '.join(free)} (the step event's geometry and reset): grid over those"
            )


@dataclass
class GridBasin:
    """A basin over a 1-D or 2-D slice of the section (see :func:`grid_basin`); a 1-D one
    has ``y_name`` None, no ``y`` and one row."""

    model: str
    parameters: dict[str, float]
    x_name: str
    y_name: str | None
    x: np.ndarray
    y: np.ndarray
    outcome: list[list[str]]  # rows over y, columns over x
    ended: list[list[str]]
    steps: np.ndarray  # (len(y), len(x))
    gait: Orbit
    fixed_point: dict[str, float]
    tol: float
    max_steps: int
    route: str = "compiled"

    def counts(self) -> dict[str, int]:
        flat = [c for row in self.outcome for c in row]
        return {label: flat.count(label) for label in sorted(set(flat), key=_label_key)}

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "parameters": self.parameters,
            "x_name": self.x_name,
            "y_name": self.y_name,
            "x": [float(v) for v in self.x],
            "y": None if self.y_name is None else [float(v) for v in self.y],
            "outcome": self.outcome,
            "steps": self.steps.tolist(),
            "fixed_point": self.fixed_point,
            "ended": self.ended,
            "counts": self.counts(),
            "gait": self.gait.to_dict(),
            "tol": self.tol,
            "max_steps": self.max_steps,
            "fields": {
                "x, y": "the grid values of x_name and y_name just after the step event; the "
                "other components are the gait's, those the section determines recomputed",
                "outcome": "rows over y, columns over x: converged (to the period-one gait), "
                "period-K (repeats every K steps, 2 <= K <= 8), fell, or other (walked "
                "max_steps without settling, or the integration stalled)",
                "ended": "as outcome, with the failure's name for fell, 'stalled' or 'walked'",
                "steps": "steps walked until the outcome was decided",
                "fixed_point": "the period-one gait's section state (the rootfinder's)",
                "tol": "converged / period-K: within tol * max(1, |state|) in every component",
            },
        }


def _label_key(label: str) -> tuple[int, int]:
    if label.startswith("period-"):
        return (1, int(label.split("-")[1]))
    return ({"converged": 0, "fell": 2}.get(label, 3), 0)


def grid_basin(
    model: Model,
    params: Sequence[float],
    x_name: str,
    x: np.ndarray,
    y_name: str | None = None,
    y: np.ndarray | None = None,
    steps: int = 50,
    *,
    tol: float = 1e-6,
    gait: Orbit | None = None,
    threads: int | None = None,
    runner: Runner | None = None,
) -> GridBasin:
    """The basin of the stable period-one gait over the grid ``x`` x ``y`` of two section
    components, or over ``x`` alone where the section has one free component (see the
    module docstring)."""
    # the gait search's solves and eigenvalues too
    with blas.limited(default_threads() if threads is None else threads):
        check_grid_names(model, x_name, y_name)
        gait = gait or model.stable_gait(params, "no basin to draw")
        target = np.array([gait.state[n] for n in (*model.coordinates, *model.rates)])
        states = grid_states(model, params, target, x_name, x, y_name, y)
        sim = simulator(model)
        result = sim.walk(params, states, steps, target=target, converge_tol=tol, period_tol=tol,
                          threads=threads, runner=runner)  # fmt: skip
        y = np.zeros(0) if y_name is None else np.asarray(y, float)
        shape = (max(1, len(y)), len(x))
        labels, ended = result.labels(), result.ended()
        return GridBasin(
            model=model.name,
            parameters=dict(zip(model.spec["parameters"], (float(p) for p in params))),
            x_name=x_name,
            y_name=y_name,
            x=np.asarray(x, float),
            y=np.asarray(y, float),
            outcome=[labels[i * shape[1] : (i + 1) * shape[1]] for i in range(shape[0])],
            ended=[ended[i * shape[1] : (i + 1) * shape[1]] for i in range(shape[0])],
            steps=result.steps.reshape(shape),
            gait=gait,
            fixed_point=dict(gait.state),
            tol=tol,
            max_steps=steps,
            route=result.route,
        )


_CLASS_COLORS = {
    "converged": "green",
    "fell": "light_grey",
    "other": "blue",
}
_PERIOD_COLORS = ("orange", "purple", "vermillion", "sky_blue", "yellow")


def _colors_for(labels: Sequence[str]) -> dict[str, str]:
    out, k = {}, 0
    for label in labels:
        if label in _CLASS_COLORS:
            out[label] = plotstyle.COLORS[_CLASS_COLORS[label]]
        else:
            out[label] = plotstyle.COLORS[_PERIOD_COLORS[k % len(_PERIOD_COLORS)]]
            k += 1
    return out


def basin_plot(
    data: Mapping[str, Any],
    units: Mapping[str, str] | None = None,
    title: str | None = None,
) -> Figure:
    """Two panels from a basin's JSON record, one journal column: the classes
    (colour-blind-safe colours, the gait's fixed point starred) and the steps walked until
    each converged cell converged. ``units``: of the gridded state components (mathtext
    labels with them); ``title``: the model and its parameters (default: from the record,
    without units: pass :func:`vsw.plots.plotstyle.parameter_text`). The legend lies below the
    panels, outside the data."""
    with plotstyle.context():
        return _basin_plot(data, units or {}, title)


def _basin_plot(data: Mapping[str, Any], units: Mapping[str, str], title: str | None) -> Figure:
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    x, y = np.asarray(data["x"]), np.asarray(data["y"])
    one_d = data.get("y_name") is None
    if one_d:  # one row: a strip along x
        y = np.zeros(1)
    labels = sorted({c for row in data["outcome"] for c in row}, key=_label_key)
    colors = _colors_for(labels)
    index = {label: k for k, label in enumerate(labels)}
    classes = np.array([[index[c] for c in row] for row in data["outcome"]], dtype=float)
    steps = np.asarray(data["steps"], dtype=float)
    height = plotstyle.COLUMN_WIDTH * (0.75 if one_d else 1.55)
    fig, axes = plotstyle.new_figure(height=height, nrows=2, sharex=True)
    extent = _extent(x, y)
    cmap = ListedColormap([colors[label] for label in labels])
    norm = BoundaryNorm(np.arange(len(labels) + 1) - 0.5, len(labels))
    axes[0].imshow(classes, origin="lower", extent=extent, aspect="auto", cmap=cmap, norm=norm,
                   interpolation="nearest")  # fmt: skip
    converged = np.array([[c == "converged" for c in row] for row in data["outcome"]])
    shown = np.where(converged, steps, np.nan)
    image = axes[1].imshow(shown, origin="lower", extent=extent, aspect="auto",
                           cmap="cividis", interpolation="nearest")  # fmt: skip
    fig.colorbar(image, ax=axes[1], label="steps to converge")
    fp = data["fixed_point"]
    for ax in axes:
        star_y = 0.0 if one_d else fp[data["y_name"]]
        ax.plot([fp[data["x_name"]]], [star_y], marker="*", markersize=9,
                markerfacecolor="white", markeredgecolor="black", linestyle="none")  # fmt: skip
        if one_d:
            ax.set_yticks([])
        else:
            ax.set_ylabel(_label(data["y_name"], units))
    axes[1].set_xlabel(_label(data["x_name"], units))
    counts = data.get("counts", {})
    handles = [
        Patch(facecolor=colors[label], edgecolor="black", linewidth=0.4,
              label=f"{label} ({counts.get(label, '')} cells)")
        for label in labels
    ]  # fmt: skip
    handles.append(_star_handle())
    plotstyle.figure_legend(fig, handles, [h.get_label() for h in handles], ncols=2)
    if title is None:
        params = ", ".join(f"{k} = {v:.6g}" for k, v in data["parameters"].items())
        title = f"{data['model']}: {params}"
    fig.suptitle(title, x=0.02, ha="left", fontsize="medium")
    axes[1].set_title(f"converged cells, at most {data['max_steps']} steps", fontsize=7)
    plotstyle.settle_layout(fig)
    return fig


def _star_handle():
    from matplotlib.lines import Line2D

    return Line2D([], [], marker="*", markersize=8, markerfacecolor="white",
                  markeredgecolor="black", linestyle="none", label="period-one gait")  # fmt: skip


def _extent(x: np.ndarray, y: np.ndarray) -> list[float]:
    dx = (x[-1] - x[0]) / max(1, len(x) - 1) if len(x) > 1 else 1.0
    dy = (y[-1] - y[0]) / max(1, len(y) - 1) if len(y) > 1 else 1.0
    return [x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2]


def _label(name: str, units: Mapping[str, str]) -> str:
    """A state component's label; ``-name``: minus it (an angle in another sign)."""
    if name.startswith("-"):
        return "\u2212" + plotstyle.state_label(name[1:], units.get(name[1:], "1"))
    return plotstyle.state_label(name, units.get(name, "1"))
