"""``vsw simulate --plot`` for every model: the walk over time in the audit's style."""

from __future__ import annotations

import pytest

from tests.conftest import gait_start, passive_keys
from vsw.dynamics.trajectories import sample_walk
from vsw.plots import plotstyle
from vsw.plots.figures import save_figure
from vsw.plots.plotstyle import state_label, unit_tex
from vsw.plots.walk_plot import walk_figure

GENERIC = [k for k in passive_keys() if k != "ile"]  # the ILE keeps its closed-form figure


@pytest.fixture(scope="module")
def figures():
    out = {}
    for key in GENERIC:
        model, params, start = gait_start(key)  # the kept gait, confirmed: no search
        out[key] = (model, params, sample_walk(model, params, start, 2, 200.0))
    return out


# Two models' figures in PNG; the other models and the vector formats in the slow tier: the
# bytes are the figure writer's, one path for every model, and the test below draws every
# model in the default tier.
BYTES_CHECKED = ("compass_gait", "vsw_biped")


@pytest.mark.parametrize(
    "key", [k if k in BYTES_CHECKED else pytest.param(k, marks=pytest.mark.slow) for k in GENERIC]
)
@pytest.mark.parametrize(
    "suffix",
    [
        "png",
        pytest.param("svg", marks=pytest.mark.slow),
        pytest.param("pdf", marks=pytest.mark.slow),
    ],
)
def test_every_model_draws_its_walk_byte_identically(figures, tmp_path, key, suffix):
    model, params, walk = figures[key]
    first, second = tmp_path / f"a.{suffix}", tmp_path / f"b.{suffix}"
    save_figure(walk_figure(model, params, walk), first)
    save_figure(walk_figure(model, params, walk), second)
    assert first.read_bytes() == second.read_bytes()


@pytest.mark.parametrize("key", GENERIC)
def test_legend_and_title_lie_outside_the_data_and_inside_the_figure(figures, key):
    model, params, walk = figures[key]
    fig = walk_figure(model, params, walk)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    plotstyle.settle_layout(fig)
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    legend = fig.legends[0].get_window_extent(renderer)
    page = fig.bbox
    for ax in fig.axes:
        assert not legend.overlaps(ax.get_window_extent(renderer)), "the legend covers data"
    texts = [fig._suptitle, *fig.legends[0].get_texts()]
    texts += [label for ax in fig.axes for label in (ax.xaxis.label, ax.yaxis.label)]
    for text in texts:
        if text is None or not text.get_text().strip():
            continue
        box = text.get_window_extent(renderer)
        inside = box.x0 >= page.x0 - 1 and box.x1 <= page.x1 + 1 and box.y0 >= page.y0 - 1
        assert inside and box.y1 <= page.y1 + 1, f"cut off: {text.get_text()!r}"
    assert legend.x0 >= page.x0 - 1 and legend.x1 <= page.x1 + 1
    assert fig.get_size_inches()[0] == pytest.approx(3.5), "one journal column"
    labels = [ax.get_ylabel() for ax in fig.axes] + [fig.axes[-1].get_xlabel()]
    assert all("[" in label and "]" in label for label in labels), labels


def test_units_and_symbols_in_mathtext():
    assert unit_tex("sqrt(r_e/g)") == r"$\sqrt{r_{e}/g}$"
    assert unit_tex("m_H g l") == r"$m_{H}\,g\,l$"
    assert unit_tex("rad/s") == "rad/s"
    assert state_label("theta_dot", "rad/s") == r"$\dot{\theta}$ [rad/s]"
    assert state_label("theta_II", "rad") == r"$\theta_{\mathrm{II}}$ [rad]"
