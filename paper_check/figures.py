"""The paper's Fig. 5-9 reproduced from the generated code, with the simulation overlaid.

Every curve is solid where the gait walks (every physical existence condition of the
derivation holds) and dotted where the paper's plotted range reaches no valid gait.
Files are written deterministically (PNG and SVG, no dates, fixed SVG hash salt).
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np

from generated import ile

__all__ = ["FIGURES", "curves", "gait_gaps", "write_figures"]

FIGURES = ("fig5", "fig6", "fig7", "fig8", "fig9")
_NO_GAIT = "dotted: no valid gait"


def _walks(beta: Any, theta_II: Any, phi0: Any) -> np.ndarray:
    from paper_check.audit import _walk_mask

    return _walk_mask(np.asarray(beta, float), np.asarray(theta_II, float), np.asarray(phi0, float))


def _split_curve(
    ax: Any, x: np.ndarray, y: np.ndarray, ok: np.ndarray, color: str, label: str
) -> None:
    ax.plot(x, np.where(ok, y, np.nan), color=color, lw=1.8, label=label)
    ax.plot(x, np.where(ok, np.nan, y), color=color, lw=1.2, ls=":")


def _finish(ax: Any, title: str, xlabel: str, ylabel: str) -> None:
    ax.set_title(title, fontsize=10)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, lw=0.3, alpha=0.6)
    handles, labels = ax.get_legend_handles_labels()
    from matplotlib.lines import Line2D

    handles.append(Line2D([], [], color="0.3", ls=":", lw=1.2))
    labels.append(_NO_GAIT)
    ax.legend(handles, labels, fontsize=7, loc="best")


def curves(name: str) -> list[tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """The paper's plotted curves of Fig. 5-7: ``(label, x, beta, theta_II, phi0)``.

    ``x`` is the plotted abscissa (beta, or an angle in degrees); the parameter arrays are
    broadcast to its shape (angles in radians).
    """
    out = []
    if name == "fig5":
        beta = np.linspace(0.4, 0.999, 600)
        for phi_deg in (45, 50, 55, 60):
            p = np.full_like(beta, math.radians(phi_deg))
            out.append((rf"$\varphi_0={phi_deg}^\circ$", beta, beta, 0 * beta, p))
    elif name == "fig6":
        theta = np.linspace(-40.0, 40.0, 801)
        for b in (0.8, 0.9):
            for phi_deg in (45, 60):
                label = rf"$\beta={b}$, $\varphi_0={phi_deg}^\circ$"
                p = np.full_like(theta, math.radians(phi_deg))
                out.append((label, theta, np.full_like(theta, b), np.radians(theta), p))
    elif name == "fig7":
        phi = np.linspace(5.0, 89.0, 841)
        for b in (0.6, 0.7, 0.8, 0.9):
            out.append((rf"$\beta={b}$", phi, np.full_like(phi, b), 0 * phi, np.radians(phi)))
    return out


def gait_gaps() -> list[dict[str, Any]]:
    """Parts of the plotted curves of Fig. 5-7 where no valid gait exists.

    Each gap is a contiguous run of non-walking points, with the failing physical
    conditions at its ends and middle, and the time-domain simulation at its middle
    (started at q^f, three steps).

    Returns
    -------
    list of dict
        Keys ``figure, curve, from, to, fails, simulated``.
    """
    from paper_check.audit import _failing_reason
    from paper_check.simulation import converged, run

    gaps = []
    for name in ("fig5", "fig6", "fig7"):
        for label, x, b, t, p in curves(name):
            ok = _walks(b, t, p)
            edges = np.flatnonzero(np.diff(np.r_[0, (~ok).astype(int), 0]))
            for start, stop in zip(edges[::2], edges[1::2]):
                idx = (start, (start + stop - 1) // 2, stop - 1)
                fails = sorted(
                    {r for i in idx for r in _failing_reason(b[i], t[i], p[i]).split(", ")}
                )
                i = idx[1]
                qf = float(ile.q_fixed(b[i], t[i], p[i]))
                if qf > 0:
                    res = run(b[i], t[i], p[i], qf, 3)
                    simulated = "walks" if converged(res, qf) else res.ended
                else:
                    simulated = "q^f <= 0"
                gaps.append(
                    {
                        "figure": name,
                        "curve": label.replace("$", "")
                        .replace("\\", "")
                        .replace("varphi_0", "phi0")
                        .replace("^circ", " deg"),
                        "from": float(x[start]),
                        "to": float(x[stop - 1]),
                        "fails": ", ".join(fails),
                        "simulated at the middle": simulated,
                    }
                )
    return gaps


def _plot_curves(ax: Any, name: str) -> None:
    for k, (label, x, b, t, p) in enumerate(curves(name)):
        _split_curve(ax, x, ile.q_fixed(b, t, p), _walks(b, t, p), f"C{k}", label)


def _fig5(ax: Any) -> None:
    _plot_curves(ax, "fig5")
    ax.set_ylim(0, 3)
    _finish(ax, r"Fig. 5: $q^f(\beta)$, $\theta_{II}=0^\circ$", r"$\beta$", r"$q^f$")


def _fig6(ax: Any) -> None:
    _plot_curves(ax, "fig6")
    _finish(ax, r"Fig. 6: $q^f(\theta_{II})$", r"$\theta_{II}$ (deg)", r"$q^f$")


def _fig7(ax: Any) -> None:
    _plot_curves(ax, "fig7")
    ax.set_ylim(0, 3)
    _finish(ax, r"Fig. 7: $q^f(\varphi_0)$, $\theta_{II}=0^\circ$", r"$\varphi_0$ (deg)", r"$q^f$")


def _fig8(ax: Any, data: dict[str, Any]) -> None:
    from paper_check.audit import FIG_BETA, FIG_PHI0, FIG_THETA_II
    from vsw.simulate import simulate

    b, t2, p = FIG_BETA, FIG_THETA_II, FIG_PHI0
    qf = float(ile.q_fixed(b, t2, p))
    lo = float(ile.q_apex_min(b, t2, p))
    transient = simulate(b, t2, p, lo + 0.15 * (qf - lo), 6, rtol=1e-10, atol=1e-12)
    cycle = simulate(b, t2, p, qf, 1, rtol=1e-10, atol=1e-12)
    for res, style in ((transient, {"color": "0.6", "lw": 0.8}), (cycle, {"color": "C0", "lw": 2})):
        deg = np.degrees(res.theta)
        for step in np.unique(res.step):
            for phase in (1, 2):
                sel = (res.step == step) & (res.phase == phase)
                ax.plot(deg[sel], res.omega[sel], **style)
        # Jumps: extension II -> III and heelstrike IV -> I.
        ev = res.events
        for a, c in itertools.pairwise(ev):
            if (a[0], c[0]) in (("II", "III"), ("IV", "I")):
                ax.plot(np.degrees([a[2], c[2]]), [a[3], c[3]], ls="--", **style)
    ax.plot([], [], color="C0", lw=2, label="simulated cycle from $q^f$")
    ax.plot([], [], color="0.6", lw=0.8, label="simulated transient (6 steps)")
    for name, (theta, omega) in data["analytic_instants"].items():
        ax.plot(math.degrees(theta), omega, "o", ms=7, mfc="none", mec="C3")
        ax.annotate(name, (math.degrees(theta), omega), xytext=(5, 5), textcoords="offset points")
    ax.plot([], [], "o", mfc="none", mec="C3", label="closed-form instants I-IV")
    ax.set_title(
        r"Fig. 8: phase portrait, $\theta_{II}=0^\circ$, $\beta=0.8$, $\varphi_0=45^\circ$",
        fontsize=10,
    )
    ax.set_xlabel(r"$\theta$ (deg)")
    ax.set_ylabel(r"$\omega = d\theta/d\tau$")
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(fontsize=7, loc="lower center")


def _fig9(ax: Any, data: dict[str, Any]) -> None:
    theta = np.degrees(data["theta_II"])
    q_min, q_max = data["q_min"], data["q_max"]
    has = np.isfinite(q_min) & np.isfinite(q_max)
    w_min, w_max = np.sqrt(np.where(has, q_min, np.nan)), np.sqrt(np.where(has, q_max, np.nan))
    ax.fill_betweenx(theta, w_min, w_max, color="C0", alpha=0.25, lw=0, label="basin (map)")
    ax.plot(w_min, theta, color="C0", lw=1.5, label="left edge: exact (14)")
    ax.plot(w_max, theta, color="C1", lw=1.5, label="right edge: stance foot lifts off")
    ax.plot(np.sqrt(np.where(has, data["q_fixed"], np.nan)), theta, "k-", lw=1, label="$q^f$")
    paper14 = np.where(np.asarray(data["paper14"]) > 0, data["paper14"], np.nan)
    ax.plot(np.sqrt(paper14), theta, "C2--", lw=1, label="printed (14)")
    xmax = float(np.nanmax(w_max)) * 1.1
    ax.axhspan(theta.min(), math.degrees(data["theta_I"]), color="0.85", zorder=0)
    ax.axhspan(math.degrees(data["theta_IV"]), theta.max(), color="0.85", zorder=0)
    ax.axhline(22.5, color="C3", ls=":", lw=1, label=r"printed (17): $\varphi_0/2$")
    for c in data["checks"]:
        marker = "o" if c.side == "inside" else "x"
        color = "g" if c.ok else "r"
        ax.plot(math.sqrt(c.q0), math.degrees(c.theta_II), marker, color=color, ms=4)
    ax.plot([], [], "go", ms=4, label="simulated inside: converges")
    ax.plot([], [], "gx", ms=4, label="simulated outside: falls / lifts off")
    ax.set_xlim(0, xmax)
    ax.set_ylim(theta.min(), theta.max())
    ax.text(
        0.02 * xmax,
        (theta.min() + math.degrees(data["theta_I"])) / 2,
        r"no gait: $\theta_{II} \leq \theta_I$",
        fontsize=7,
        va="center",
    )
    ax.text(
        0.02 * xmax,
        (theta.max() + math.degrees(data["theta_IV"])) / 2,
        r"no gait: $\theta_{II} \geq \theta_{IV}$",
        fontsize=7,
        va="center",
    )
    ax.set_title(r"Fig. 9: basin of attraction, $\beta=0.8$, $\varphi_0=45^\circ$", fontsize=10)
    ax.set_xlabel(r"$\omega_I = \sqrt{q}$ at instant I")
    ax.set_ylabel(r"$\theta_{II}$ (deg)")
    ax.legend(fontsize=6, loc="lower right", framealpha=0.9)


def write_figures(out: Path, figure_data: dict[str, Any]) -> list[Path]:
    """Draw Fig. 5-9 into ``out`` as PNG and SVG.

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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from vsw.plots import save_figure

    written = []
    with matplotlib.rc_context({"svg.hashsalt": "paper_check", "font.size": 9}):
        for name in FIGURES:
            fig, ax = plt.subplots(figsize=(6.0, 4.2))
            if name == "fig5":
                _fig5(ax)
            elif name == "fig6":
                _fig6(ax)
            elif name == "fig7":
                _fig7(ax)
            elif name == "fig8":
                _fig8(ax, figure_data["fig8"])
            else:
                _fig9(ax, figure_data["basin"])
            fig.tight_layout()
            for ext in ("png", "svg"):
                written.append(save_figure(fig, out / f"{name}.{ext}", dpi=110))
            plt.close(fig)
    return written
