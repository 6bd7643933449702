"""One figure style for the CLI plots (:mod:`vsw.models.ile.plots`) and the audit's figures.

Everything a figure looks like is decided here: sizes for a journal column, font sizes
that stay readable at that width, a colour-blind-safe palette (Okabe & Ito) with marker
shapes that differ too, axis labels in mathtext with units, legends outside the data, and
deterministic files (PNG at :data:`PNG_DPI`, SVG, PDF with TrueType fonts).

The style is a matplotlib rc context applied around drawing and saving
(:func:`context`, :func:`styled`); nothing here changes the global ``rcParams``, and
matplotlib is imported only inside the functions, so importing this module is cheap.
"""

from __future__ import annotations

import contextlib
import functools
import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend

__all__ = [
    "COLORS",
    "COLUMN_WIDTH",
    "CYCLE",
    "DEG",
    "LABELS",
    "MARKERS",
    "PAGE_WIDTH",
    "PNG_DPI",
    "RC",
    "SAVE_METADATA",
    "context",
    "curve_style",
    "direction_arrow",
    "figure_legend",
    "legend_outside",
    "mark_off_scale",
    "new_figure",
    "parameter_symbol",
    "parameter_text",
    "params_title",
    "raw_names",
    "settle_layout",
    "state_label",
    "styled",
    "unit_tex",
    "words",
]

# Okabe & Ito (2008), "Color Universal Design": distinguishable under the common colour
# vision deficiencies and in greyscale by lightness. Yellow is left out of the cycle: too
# light for thin lines on white.
COLORS = {
    "black": "#000000",
    "orange": "#E69F00",
    "sky_blue": "#56B4E9",
    "green": "#009E73",
    "yellow": "#F0E442",
    "blue": "#0072B2",
    "vermillion": "#D55E00",
    "purple": "#CC79A7",
    "grey": "#8C8C8C",
    "light_grey": "#E4E4E4",
}
CYCLE = ("blue", "vermillion", "green", "purple", "orange", "sky_blue", "black")
"""Colour order for families of curves (names of :data:`COLORS`)."""
MARKERS = ("o", "s", "^", "D", "v", "P", "X")
"""Marker shapes in the order of :data:`CYCLE`: curves differ without colour too."""

COLUMN_WIDTH = 3.5
"""Inches: one column of a two-column journal page (IEEE: 3.5 in = 88.9 mm)."""
PAGE_WIDTH = 7.16
"""Inches: the full text width of a two-column page."""
PNG_DPI = 300
"""Raster resolution for PNG (journals ask for >= 300 dpi for line art with text)."""

DEG = "\u00b0"
"""The degree sign U+00B0 (mathtext's ``^\\circ`` renders as a raised ring/dot)."""

LABELS = {
    "theta_deg": r"$\theta$ [" + DEG + "]",
    "theta_II_deg": r"$\theta_{\mathrm{II}}$ [" + DEG + "]",
    "phi0_deg": r"$\varphi_0$ [" + DEG + "]",
    "beta": r"$\beta = r_s / r_e$",
    "q": r"$q = \omega_{\mathrm{I}}^2$ [$g/r_e$]",
    "q_fixed": r"$q^f$ [$g/r_e$]",
    "omega": r"$\omega$ [$\sqrt{g/r_e}$]",
    "omega_I": r"$\omega_{\mathrm{I}} = \sqrt{q}$ [$\sqrt{g/r_e}$]",
    "tau": r"$\tau$ [$\sqrt{r_e/g}$]",
    "step": r"step $n$",
}
"""Axis labels: symbol in mathtext and its unit (model units: lengths in r_e)."""

FONT_SIZE = 8.0
"""Points at the printed size: at one column width the text matches a caption's size."""

RC: dict[str, Any] = {
    "font.family": "sans-serif",
    "font.sans-serif": ["DejaVu Sans"],
    "mathtext.fontset": "dejavusans",
    "font.size": FONT_SIZE,
    "axes.titlesize": FONT_SIZE,
    "axes.labelsize": FONT_SIZE,
    "xtick.labelsize": FONT_SIZE - 0.5,
    "ytick.labelsize": FONT_SIZE - 0.5,
    "legend.fontsize": FONT_SIZE - 0.5,
    "figure.titlesize": FONT_SIZE + 0.5,
    "axes.linewidth": 0.6,
    "lines.linewidth": 1.3,
    "lines.markersize": 4.0,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "xtick.major.size": 3.0,
    "ytick.major.size": 3.0,
    "xtick.direction": "out",
    "ytick.direction": "out",
    "axes.grid": True,
    "grid.linewidth": 0.4,
    "grid.color": "#D9D9D9",
    "axes.axisbelow": True,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.unicode_minus": True,
    "legend.frameon": False,
    "legend.handlelength": 2.4,
    "legend.columnspacing": 1.2,
    "figure.dpi": 100,
    "savefig.dpi": PNG_DPI,
    # TrueType in PDF (journals' checkers reject Type 3 fonts); text as paths in SVG so
    # the drawing does not depend on the viewer's fonts; fixed ids for identical bytes.
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "path",
    "svg.hashsalt": "vsw",
    "axes.prop_cycle": None,  # set in context(): needs matplotlib's cycler
}

