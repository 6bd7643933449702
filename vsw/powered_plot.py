"""The figure of ``vsw optimize --plot``: a powered gait's states and inputs over its step."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from vsw import plotstyle
from vsw.powered import PoweredGait, input_names

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["powered_figure"]


@plotstyle.styled
def powered_figure(model: Any, params: Sequence[float], gait: PoweredGait) -> Figure:
    """Angles (solid) and rates (dashed) on the collocation's knots, and each input on its
    knots and midpoints, over one step; the phases' ends as vertical lines."""
    units = {s["name"]: s["unit"] for s in model.spec["state"]}
    fig, (ax_state, ax_input) = plotstyle.new_figure(
        height=plotstyle.COLUMN_WIDTH * 1.1, nrows=2, sharex=True
    )  # fmt: skip
    n = len(model.coordinates)
    for times, states in zip(gait.times, gait.states):
        for k, name in enumerate((*model.coordinates, *model.rates)):
            style = plotstyle.curve_style(k % n)
            ax_state.plot(times, states[:, k], color=style["color"], lw=1.0,
                          ls="-" if k < n else (0, (4, 1.5)),
                          label=name if times is gait.times[0] else None)  # fmt: skip
    inputs = input_names(model)
    for (phase, _), times, values in zip(model._phase_sequence(), gait.input_times, gait.inputs):
        for j, name in enumerate(inputs[phase]):
            ax_input.plot(times, values[:, j], color=plotstyle.curve_style(j)["color"], lw=1.0,
                          label=name)  # fmt: skip
    for times in gait.times:
        for ax in (ax_state, ax_input):
            ax.axvline(times[-1], color=plotstyle.COLORS["grey"], lw=0.5, zorder=0)
    ax_state.set_ylabel(f"state [{plotstyle.unit_tex(units.get(model.coordinates[0], ''))}, "
                        "per time]")  # fmt: skip
    units = {i["unit"] for ph in model.phases for i in ph.get("inputs", ())}
    ax_input.set_ylabel(f"input [{plotstyle.unit_tex(units.pop())}]" if len(units) == 1
                        else "input")  # fmt: skip
    ax_input.set_xlabel(f"time [{plotstyle.unit_tex(model.units.get('time', ''))}]")
    ax_state.legend(fontsize="small", ncols=2)
    if ax_input.get_legend_handles_labels()[0]:
        ax_input.legend(fontsize="small")
    fig.suptitle(f"{plotstyle.parameter_text(model, params)}\n{gait.status}, cost "
                 f"{gait.cost:.6g}", x=0.02, ha="left", fontsize="medium")  # fmt: skip
    return fig
