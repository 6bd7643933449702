"""One labelling style in every figure the commands draw: symbols and units in mathtext,
no identifier of a model file typed out (``m_h``, ``theta_II``, ``b_over_l`` outside
mathtext, ``kappa`` spelled in it), and no legend over the data more than matplotlib's
'best' place would put it."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from matplotlib.figure import Figure
from matplotlib.transforms import Bbox

from vsw.dynamics.trajectories import sample_walk
from vsw.models import keys, load
from vsw.models.ile import plots
from vsw.models.ile.basin import basin
from vsw.models.ile.simulate import simulate
from vsw.plots import plotstyle
from vsw.plots.walk_plot import walk_figure
from vsw.synthesis.powered import PoweredGait, input_names
from vsw.synthesis.powered.plot import powered_figure

GREEK = ("alpha|beta|gamma|delta|epsilon|zeta|eta|theta|iota|kappa|lambda|mu|nu|xi|pi|rho|"
         "sigma|tau|upsilon|phi|chi|psi|omega")  # fmt: skip
SPELLED = re.compile(rf"(?<![\\A-Za-z])({GREEK})(?![A-Za-z])")


def spelled_greek(fig: Figure) -> list[str]:
    """Texts whose mathtext spells a Greek letter's name (``$kappa$``: italic k, a, p...)."""
    from matplotlib.text import Text

    found = []
    for text in fig.findobj(Text):
        for math_part in re.findall(r"(?<!\\)\$(.*?)(?<!\\)\$", text.get_text()):
            if SPELLED.search(re.sub(r"\\mathrm\{[^}]*\}", "", math_part)):
                found.append(text.get_text())
    return found


def _covered(fig: Figure, box: Bbox) -> int:
    """The data points (line vertices, scatter offsets) of every axes inside ``box``."""
    count = 0
    for ax in fig.axes:
        for line in ax.lines:
            xy = line.get_transform().transform(np.asarray(line.get_xydata(), float))
            count += int(box.count_contains(xy[np.all(np.isfinite(xy), 1)]))
        for collection in ax.collections:
            offsets = np.asarray(collection.get_offsets(), float)
            if offsets.size:
                xy = collection.get_offset_transform().transform(offsets)
                count += int(box.count_contains(xy[np.all(np.isfinite(xy), 1)]))
    return count


def legends_over_data(fig: Figure) -> list[str]:
    """Legends that cover more data than at 'best' (an axes' legend) or cover an axes at
    all (a figure's legend)."""
    fig.draw_without_rendering()
    problems = []
    for legend in fig.legends:
        box = legend.get_window_extent()
        for ax in fig.axes:
            if Bbox.intersection(box, ax.get_window_extent()) is not None and _covered(
                    fig, Bbox.intersection(box, ax.get_window_extent())):  # fmt: skip
                problems.append("a figure legend over an axes' data")
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None:
            continue
        here = _covered(fig, legend.get_window_extent())
        placed = legend._loc
        legend.set_loc("best")
        fig.draw_without_rendering()
        best = _covered(fig, legend.get_window_extent())
        legend._loc = placed
        fig.draw_without_rendering()
        if here > best:
            problems.append(f"a legend over {here} data points ('best': {best})")
    return problems


def _synthetic_gait(model) -> PoweredGait:
    """A gait of the model's shape (one phase's knots, its inputs) for drawing only."""
    ((phase, _),) = model.phase_sequence()
    t = np.linspace(0.0, 0.7, 21)
    nx = 2 * len(model.coordinates)
    states = np.column_stack([np.sin(t * (k + 1)) * 0.3 for k in range(nx)])
    inputs = np.column_stack([np.cos(t * (j + 2)) for j in range(len(input_names(model)[phase]))])
    return PoweredGait(status="optimal", reason="", cost=0.120106, durations=(0.7,),
                       times=[t], states=[states], inputs=[inputs], input_times=[t],
                       work={}, step_length=0.4, speed=0.57, resimulation_error=1e-12,
                       guard_at_end=0.0, ipopt_status="Solve_Succeeded", iterations=10)  # fmt: skip


# Starts on the gaits (vsw analyze), rounded: a step each, no gait search.
STARTS = {
    "kneed_walker": [-0.23858546, 0.23858546, 0.0, 1.10958733, 0.05714811, 0.0],
    "compass_gait": [-0.271275, 0.271275, 1.15, 0.376135],
}


