"""The ILE's figures: phase portrait (Fig. 8), simulation, convergence of q, basin (Fig. 9),
and the closed-form outputs along a parameter (``vsw sweep --plot``).

matplotlib is imported lazily. Figures are built with ``matplotlib.figure.Figure`` (no
pyplot state, no GUI backend) in the style of :mod:`vsw.plots.plotstyle` (the same as the
audit's figures): sized for a journal column, mathtext labels with units, colour-blind-safe
colours with distinct markers, legends outside the data; :func:`vsw.plots.figures.save_figure`
writes them.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from generated import ile
from vsw.models.ile.analysis import analyze
from vsw.plots import plotstyle
from vsw.plots.plotstyle import COLORS, DEG, LABELS
from vsw.runtime.errors import VswInputError

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from vsw.models.ile.basin import Basin, EdgeCheck

__all__ = [
    "basin_plot",
    "convergence_plot",
    "phase_portrait",
    "simulation_plot",
    "time_series",
]

ENDED = {
    "completed": "completed",
    "fell-backward": "falls backward (14)",
    "lift-off": "stance foot lifts off",
}
"""How a simulation's end (``SimulationResult.ended``) is named in figures."""


def _axes(ax: Axes | None, width: float = plotstyle.COLUMN_WIDTH, height: float | None = None):
    """The given axes and its figure, or a new styled figure with one axes (no pyplot)."""
    if ax is not None:
        return ax.figure, ax
    return plotstyle.new_figure(width, height)


def _break_at_resets(t: np.ndarray, *ys: np.ndarray) -> tuple[np.ndarray, ...]:
    """Insert NaN between samples at the same time (a reset) so lines do not jump."""
    t = np.asarray(t, float)
    cut = np.flatnonzero(np.diff(t) == 0) + 1
    return tuple(np.insert(np.asarray(y, float), cut, np.nan) for y in (t, *ys))


_INSTANT_OFFSETS = {
    # (dx, dy) points, horizontal and vertical alignment: labels clear of the curves
    # and inside the frame (IV sits at the top right of the cycle).
    "I": ((-5, 3), "right", "bottom"),
    "II": ((6, -2), "left", "top"),
    "III": ((-5, -3), "right", "top"),
    "IV": ((-5, 3), "right", "bottom"),
}


def label_instants(ax: Axes, points: dict[str, tuple[float, float]], **marker: Any) -> None:
    """Mark instants I-IV (x, y in data units) with open circles and their names."""
    style = {"marker": "o", "ms": 5, "mfc": "white", "mec": COLORS["black"], "mew": 0.9}
    style.update(marker)
    for name, (x, y) in points.items():
        ax.plot([x], [y], ls="none", zorder=5, **style)
        offset, ha, va = _INSTANT_OFFSETS.get(name, ((4, 4), "left", "bottom"))
        ax.annotate(name, (x, y), xytext=offset, textcoords="offset points", ha=ha, va=va, zorder=6)


