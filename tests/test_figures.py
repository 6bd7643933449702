"""Figures fit for a paper: deterministic PNG/SVG/PDF, resolution, legends outside the data,
the simulate plot after a fall, curves cut by the axis limits, and one style throughout."""

from __future__ import annotations

import math
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from generated import ile
from vsw.models.ile import plots
from vsw.models.ile.basin import basin, check_edges_by_simulation
from vsw.models.ile.simulate import simulate
from vsw.plots import plotstyle
from vsw.plots.figures import SAVE_FORMATS, save_figure

ROOT = Path(__file__).resolve().parents[1]
R45 = math.radians(45.0)
# A walker whose fixed point lies below the fall threshold (q^f < q_apex_min): from
# q0 = 0.85 it slows down step by step and falls backward during step 7.
FALL = (0.98, 0.0, math.radians(39.0), 0.85, 12)


@pytest.fixture(scope="module")
def small_basin():
    return basin(0.8, R45, np.radians(np.arange(-30.0, 40.01, 1.0)), n_q=201)


@pytest.fixture(scope="module")
def audit_figure_data():
    """The audit's data behind Fig. 8 and 9 (the pieces of ``run_audit`` that make it)."""
    from paper_check.audit import _basin_claims, _fig8_claim

    _, fig8 = _fig8_claim()
    *_, basin_data = _basin_claims()
    return {"fig8": fig8, "basin": basin_data}


def _cli_figures(small_basin):
    b, t, p, q0, n = FALL
    checks = check_edges_by_simulation(small_basin, n_samples=3)
    return {
        "phase": lambda: plots.phase_portrait(0.8, 0.0, R45),
        "simulate": lambda: plots.simulation_plot(b, t, p, q0, n, simulate(b, t, p, q0, n)),
        "convergence": lambda: plots.convergence_plot(0.8, 0.0, R45, 0.2, 8),
        "basin": lambda: plots.basin_plot(small_basin, checks=checks),
    }