@pytest.fixture(scope="module")
def figures() -> dict[str, Figure]:
    out = {}
    for key, start in STARTS.items():
        model = load(key)
        params = model.parameters()
        walk = sample_walk(model, params, np.array(start), 1, 100.0)
        out[f"simulate {key}"] = walk_figure(model, params, walk)
    level = load("level_compass_gait")
    out["optimize level_compass_gait"] = powered_figure(level, level.parameters(),
                                                        _synthetic_gait(level), "J")  # fmt: skip
    b, t, p, q0, n = 0.8, 0.0, math.radians(45.0), 0.3, 6
    out["ile phase"] = plots.phase_portrait(b, t, p)
    out["ile simulate"] = plots.simulation_plot(b, t, p, q0, n, simulate(b, t, p, q0, n))
    out["ile convergence"] = plots.convergence_plot(b, t, p, 0.2, 8)
    out["ile basin"] = plots.basin_plot(basin(b, p, np.radians(np.arange(-30.0, 40.01, 5.0)),
                                              n_q=51))  # fmt: skip
    return out


def test_the_checks_find_what_they_look_for():
    fig = Figure()
    ax = fig.subplots()
    ax.plot(np.linspace(0, 1, 50), np.linspace(0, 1, 50), label="$kappa$ and $\\theta$")
    ax.legend(loc="center")  # on the line: 'best' finds a free corner
    fig.suptitle("m_h = 10 kg, $b_{over}$")
    assert plotstyle.raw_names(fig) == ["m_h = 10 kg, $b_{over}$"]
    assert spelled_greek(fig) == ["$kappa$ and $\\theta$"]
    assert legends_over_data(fig)


@pytest.mark.parametrize("key", sorted(keys()))
def test_every_models_parameters_are_symbols_in_titles(key):
    model = load(key)
    fig = Figure()
    fig.suptitle(plotstyle.parameter_text(model, model.parameters()))
    assert plotstyle.raw_names(fig) == [], key
    assert spelled_greek(fig) == [], key
    fig.draw_without_rendering()  # the mathtext parses


@pytest.mark.parametrize("name", ["simulate kneed_walker", "simulate compass_gait",
                                  "optimize level_compass_gait", "ile phase", "ile simulate",
                                  "ile convergence", "ile basin"])  # fmt: skip
def test_every_figure_labels_in_one_style(figures, name, tmp_path):
    """No raw name, no spelled Greek letter, no legend over the data, and nothing cut at the
    edges of the saved PNG (laid out at the resolution it is saved at)."""
    from PIL import Image

    from vsw.plots.figures import save_figure

    fig = figures[name]
    assert plotstyle.raw_names(fig) == [], name
    assert spelled_greek(fig) == [], name
    assert legends_over_data(fig) == [], name
    save_figure(fig, tmp_path / "f.png")
    ink = np.asarray(Image.open(tmp_path / "f.png").convert("L")) < 200
    assert not (ink[:, :2].any() or ink[:, -2:].any() or ink[:2].any() or ink[-2:].any()), name


def test_the_powered_figure_says_its_units(tmp_path):
    """Its panels' labels and legend in symbols and units, and nothing cut at the edges of
    the saved PNG (an input at zero has the widest tick labels)."""
    from PIL import Image

    from vsw.plots.figures import save_figure

    level = load("level_compass_gait")
    gait = _synthetic_gait(level)
    gait.inputs = [np.zeros_like(gait.inputs[0])]
    save_figure(powered_figure(level, level.parameters(), gait, "J"), tmp_path / "p.png")
    ink = np.asarray(Image.open(tmp_path / "p.png").convert("L")) < 200
    assert not ink[:, :2].any() and not ink[:, -2:].any() and not ink[:2].any()
    fig = powered_figure(level, level.parameters(), _synthetic_gait(level), "J")
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert labels == ["angle [rad]", "rate [rad/s]", "input [N m]"]
    assert fig.get_suptitle().endswith("optimal, cost 0.120106 J")
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert r"$\theta$ [rad] and its rate (dashed)" in legend and "hip torque [N m]" in legend