SAVE_METADATA = {
    "png": {"Software": None},
    "svg": {"Date": None, "Creator": None},
    "pdf": {"CreationDate": None, "ModDate": None, "Creator": None, "Producer": None},
}
"""``savefig(metadata=...)`` per format: no dates or version strings in the files."""

F = TypeVar("F", bound=Callable[..., Any])


@contextlib.contextmanager
def context() -> Iterator[None]:
    """Apply the style (matplotlib rc context) for the drawing or saving inside."""
    import matplotlib
    from cycler import cycler

    rc = dict(RC)
    rc["axes.prop_cycle"] = cycler(color=[COLORS[c] for c in CYCLE])
    with matplotlib.rc_context(rc):
        yield


def styled(fn: F) -> F:
    """Decorator: run a drawing function inside :func:`context`."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        with context():
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]


def new_figure(
    width: float = COLUMN_WIDTH,
    height: float | None = None,
    nrows: int = 1,
    ncols: int = 1,
    **subplot_kw: Any,
) -> tuple[Figure, Any]:
    """A figure (no pyplot, constrained layout) and its axes, drawn inside :func:`context`.

    Parameters
    ----------
    width, height : float
        Inches; the height defaults to 0.75 of the width per row.
    nrows, ncols : int
    **subplot_kw
        Passed to ``Figure.subplots`` (``sharex``, ``height_ratios`` ...).

    Returns
    -------
    (Figure, Axes or array of Axes)
    """
    from matplotlib.figure import Figure

    if height is None:
        height = 0.75 * width * nrows
    with context():
        fig = Figure(figsize=(width, height), layout="constrained")
        fig.get_layout_engine().set(w_pad=0.03, h_pad=0.03, hspace=0.02, wspace=0.02)
        axes = fig.subplots(nrows, ncols, squeeze=True, **subplot_kw)
    return fig, axes


def settle_layout(
    fig: Figure, max_rounds: int = 4, tol: float = 1e-9, dpi: float | None = None
) -> None:
    """Run constrained layout to its fixed point, then freeze it (before saving).

    Each draw lays a figure out again starting from the previous positions, so a figure
    saved twice (or after a save in another format) would not give the same bytes. Here
    the layout is repeated until no axes moves by more than ``tol`` (usually two rounds)
    and then switched off: every later save of the figure draws the same positions.
    ``dpi``: lay out at the resolution the figure is saved at (text measured at 100 dpi
    is narrower than at 300, and a label laid out to fit at 100 is cut at 300).
    """
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    if not isinstance(fig.get_layout_engine(), ConstrainedLayoutEngine):
        return
    shown = fig.dpi
    if dpi is not None:
        fig.set_dpi(dpi)
    previous = None
    for _ in range(max_rounds):
        fig.draw_without_rendering()
        current = np.array([ax.get_position().bounds for ax in fig.axes])
        if previous is not None and np.max(np.abs(current - previous), initial=0.0) <= tol:
            break
        previous = current
    fig.set_layout_engine("none")
    fig.set_dpi(shown)


def curve_style(k: int) -> dict[str, Any]:
    """Colour and marker of the k-th curve of a family (cycles through :data:`CYCLE`)."""
    return {"color": COLORS[CYCLE[k % len(CYCLE)]], "marker": MARKERS[k % len(MARKERS)]}


def legend_outside(
    ax: Axes,
    handles: Sequence[Any] | None = None,
    labels: Sequence[str] | None = None,
    ncols: int = 2,
    where: str = "below",
) -> Legend:
    """A legend outside the data: below the axes' figure, or right of the axes.

    When ``ax`` is the only axes of its figure and ``where='below'``, the legend is a
    figure legend at the bottom ("outside lower center"), for which constrained layout
    makes room; it falls back to fewer columns when it would be wider than the figure.
    Otherwise (an axes in a larger figure, or ``where='right'``) it goes right of the axes.

    Parameters
    ----------
    ax : Axes
    handles, labels : sequence, optional
        Default: the axes' labelled artists.
    ncols : int
        Columns of a bottom legend (at most).
    where : {'below', 'right'}
    """
    if handles is None or labels is None:
        handles, labels = ax.get_legend_handles_labels()
    fig = ax.figure
    if where == "below" and len(fig.axes) == 1:
        return figure_legend(fig, handles, labels, ncols)
    return ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.02, 1.0), ncols=1)


def figure_legend(
    fig: Figure, handles: Sequence[Any], labels: Sequence[str], ncols: int = 2
) -> Legend:
    """A figure legend below the axes, in as many columns (<= ncols) as fit its width."""
    for n in range(max(ncols, 1), 0, -1):
        legend = fig.legend(handles, labels, loc="outside lower center", ncols=n)
        # Measured with the figure's renderer: the text extents are exact.
        if n == 1 or legend.get_window_extent().width <= 0.98 * fig.bbox.width:
            return legend
        legend.remove()
    raise AssertionError("unreachable")


def direction_arrow(
    ax: Axes,
    x: Any,
    y: Any,
    color: str,
    at: float = 0.5,
    size: float = 1.0,
    zorder: float = 4,
) -> None:
    """An arrowhead on the polyline (x, y) at fraction ``at`` of its length.

    The head is drawn along a short chord of the polyline in data coordinates, so it
    follows the curve whatever the final layout and aspect; ``size`` scales the head
    (1: about 6 pt long). The length fraction is measured in axes-fraction space.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    if x.size < 2:
        return
    pts = ax.transLimits.transform(np.column_stack([x, y]))
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(pts, axis=0).T))]
    if not s[-1] > 0:
        return
    s /= s[-1]
    tail = (float(np.interp(at - 0.01, s, x)), float(np.interp(at - 0.01, s, y)))
    tip = (float(np.interp(at, s, x)), float(np.interp(at, s, y)))
    ax.annotate(
        "",
        xy=tip,
        xytext=tail,
        arrowprops={
            "arrowstyle": f"-|>,head_length={0.8 * size:.2f},head_width={0.35 * size:.2f}",
            "color": color,
            "lw": 0.0,
            "shrinkA": 0,
            "shrinkB": 0,
            "mutation_scale": 8,
        },
        zorder=zorder,
        annotation_clip=False,
    )


