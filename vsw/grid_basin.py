"""Basins of attraction of any engine model over a 2-D slice of its section, by the batch
simulator (:mod:`vsw.batch`), and brute-force bifurcation diagrams.

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

from vsw.batch import Runner, simulator
from vsw.errors import ConvergenceError, ModelConditionError, VswInputError
from vsw.gaits import search, stable_gait
from vsw.hybrid import HybridModel, Orbit, by_modulus, repeat_period

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "LABEL_ORDER",
    "basin_plot",
    "brute_force_sweep",
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
    y_name: str,
    y: np.ndarray,
) -> np.ndarray:
    """The section states of a grid: ``base`` with ``x_name``/``y_name`` set (rows: y,
    columns: x) and the components the section determines recomputed. Shape
    (len(y) * len(x), 2 n), row-major over (y, x)."""
    check_grid_names(model, x_name, y_name)
    names = (*model.coordinates, *model.rates)
    determined = model.spec.get("section", ())
    yy, xx = np.meshgrid(np.asarray(y, float), np.asarray(x, float), indexing="ij")
    states = np.tile(np.asarray(base, dtype=float), (xx.size, 1))
    states[:, names.index(x_name)] = xx.ravel()
    states[:, names.index(y_name)] = yy.ravel()
    if determined:
        completed = model.module.section_completion(*params, *states.T)
        states = np.column_stack([np.broadcast_to(c, len(states)) for c in completed])
    return np.ascontiguousarray(states, dtype=float)


def check_grid_names(model: HybridModel, x_name: str, y_name: str) -> None:
    """One line for a grid over components that are not the model's or that its section
    determines."""
    names = (*model.coordinates, *model.rates)
    shown = model.name.replace("_", "-")  # as the command line names it
    for name in (x_name, y_name):
        if name not in names:
            raise VswInputError(
                f"--grid {name}: not a coordinate or rate of {shown}: choose from "
                f"{', '.join(names)}"
            )
    if x_name == y_name:
        raise VswInputError(f"--grid {x_name} given twice: grid over two different components")
    determined = model.spec.get("section", ())
    for name in (x_name, y_name):
        if name in determined:
            free = [n for n in names if n not in determined]
            raise VswInputError(
                f"--grid {name}: on the section of {shown} {name} follows from "
                f"{', '.join(free)} (the step event's geometry and reset): grid over those"
            )


@dataclass
class GridBasin:
    """A basin over a 2-D slice of the section (see :func:`grid_basin`)."""

    model: str
    parameters: dict[str, float]
    x_name: str
    y_name: str
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
            "y": [float(v) for v in self.y],
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
    model: HybridModel,
    params: Sequence[float],
    x_name: str,
    x: np.ndarray,
    y_name: str,
    y: np.ndarray,
    steps: int = 50,
    *,
    tol: float = 1e-6,
    gait: Orbit | None = None,
    threads: int | None = None,
    runner: Runner | None = None,
) -> GridBasin:
    """The basin of the stable period-one gait over the grid ``x`` x ``y`` of two section
    components (see the module docstring)."""
    check_grid_names(model, x_name, y_name)
    gait = gait or stable_gait(model, params, "no basin to draw")
    target = np.array([gait.state[n] for n in (*model.coordinates, *model.rates)])
    states = grid_states(model, params, target, x_name, x, y_name, y)
    sim = simulator(model)
    result = sim.walk(params, states, steps, target=target, converge_tol=tol, period_tol=tol,
                      threads=threads, runner=runner)  # fmt: skip
    shape = (len(y), len(x))
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


def brute_force_sweep(
    model: HybridModel,
    values: Mapping[str, float],
    over: str,
    grid: np.ndarray,
    transient: int,
    keep: int,
    start: Sequence[float] | None = None,
    threads: int | None = None,
    runner: Runner | None = None,
) -> list[dict[str, Any]]:
    """The classic bifurcation diagram by brute force, all from the batch simulator: at
    each value of the parameter ``over`` the period-one gait by Newton on the batch map
    (continued from the previous value; its eigenvalues from the map's Jacobian by central
    differences), then one batch walk over every value, ``transient + keep`` steps each,
    from that value's gait moved by 1e-6 (relative) where it was found, else from the last
    gait found before it (or ``start``; default: the first stable gait of the first value's
    scan), keeping the last ``keep`` steps. Returns the points of ``vsw sweep --json``:
    each with its gait and ``attractor`` (states, step lengths and periods, ``ended``,
    ``period``)."""
    names_p = list(model.spec["parameters"])
    if over not in names_p:
        raise VswInputError(f"{over!r} is not a parameter of {model.name}: {', '.join(names_p)}")
    state_names = [*model.coordinates, *model.rates]
    sim = simulator(model)
    tables = [model.parameters({**values, over: float(v)}) for v in grid]
    if start is None:
        first = search(model, tables[0]).gaits
        if not first:
            raise ModelConditionError(
                f"{model.name}: no period-one gait at {over} = {grid[0]:g} to start from: "
                "give the start with --state"
            )
        pick = next((o for o in first if o.stable), first[0])
        start = [pick.state[n] for n in state_names]
    start = np.asarray(start, dtype=float)
    points: list[dict[str, Any]] = []
    starts = np.empty((len(grid), len(state_names)))
    previous = start
    for i, (value, params) in enumerate(zip(grid, tables)):
        point: dict[str, Any] = {over: float(value), "from": "batch Newton"}
        try:
            x, jacobian = sim.fixed_point(params, previous)
        except ConvergenceError:
            x = None
        if x is None or not np.all(np.isfinite(x)):
            point["found"] = False
            for key in ("state", "period", "eigenvalues", "max_abs_eigenvalue", "stable",
                        "step_length", "speed"):  # fmt: skip
                point[key] = None
            starts[i] = previous
        else:
            step = sim.step(params, x[None], threads=1)
            eigenvalues = by_modulus(np.linalg.eigvals(jacobian))
            largest = max(abs(e) for e in eigenvalues)
            length = float(step.kept_lengths[0, 0])
            period = float(step.kept_durations[0, 0])
            length = None if np.isnan(length) else length
            point.update(
                found=True, state=dict(zip(state_names, (float(v) for v in x))), period=period,
                eigenvalues=[[e.real, e.imag] for e in eigenvalues],
                max_abs_eigenvalue=largest, stable=largest < 1.0, step_length=length,
                speed=None if length is None else length / period,
            )  # fmt: skip
            starts[i] = x * (1 + 1e-6)
            previous = x
        points.append(point)
    walks = sim.walk(np.array(tables), starts, transient + keep, converge_tol=0.0,
                     period_tol=0.0, keep=keep, threads=threads, runner=runner)  # fmt: skip
    ended = walks.ended()
    for i, point in enumerate(points):
        walked = int(walks.steps[i])
        # The ring holds the last min(walked, keep) steps, oldest first; of them only those
        # past the transient count (as HybridModel.attractor keeps them).
        held = min(walked, keep)
        after = max(0, min(keep, walked - transient))
        kept = slice(held - after, held)
        kept_rows = walks.kept_states[i][kept]
        lengths = walks.kept_lengths[i][kept]
        durations = walks.kept_durations[i][kept]
        completed = ended[i] == "walked"
        period = repeat_period(kept_rows, 1e-7) if completed and len(kept_rows) > 1 else None
        point["attractor"] = {
            "ended": "completed" if completed else ended[i],
            "steps_walked": walked,
            "period": period,
            "states": [dict(zip(state_names, (float(v) for v in r))) for r in kept_rows],
            "step_lengths": [None if np.isnan(v) else float(v) for v in lengths],
            "step_periods": [float(v) for v in durations],
        }
    return points


_CLASS_COLORS = {
    "converged": "green",
    "fell": "light_grey",
    "other": "blue",
}
_PERIOD_COLORS = ("orange", "purple", "vermillion", "sky_blue", "yellow")


def _colors_for(labels: Sequence[str]) -> dict[str, str]:
    from vsw.plotstyle import COLORS

    out, k = {}, 0
    for label in labels:
        if label in _CLASS_COLORS:
            out[label] = COLORS[_CLASS_COLORS[label]]
        else:
            out[label] = COLORS[_PERIOD_COLORS[k % len(_PERIOD_COLORS)]]
            k += 1
    return out


def basin_plot(data: Mapping[str, Any], units: Mapping[str, str] | None = None) -> Figure:
    """Two panels from a basin's JSON record: the classes (colour-blind-safe colours, the
    gait's fixed point marked) and the steps walked until each cell's class was decided."""
    from vsw import plotstyle

    with plotstyle.context():
        return _basin_plot(data, units or {})


def _basin_plot(data: Mapping[str, Any], units: Mapping[str, str]) -> Figure:
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.patches import Patch

    from vsw import plotstyle

    x, y = np.asarray(data["x"]), np.asarray(data["y"])
    labels = sorted({c for row in data["outcome"] for c in row}, key=_label_key)
    colors = _colors_for(labels)
    index = {label: k for k, label in enumerate(labels)}
    classes = np.array([[index[c] for c in row] for row in data["outcome"]], dtype=float)
    steps = np.asarray(data["steps"], dtype=float)
    fig, axes = plotstyle.new_figure(plotstyle.PAGE_WIDTH, 3.0, ncols=2)
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
        ax.plot([fp[data["x_name"]]], [fp[data["y_name"]]], marker="*", markersize=9,
                markerfacecolor="white", markeredgecolor="black", linestyle="none")  # fmt: skip
        ax.set_xlabel(_label(data["x_name"], units))
        ax.set_ylabel(_label(data["y_name"], units))
    counts = data.get("counts", {})
    handles = [Patch(facecolor=colors[label], edgecolor="black", linewidth=0.4,
                     label=f"{label} ({counts.get(label, '')})") for label in labels]  # fmt: skip
    handles.append(_star_handle())
    axes[0].legend(handles=handles, loc="upper left", fontsize=6, framealpha=0.9)
    params = ", ".join(f"{k} = {v:.6g}" for k, v in data["parameters"].items())
    axes[0].set_title(f"{data['model']}: {params}", fontsize=7)
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
    unit = units.get(name)
    return f"{name} [{unit}]" if unit else name
