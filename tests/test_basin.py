"""Basin of attraction: iterated map with failure checks vs closed form vs simulation."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vsw.models.ile.analysis import analyze
from vsw.models.ile.basin import basin, check_edges_by_simulation
from vsw.runtime.errors import VswInputError

PHI0 = math.radians(45.0)


def closed_form_interval(beta, theta_II, phi0):
    """The interval (q_apex_min, q_liftoff_max] where the gait walks, NaN elsewhere."""
    a = analyze(beta, theta_II, phi0, timing=False)
    return (
        np.where(a.walks, a.q_apex_min, np.nan),
        np.where(a.walks, a.q_liftoff_max, np.nan),
    )


def test_fig9_basin_equals_closed_form_interval():
    theta_II = np.radians(np.linspace(-30, 40, 71))
    b = basin(0.8, PHI0, theta_II, n_q=801)
    low, high = closed_form_interval(0.8, theta_II, PHI0)
    assert np.array_equal(np.isnan(b.q_min), np.isnan(low))
    assert np.isfinite(b.q_min).sum() > 30
    np.testing.assert_allclose(b.q_min, low, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(b.q_max, high, rtol=1e-9)
    # The paper's reading of Fig. 9: the left edge is eq. (14) for theta_II >= 0.
    theta_I = -math.atan((0.8 - math.cos(PHI0)) / math.sin(PHI0))
    positive = (theta_II >= 0) & np.isfinite(b.q_min)
    np.testing.assert_allclose(b.q_min[positive], 2 * (1 - math.cos(theta_I)) / 0.8, rtol=1e-9)
    assert np.all(b.q_min[np.isfinite(b.q_min)] < b.q_fixed[np.isfinite(b.q_min)])
    assert np.all(b.q_fixed[np.isfinite(b.q_min)] <= b.q_max[np.isfinite(b.q_min)])


def test_unrefined_grid_edges_are_within_one_grid_step():
    theta_II = np.radians([-5.0, 0.0, 10.0])
    fine = basin(0.8, PHI0, theta_II, n_q=201)
    coarse = basin(0.8, PHI0, theta_II, n_q=201, refine=False)
    step = 1.5 / 0.8 / 200
    assert np.all(coarse.q_min >= fine.q_min)
    assert np.all(coarse.q_min - fine.q_min <= step)
    assert np.all(fine.q_max - coarse.q_max <= step)


@settings(max_examples=25, deadline=None)
@given(beta=st.floats(0.3, 0.98), phi0_deg=st.floats(10, 80))
def test_basin_matches_closed_form_for_random_parameters(beta, phi0_deg):
    phi0 = math.radians(phi0_deg)
    theta_II = np.radians(np.linspace(-25, 35, 13))
    b = basin(beta, phi0, theta_II, n_q=201)
    low, high = closed_form_interval(beta, theta_II, phi0)
    a = analyze(beta, theta_II, phi0, timing=False)
    # Sets within rounding of a condition boundary may go either way.
    clear = np.abs(a.contact_margin) > 1e-9
    clear &= np.abs(a.q_fixed - a.q_apex_min) > 1e-9
    assert np.array_equal(np.isnan(b.q_min[clear]), np.isnan(low[clear]))
    both = clear & np.isfinite(low)
    np.testing.assert_allclose(b.q_min[both], low[both], rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(b.q_max[both], high[both], rtol=1e-8)


def test_basin_json_contract():
    theta_II = np.radians([-60.0, 0.0, 10.0])
    d = json.loads(json.dumps(basin(0.8, PHI0, theta_II, n_q=101).to_dict(), allow_nan=False))
    assert len(d["theta_II"]) == len(d["q_min"]) == len(d["q_max"]) == 3
    assert d["q_min"][0] is None and d["q_max"][0] is None
    assert d["q_min"][1] < d["q_max"][1]


def test_basin_rejects_bad_input():
    with pytest.raises(VswInputError, match="phi0"):
        basin(0.8, 2.0)
    with pytest.raises(VswInputError, match="theta_II"):
        basin(0.8, PHI0, [0.0, 3.0])


def test_edges_checked_by_simulation():
    pytest.importorskip("vsw.models.ile.simulate")
    theta_II = np.radians([-5.0, 0.0, 20.0])
    b = basin(0.8, PHI0, theta_II, n_q=201)
    calls = []
    checks = check_edges_by_simulation(b, n_samples=3, progress=lambda d, t: calls.append(d))
    assert len(checks) == 12
    assert calls[-1] == 12
    failed = [c for c in checks if not c.ok]
    assert not failed, failed
    assert {c.ended for c in checks} == {"completed", "fell-backward", "lift-off"}


def test_thread_count_does_not_change_the_basin(monkeypatch):
    # 60 x 800 initial states: several row blocks, so the threaded path runs even where
    # the machine has one core.
    theta_II = np.radians(np.linspace(-25, 35, 60))
    results = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("VSW_THREADS", threads)
        b = basin(0.8, PHI0, theta_II, n_q=801, refine=False)
        results[threads] = (b.q_min, b.q_max)
    for one, two in zip(results["1"], results["2"]):
        np.testing.assert_array_equal(one, two)