@plotstyle.styled
def phase_portrait(
    beta: float,
    theta_II: float,
    phi0: float,
    q: float | None = None,
    ax: Axes | None = None,
    n_points: int = 400,
) -> Figure:
    """Phase portrait (theta, omega) of one step with instants I-IV marked (paper's Fig. 8).

    Drawn from the energy integrals of the two swing phases and the resets (3), (6), with
    arrows in the direction of motion; theta in degrees.

    Parameters
    ----------
    beta, theta_II, phi0 : float
        Parameters (rad).
    q : float, optional
        q = omega_I^2 at instant I; default the fixed point (a closed gait cycle).
    ax : matplotlib Axes, optional
    n_points : int
        Points per swing phase.

    Returns
    -------
    matplotlib.figure.Figure
    """
    a = analyze(beta, theta_II, phi0)
    q = float(a.q_fixed) if q is None else float(q)
    theta_I, theta_IV = float(a.theta_I), float(a.theta_IV)
    with np.errstate(invalid="ignore"):
        theta_1 = np.linspace(theta_I, theta_II, n_points)
        omega_1 = np.sqrt(q + (2 / beta) * (math.cos(theta_I) - np.cos(theta_1)))
        omega_II = omega_1[-1]
        omega_III = float(ile.extension_reset(beta, omega_II))
        theta_2 = np.linspace(theta_II, theta_IV, n_points)
        omega_2 = np.sqrt(omega_III**2 + 2 * (math.cos(theta_II) - np.cos(theta_2)))
        omega_IV = omega_2[-1]
        omega_I_next = float(ile.heelstrike_reset(beta, phi0, omega_IV))
    fig, ax = _axes(ax)
    deg = np.degrees
    blue, verm, black = COLORS["blue"], COLORS["vermillion"], COLORS["black"]
    ax.plot(deg(theta_1), omega_1, color=blue, label=r"swing I$\to$II, leg $\beta r_e$ (2)")
    ax.plot(deg(theta_2), omega_2, color=verm, ls="-.", label=r"swing III$\to$IV, leg $r_e$ (4)")
    ext = ([deg(theta_II)] * 2, [omega_II, omega_III])
    hs = (deg([theta_IV, theta_I]), [omega_IV, omega_I_next])
    ax.plot(*ext, color=black, ls="--", lw=0.9, label="leg extension (3)")
    ax.plot(*hs, color=black, ls=":", lw=0.9, label="heelstrike (6)")
    ax.margins(x=0.08, y=0.1)
    for (x, y), color in (
        ((deg(theta_1), omega_1), blue),
        ((deg(theta_2), omega_2), verm),
        (ext, black),
        (hs, black),
    ):
        plotstyle.direction_arrow(ax, x, y, color)
    label_instants(
        ax,
        {
            "I": (deg(theta_I), math.sqrt(q)),
            "II": (deg(theta_II), omega_II),
            "III": (deg(theta_II), omega_III),
            "IV": (deg(theta_IV), omega_IV),
        },
    )
    ax.set_xlabel(LABELS["theta_deg"])
    ax.set_ylabel(LABELS["omega"])
    ax.set_title(plotstyle.params_title(beta, theta_II, phi0))
    plotstyle.legend_outside(ax)
    return fig


def _outcome_x(result: Any) -> float | None:
    """Time of the end of a simulation that did not complete (None if it completed)."""
    if result.ended == "completed" or len(result.t) == 0:
        return None
    return float(np.asarray(result.t)[-1])


