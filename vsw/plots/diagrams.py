"""The bifurcation diagrams of ``vsw sweep --plot`` and ``vsw continue --plot`` for every
model of the engine.

Each draws from its command's own JSON record (the dictionary ``--json`` prints), so a
figure shows exactly the numbers the command reports. The style is
:mod:`vsw.plots.plotstyle`'s; matplotlib is imported by it, inside the functions.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from vsw.plots import plotstyle
from vsw.plots.plotstyle import COLORS
from vsw.runtime.errors import VswInputError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "bifurcation_plot",
    "continuation_plot",
    "diagram_quantity",
    "diagram_units",
    "diagram_value",
    "parameter_plane_plot",
]


SPECIAL_MARKERS = {"fold": "s", "flip": "D", "neimark-sacker": "^", "boundary": "X"}
"""Markers of ``vsw continue``'s special points."""

SPECIAL_LABELS = {"fold": "LP", "flip": "PD", "neimark-sacker": "NS", "boundary": "B"}
"""Labels of the special points (AUTO's and MatCont's)."""


def diagram_quantity(model: Any, y: str | None) -> str:
    """``--y``: what the bifurcation diagram shows (step length where the model has one)."""
    choices = ["step_period", *model.coordinates, *model.rates]
    if model.spec["step_length"]:
        choices.insert(0, "step_length")
    if y is None:
        return choices[0]
    if y.removeprefix("-") not in choices:
        raise VswInputError(f"--y {y!r} is not one of the {model.cli_name} model's: "
                            f"{', '.join(choices)} (or minus one: --y=-NAME)")  # fmt: skip
    return y


def diagram_units(units: Mapping[str, str]) -> dict[str, str]:
    """The axis units of a diagram from a model's units."""
    time, length = units.get("time", ""), units.get("length", "")
    return {"time": time, "length": length, "speed": f"{length}/{time}" if time else ""}


def diagram_value(y: str, state: Mapping[str, float] | None, step_length, step_period):
    """The diagram's quantity ``y`` of one step: a state component (``-name``: minus it,
    for an angle whose sign convention runs the other way) or the step's length or period
    (None where the sweep has no value)."""
    if y.startswith("-"):
        value = diagram_value(y[1:], state, step_length, step_period)
        return None if value is None else -value
    if y == "step_length":
        return step_length
    if y == "step_period":
        return step_period
    return None if state is None else state.get(y)


def _axis_label(y: str, units: Mapping[str, str]) -> str:
    if y.startswith("-"):
        return "\u2212" + _axis_label(y[1:], units)
    if y == "step_length":
        return f"step length [{units.get('length', '')}]"
    if y == "step_period":
        return f"step period [{units.get('time', '')}]"
    return f"{y} (after the step event)"


@plotstyle.styled
def bifurcation_plot(
    data: Mapping[str, Any], y: str, units: Mapping[str, str], title: str
) -> Figure:
    """The period-one gait along the swept parameter (solid where stable, dashed where
    not) and, where it is unstable or was not found, the last steps of the iterated map
    (dots where the walk settled on an orbit: a period-k orbit shows k dots; crosses of
    another colour where it had not settled by the sweep's cap: chaos or a transient, no
    orbit claimed); below, the largest |eigenvalue|
    of the period-one gait against 1. The special points located by continuation
    (``special_points``: fold LP, flip PD, Neimark-Sacker NS, boundary B) are dotted
    vertical lines through both panels.

    Parameters
    ----------
    data : mapping
        The record of ``vsw sweep --json`` (``over``, ``points``; each point's
        ``attractor`` where the map was iterated).
    y : str
        What the diagram shows (:func:`diagram_value`).
    units : mapping
        The model's units (``length``, ``time``), for the axis label.
    title : str
        The model and its fixed parameters with units (:func:`vsw.plots.plotstyle
        .parameter_text`).

    The whole swept range is shown: values where no period-one gait was found are marked
    on the top edge, walks that fell on the bottom edge (outside the data).
    """
    over = data["over"]
    points = data["points"]
    fig, (ax, ax_eig) = plotstyle.new_figure(
        width=plotstyle.COLUMN_WIDTH, height=1.25 * plotstyle.COLUMN_WIDTH, nrows=2,
        sharex=True, height_ratios=(2.2, 1.0),
    )  # fmt: skip
    xs = np.array([p[over] for p in points], dtype=float)
    _draw_period_one(ax, xs, points, y)
    _draw_iterated_map(ax, data, y)
    if len(xs):
        ax.set_xlim(float(np.min(xs)), float(np.max(xs)))
    ax.set_ylabel(_axis_label(y, units))
    fig.suptitle(title, x=0.02, ha="left", fontsize="medium")
    plotstyle.figure_legend(fig, *ax.get_legend_handles_labels(), ncols=2)
    _draw_eigenvalues(ax, ax_eig, data, xs)
    return fig


