"""Sweeps over parameter grids and deterministic figures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsw.models.ile.analysis import analyze
from vsw.models.ile.params import STEPPER_2D
from vsw.models.ile.sweep import sweep
from vsw.runtime.errors import VswInputError


def test_sweep_equals_pointwise_analysis_on_meshgrid():
    beta = np.array([0.7, 0.8, 0.9])
    theta_II = np.radians([-5.0, 0.0, 5.0, 10.0])
    phi0 = np.radians([40.0, 50.0])
    s = sweep(["q_fixed", "speed_m_s", "walks", "margin:apex"], beta, theta_II, phi0, STEPPER_2D)
    assert s["q_fixed"].shape == (3, 4, 2)
    for i, j, k in [(0, 0, 0), (2, 3, 1), (1, 2, 0)]:
        a = analyze(beta[i], theta_II[j], phi0[k], STEPPER_2D)
        assert s["q_fixed"][i, j, k] == pytest.approx(a.q_fixed, rel=1e-13)
        np.testing.assert_allclose(s["speed_m_s"][i, j, k], a.speed_m_s, rtol=1e-13)
        assert s["walks"][i, j, k] == a.walks
        assert s["margin:apex"][i, j, k] == pytest.approx(a.condition("apex").value, rel=1e-13)


def test_sweep_progress_and_errors():
    calls = []
    sweep(
        "q_fixed", 0.8, np.linspace(-0.1, 0.1, 5), 0.7, progress=lambda d, t: calls.append((d, t))
    )
    assert calls[-1] == (5, 5)
    with pytest.raises(VswInputError, match="unknown"):
        sweep("nope", 0.8, 0.0, 0.7)
    with pytest.raises(VswInputError, match="RobotScale"):
        sweep("speed_m_s", 0.8, 0.0, 0.7)
    with pytest.raises(VswInputError, match="beta"):
        sweep("q_fixed", [0.5, 1.0], 0.0, 0.7)


def test_figures_are_deterministic_and_paths_checked(tmp_path):
    from vsw.models.ile import plots
    from vsw.models.ile.basin import basin
    from vsw.plots.figures import save_figure

    fig = plots.phase_portrait(0.8, 0.0, math.radians(45))
    first = save_figure(fig, tmp_path / "a.svg").read_bytes()
    second = save_figure(plots.phase_portrait(0.8, 0.0, math.radians(45)), tmp_path / "b.svg")
    assert first == second.read_bytes()
    png = save_figure(fig, tmp_path / "a.png").read_bytes()
    assert png == save_figure(fig, tmp_path / "c.png").read_bytes()
    b = basin(0.8, math.radians(45), np.radians(np.linspace(-10, 30, 9)), n_q=101)
    save_figure(plots.basin_plot(b), tmp_path / "basin.png")
    save_figure(plots.convergence_plot(0.8, 0.0, math.radians(45), 0.2, 8), tmp_path / "q.png")
    with pytest.raises(VswInputError, match="does not exist"):
        save_figure(fig, tmp_path / "missing" / "x.png")
    with pytest.raises(VswInputError, match="must end in"):
        save_figure(fig, tmp_path / "x.gif")


def test_time_series_from_simulation(tmp_path):
    simulate = pytest.importorskip("vsw.models.ile.simulate").simulate
    from vsw.models.ile import plots
    from vsw.plots.figures import save_figure

    result = simulate(0.8, 0.0, math.radians(45), 0.3, 4)
    fig = plots.time_series(result)
    assert len(fig.axes) == 2
    save_figure(fig, tmp_path / "t.png")


# --- vsw continue's figure ------------------------------------------------------------------

CASCADE_FLIPS = (0.0150884, 0.0176694, 0.0181601, 0.0182648, 0.0182873)
"""The simplest walker's flips as ``vsw continue`` locates them: the last three lie within
3e-4 of gamma, a few pixels apart on a range of 0.0105."""


def _cascade_record() -> dict:
    """A ``vsw continue --json`` record shaped like the simplest walker's cascade: one
    branch per period 1 ... 16, each flipping at the next of :data:`CASCADE_FLIPS`, its
    steps' lengths spread as the doubled gaits' are (0.47 to 0.52)."""
    branches = []
    for k, flip in enumerate(CASCADE_FLIPS):
        period = 2**k
        start = 0.009 if k == 0 else CASCADE_FLIPS[k - 1]
        lengths = [0.47 + 0.05 * j / max(period - 1, 1) for j in range(period)]

        def gait(parameter, stable, lengths=lengths, period=period):
            return {"parameter": parameter, "stable": stable, "max_abs_eigenvalue": 0.9,
                    "section_states": [{"theta": -0.25}] * period, "step_lengths": lengths,
                    "step_periods": [3.9] * period}  # fmt: skip

        points = [gait(x, x < flip) for x in np.linspace(start, 0.0195, 12)]
        special = {"type": "flip", **gait(flip, False)}
        branches.append({"period": period, "points": points, "special_points": [special]})
    return {"over": "gamma", "over_unit": "rad", "range": [0.009, 0.0195],
            "branches": branches}  # fmt: skip


def test_continuation_labels_do_not_overlap_in_a_cascade(tmp_path):
    """Every PD label's text box, measured with matplotlib's renderer on the saved figure,
    meets no other's, though the flips' points are closer than a label is wide (a label
    at one fixed offset from each would overlap its neighbour)."""
    from matplotlib.text import Text

    from vsw.plots.diagrams import continuation_plot
    from vsw.plots.figures import save_figure
    from vsw.plots.plotstyle import PNG_DPI

    units = {"length": "l", "time": "sqrt(l/g)"}
    figure = continuation_plot(_cascade_record(), "step_length", units, "simplest walker")
    save_figure(figure, tmp_path / "cascade.png")
    figure.set_dpi(PNG_DPI)  # measured at the resolution saved
    renderer = figure._get_renderer()
    labels = [t for t in figure.axes[0].texts if t.get_text() == "PD"]
    assert len(labels) == len(CASCADE_FLIPS)
    boxes = [Text.get_window_extent(t, renderer) for t in labels]
    for i, box in enumerate(boxes):
        for other in boxes[i + 1 :]:
            assert not box.overlaps(other), (box, other)
    anchors = [figure.axes[0].transData.transform(t.xy) for t in labels]
    closest = min(np.hypot(*(a - b)) for i, a in enumerate(anchors) for b in anchors[i + 1 :])
    assert closest < boxes[0].width  # the test's cascade does crowd the labels
    figure = continuation_plot(_cascade_record(), "step_length", units, "simplest walker")
    again = continuation_plot(_cascade_record(), "step_length", units, "simplest walker")
    first = save_figure(figure, tmp_path / "a.svg").read_bytes()
    assert save_figure(again, tmp_path / "b.svg").read_bytes() == first


def test_continuation_legend_has_the_shared_style():
    """vsw continue's legend is drawn as vsw sweep's: frameless, the style's font size."""
    from vsw.plots.diagrams import bifurcation_plot, continuation_plot

    units = {"length": "l", "time": "sqrt(l/g)"}
    cascade = continuation_plot(_cascade_record(), "step_length", units, "simplest walker")
    sweep = {"over": "gamma", "over_unit": "rad", "points": [
        {"gamma": g, "found": True, "state": {"theta": -0.25}, "step_length": 0.47,
         "period": 3.9, "stable": True, "max_abs_eigenvalue": 0.5, "attractor": None}
        for g in (0.009, 0.01)]}  # fmt: skip
    reference = bifurcation_plot(sweep, "step_length", units, "simplest walker")
    ours, theirs = cascade.legends[0], reference.legends[0]
    assert ours.get_frame_on() is theirs.get_frame_on() is False
    sizes = {t.get_fontsize() for t in ours.get_texts()}
    assert sizes == {theirs.get_texts()[0].get_fontsize()}