@plotstyle.styled
def time_series(result: Any, ax: Axes | None = None, ax_omega: Axes | None = None) -> Figure:
    """theta (degrees) and omega against time over the simulated steps.

    Lines break at the resets (extension, heelstrike); thin vertical lines mark the
    heelstrikes, and a run that did not complete is marked where it ended.

    Parameters
    ----------
    result : vsw.models.ile.simulate.SimulationResult
        Needs ``t``, ``theta``, ``omega`` (shape (n,)), ``events`` and ``ended``.
    ax, ax_omega : matplotlib Axes, optional
        Axes for theta and for omega. Without either, a new figure with both stacked
        (shared time axis); with ``ax`` alone, omega goes on a twin axes of ``ax``.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if ax is None:
        fig, (ax, ax_omega) = plotstyle.new_figure(plotstyle.PAGE_WIDTH, 3.6, nrows=2, sharex=True)
    else:
        fig = ax.figure
    twin = ax_omega is None
    if twin:
        ax_omega = ax.twinx()
        ax_omega.grid(False)
        ax_omega.spines["right"].set_visible(True)
    t, theta, omega = _break_at_resets(result.t, np.degrees(result.theta), result.omega)
    theta_color = COLORS["blue"]
    omega_color = COLORS["vermillion"] if twin else COLORS["blue"]
    ax.plot(t, theta, color=theta_color, lw=1.0)
    ax_omega.plot(t, omega, color=omega_color, lw=1.0, ls="-" if not twin else "-.")
    ax.set_ylabel(LABELS["theta_deg"], color=theta_color if twin else COLORS["black"])
    ax_omega.set_ylabel(LABELS["omega"], color=omega_color if twin else COLORS["black"])
    (ax_omega if not twin else ax).set_xlabel(LABELS["tau"])
    for kind, t_event, *_ in getattr(result, "events", []):
        if kind == "I" and t_event > 0:
            for a in {ax, ax_omega}:
                a.axvline(t_event, color=COLORS["light_grey"], lw=0.6, zorder=0)
    end = _outcome_x(result)
    if end is not None:
        for a in {ax, ax_omega}:
            a.axvline(end, color=COLORS["vermillion"], ls="--", lw=1.0)
        # Above the frame, so the label covers no data.
        ax.annotate(
            ENDED.get(result.ended, result.ended),
            (end, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(0, 2),
            textcoords="offset points",
            ha="right",
            va="bottom",
            color=COLORS["vermillion"],
        )
    return fig


def _map_iterates(
    beta: float, theta_II: float, phi0: float, q0: float, steps: int
) -> tuple[np.ndarray, str]:
    """q_0 .. q_k of the stride map (9) over the steps the walker completes, and the end.

    Step n + 1 starts from q_n and completes only if q_apex_min < q_n <= q_liftoff_max:
    below, the walker falls backward (14); above, the stance foot lifts off. The
    iteration stops at the first q_k outside that interval (step k + 1 fails) or after
    ``steps`` steps.

    Returns
    -------
    (numpy.ndarray, str)
        The iterates, and ``'completed'``, ``'fell-backward'`` or ``'lift-off'``.
    """
    lo = float(ile.q_apex_min(beta, theta_II, phi0))
    hi = float(ile.q_liftoff_max(beta, theta_II, phi0))
    qs = [float(q0)]
    while len(qs) <= steps and lo < qs[-1] <= hi:
        qs.append(float(ile.stride_map(beta, theta_II, phi0, qs[-1])))
    if len(qs) == steps + 1:
        ended = "completed"
    else:
        ended = "lift-off" if qs[-1] > hi else "fell-backward"
    return np.asarray(qs), ended


@plotstyle.styled
def convergence_plot(
    beta: float,
    theta_II: float,
    phi0: float,
    q0: float,
    steps: int,
    result: Any = None,
    ax: Axes | None = None,
    legend: bool = True,
) -> Figure:
    """q after each heelstrike from a perturbed start, by the stride map (and simulation).

    The map is drawn only over the steps the walker completes: up to the last completed
    step of ``result`` when given, else while q stays in the feasible interval
    (q_apex_min, q_liftoff_max]. A step that ends in a fall or lift-off is marked.

    Parameters
    ----------
    beta, theta_II, phi0 : float
    q0 : float
        Initial q.
    steps : int
        Steps asked for (the horizontal axis spans them).
    result : vsw.models.ile.simulate.SimulationResult, optional
        Its ``q`` (shape (k,)) is overlaid as markers; its ``ended`` marks the failure.
    ax : matplotlib Axes, optional
    legend : bool
        Add the legend (outside the axes).

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.ticker import MaxNLocator

    q_map, ended = _map_iterates(beta, theta_II, phi0, q0, steps)
    if result is not None:
        # The simulation is the authority on when the walker failed.
        q_map = q_map[: len(result.q)]
        ended = result.ended
    own = ax is None
    fig, ax = _axes(ax)
    _draw_convergence(ax, float(ile.q_fixed(beta, theta_II, phi0)), q_map, result)
    if ended != "completed":
        _draw_failure(ax, (beta, theta_II, phi0), ended, len(q_map))
    ax.set_xlim(-0.5, steps + 0.5)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel(LABELS["step"])
    ax.set_ylabel(LABELS["q"])
    if own:
        ax.set_title(plotstyle.params_title(beta, theta_II, phi0, q_0=q0))
    if legend:
        plotstyle.legend_outside(ax, where="below" if own else "right")
    return fig


def _draw_convergence(ax: Axes, q_fixed: float, q_map: np.ndarray, result: Any) -> None:
    """The fixed point, the stride map's iterates and the simulated q (with ``result``)."""
    ax.axhline(q_fixed, color=COLORS["black"], ls="--", lw=0.9, label=r"fixed point $q^f$ (10)")
    ax.plot(
        np.arange(len(q_map)),
        q_map,
        "-",
        color=COLORS["blue"],
        marker="s",
        ms=2.5,
        label="stride map (9)",
    )
    if result is not None:
        ax.plot(
            np.arange(len(result.q)),
            result.q,
            ls="none",
            marker="o",
            ms=5,
            mfc="none",
            mec=COLORS["vermillion"],
            mew=1.0,
            label="simulation",
        )


def _draw_failure(ax: Axes, params: tuple[float, float, float], ended: str, fail: int) -> None:
    """Where a walk that did not complete failed: in step ``fail``, past which bound."""
    if ended in ("fell-backward", "lift-off"):
        # The bound the last state crossed, so the reader sees why the step failed.
        bound, name = (
            (ile.q_apex_min, "fall threshold (14)")
            if ended == "fell-backward"
            else (ile.q_liftoff_max, "lift-off threshold")
        )
        ax.axhline(
            float(bound(*params)),
            color=COLORS["vermillion"],
            ls="-.",
            lw=0.9,
            label=name,
        )
    # q_k is the last state reached; step k + 1 ends without a heelstrike.
    ax.axvline(
        fail,
        color=COLORS["vermillion"],
        ls=":",
        lw=1.2,
        label=f"{ENDED.get(ended, ended)}: step {fail}",
    )