def _draw_eigenvalues(ax: Axes, ax_eig: Axes, data: Mapping[str, Any], xs: np.ndarray) -> None:
    """The period-one gait's largest |eigenvalue| against 1 (on a log scale where it spans
    much), and the special points of continuation through both panels."""
    points = data["points"]
    over = data["over"]
    eig = np.array([np.nan if p["max_abs_eigenvalue"] is None else p["max_abs_eigenvalue"]
                    for p in points], dtype=float)  # fmt: skip
    ax_eig.axhline(1.0, color=COLORS["grey"], linewidth=0.8)
    ax_eig.plot(xs, eig, "-", color=COLORS["blue"], marker="none")
    ax_eig.set_ylabel(r"max $|\lambda|$")
    ax_eig.set_xlabel(plotstyle.state_label(over, data.get("over_unit") or "1"))
    for special in data.get("special_points") or ():
        # Located by continuation (vsw sweep --plot): a vertical line through both panels.
        for axis in (ax, ax_eig):
            axis.axvline(special["parameter"], color=COLORS["grey"], linestyle=":",
                         linewidth=0.8)  # fmt: skip
        ax.annotate(SPECIAL_LABELS[special["type"]], (special["parameter"], 1.0),
                    xycoords=ax.get_xaxis_transform(), textcoords="offset points",
                    xytext=(2, -8), fontsize="x-small")  # fmt: skip
    if np.any(eig > 0):
        finite = eig[np.isfinite(eig)]
        if finite.size and finite.max() / max(finite.min(), 1e-300) > 50:
            ax_eig.set_yscale("log")


def _draw_period_one(ax: Axes, xs: np.ndarray, points: list[Mapping[str, Any]], y: str) -> None:
    """The period-one gait's ``y`` at each swept value ``xs``: solid where stable, dashed
    where not."""
    ys = np.array(
        [
            np.nan if (v := diagram_value(y, p["state"], p["step_length"], p["period"])) is None
            else v
            for p in points
        ],
        dtype=float,
    )  # fmt: skip
    stable = np.array([bool(p["stable"]) for p in points])
    # One line per kind, so a dashed line keeps its pattern over many short segments: the
    # stable gaits solid, the unstable dashed and joined to their stable neighbours.
    unstable = ~stable & ~np.isnan(ys)
    joined = unstable | np.r_[unstable[1:], False] | np.r_[False, unstable[:-1]]
    for mask, style, label in (
        (stable, "-", "period-one gait, stable"),
        (joined, "--", "period-one gait, unstable"),
    ):
        line = np.where(mask, ys, np.nan)
        if np.count_nonzero(~np.isnan(line)) >= 2:
            ax.plot(xs, line, style, color=COLORS["blue"], marker="none", label=label)
        elif np.any(~np.isnan(line)):  # one gait alone: a marker
            fill = "full" if style == "-" else "none"
            ax.plot(xs, line, marker="o", fillstyle=fill, color=COLORS["blue"],
                    linestyle="none", label=label)  # fmt: skip


