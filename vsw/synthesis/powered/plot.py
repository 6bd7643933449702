"""The figure of ``vsw optimize --plot``: a powered gait's states and inputs over its step."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from vsw.plots import plotstyle
from vsw.synthesis.powered.request import PoweredGait, input_names

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["powered_figure"]


def _quantity(names: Sequence[str], units: dict[str, str], angle: str, other: str) -> str:
    """An axis label: ``angle`` where every one of ``names`` is in radians, else ``other``,
    with their unit where they share one."""
    shared = {units.get(n, "") for n in names}
    unit = shared.pop() if len(shared) == 1 else ""
    word = angle if unit.startswith("rad") else other
    return f"{word} [{plotstyle.unit_tex(unit)}]" if unit else word


@plotstyle.styled
def powered_figure(model: Any, params: Sequence[float], gait: PoweredGait,
                   cost_unit: str = "") -> Figure:  # fmt: skip
    """Coordinates and their rates on the collocation's knots, and each input on its knots
    and midpoints, over one step, in three panels; the phases' ends as vertical lines; the
    legend below the panels, the title the parameters (:func:`vsw.plots.plotstyle.parameter_text`),
    the status and the cost with ``cost_unit`` (the model table's way of writing it)."""
    from matplotlib.lines import Line2D

    units = {s["name"]: s["unit"] for s in model.spec["state"]}
    fig, (ax_q, ax_rate, ax_input) = plotstyle.new_figure(
        height=plotstyle.COLUMN_WIDTH * 1.45, nrows=3, sharex=True
    )  # fmt: skip
    n = len(model.coordinates)
    for times, states in zip(gait.times, gait.states):
        for k in range(2 * n):
            ax = ax_q if k < n else ax_rate
            ax.plot(times, states[:, k], color=plotstyle.curve_style(k % n)["color"], lw=1.0,
                    ls="-" if k < n else (0, (4, 1.5)))  # fmt: skip
    inputs = input_names(model)
    input_units = {i["name"]: i["unit"] for ph in model.phases for i in ph.get("inputs", ())}
    order = list(dict.fromkeys(name for names in inputs.values() for name in names))
    for (phase, _), times, values in zip(model.phase_sequence(), gait.input_times, gait.inputs):
        for j, name in enumerate(inputs[phase]):
            style = plotstyle.curve_style(n + order.index(name))
            ax_input.plot(times, values[:, j], color=style["color"], lw=1.0, ls=(0, (1, 1)))
    for times in gait.times:
        for ax in (ax_q, ax_rate, ax_input):
            ax.axvline(times[-1], color=plotstyle.COLORS["grey"], lw=0.5, zorder=0)
    ax_q.set_ylabel(_quantity(model.coordinates, units, "angle", "coordinate"))
    ax_rate.set_ylabel(_quantity(model.rates, units, "rate", "rate"))
    ax_input.set_ylabel(_quantity(order, input_units, "input", "input"))
    ax_input.set_xlabel(f"time [{plotstyle.unit_tex(model.units.get('time', ''))}]")
    handles = [Line2D([], [], color=plotstyle.curve_style(k)["color"], lw=1.0)
               for k in range(n)]  # fmt: skip
    labels = [plotstyle.state_label(c, units.get(c, "")) + " and its rate (dashed)"
              for c in model.coordinates]  # fmt: skip
    for name in order:
        handles.append(Line2D([], [], color=plotstyle.curve_style(n + order.index(name))["color"],
                              lw=1.0, ls=(0, (1, 1))))  # fmt: skip
        labels.append(f"{plotstyle.words(name)} [{plotstyle.unit_tex(input_units[name])}]")
    handles.append(Line2D([], [], color=plotstyle.COLORS["grey"], lw=0.5))
    labels.append("end of a phase")
    plotstyle.figure_legend(fig, handles, labels, ncols=2)
    shown = plotstyle.unit_tex(cost_unit.replace("^2", "²"))
    unit = f" {shown}" if cost_unit not in ("", "1") else ""
    fig.suptitle(f"{plotstyle.parameter_text(model, params)}\n{gait.status}, cost "
                 f"{gait.cost:.6g}{unit}", x=0.02, ha="left", fontsize="medium")  # fmt: skip
    for ax in (ax_q, ax_rate, ax_input):
        ax.margins(x=0.0)
    return fig