@plotstyle.styled
def simulation_plot(
    beta: float, theta_II: float, phi0: float, q0: float, steps: int, result: Any
) -> Figure:
    """The ``vsw simulate --plot`` figure: theta and omega against time, q per step.

    Parameters
    ----------
    beta, theta_II, phi0 : float
        Parameters (rad).
    q0 : float
        Initial q.
    steps : int
        Steps asked for.
    result : vsw.models.ile.simulate.SimulationResult
        Recorded run (``simulate(..., record=True)``).

    Returns
    -------
    matplotlib.figure.Figure
        Three panels; the title names the parameters and how the run ended.
    """
    fig, axes = plotstyle.new_figure(
        plotstyle.PAGE_WIDTH, 5.6, nrows=3, height_ratios=(1.0, 1.0, 1.15)
    )
    ax_theta, ax_omega, ax_q = axes
    ax_omega.sharex(ax_theta)
    ax_theta.tick_params(labelbottom=False)
    time_series(result, ax=ax_theta, ax_omega=ax_omega)
    convergence_plot(beta, theta_II, phi0, q0, steps, result=result, ax=ax_q, legend=False)
    plotstyle.figure_legend(fig, *ax_q.get_legend_handles_labels(), ncols=5)
    done = len(result.q) - 1
    outcome = ENDED.get(result.ended, result.ended)
    fig.suptitle(
        plotstyle.params_title(beta, theta_II, phi0, q_0=q0)
        + f" \u2014 {done} of {steps} steps, {outcome}"
    )
    return fig


_NO_GAIT_REASONS = {
    # condition name: (short form, explanation) of why no gait exists
    "extension_reached": (
        r"$\theta_{\mathrm{II}} \leq \theta_{\mathrm{I}}$",
        "the leg never extends",
    ),
    "extension_before_heelstrike": (
        r"$\theta_{\mathrm{II}} \geq \theta_{\mathrm{IV}}$",
        "heelstrike comes first",
    ),
    "q_positive": (r"$q^f \leq 0$ (12)", "no fixed point"),
    "apex": ("(14) fails at $q^f$", "the fixed point falls backward"),
    "stance_contact": ("lift-off at $q^f$", "the stance foot lifts off"),
    "phi0_below_right_angle": (r"$\varphi_0 \geq 90$" + DEG + " (16)", "no forward motion"),
}