def _draw_iterated_map(ax: Axes, data: Mapping[str, Any], y: str) -> None:
    """The iterated map's last steps (:func:`_attractor_dots`), and on the panel's edges
    the values without a period-one gait (top) and those where the walk fell (bottom)."""
    over = data["over"]
    points = data["points"]
    dots, fell_x = _attractor_dots(points, over, y)
    for settled, marker, size, color, label in (
        (True, ".", 1.8, "vermillion", "iterated map, settled (last steps)"),
        (False, "+", 2.4, "purple", f"iterated map, not settled after {_cap(data)} steps"),
    ):
        if dots[settled][0]:
            ax.plot(*dots[settled], linestyle="none", marker=marker, markersize=size,
                    markeredgewidth=0.5, color=COLORS[color], label=label)  # fmt: skip
    edge = ax.get_xaxis_transform()  # x in data, y in axes fractions
    lost = [p[over] for p in points if not p["found"]]
    if lost:
        ax.plot(lost, [1.0] * len(lost), linestyle="none", marker="v", markersize=3.5,
                color=COLORS["grey"], transform=edge, clip_on=False,
                label="no period-one gait (top edge)")  # fmt: skip
    if fell_x:
        ax.plot(fell_x, [0.0] * len(fell_x), linestyle="none", marker="x", markersize=3.5,
                color=COLORS["black"], transform=edge, clip_on=False,
                label="the walk fell (bottom edge)")  # fmt: skip


def _attractor_dots(
    points: list[Mapping[str, Any]], over: str, y: str
) -> tuple[dict[bool, tuple[list[float], list[float]]], list[float]]:
    """The iterated map's kept steps as dots, apart for walks that settled on an orbit and
    walks that did not (a smear that is a transient, not an attractor, must not read as
    one), and the values where the walk fell."""
    dots: dict[bool, tuple[list[float], list[float]]] = {True: ([], []), False: ([], [])}
    fell_x = []
    for p in points:
        attractor = p.get("attractor")
        if not attractor:
            continue
        if attractor["ended"] != "completed":
            fell_x.append(p[over])
        settled = bool(attractor.get("settled", attractor["period"] is not None))
        xs, ys = dots[settled]
        for state, length, period in zip(
            attractor["states"], attractor["step_lengths"], attractor["step_periods"]
        ):
            value = diagram_value(y, state, length, period)
            if value is not None:
                xs.append(p[over])
                ys.append(value)
    return dots, fell_x


def _cap(data: Mapping[str, Any]) -> int:
    """The steps an unsettled walk took: the sweep's cap (the most walked where a record
    has none)."""
    if data.get("max_steps"):
        return int(data["max_steps"])
    walked = [p["attractor"]["steps_walked"] for p in data["points"] if p.get("attractor")]
    return max(walked, default=0)


def _branch_values(y: str, record: Mapping[str, Any], step: int) -> float:
    """The diagram's quantity of one step of a branch point's (or special point's) gait."""
    value = diagram_value(
        y,
        record["section_states"][step],
        record["step_lengths"][step] if record["step_lengths"] else None,
        record["step_periods"][step],
    )
    return np.nan if value is None else float(value)


