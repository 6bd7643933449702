"""The figure of ``vsw simulate --plot`` for every model: a walk over time.

Three panels over the walk's time (one journal column, :mod:`vsw.plots.plotstyle`): the
coordinates, their rates, and the mechanical energy of each phase in its own chart; every
event a vertical line (the step event solid, the others dashed) and each curve continuous
within a phase and broken at an event (an impact or an actuator's jump changes a rate or
the energy at once). Labels are mathtext with the model's units; the legend lies below the
axes, outside the data; the title names the model and its parameters with their units.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vsw.dynamics.trajectories import SampledWalk
from vsw.plots import plotstyle

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["walk_figure"]


@plotstyle.styled
def walk_figure(model: Any, params: Sequence[float], walk: SampledWalk) -> Figure:
    """The walk over time (module docstring)."""
    from matplotlib.lines import Line2D

    units = {s["name"]: s["unit"] for s in model.spec["state"]}
    fig, axes = plotstyle.new_figure(
        height=plotstyle.COLUMN_WIDTH * 1.45, nrows=3, sharex=True
    )  # fmt: skip
    ax_q, ax_rate, ax_energy = axes
    # Pieces: consecutive rows of one phase and step, broken at every event.
    breaks = [0]
    for i in range(1, len(walk.t)):
        if walk.event[i].endswith(":after") or (walk.phase[i], walk.step[i]) != (
            walk.phase[i - 1], walk.step[i - 1]):  # fmt: skip
            breaks.append(i)
    breaks.append(len(walk.t))
    n = len(model.coordinates)
    for k in range(len(walk.names)):
        ax = ax_q if k < n else ax_rate
        style = plotstyle.curve_style(k % n)
        for a, b in itertools.pairwise(breaks):
            ax.plot(walk.t[a:b], walk.states[a:b, k], color=style["color"], lw=1.0,
                    ls="-" if k < n else (0, (4, 1.5)))  # fmt: skip
    for a, b in itertools.pairwise(breaks):
        ax_energy.plot(walk.t[a:b], walk.energy[a:b], color=plotstyle.COLORS["black"], lw=1.0)
    step_event = model.step_event["name"]
    for i, event in enumerate(walk.event):
        if not event.endswith(":before"):
            continue
        is_step = event.split(":")[0] == step_event
        for ax in axes:
            ax.axvline(walk.t[i], color=plotstyle.COLORS["grey"], lw=0.5,
                       ls="-" if is_step else "--", zorder=0)  # fmt: skip
    coordinate_unit = units.get(model.coordinates[0], "rad")
    ax_q.set_ylabel(f"angle [{plotstyle.unit_tex(coordinate_unit)}]")
    ax_rate.set_ylabel(f"rate [{plotstyle.unit_tex(units.get(model.rates[0], ''))}]")
    ax_energy.set_ylabel(f"energy [{plotstyle.unit_tex(model.units.get('energy', ''))}]")
    ax_energy.set_xlabel(f"time [{plotstyle.unit_tex(model.units.get('time', ''))}]")
    # A figure title: constrained layout makes room for it whatever the axes' width.
    fig.suptitle(plotstyle.parameter_text(model, params), x=0.02, ha="left", fontsize="medium")
    handles = [
        Line2D([], [], color=plotstyle.curve_style(k)["color"], lw=1.0)
        for k in range(n)
    ] + [
        Line2D([], [], color=plotstyle.COLORS["grey"], lw=0.5, ls="-"),
    ]  # fmt: skip
    labels = [plotstyle.state_label(c, units.get(c, "")) + " and its rate (dashed)"
              for c in model.coordinates]  # fmt: skip
    labels.append(f"{plotstyle.words(step_event)} (step event)")
    others = sorted({e["name"] for e in model.events} - {step_event})
    if others:
        handles.append(Line2D([], [], color=plotstyle.COLORS["grey"], lw=0.5, ls="--"))
        labels.append(", ".join(map(plotstyle.words, others)))
    if walk.ended != "completed":
        labels[-1] += f"; the walk ended: {plotstyle.words(walk.ended)}"
    plotstyle.figure_legend(fig, handles, labels, ncols=2)
    # A conserved energy drifts by the integrator's 1e-12: shown at least 1e-3 of its size
    # tall, it reads as the constant it is, and the events' jumps as what they are.
    energy = walk.energy[np.isfinite(walk.energy)]
    if len(energy):
        low, high = float(np.min(energy)), float(np.max(energy))
        least = 1e-3 * max(abs(low), abs(high), 1e-300)
        if high - low < least:
            middle = 0.5 * (low + high)
            ax_energy.set_ylim(middle - least, middle + least)
    for ax in axes:
        ax.margins(x=0.0)
    if len(walk.t) and np.max(walk.t) > walk.t[0]:  # a walk that ended at once: one instant
        ax_energy.set_xlim(float(walk.t[0]), float(np.max(walk.t)))
    return fig