def _no_gait_runs(result: Basin) -> list[tuple[float, float, tuple[str, str]]]:
    """Contiguous theta_II ranges (deg) without a basin and why: (short, explanation)."""
    theta = np.degrees(result.theta_II)
    none = ~(np.isfinite(result.q_min) & np.isfinite(result.q_max))
    edges = np.flatnonzero(np.diff(np.r_[0, none.astype(int), 0]))
    runs = []
    for a, b in zip(edges[::2], edges[1::2]):
        # Each run reaches halfway to the neighbouring grid values that have a gait.
        low = theta[a] if a == 0 else 0.5 * (theta[a - 1] + theta[a])
        high = theta[b - 1] if b == theta.size else 0.5 * (theta[b - 1] + theta[b])
        mid = result.theta_II[(a + b - 1) // 2]
        failing = [
            c.name
            for c in analyze(result.beta, mid, result.phi0, timing=False).conditions
            if c.physical and not bool(c.holds)
        ]
        # The first failing condition in the table's order names the range.
        reason = _NO_GAIT_REASONS.get(failing[0], (failing[0], "")) if failing else ("", "")
        runs.append((float(low), float(high), reason))
    return runs


@plotstyle.styled
def basin_plot(
    result: Basin,
    ax: Axes | None = None,
    variable: str = "omega",
    checks: Sequence[EdgeCheck] | None = None,
    legend: bool = True,
) -> Figure:
    """The basin of attraction against theta_II (paper's Fig. 9).

    The basin is the shaded interval between its left edge (below it the walker falls
    backward, exact (14)) and its right edge (beyond it the stance foot lifts off); the
    theta_II ranges of the grid without a gait are shaded grey and named, not cropped.

    Parameters
    ----------
    result : vsw.models.ile.basin.Basin
    ax : matplotlib Axes, optional
    variable : {'omega', 'q'}
        Horizontal axis: omega_I (as in the paper) or q = omega_I^2.
    checks : sequence of vsw.models.ile.basin.EdgeCheck, optional
        Simulations next to the edges (:func:`vsw.models.ile.basin.check_edges_by_simulation`):
        open circles just inside (converge), crosses just outside (fail), drawn so that
        neither hides the other; a check that failed is a filled diamond.
    legend : bool
        Add the legend (outside the axes); False lets a caller add curves first.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if variable not in ("omega", "q"):
        raise VswInputError(f"variable = {variable!r} must be 'omega' or 'q'")
    transform = np.sqrt if variable == "omega" else np.asarray
    with np.errstate(invalid="ignore"):
        low, high = transform(result.q_min), transform(result.q_max)
        fixed = transform(result.q_fixed)
    theta_deg = np.degrees(result.theta_II)
    fig, ax = _axes(ax, height=4.3)
    x_max = _draw_basin(ax, theta_deg, low, high, fixed)
    _draw_no_gait(ax, _no_gait_runs(result), theta_deg, low, high, x_max)
    if checks:
        _draw_edge_checks(ax, checks, transform)
    ax.set_xlabel(LABELS["omega_I"] if variable == "omega" else LABELS["q"])
    ax.set_ylabel(LABELS["theta_II_deg"])
    ax.set_title(plotstyle.params_title(result.beta, None, result.phi0))
    if legend:
        plotstyle.legend_outside(ax)
    return fig


def _draw_basin(
    ax: Axes, theta_deg: np.ndarray, low: np.ndarray, high: np.ndarray, fixed: np.ndarray
) -> float:
    """The basin between its edges and the fixed point against theta_II, the axes' limits
    set; returns the right limit."""
    ax.fill_betweenx(
        theta_deg, low, high, color=COLORS["sky_blue"], alpha=0.35, lw=0, label="basin", zorder=1
    )
    ax.plot(low, theta_deg, color=COLORS["blue"], label="left edge: falls backward (14)", zorder=3)
    ax.plot(
        high,
        theta_deg,
        color=COLORS["vermillion"],
        ls="-.",
        label="right edge: foot lifts off",
        zorder=3,
    )
    ax.plot(fixed, theta_deg, color=COLORS["black"], ls="--", lw=1.0, label="fixed point $q^f$")
    x_max = 1.08 * float(np.nanmax(high)) if np.isfinite(high).any() else 1.0
    ax.set_xlim(0.0, x_max)
    y_low, y_high = float(theta_deg.min()), float(theta_deg.max())
    if y_high == y_low:  # one theta_II row: a band of one degree around it
        y_low, y_high = y_low - 0.5, y_high + 0.5
    ax.set_ylim(y_low, y_high)
    return x_max


def _draw_no_gait(
    ax: Axes,
    runs: list[tuple[float, float, tuple[str, str]]],
    theta_deg: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    x_max: float,
) -> None:
    """The theta_II ranges without a gait (:func:`_no_gait_runs`) as grey bands, each
    named where it is tall enough."""
    y_span = float(np.ptp(theta_deg)) or 1.0
    grid_step = float(np.median(np.abs(np.diff(theta_deg)))) if theta_deg.size > 1 else 1.0
    for k, (low_deg, high_deg, reason) in enumerate(runs):
        ax.axhspan(
            low_deg,
            high_deg,
            color=COLORS["light_grey"],
            lw=0,
            zorder=0,
            label="no gait" if k == 0 else None,
        )
        # Named inside the band where it is tall enough for a line of text, on the side
        # away from the basin's edges next to it (their markers sit on the band's border).
        short, why = reason
        height = (high_deg - low_deg) / y_span
        text = "no gait" + (f": {short}" if short else "")
        if height > 0.08 and why:
            text += f"\n({why})"
        if height > 0.025:
            gap = np.abs(theta_deg - np.clip(theta_deg, low_deg, high_deg))
            near = gap <= 2.0 * grid_step
            near &= np.isfinite(low) & np.isfinite(high)
            left_free = float(np.min(low[near])) if near.any() else x_max
            right_free = x_max - float(np.max(high[near])) if near.any() else x_max
            # Right of the basin when there is room: overlays (e.g. the printed bound)
            # tend to continue the left edge into the band.
            right = right_free >= 0.1 * x_max or right_free > left_free
            ax.text(
                0.98 * x_max if right else 0.02 * x_max,
                0.5 * (low_deg + high_deg),
                text,
                va="center",
                ha="right" if right else "left",
                fontsize=plotstyle.FONT_SIZE - 1,
                linespacing=1.1,
                zorder=2,
            )


def _draw_edge_checks(ax: Axes, checks: Sequence[EdgeCheck], transform: Any) -> None:
    """Edge checks: inside (open circles) under outside (crosses); failures on top."""
    groups = {
        "inside": ([c for c in checks if c.side == "inside" and c.ok], 4),
        "outside": ([c for c in checks if c.side == "outside" and c.ok], 5),
        "failed": ([c for c in checks if not c.ok], 6),
    }
    styles = {
        "inside": {"marker": "o", "ms": 6, "mfc": "none", "mec": COLORS["green"], "mew": 1.1},
        "outside": {"marker": "x", "ms": 4, "mec": COLORS["black"], "mew": 0.9},
        "failed": {"marker": "D", "ms": 5, "mfc": COLORS["vermillion"], "mec": COLORS["black"]},
    }
    labels = {
        "inside": "simulated inside: converges",
        "outside": "simulated outside: falls / lifts off",
        "failed": "simulation disagrees with the edge",
    }
    for key, (group, z) in groups.items():
        if not group:
            continue
        x = transform(np.array([c.q0 for c in group]))
        y = np.degrees([c.theta_II for c in group])
        ax.plot(x, y, ls="none", zorder=z, label=labels[key], clip_on=False, **styles[key])


_ILE_PANELS = (
    ("q_fixed", r"$q^f$ [$g/r_e$]"),
    ("eigenvalue", r"eigenvalue $\lambda$"),
    ("speed", r"speed [$\sqrt{g r_e}$]"),
)


@plotstyle.styled
def ile_sweep_plot(data: Mapping[str, Any], xlabel: str, title: str) -> Figure:
    """The ILE's fixed point q^f (10), eigenvalue (20) and speed along the swept
    parameter over the whole swept range; where no gait exists (a condition fails) the
    range is shaded and named in the legend below. ``title``: the fixed parameters with
    units (:func:`vsw.plots.plotstyle.parameter_text`)."""
    over = data["over"]
    points: Sequence[Mapping[str, Any]] = data["points"]
    fig, axes = plotstyle.new_figure(
        width=plotstyle.COLUMN_WIDTH, height=1.5 * plotstyle.COLUMN_WIDTH, nrows=3,
        sharex=True,
    )  # fmt: skip
    xs = np.array([p[over] for p in points], dtype=float)
    for ax, (field, label) in zip(axes, _ILE_PANELS):
        values = np.array(
            [np.nan if not p.get("walks") or p.get(field) is None else p[field] for p in points],
            dtype=float,
        )
        values[~np.isfinite(values)] = np.nan
        ax.plot(xs, values, "-", color=COLORS["blue"], marker="none")
        ax.set_ylabel(label)
    axes[1].axhline(1.0, color=COLORS["grey"], linewidth=0.8)
    axes[1].axhline(-1.0, color=COLORS["grey"], linewidth=0.8)
    walks = np.array([bool(p.get("walks")) for p in points])
    spans = _runs(xs, ~walks)
    for ax in axes:
        for low, high in spans:
            ax.axvspan(low, high, color=COLORS["light_grey"], linewidth=0, zorder=0)
        if len(xs):
            ax.set_xlim(float(np.min(xs)), float(np.max(xs)))
    if spans:
        from matplotlib.patches import Patch

        plotstyle.figure_legend(fig, [Patch(color=COLORS["light_grey"])],
                                ["no gait (a condition of the closed form fails)"])  # fmt: skip
    fig.suptitle(title, x=0.02, ha="left", fontsize="medium")
    axes[-1].set_xlabel(xlabel)
    return fig


def _runs(xs: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    """The x ranges of consecutive True points of ``mask``, each widened to halfway to its
    neighbours (a single point is a band, not a line)."""
    spans, k = [], 0
    while k < len(xs):
        if not mask[k]:
            k += 1
            continue
        start = k
        while k + 1 < len(xs) and mask[k + 1]:
            k += 1
        low = xs[start] if start == 0 else 0.5 * (xs[start - 1] + xs[start])
        high = xs[k] if k == len(xs) - 1 else 0.5 * (xs[k] + xs[k + 1])
        spans.append((float(low), float(high)))
        k += 1
    return spans