def mark_off_scale(
    ax: Axes, x: Any, y: Any, top: float, color: str, marker: str = "^", ms: float = 5.0
) -> list[float]:
    """Mark with a marker on the top edge where the curve (x, y) crosses ``y = top``.

    For curves cut by the axis limit: the marker says "continues off scale" at the
    crossing. Returns the marked x positions.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    over = (np.isfinite(y) & (y > top)).astype(int)
    crossings = np.flatnonzero(np.diff(over))
    marked = [float(0.5 * (x[i] + x[i + 1])) for i in crossings]
    if marked:
        ax.plot(
            marked,
            [top] * len(marked),
            marker=marker,
            ms=ms,
            color=color,
            ls="none",
            clip_on=False,
            zorder=4,
        )
    return marked


def fmt_angle(rad: float) -> str:
    """An angle in radians as degrees with the degree sign (4 significant digits)."""
    return f"{math.degrees(rad):.4g}{DEG}"


def params_title(beta: float, theta_II: float | None, phi0: float, **extra: float) -> str:
    """Parameters as a title: ``beta = 0.8, theta_II = 0°, phi0 = 45°`` (angles in rad).

    ``extra`` adds ``name = value`` pairs (name in mathtext, e.g. ``q_0=0.3``).
    """
    parts = [rf"$\beta$ = {beta:.4g}"]
    if theta_II is not None:
        parts.append(r"$\theta_{\mathrm{II}}$ = " + fmt_angle(theta_II))
    parts.append(r"$\varphi_0$ = " + fmt_angle(phi0))
    for name, value in extra.items():
        parts.append(f"${name}$ = {value:.4g}")
    return ", ".join(parts)


# --- labels: the models' names and units in mathtext ------------------------------------

_GREEK = {"alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota",
          "kappa", "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi",
          "chi", "psi", "omega", "Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma",
          "Phi", "Psi", "Omega"}  # fmt: skip
"""Names drawn as their Greek letter (``kappa`` as κ, not the italic letters k, a, p, ...)."""


def unit_tex(unit: str) -> str:
    """A unit of the model tables in mathtext: ``sqrt(r_e/g)`` as a root with ``r_e``
    subscripted, its letters symbols (m, g, l) and rad upright; plain SI units
    (``rad/s``, ``J``) as they are."""
    if not unit or unit == "1":
        return "1"
    if "sqrt" not in unit and "_" not in unit:
        return unit
    body = re.sub(r"sqrt\(([^)]*)\)", r"\\sqrt{\1}", unit)
    body = re.sub(r"\brad\b", r"\\mathrm{rad}", body)  # letters are symbols (m: mass)
    body = re.sub(r"_([A-Za-z0-9]+)", r"_{\1}", body).replace(" ", r"\,")
    return f"${body}$"


def _symbol(name: str) -> str:
    base, _, sub = name.partition("_")
    head = f"\\{base}" if base in _GREEK else base
    if sub:
        sub = sub if sub.isupper() else sub.replace("_", r"\_")
        return f"{head}_{{\\mathrm{{{sub}}}}}" if sub.isupper() else f"{head}_{{{sub}}}"
    return head


def state_label(name: str, unit: str) -> str:
    """``theta`` [rad] as ``$\\theta$ [rad]``, ``theta_dot`` as ``$\\dot{\\theta}$``."""
    if name.endswith("_dot"):
        symbol = f"\\dot{{{_symbol(name[: -len('_dot')])}}}"
    else:
        symbol = _symbol(name)
    return f"${symbol}$ [{unit_tex(unit)}]"


def parameter_symbol(p: Any) -> str:
    """A parameter of a model's table as its symbol in mathtext: the table's ``latex``
    (``m_h`` as ``$m_H$``), else its name as :func:`state_label` draws a name."""
    latex = getattr(p, "latex", "") or _symbol(p.name)
    # Roman-numeral subscripts upright, as state_label draws them (theta_II).
    return "$" + re.sub(r"_\{([IVX]+)\}", r"_{\\mathrm{\1}}", latex) + "$"


def words(name: str) -> str:
    """An identifier of the model file (an event's, an input's) as words: ``hip_torque``
    as ``hip torque``."""
    return name.replace("_", " ")


def _shown_length(text: str) -> int:
    """About the characters ``text`` shows: a mathtext command one character, braces,
    sub- and superscript marks and dollar signs none."""
    return len(re.sub(r"[${}_^]|\\,", "", re.sub(r"\\[A-Za-z]+", "x", text)))


def parameter_text(
    model: Any, params: Sequence[float] | Mapping[str, float], width: int = 46
) -> str:
    """The model's title and its parameters, each its symbol in mathtext with its unit
    (:func:`unit_tex`; angles also in degrees), wrapped to a column's width (in shown
    characters). ``params``: the whole vector in the table's order, or a mapping of some
    of them (a sweep's fixed ones)."""
    import textwrap

    if isinstance(params, Mapping):
        rows = [(p, params[p.name]) for p in model.parameter_table if p.name in params]
    else:
        rows = list(zip(model.parameter_table, params))
    parts = []
    for p, value in rows:
        symbol = parameter_symbol(p)
        if p.unit == "rad":
            parts.append(f"{symbol} = {value:.4g} rad ({math.degrees(value):.3g}°)")
        elif p.unit in ("", "1"):
            parts.append(f"{symbol} = {value:.4g}")
        else:
            parts.append(f"{symbol} = {value:.4g} {unit_tex(p.unit.replace('^2', '²'))}")
    if not parts:
        return "\n".join(textwrap.wrap(model.title, width))
    # Wrapped between parameters, never inside "name = value unit".
    lines = textwrap.wrap(f"{model.title}:", width)
    for k, part in enumerate(parts):
        piece = part + ("," if k < len(parts) - 1 else "")
        if _shown_length(lines[-1]) + 1 + _shown_length(piece) <= width:
            lines[-1] += " " + piece
        else:
            lines.append(piece)
    return "\n".join(lines)


RAW_NAME = re.compile(r"\b[A-Za-z][A-Za-z0-9]*_[A-Za-z0-9_]+\b")
"""An identifier with an underscore: a model file's name drawn as it is typed."""


def raw_names(fig: Figure) -> list[str]:
    """Every text of ``fig`` (titles, axis and tick labels, legends, notes) that shows an
    identifier with an underscore outside mathtext (``m_h``, ``theta_II``, ``b_over_l``);
    empty for a figure labelled throughout by :func:`parameter_text`, :func:`state_label`,
    :func:`unit_tex` and :func:`words`."""
    from matplotlib.text import Text

    found = []
    for text in fig.findobj(Text):
        shown = text.get_text()
        outside = re.sub(r"(?<!\\)\$.*?(?<!\\)\$", " ", shown)  # mathtext pairs of $
        if RAW_NAME.search(outside):
            found.append(shown)
    return found