def _png_dpi(data: bytes) -> tuple[int, int, float]:
    """(width, height, dots per inch) from a PNG's IHDR and pHYs chunks."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, size, dpi = 8, None, None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            size = struct.unpack(">II", body[:8])
        elif kind == b"pHYs":
            x_ppm, y_ppm, unit = struct.unpack(">IIB", body)
            assert unit == 1 and x_ppm == y_ppm  # pixels per metre, square pixels
            dpi = x_ppm * 0.0254
        pos += 12 + length
    assert size is not None and dpi is not None
    return size[0], size[1], dpi


@pytest.mark.slow  # every figure twice in every format
def test_cli_figures_identical_bytes_in_every_format(tmp_path, small_basin):
    # The two richest figures (the others are drawn by the same helpers; the audit's
    # figures are compared byte for byte in tests/test_paper_check.py).
    figures = _cli_figures(small_basin)
    for name, formats in (("simulate", SAVE_FORMATS), ("basin", ("pdf",))):
        make = figures[name]
        for ext in formats:
            first = save_figure(make(), tmp_path / f"{name}-1.{ext}").read_bytes()
            second = save_figure(make(), tmp_path / f"{name}-2.{ext}").read_bytes()
            assert first == second, f"{name}.{ext} differs between two runs"
            if ext == "pdf":
                # No dates or producer strings; TrueType fonts (journals reject Type 3).
                assert b"/CreationDate" not in first and b"/Producer" not in first
                assert b"/FontFile2" in first and b"/Type3" not in first
            elif ext == "svg":
                assert b"<dc:date>" not in first


def test_png_resolution_at_least_200_dpi(tmp_path, small_basin):
    figures = _cli_figures(small_basin)
    # The resolution is save_figure's (the CLI's --plot); two figure sizes suffice.
    for name in ("simulate", "basin"):
        fig = figures[name]()
        path = save_figure(fig, tmp_path / f"{name}.png")
        width, height, dpi = _png_dpi(path.read_bytes())
        assert dpi >= 200, name
        w_in, h_in = fig.get_size_inches()
        assert width == pytest.approx(w_in * dpi, abs=1) and height == pytest.approx(
            h_in * dpi, abs=1
        )


def _boxes_overlap(a, b) -> bool:
    return min(a.x1, b.x1) - max(a.x0, b.x0) > 0.5 and min(a.y1, b.y1) - max(a.y0, b.y0) > 0.5


def _assert_legends_outside_axes(fig, name: str) -> None:
    fig.draw_without_rendering()
    legends = list(fig.legends) + [ax.get_legend() for ax in fig.axes if ax.get_legend()]
    assert legends, f"{name}: no legend"
    for legend in legends:
        box = legend.get_window_extent()
        for ax in fig.axes:
            assert not _boxes_overlap(box, ax.get_window_extent()), f"{name}: legend over data"
        assert box.x0 >= -0.5 and box.x1 <= fig.bbox.width + 0.5, f"{name}: legend cut off"


def test_cli_legends_outside_the_data(small_basin):
    for name, make in _cli_figures(small_basin).items():
        _assert_legends_outside_axes(make(), name)


def test_audit_figures_legends_outside_and_one_style(audit_figure_data):
    from matplotlib.text import Text

    from paper_check.figures import FIGURES, draw_figure

    for name in FIGURES:
        fig = draw_figure(name, audit_figure_data)
        _assert_legends_outside_axes(fig, name)
        assert fig.get_figwidth() == plotstyle.COLUMN_WIDTH
        texts = [t.get_text() for t in fig.findobj(Text)]
        # The degree sign is U+00B0, not mathtext's raised ring ^\circ.
        assert not any("circ" in t for t in texts), name
        assert any("\N{DEGREE SIGN}" in t for t in texts), name


def test_family_curves_differ_by_marker_not_only_colour(audit_figure_data):
    from paper_check.figures import draw_figure

    for name in ("fig5", "fig6", "fig7"):
        (ax,) = draw_figure(name, audit_figure_data).axes
        pairs = {
            (line.get_color(), line.get_marker())
            for line in ax.get_lines()
            if line.get_marker() not in (None, "None", "", " ")
            and line.get_linestyle() == "None"
            and not str(line.get_marker()).startswith("$")
        }
        markers = [m for _, m in pairs]
        assert len(pairs) == 4 and len(set(markers)) == 4, name


def test_cut_curves_are_marked_where_they_leave_the_frame(audit_figure_data):
    from paper_check.figures import Q_TOP, draw_figure, off_scale

    # Independent of the generated code: eq. (10) and (11) as printed, at the curve's start
    # (beta = 0.4, phi0 = 45 deg, theta_II = 0), where Fig. 5 is highest.
    beta, phi0 = 0.4, R45
    theta_1 = -math.atan((beta - math.cos(phi0)) / math.sin(phi0))
    c2 = math.cos(phi0) ** 2
    q_printed = (
        2
        * c2
        * ((1 - beta**3) - math.cos(theta_1) * (beta - beta**3))
        / (beta**2 * (1 - c2 * beta**2))
    )
    cut = {c["curve"]: c for c in off_scale("fig5")}
    assert q_printed > Q_TOP["fig5"]
    assert cut["phi0=45 deg"]["max"] == pytest.approx(q_printed, rel=1e-12)
    assert not any(c["walks"] for c in cut.values())
    assert "phi0=60 deg" not in cut  # q^f(0.4) = 1.96 < 3: nothing hidden
    (ax,) = draw_figure("fig5", audit_figure_data).axes
    arrows = [
        line
        for line in ax.get_lines()
        if str(line.get_marker()).startswith("$") and len(line.get_xdata())
    ]
    assert len(arrows) == len(cut)
    for line in arrows:
        assert set(line.get_ydata()) == {Q_TOP["fig5"]} and not line.get_clip_on()
    assert ax.get_ylim()[1] == Q_TOP["fig5"]


def _line(ax, label: str):
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == label]
    return line


def test_simulate_plot_after_a_fall():
    b, t, p, q0, n = FALL
    result = simulate(b, t, p, q0, n)
    assert result.ended == "fell-backward" and len(result.q) == 7
    fig = plots.simulation_plot(b, t, p, q0, n, result)
    ax_theta, ax_omega, ax_q = fig.axes
    # The map stops at the last completed step; the failing step is marked.
    map_line = _line(ax_q, "stride map (9)")
    assert list(map_line.get_xdata()) == list(range(len(result.q)))
    fall = [ln for ln in ax_q.get_lines() if ln.get_label().startswith("falls backward")]
    assert [list(ln.get_xdata()) for ln in fall] == [[7, 7]]
    # Without the simulation the map's own bounds (q_apex_min, q_liftoff_max] stop it at
    # the same step: two independent routes to the fall agree.
    alone = plots.convergence_plot(b, t, p, q0, n).axes[0]
    assert len(_line(alone, "stride map (9)").get_xdata()) == len(result.q)
    assert any(ln.get_label().startswith("falls backward") for ln in alone.get_lines())
    # And the simulation falls from the first state below the fall threshold (14).
    q_apex = float(ile.q_apex_min(b, t, p))
    assert result.q[-1] < q_apex < result.q[-2]
    # The time panels end at the fall, marked there.
    t_end = float(result.t[-1])
    for ax in (ax_theta, ax_omega):
        assert any(list(ln.get_xdata()) == [t_end, t_end] for ln in ax.get_lines())
    # theta in degrees: the largest angle is theta_IV in degrees, not radians.
    theta_line = ax_theta.get_lines()[0]
    assert np.nanmax(theta_line.get_ydata()) == pytest.approx(
        math.degrees(float(ile.theta_IV(b, p))), rel=1e-6
    )
    # Integer step ticks and the parameters in the title.
    fig.draw_without_rendering()
    ticks = [x for x in ax_q.get_xticks() if -0.5 <= x <= n + 0.5]
    assert ticks and all(float(x).is_integer() for x in ticks)
    title = fig.get_suptitle()
    for part in ("0.98", "39\N{DEGREE SIGN}", "0\N{DEGREE SIGN}", "q_0", "0.85", "6 of 12"):
        assert part in title


def test_simulate_plot_completed_draws_every_step():
    result = simulate(0.8, 0.0, R45, 0.3, 5)
    fig = plots.simulation_plot(0.8, 0.0, R45, 0.3, 5, result)
    ax_q = fig.axes[2]
    assert len(_line(ax_q, "stride map (9)").get_xdata()) == 6
    assert not any("step" in ln.get_label() for ln in ax_q.get_lines())
    assert "5 of 5 steps, completed" in fig.get_suptitle()


def test_basin_plot_shows_no_gait_range_and_names_edges(small_basin):
    fig = plots.basin_plot(small_basin)
    (ax,) = fig.axes
    theta_deg = np.degrees(small_basin.theta_II)
    assert ax.get_ylim() == (theta_deg.min(), theta_deg.max())  # not cropped to the gaits
    labels = [text.get_text() for text in fig.legends[0].get_texts()]
    assert "left edge: falls backward (14)" in labels
    assert "right edge: foot lifts off" in labels
    assert "no gait" in labels
    # Bands below theta_I and above theta_IV, named by the failing condition.
    notes = " ".join(text.get_text() for text in ax.texts)
    assert r"\theta_{\mathrm{I}}" in notes and r"\theta_{\mathrm{IV}}" in notes
    theta_I = math.degrees(float(ile.theta_I(0.8, R45)))
    theta_IV = math.degrees(float(ile.theta_IV(0.8, R45)))
    runs = plots._no_gait_runs(small_basin)
    assert runs[0][0] == theta_deg.min() and runs[0][1] == pytest.approx(theta_I, abs=1.0)
    assert runs[-1][1] == theta_deg.max() and runs[-1][0] == pytest.approx(theta_IV, abs=1.0)


def test_edge_checks_drawn_so_none_hides_another(small_basin):
    checks = check_edges_by_simulation(small_basin, n_samples=3)
    (ax,) = plots.basin_plot(small_basin, checks=checks).axes
    inside = _line(ax, "simulated inside: converges")
    outside = _line(ax, "simulated outside: falls / lifts off")
    # Open circles under smaller crosses: a cross on top of a circle leaves both visible.
    assert inside.get_markerfacecolor() == "none" and inside.get_marker() == "o"
    assert outside.get_marker() == "x" and outside.get_zorder() > inside.get_zorder()
    assert outside.get_markersize() < inside.get_markersize()


def test_import_vsw_and_plots_does_not_load_matplotlib():
    code = (
        "import sys, vsw, vsw.models.ile.plots, vsw.plots.plotstyle\n"
        "assert 'matplotlib' not in sys.modules, 'matplotlib imported'\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120
    )
    assert proc.returncode == 0, proc.stderr


def test_style_does_not_change_global_rcparams():
    import matplotlib

    before = dict(matplotlib.rcParams)
    plots.phase_portrait(0.8, 0.0, R45)
    with plotstyle.context():
        assert matplotlib.rcParams["pdf.fonttype"] == 42
    assert dict(matplotlib.rcParams) == before