@plotstyle.styled
def continuation_plot(
    data: Mapping[str, Any], y: str, units: Mapping[str, str], title: str
) -> Figure:
    """Every branch of ``vsw continue`` against the parameter: a period-k gait as k curves
    (one per step of its cycle), solid where stable and dashed where not, one colour per
    period; special points marked and labelled (LP fold, PD flip, NS Neimark-Sacker, B
    boundary; a cascade's labels stacked apart, :func:`_place_labels`); below, each
    branch's largest |eigenvalue| against 1.

    Parameters
    ----------
    data : mapping
        The record of ``vsw continue --json`` (``over``, ``branches``).
    y, units, title
        As :func:`bifurcation_plot`'s.
    """
    fig, (ax, ax_eig) = plotstyle.new_figure(
        width=plotstyle.COLUMN_WIDTH, height=1.25 * plotstyle.COLUMN_WIDTH, nrows=2,
        sharex=True, height_ratios=(2.2, 1.0),
    )  # fmt: skip
    labels = SPECIAL_LABELS
    periods = sorted({b["period"] for b in data["branches"]})
    handles: dict[str, Any] = {}
    anchors: list[tuple[str, float, float]] = []
    for branch in data["branches"]:
        color = COLORS[plotstyle.CYCLE[periods.index(branch["period"]) % len(plotstyle.CYCLE)]]
        points = branch["points"]
        xs = np.array([p["parameter"] for p in points], dtype=float)
        stable = np.array([bool(p["stable"]) for p in points])
        unstable = ~stable
        joined = unstable | np.r_[unstable[1:], False] | np.r_[False, unstable[:-1]]
        for step in range(branch["period"]):
            ys = np.array([_branch_values(y, p, step) for p in points])
            for mask, style in ((stable, "-"), (joined, "--")):
                line = np.where(mask, ys, np.nan)
                if np.any(~np.isnan(line)):
                    (drawn,) = ax.plot(xs, line, style, color=color, marker="none")
                    handles.setdefault(f"period {branch['period']}", drawn)
        eig = np.array([np.nan if p["max_abs_eigenvalue"] is None else p["max_abs_eigenvalue"]
                        for p in points], dtype=float)  # fmt: skip
        ax_eig.plot(xs, eig, "-", color=color, marker="none")
        for special in branch["special_points"]:
            kind = special["type"]
            for step in range(branch["period"]):
                value = _branch_values(y, special, step)
                (drawn,) = ax.plot([special["parameter"]], [value], linestyle="none",
                                   marker=SPECIAL_MARKERS[kind], markersize=4,
                                   color=COLORS["black"], fillstyle="none")  # fmt: skip
                handles.setdefault(f"{labels[kind]}: {kind}", drawn)
                if step == 0 and np.isfinite(value):
                    anchors.append((labels[kind], special["parameter"], value))
    for style, label in (("-", "stable"), ("--", "unstable")):
        (handles[label],) = ax.plot([], [], style, color=COLORS["grey"], marker="none")
    low, high = sorted(data["range"])
    ax.set_xlim(low, high)
    ax.set_ylabel(_axis_label(y, units))
    fig.suptitle(title, x=0.02, ha="left", fontsize="medium")
    plotstyle.figure_legend(fig, list(handles.values()), list(handles), ncols=3)
    ax_eig.axhline(1.0, color=COLORS["grey"], linewidth=0.8)
    ax_eig.set_ylabel(r"max $|\lambda|$")
    ax_eig.set_xlabel(plotstyle.state_label(data["over"], data.get("over_unit") or "1"))
    values = np.concatenate([[p["max_abs_eigenvalue"] or np.nan for p in b["points"]]
                             for b in data["branches"]]).astype(float)  # fmt: skip
    finite = values[np.isfinite(values) & (values > 0)]
    if finite.size and finite.max() / finite.min() > 50:
        ax_eig.set_yscale("log")
    _place_labels(fig, ax, anchors)
    return fig


def _place_labels(fig: Figure, ax: Any, anchors: list[tuple[str, float, float]]) -> None:
    """Label each special point (text, parameter, value) beside it where the label's box
    meets no other label's: a cascade's flips lie a few pixels apart, and labels at one
    fixed offset print over each other. The layout is settled and frozen first, at the
    resolution :func:`vsw.plots.figures.save_figure` saves at (:func:`vsw.plots.plotstyle
    .settle_layout`), and the boxes are measured with the figure's renderer at that
    resolution, so they are those saved; each label takes the first free slot,
    alternately above and below its point and further out, joined to it by a thin line
    when not beside it."""
    plotstyle.settle_layout(fig, dpi=plotstyle.PNG_DPI)
    shown = fig.dpi
    fig.set_dpi(plotstyle.PNG_DPI)
    try:
        frame = ax.get_window_extent()
        placed: list[Any] = []
        for text, x, value in sorted(anchors, key=lambda a: (a[1], a[2])):
            slot, offset, box = _free_slot(ax, text, (x, value), frame, placed)
            leader = {"arrowprops": {"arrowstyle": "-", "linewidth": 0.4, "shrinkA": 0,
                                     "shrinkB": 0, "color": COLORS["grey"],
                                     "relpos": (0.0, 0.5)}} if slot else {}  # fmt: skip
            ax.annotate(text, (x, value), textcoords="offset points", xytext=offset,
                        fontsize="x-small", annotation_clip=False, **leader)  # fmt: skip
            placed.append(box)
    finally:
        fig.set_dpi(shown)


