"""``vsw hzd --plot``: the zero dynamics' phase portrait, the outputs and the torques over a
step, in the project's style (:mod:`vsw.plots.plotstyle`), saved byte for byte the same
(:func:`vsw.plots.figures.save_figure`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vsw.plots import plotstyle
from vsw.plots.figures import save_figure

__all__ = ["hzd_figure", "save_hzd_plot"]


@plotstyle.styled
def hzd_figure(report: Any, surface: Any, phase_name: str, time_unit: str) -> Any:
    """Three panels over the phase: theta_dot on the gait and on neighbouring levels of
    zeta (with the impact's jump), the controlled coordinates' desired values, and the
    feed-forward torques."""
    z = report.zero
    lo, hi = surface.theta_plus, surface.theta_minus
    theta = np.linspace(lo, hi, 241)
    inertia, _ = surface.zero(theta)
    fig, axes = plotstyle.new_figure(height=2 * plotstyle.COLUMN_WIDTH, nrows=3, sharex=True)
    for factor in (0.85, 1.0, 1.15):
        zeta = factor * z.delta_squared * z.zeta_star - z.potential(theta)
        rate = np.where(zeta > 0, np.sqrt(np.clip(2 * zeta, 0, None)) / inertia, np.nan)
        style = {"color": plotstyle.COLORS[plotstyle.CYCLE[0]], "lw": 1.6} if factor == 1 else {
            "color": "0.6", "lw": 0.8}  # fmt: skip
        axes[0].plot(theta, rate, label="gait" if factor == 1 else None, **style)
    axes[0].plot([hi, lo], [z.theta_dot_minus, z.theta_dot_plus], ls=":", color="0.3",
                 label="impact")  # fmt: skip
    axes[0].set_ylabel(f"$\\dot\\theta$ [rad/{time_unit}]")
    axes[0].legend(loc="best")
    h, _, _ = surface.desired(theta)
    for k, name in enumerate(report.output_names):
        axes[1].plot(theta, np.broadcast_to(h[k], theta.shape), label=name,
                     **{"color": plotstyle.curve_style(k)["color"]})  # fmt: skip
    axes[1].set_ylabel("desired [rad]")
    axes[1].legend(loc="best")
    grid, torques = report.samples["grid"], report.samples["torques"]
    for k, name in enumerate(report.input_names):
        axes[2].plot(grid, torques[:, k], label=name.replace("_", " "),
                     color=plotstyle.curve_style(k)["color"])  # fmt: skip
    axes[2].set_ylabel("torque [N m]")
    axes[2].set_xlabel(f"phase {phase_name} [rad]")
    axes[2].legend(loc="best")
    return fig


def save_hzd_plot(report: Any, surface: Any, phase_name: str, time_unit: str,
                  path: str | Path) -> Path:  # fmt: skip
    return save_figure(hzd_figure(report, surface, phase_name, time_unit), path)
