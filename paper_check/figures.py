"""The paper's Fig. 5-9 reproduced from the generated code, with the simulation overlaid.

Every curve of Fig. 5-7 is solid where the gait walks (every physical existence condition
of the derivation holds) and dotted where the paper's plotted range reaches no valid gait;
where a curve leaves the frame at the top an arrow marks it (:func:`off_scale`). Drawn in
the style of :mod:`vsw.plots.plotstyle` (the same as the CLI's plots) and written
deterministically as PNG, SVG and PDF.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np

from generated import ile
from paper_check.walking import FIG_BETA, FIG_PHI0, FIG_THETA_II, walk_mask
from vsw.plots.plotstyle import COLORS, DEG, LABELS

__all__ = [
    "FIGURES",
    "FORMATS",
    "Q_TOP",
    "curves",
    "draw_figure",
    "off_scale",
    "write_figures",
]

FIGURES = ("fig5", "fig6", "fig7", "fig8", "fig9")
FORMATS = ("png", "svg", "pdf")
Q_TOP = {"fig5": 3.0, "fig7": 3.0}
"""Upper q^f limit of the plots that cut their curves (the paper's range)."""
_OFF_SCALE_MARKER = r"$\uparrow$"


def walks(beta: Any, theta_II: Any, phi0: Any) -> np.ndarray:
    """Whether each parameter set walks (every physical condition holds)."""
    return walk_mask(np.asarray(beta, float), np.asarray(theta_II, float), np.asarray(phi0, float))


def curves(name: str) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """The paper's plotted curves of Fig. 5-7: ``(label, x, beta, theta_II, phi0)``.

    ``x`` is the plotted abscissa (beta, or an angle in degrees); the parameter arrays are
    broadcast to its shape (angles in radians); ``label`` is mathtext.
    """
    out = []
    if name == "fig5":
        beta = np.linspace(0.4, 0.999, 600)
        for phi_deg in (45, 50, 55, 60):
            p = np.full_like(beta, math.radians(phi_deg))
            out.append((rf"$\varphi_0={phi_deg}${DEG}", beta, beta, 0 * beta, p))
    elif name == "fig6":
        theta = np.linspace(-40.0, 40.0, 801)
        for b in (0.8, 0.9):
            for phi_deg in (45, 60):
                label = rf"$\beta={b}$, $\varphi_0={phi_deg}${DEG}"
                p = np.full_like(theta, math.radians(phi_deg))
                out.append((label, theta, np.full_like(theta, b), np.radians(theta), p))
    elif name == "fig7":
        phi = np.linspace(5.0, 89.0, 841)
        for b in (0.6, 0.7, 0.8, 0.9):
            out.append((rf"$\beta={b}$", phi, np.full_like(phi, b), 0 * phi, np.radians(phi)))
    return out


def plain(label: str) -> str:
    """A curve's mathtext label as plain text (``beta=0.8, phi0=45 deg``)."""
    text = label.replace("$", "").replace("\\", "").replace("varphi_0", "phi0")
    return text.replace(DEG, " deg")


def off_scale(name: str) -> list[dict[str, Any]]:
    """Curves of ``name`` cut by the plot's upper limit :data:`Q_TOP`, with what is hidden.

    Returns
    -------
    list of dict
        Keys ``curve`` (plain text), ``label`` (mathtext), ``max`` (largest q^f of the
        curve) and ``walks`` (whether any hidden point has a gait). Empty for figures
        without a limit.
    """
    top = Q_TOP.get(name)
    if top is None:
        return []
    cut = []
    for label, _, b, t, p in curves(name):
        q = ile.q_fixed(b, t, p)
        hidden = q > top
        if hidden.any():
            cut.append(
                {
                    "curve": plain(label),
                    "label": label,
                    "max": float(np.max(q)),
                    "walks": bool(walks(b, t, p)[hidden].any()),
                }
            )
    return cut


Legend = tuple[list[Any], list[str]]


def _family(ax: Any, name: str) -> Legend:
    """Fig. 5-7: q^f curves, solid where a gait exists, dotted where none, with markers."""
    from matplotlib.lines import Line2D

    from vsw.plots.plotstyle import curve_style, mark_off_scale

    handles, labels = [], []
    top = Q_TOP.get(name)
    for k, (label, x, b, t, p) in enumerate(curves(name)):
        style = curve_style(k)
        q = ile.q_fixed(b, t, p)
        ok = walks(b, t, p)
        ax.plot(x, np.where(ok, q, np.nan), color=style["color"], lw=1.5)
        ax.plot(x, np.where(ok, np.nan, q), color=style["color"], lw=1.1, ls=(0, (1, 1.5)))
        # Sparse markers, evenly spaced along the drawn curve: the curves differ in shape,
        # not only in colour.
        shown = q if top is None else np.where(q <= top, q, np.nan)
        ax.plot(
            x,
            shown,
            ls="none",
            marker=style["marker"],
            ms=3.5,
            color=style["color"],
            mfc="white",
            mew=0.9,
            markevery=(0.04 * (k + 1), 0.22),
        )
        if top is not None:
            mark_off_scale(ax, x, q, top, style["color"], marker=_OFF_SCALE_MARKER, ms=8)
        handles.append(
            Line2D(
                [],
                [],
                color=style["color"],
                marker=style["marker"],
                ms=3.5,
                mfc="white",
                mew=0.9,
                lw=1.5,
            )
        )
        labels.append(label)
    grey = COLORS["grey"]
    handles += [
        Line2D([], [], color=grey, lw=1.5),
        Line2D([], [], color=grey, lw=1.1, ls=(0, (1, 1.5))),
    ]
    labels += ["gait exists", "no valid gait"]
    if top is not None:
        handles.append(Line2D([], [], ls="none", marker=_OFF_SCALE_MARKER, ms=8, color=grey))
        labels.append(f"continues above $q^f$ = {top:g}")
        ax.set_ylim(0.0, top)
    ax.set_ylabel(LABELS["q_fixed"])
    return handles, labels


def _fig5(ax: Any) -> Legend:
    legend = _family(ax, "fig5")
    ax.set_xlabel(LABELS["beta"])
    ax.set_title(r"$\theta_{\mathrm{II}}$ = 0" + DEG)
    return legend


def _fig6(ax: Any) -> Legend:
    legend = _family(ax, "fig6")
    ax.set_xlabel(LABELS["theta_II_deg"])
    ax.set_xlim(-40, 40)
    ax.set_ylim(bottom=0.0)
    return legend


def _fig7(ax: Any) -> Legend:
    legend = _family(ax, "fig7")
    ax.set_xlabel(LABELS["phi0_deg"])
    ax.set_title(r"$\theta_{\mathrm{II}}$ = 0" + DEG)
    return legend


def _fig8(ax: Any, data: dict[str, Any]) -> Legend:
    from matplotlib.lines import Line2D

    from vsw.models.ile.plots import label_instants
    from vsw.models.ile.simulate import simulate
    from vsw.plots import plotstyle
    from vsw.plots.plotstyle import direction_arrow

    b, t2, p = FIG_BETA, FIG_THETA_II, FIG_PHI0
    qf = float(ile.q_fixed(b, t2, p))
    lo = float(ile.q_apex_min(b, t2, p))
    transient = simulate(b, t2, p, lo + 0.15 * (qf - lo), 6, rtol=1e-10, atol=1e-12)
    cycle = simulate(b, t2, p, qf, 1, rtol=1e-10, atol=1e-12)
    grey, blue = "#A6A6A6", COLORS["blue"]
    pieces = []
    for res, color, lw in ((transient, grey, 0.6), (cycle, blue, 1.8)):
        deg = np.degrees(res.theta)
        for step in np.unique(res.step):
            for phase in (1, 2):
                sel = (res.step == step) & (res.phase == phase)
                ax.plot(deg[sel], res.omega[sel], color=color, lw=lw)
                pieces.append((res is cycle, deg[sel], res.omega[sel], color))
        # Jumps: extension II -> III and heelstrike IV -> I.
        for a, c in itertools.pairwise(res.events):
            if (a[0], c[0]) in (("II", "III"), ("IV", "I")):
                x, y = np.degrees([a[2], c[2]]), [a[3], c[3]]
                ax.plot(x, y, color=color, lw=lw * 0.7, ls="--")
                pieces.append((res is cycle, x, np.asarray(y), color))
    ax.margins(x=0.08, y=0.08)
    ax.autoscale_view()
    for on_cycle, x, y, color in pieces:
        if on_cycle:
            direction_arrow(ax, x, y, color)
    instants = {k: (math.degrees(th), om) for k, (th, om) in data["analytic_instants"].items()}
    label_instants(ax, instants, mec=COLORS["vermillion"], ms=6, mew=1.1)
    ax.set_xlabel(LABELS["theta_deg"])
    ax.set_ylabel(LABELS["omega"])
    ax.set_title(plotstyle.params_title(b, t2, p))
    handles = [
        Line2D([], [], color=blue, lw=1.8),
        Line2D([], [], color=grey, lw=0.6),
        Line2D([], [], color="k", lw=0.9, ls="--"),
        Line2D([], [], ls="none", marker="o", ms=6, mfc="white", mec=COLORS["vermillion"], mew=1.1),
    ]
    labels = [
        "simulated cycle from $q^f$",
        "simulated transient, 6 steps",
        "jumps: extension, heelstrike",
        "closed-form instants I\u2013IV",
    ]
    return handles, labels


def _fig9(ax: Any, data: dict[str, Any]) -> Legend:
    from vsw.models.ile.basin import Basin
    from vsw.models.ile.plots import basin_plot

    # The audit's basin as a vsw Basin, so the CLI's drawing is reused (n_steps is not
    # drawn).
    result = Basin(
        FIG_BETA,
        FIG_PHI0,
        data["theta_II"],
        data["q_min"],
        data["q_max"],
        data["q_fixed"],
        n_steps=0,
    )
    basin_plot(result, ax=ax, checks=data["checks"], legend=False)
    theta = np.degrees(data["theta_II"])
    paper14 = np.where(np.asarray(data["paper14"]) > 0, data["paper14"], np.nan)
    ax.plot(
        np.sqrt(paper14),
        theta,
        color=COLORS["orange"],
        lw=1.1,
        ls=(0, (5, 1.5, 1, 1.5, 1, 1.5)),
        label="printed (14)",
        zorder=2,
    )
    ax.axhline(
        math.degrees(FIG_PHI0) / 2,
        color=COLORS["purple"],
        ls=(0, (1, 1.2)),
        lw=1.2,
        label=r"printed (17): $\theta_{\mathrm{II}} = \varphi_0/2$",
        zorder=2,
    )
    return ax.get_legend_handles_labels()


_HEIGHTS = {"fig5": 3.4, "fig6": 3.4, "fig7": 3.4, "fig8": 3.2, "fig9": 4.6}
"""Figure heights in inches (all one column wide), legend below included."""


def draw_figure(name: str, figure_data: dict[str, Any]) -> Any:
    """One of the audit's figures as a matplotlib Figure (not saved).

    Parameters
    ----------
    name : str
        One of :data:`FIGURES`.
    figure_data : dict
        ``Audit.figure_data``: ``fig8`` (closed-form instants) for Fig. 8, ``basin``
        (basin and edge checks) for Fig. 9; Fig. 5-7 need nothing from it.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from vsw.plots import plotstyle

    with plotstyle.context():
        fig, ax = plotstyle.new_figure(plotstyle.COLUMN_WIDTH, _HEIGHTS[name])
        if name == "fig8":
            handles, labels = _fig8(ax, figure_data["fig8"])
        elif name == "fig9":
            handles, labels = _fig9(ax, figure_data["basin"])
        else:
            handles, labels = {"fig5": _fig5, "fig6": _fig6, "fig7": _fig7}[name](ax)
        plotstyle.figure_legend(fig, handles, labels, ncols=2)
    return fig


def write_figures(out: Path, figure_data: dict[str, Any]) -> list[Path]:
    """Draw Fig. 5-9 into ``out`` as PNG, SVG and PDF.

    Parameters
    ----------
    out : Path
        Existing output directory.
    figure_data : dict
        ``Audit.figure_data`` (Fig. 8 instants, Fig. 9 basin and edge checks).

    Returns
    -------
    list of Path
        The written files, in order.
    """
    from vsw.plots.figures import save_figure

    written = []
    for name in FIGURES:
        fig = draw_figure(name, figure_data)
        for ext in FORMATS:
            written.append(save_figure(fig, out / f"{name}.{ext}"))
    return written
