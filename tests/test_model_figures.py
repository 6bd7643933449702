"""The basin and sweep figures of every model in the audit's style: one column,
legends outside the data, labels with units, the whole swept range shown."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from vsw.cli import main
from vsw.models import load
from vsw.models.ile.plots import ile_sweep_plot
from vsw.plots import plotstyle
from vsw.plots.diagrams import bifurcation_plot, diagram_units
from vsw.runtime.jsonable import clean
from vsw.studies.grid_basin import basin_plot, grid_basin
from vsw.studies.sweeps import continuation, record


def _drawn(fig):
    plotstyle.settle_layout(fig)
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    return renderer


def _legend_outside(fig, renderer):
    (legend,) = fig.legends
    box = legend.get_window_extent(renderer)
    for ax in fig.axes:
        assert not box.overlaps(ax.get_window_extent(renderer)), "the legend covers data"


def test_grid_basin_is_one_column_with_its_legend_below_and_units():
    model = load("simplest_walker")
    params = model.parameters()
    found = grid_basin(model, params, "theta", np.linspace(-0.3, -0.1, 12), "theta_dot",
                       np.linspace(0.1, 0.35, 12), 30)  # fmt: skip
    data = clean({**found.to_dict(), "model": model.cli_name})
    units = {s["name"]: s["unit"] for s in model.spec["state"]}
    fig = basin_plot(data, units, plotstyle.parameter_text(model, params))
    renderer = _drawn(fig)
    assert fig.get_size_inches()[0] == pytest.approx(plotstyle.COLUMN_WIDTH)
    _legend_outside(fig, renderer)
    assert fig.axes[1].get_xlabel() == r"$\theta$ [rad]"
    assert fig.axes[0].get_ylabel() == r"$\dot{\theta}$ [$\mathrm{rad}/\sqrt{l/g}$]"
    title = fig._suptitle.get_text().replace("\n", " ")
    assert title == r"Simplest walking model: $\gamma$ = 0.009 rad (0.516°)"


def test_sweep_shows_the_whole_range_and_marks_lost_and_fallen_points_on_the_edges():
    """A rimless-wheel sweep into slopes where it does not roll: the points without a gait
    stay on the axis (marked on the top edge), not dropped."""
    model = load("rimless_wheel")
    values = np.linspace(0.02, 0.2, 6)
    points = continuation(model, {}, "gamma", values, 0, 0)
    assert not all(p["found"] for p in points), "the sweep was meant to lose its gait"
    data = clean(record(model, {}, "gamma", points, 0, 0))
    fig = bifurcation_plot(data, "step_length", diagram_units(model.units),
                           plotstyle.parameter_text(model, data["parameters"]))  # fmt: skip
    renderer = _drawn(fig)
    ax = fig.axes[0]
    assert ax.get_xlim() == pytest.approx((0.02, 0.2))
    lost = [line for line in ax.lines if line.get_label().startswith("no period-one gait")]
    assert len(lost) == 1 and len(lost[0].get_xdata()) == sum(not p["found"] for p in points)
    assert np.all(np.asarray(lost[0].get_ydata()) == 1.0)  # axes fraction: the top edge
    _legend_outside(fig, renderer)
    assert fig.axes[-1].get_xlabel() == r"$\gamma$ [rad]"
    assert "$l$ = 1 m" in fig._suptitle.get_text()


def test_ile_sweep_keeps_the_points_without_a_gait_shaded():
    """`vsw sweep --beta 0.8 --phi0 45 --over theta_II=-0.2:0.4:13`: theta_II =
    -0.2 and -0.15 rad have no gait; the axis still starts at -0.2, the range is shaded and
    the title gives phi0 in rad and degrees."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["sweep", "--beta", "0.8", "--phi0", "45", "--over",
                     "theta_II=-0.2:0.4:13", "--json"]) == 0  # fmt: skip
    import json

    data = json.loads(out.getvalue())
    assert [p["walks"] for p in data["points"]][:3] == [False, False, True]
    model = load("ile")
    fig = ile_sweep_plot(data, plotstyle.state_label("theta_II", "rad"),
                         plotstyle.parameter_text(model, data["parameters"]))  # fmt: skip
    renderer = _drawn(fig)
    for ax in fig.axes:
        assert ax.get_xlim() == pytest.approx((-0.2, 0.4))
    shaded = [p for p in fig.axes[0].patches if p.get_facecolor()[:3] != (1.0, 1.0, 1.0)]
    assert len(shaded) == 1
    x0 = shaded[0].get_x() if hasattr(shaded[0], "get_x") else shaded[0].get_xy()[0][0]
    assert x0 == pytest.approx(-0.2)
    _legend_outside(fig, renderer)
    assert r"$\varphi_0$ = 0.7854 rad (45°)" in fig._suptitle.get_text().replace("\n", " ")


@pytest.mark.parametrize("suffix", ["png", "svg", "pdf"])
def test_basin_and_sweep_figures_are_byte_identical(tmp_path, suffix):
    runs = []
    for k in range(2):
        path = tmp_path / f"s{k}.{suffix}"
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["sweep", "--model", "rimless-wheel", "--over", "gamma=0.05:0.15:3",
                         "--plot", str(path)]) == 0  # fmt: skip
        runs.append(path.read_bytes())
    assert runs[0] == runs[1]


@pytest.mark.parametrize("suffix", ["png", "svg", "pdf"])
def test_grid_basin_figure_is_byte_identical(tmp_path, suffix):
    runs = []
    for k in range(2):
        path = tmp_path / f"b{k}.{suffix}"
        with contextlib.redirect_stdout(io.StringIO()):
            assert main(["basin", "--model", "rimless-wheel", "--grid", "theta_dot=0.5:1.5:9",
                         "--steps", "5", "--plot", str(path)]) == 0  # fmt: skip
        runs.append(path.read_bytes())
    assert runs[0] == runs[1]
