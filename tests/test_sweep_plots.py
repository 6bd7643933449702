"""Sweeps over parameter grids and deterministic figures."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vsw.errors import VswInputError
from vsw.models.ile.analysis import analyze
from vsw.models.ile.params import STEPPER_2D
from vsw.models.ile.sweep import sweep


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
    from vsw.figures import save_figure
    from vsw.models.ile import plots
    from vsw.models.ile.basin import basin

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
    from vsw.figures import save_figure
    from vsw.models.ile import plots

    result = simulate(0.8, 0.0, math.radians(45), 0.3, 4)
    fig = plots.time_series(result)
    assert len(fig.axes) == 2
    save_figure(fig, tmp_path / "t.png")
