"""matplotlib figures: phase portrait (Fig. 8), time series, convergence of q, basin (Fig. 9).

matplotlib is imported lazily. Figures are built with ``matplotlib.figure.Figure`` (no
pyplot state, no GUI backend); :func:`save_figure` writes PNG/SVG/PDF without dates or
version strings and with a fixed SVG hash salt so the same figure gives the same bytes.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from generated import ile
from vsw.analysis import analyze
from vsw.errors import VswInputError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from vsw.basin import Basin

__all__ = [
    "SAVE_FORMATS",
    "basin_plot",
    "convergence_plot",
    "phase_portrait",
    "save_figure",
    "time_series",
]

SAVE_FORMATS = ("png", "svg", "pdf")


def _axes(ax: Axes | None, figsize: tuple[float, float] = (6.0, 4.0)) -> tuple[Figure, Axes]:
    """The given axes and its figure, or a new figure with one axes (no pyplot)."""
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.add_subplot()


def phase_portrait(
    beta: float,
    theta_II: float,
    phi0: float,
    q: float | None = None,
    ax: Axes | None = None,
    n_points: int = 400,
) -> Figure:
    """Phase portrait (theta, omega) of one step with instants I-IV marked (paper's Fig. 8).

    Drawn from the energy integrals of the two swing phases and the resets (3), (6).

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
    ax.plot(theta_1, omega_1, color="C0", label="swing I-II (leg beta r_e)")
    ax.plot(theta_2, omega_2, color="C1", label="swing III-IV (leg r_e)")
    ax.plot([theta_II, theta_II], [omega_II, omega_III], "k--", lw=1, label="leg extension")
    ax.plot([theta_IV, theta_I], [omega_IV, omega_I_next], "k:", lw=1, label="heelstrike")
    points = {
        "I": (theta_I, math.sqrt(q)),
        "II": (theta_II, omega_II),
        "III": (theta_II, omega_III),
        "IV": (theta_IV, omega_IV),
    }
    for label, (x, y) in points.items():
        ax.plot([x], [y], "ko", ms=4)
        ax.annotate(label, (x, y), textcoords="offset points", xytext=(5, 5))
    ax.set_xlabel("theta [rad]")
    ax.set_ylabel("omega [sqrt(g/r_e)]")
    ax.set_title(
        f"beta={beta:g}, theta_II={math.degrees(theta_II):g} deg, phi0={math.degrees(phi0):g} deg"
    )
    ax.legend(loc="best", fontsize="small")
    return fig


def time_series(result: Any, ax: Axes | None = None) -> Figure:
    """theta and omega against time over the simulated steps.

    Parameters
    ----------
    result : vsw.simulate.SimulationResult
        Needs ``t``, ``theta``, ``omega`` (shape (n,)) and ``events``.
    ax : matplotlib Axes, optional
        theta on this axes, omega on a twin axes.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _axes(ax, figsize=(8.0, 4.0))
    t = np.asarray(result.t)
    ax.plot(t, np.asarray(result.theta), color="C0", label="theta")
    ax.set_xlabel("tau [sqrt(r_e/g)]")
    ax.set_ylabel("theta [rad]", color="C0")
    twin = ax.twinx()
    twin.plot(t, np.asarray(result.omega), color="C1", label="omega")
    twin.set_ylabel("omega [sqrt(g/r_e)]", color="C1")
    for kind, t_event, *_ in getattr(result, "events", []):
        if kind == "I":
            ax.axvline(t_event, color="0.8", lw=0.8, zorder=0)
    ax.set_title(f"{len(result.q) - 1} steps, ended: {result.ended}")
    return fig


def convergence_plot(
    beta: float,
    theta_II: float,
    phi0: float,
    q0: float,
    steps: int,
    result: Any = None,
    ax: Axes | None = None,
) -> Figure:
    """q after each heelstrike from a perturbed start, by the stride map (and simulation).

    Parameters
    ----------
    beta, theta_II, phi0 : float
    q0 : float
        Initial q.
    steps : int
        Map iterations to draw.
    result : vsw.simulate.SimulationResult, optional
        Its ``q`` (shape (k,)) is overlaid as markers.
    ax : matplotlib Axes, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    q_map = [float(q0)]
    for _ in range(steps):
        q_map.append(float(ile.stride_map(beta, theta_II, phi0, q_map[-1])))
    q_fixed = float(ile.q_fixed(beta, theta_II, phi0))
    fig, ax = _axes(ax)
    ax.plot(np.arange(steps + 1), q_map, "-", color="C0", label="stride map (9)")
    if result is not None:
        ax.plot(np.arange(len(result.q)), result.q, "o", color="C1", ms=4, label="simulation")
    ax.axhline(q_fixed, color="k", ls="--", lw=1, label="q^f (10)")
    ax.set_xlabel("step n")
    ax.set_ylabel("q = omega_I^2")
    ax.legend(loc="best", fontsize="small")
    return fig


def basin_plot(result: Basin, ax: Axes | None = None, variable: str = "omega") -> Figure:
    """The basin of attraction against theta_II (paper's Fig. 9).

    Parameters
    ----------
    result : vsw.basin.Basin
    ax : matplotlib Axes, optional
    variable : {'omega', 'q'}
        Horizontal axis: omega_I (as in the paper) or q = omega_I^2.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if variable not in ("omega", "q"):
        raise VswInputError(f"variable = {variable!r} must be 'omega' or 'q'")
    with np.errstate(invalid="ignore"):
        transform = np.sqrt if variable == "omega" else np.asarray
        low, high = transform(result.q_min), transform(result.q_max)
        fixed = transform(result.q_fixed)
    theta_deg = np.degrees(result.theta_II)
    fig, ax = _axes(ax)
    ax.fill_betweenx(theta_deg, low, high, color="C0", alpha=0.3, lw=0, label="basin")
    ax.plot(low, theta_deg, color="C0", lw=1, label="fall backward below")
    ax.plot(high, theta_deg, color="C3", lw=1, label="lift-off above")
    ax.plot(fixed, theta_deg, "k--", lw=1, label="fixed point")
    ax.set_xlabel("omega_I [sqrt(g/r_e)]" if variable == "omega" else "q = omega_I^2")
    ax.set_ylabel("theta_II [deg]")
    ax.set_title(f"beta={result.beta:g}, phi0={math.degrees(result.phi0):g} deg")
    ax.legend(loc="best", fontsize="small")
    return fig


def check_save_path(path: str | Path) -> Path:
    """Validate an output path before any work: it can be written as a figure file.

    Checks a known suffix, an existing parent directory, that the path is not a
    directory, and that the file can be opened for writing (it is opened without
    truncation and closed; a file that did not exist is removed again), so that a
    read-only or virtual file system (``/proc``, ``/sys``) fails here and not after
    the computation.

    Raises
    ------
    VswInputError
        One line naming the path and what is wrong.
    """
    import os  # here, not at the top: this function is the only user

    text = str(path)
    if not text.strip():
        raise VswInputError(
            f"plot file name is empty: give a path ending in "
            f"{', '.join('.' + s for s in SAVE_FORMATS)}"
        )
    path = Path(path)
    suffix = path.suffix.lower().lstrip(".")
    if suffix not in SAVE_FORMATS:
        raise VswInputError(
            f"plot file {text!r} must end in one of {', '.join('.' + s for s in SAVE_FORMATS)}"
        )
    parent = path.parent
    if not parent.is_dir():
        raise VswInputError(f"plot file {text!r}: directory {str(parent)!r} does not exist")
    if path.is_dir():
        raise VswInputError(f"plot file {text!r} is a directory")
    existed = os.path.lexists(path)
    try:
        # O_NONBLOCK: a FIFO without a reader fails at once instead of blocking.
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_NONBLOCK, 0o666)
    except OSError as exc:
        raise VswInputError(f"plot file {text!r} cannot be written: {exc.strerror}") from None
    os.close(fd)
    if not existed:
        path.unlink(missing_ok=True)
    return path


def save_figure(fig: Figure, path: str | Path, dpi: int = 120) -> Path:
    """Save deterministically (no dates, no software version, fixed SVG ids).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
        Ending in .png, .svg or .pdf in an existing directory.
    dpi : int

    Returns
    -------
    Path
    """
    import matplotlib

    path = check_save_path(path)
    fmt = path.suffix.lower().lstrip(".")
    metadata = {
        "png": {"Software": None},
        "svg": {"Date": None, "Creator": None},
        "pdf": {"CreationDate": None, "ModDate": None, "Creator": None, "Producer": None},
    }[fmt]
    with matplotlib.rc_context({"svg.hashsalt": "vsw", "svg.fonttype": "path"}):
        fig.savefig(path, format=fmt, dpi=dpi, metadata=metadata)
    return path