def _free_slot(ax: Any, text: str, xy: tuple[float, float], frame: Any, placed: list[Any]):
    """The first of 16 offsets (points) at which the label's text box, padded by half a
    point, stays inside the axes' height and meets none of ``placed``: (slot, offset,
    box); the last slot when none is free."""
    from matplotlib.text import Text

    probe = ax.annotate(text, xy, textcoords="offset points", xytext=(3, 3),
                        fontsize="x-small", annotation_clip=False)  # fmt: skip
    probe.get_window_extent()  # positions the text with the figure's renderer
    point = ax.figure.dpi / 72.0
    height = Text.get_window_extent(probe).height / point
    for slot in range(16):
        level, below = divmod(slot, 2)
        dy = -(3 + height + level * (height + 2)) if below else 3 + level * (height + 2)
        probe.xyann = (3, dy)
        probe.get_window_extent()
        box = Text.get_window_extent(probe).padded(0.5 * point)
        inside = frame.y0 <= box.y0 and box.y1 <= frame.y1
        if inside and not any(box.overlaps(other) for other in placed):
            break
    probe.remove()
    return slot, (3, dy), box


@plotstyle.styled
def parameter_plane_plot(data: Mapping[str, Any], title: str) -> Figure:
    """``vsw continue --free``: each special point's curve in the plane of the two
    parameters (one colour per type: the edges of the stability and existence regions),
    its starting point marked.

    Parameters
    ----------
    data : mapping
        The record of ``vsw continue --free ... --json`` (``over``, ``free``, ``curves``).
    title : str
        The model and its other parameters (:func:`vsw.plots.plotstyle.parameter_text`).
    """
    fig, ax = plotstyle.new_figure(width=plotstyle.COLUMN_WIDTH, height=plotstyle.COLUMN_WIDTH)
    names = {"fold": "fold (LP)", "flip": "flip (PD)", "neimark-sacker": "Neimark-Sacker (NS)",
             "boundary": "boundary (B)"}  # fmt: skip
    kinds = list(names)
    handles: dict[str, Any] = {}
    for curve in data.get("curves", ()):
        if "skipped" in curve:
            continue
        color = COLORS[plotstyle.CYCLE[kinds.index(curve["type"]) % len(plotstyle.CYCLE)]]
        xs = [p["parameter"] for p in curve["points"]]
        ys = [p["second_parameter"] for p in curve["points"]]
        (line,) = ax.plot(xs, ys, "-", color=color, marker="none")
        handles.setdefault(names[curve["type"]], line)
        start = curve["from"]
        ax.plot([start["parameter"]], [start["second_parameter"]], linestyle="none",
                marker="o", markersize=3, color=color)  # fmt: skip
    ax.set_xlim(*sorted(data["range"]))
    ax.set_ylim(*sorted(data["free_range"]))
    ax.set_xlabel(plotstyle.state_label(data["over"], data.get("over_unit") or "1"))
    ax.set_ylabel(plotstyle.state_label(data["free"], data.get("free_unit") or "1"))
    fig.suptitle(title, x=0.02, ha="left", fontsize="medium")
    if handles:
        plotstyle.figure_legend(fig, list(handles.values()), list(handles), ncols=2)
    return fig
