"""Walking on rough ground: the per-step slope terrain, the Monte Carlo MFPT and its
estimator (Byl & Tedrake 2009), ``vsw rough``, and the gait sensitivity norm (Hobbelen &
Wisse 2007)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import vsw.dynamics.batch
from vsw.cli import main
from vsw.dynamics.batch import WALKED, simulator
from vsw.models import load
from vsw.runtime.errors import VswInputError
from vsw.studies.rough import (
    INDICATORS,
    SlopeTerrain,
    gait_sensitivity,
    h2_norm,
    mfpt_estimate,
    philox4x32,
    rough_walks,
    slope_impulse_response,
    slope_index,
    terrain_noise,
)

SIGMA = 0.0015
"""A slope noise (rad) at which the simplest walker's MFPT is a few tens of steps."""


@pytest.fixture(scope="module")
def walker():
    model = load("simplest-walker")
    params = model.parameters({})
    gait = model.stable_gait(params, "the tests' start")
    start = np.array([gait.state[n] for n in (*model.coordinates, *model.rates)])
    return model, params, gait, start


# --- the terrain --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("counter", "key", "expected"),
    [  # Random123's kat_vectors, philox4x32 10
        ((0, 0, 0, 0), (0, 0), "6627e8d5 e169c58d bc57ac4c 9b00dbd8"),
        ((2**32 - 1,) * 4, (2**32 - 1,) * 2, "408f276d 41c83b0e a20bc7c6 6d5451fd"),
        ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
         "d16cfe09 94fdcceb 5001e420 24126ea1"),
    ],
)  # fmt: skip
def test_philox_gives_the_known_answers(counter, key, expected):
    assert " ".join(f"{int(v):08x}" for v in philox4x32(counter, key)) == expected


def test_terrain_noise_depends_on_seed_walk_and_step_alone():
    steps = np.arange(50)
    many = terrain_noise(7, np.arange(10)[:, None], steps)
    np.testing.assert_array_equal(terrain_noise(7, [4], steps[:, None])[:, 0], many[4])
    np.testing.assert_array_equal(terrain_noise(7, [9, 4], 31), many[[9, 4], 31])
    np.testing.assert_array_equal(terrain_noise(7, 2**40 + 4, 3), terrain_noise(7, 2**40 + 4, 3))
    assert terrain_noise(7, 2**40 + 4, 3) != terrain_noise(7, 4, 3)
    assert terrain_noise(8, 4, 3) != many[4, 3] and terrain_noise(7, 4, 4) != many[4, 3]
    # Standard normal: Kolmogorov-Smirnov against scipy's normal over 200 walks x 500
    # steps, the moments within 4 standard errors, no correlation between consecutive steps
    # of a walk or between neighbouring walks.
    from scipy import stats

    xi = terrain_noise(0, np.arange(200)[:, None], np.arange(500))
    assert stats.kstest(xi.ravel(), "norm").pvalue > 0.01
    n = xi.size
    assert abs(xi.mean()) < 4 / math.sqrt(n)
    assert abs(xi.var() - 1) < 4 * math.sqrt(2 / n)
    assert abs(np.mean(xi[:, 1:] * xi[:, :-1])) < 4 / math.sqrt(xi[:, 1:].size)
    assert abs(np.mean(xi[1:] * xi[:-1])) < 4 / math.sqrt(xi[1:].size)


def test_slope_terrain_is_the_walks_own_at_any_offset(walker):
    model, params, _, _ = walker
    index = slope_index(model)
    whole = SlopeTerrain(params, index, 0.01, 3)
    part = SlopeTerrain(params, index, 0.01, 3, first_walk=5)
    rows = np.arange(5, 12)
    for k in (0, 63, 64, 1000):
        np.testing.assert_array_equal(whole(rows, k), part(rows - 5, k))
        expected = params[index] + 0.01 * terrain_noise(3, rows, k)
        np.testing.assert_array_equal(whole.slopes(rows, k), expected)
        np.testing.assert_array_equal(whole(rows, k)[:, index], expected)


def test_a_model_without_a_slope_is_refused():
    with pytest.raises(VswInputError, match="no slope parameter gamma"):
        slope_index(load("vsw-biped"))


# --- the walks ----------------------------------------------------------------------------------


def test_walks_do_not_depend_on_threads_blocks_or_partition(walker, monkeypatch):
    model, params, gait, start = walker
    runs = [rough_walks(model, params, SIGMA, 300, 60, 11, gait=gait, threads=t) for t in (1, 2)]
    monkeypatch.setattr(vsw.dynamics.batch, "CHUNK", 7)
    runs.append(rough_walks(model, params, SIGMA, 300, 60, 11, gait=gait, threads=2))
    for other in runs[1:]:
        np.testing.assert_array_equal(other.steps, runs[0].steps)
        assert other.ended == runs[0].ended
    # Walks 200..299 alone, as a part of the walks elsewhere would run them.
    terrain = SlopeTerrain(params, slope_index(model), SIGMA, 11, first_walk=200)
    part = simulator(model).walk_varying(terrain, np.tile(start, (100, 1)), 60, threads=1)
    np.testing.assert_array_equal(part.steps, runs[0].steps[200:])
    assert part.ended() == runs[0].ended[200:]
    assert 1 < len(set(runs[0].steps.tolist())) and "walked" in runs[0].ended


def test_the_walks_are_the_scipy_routes_on_the_same_slopes(walker):
    """Three walks by the batch simulator equal the SciPy route's steps
    (:meth:`HybridModel.step`) on the same slopes: step counts, failures, states."""
    model, params, _, start = walker
    index = slope_index(model)
    terrain = SlopeTerrain(params, index, 0.002, 5)
    batch = simulator(model).walk_varying(terrain, np.tile(start, (3, 1)), 60, threads=1)
    for w in range(3):
        x, k, ended = start.copy(), 0, "walked"
        while k < 60:
            p = list(params)
            p[index] = float(terrain.slopes(np.array([w]), k)[0])
            step = model.step(tuple(p), x)
            if step.ended != "completed":
                ended = step.ended
                break
            x, k = step.state, k + 1
        assert (int(batch.steps[w]), batch.ended()[w]) == (k, ended)
        if ended == "walked":
            np.testing.assert_allclose(batch.final[w], x, atol=1e-8)


def test_mfpt_agrees_with_an_independent_simulation(walker):
    """The batch Monte Carlo against walks of the compiled scalar step (step_phases) one at
    a time, on slopes from another generator (numpy's default PCG64), the plain mean of
    their first-passage steps: within three combined standard errors."""
    model, params, gait, start = walker
    mc = rough_walks(model, params, SIGMA, 4000, 5000, 0, gait=gait).estimate()
    assert mc.censored == 0 and mc.estimator.startswith("sample mean")
    rng = np.random.default_rng(0)
    sim, index, counts = simulator(model), slope_index(model), []
    for _ in range(1000):
        x, k = start.copy(), 0
        while True:
            p = list(params)
            p[index] += SIGMA * rng.standard_normal()
            step = sim.step_phases(p, x)
            if step.ended != "completed":
                break
            x, k = step.state, k + 1
        counts.append(k)
    mean, se = np.mean(counts), np.std(counts, ddof=1) / math.sqrt(len(counts))
    assert 10 < mc.mfpt < 100
    assert abs(mc.mfpt - mean) <= 3 * math.hypot(mc.se, se), (mc, mean, se)
    assert 0.5 < mc.se / (np.std(counts, ddof=1) / math.sqrt(4000)) < 2  # the same spread


def test_no_noise_no_failure(walker):
    model, params, gait, _ = walker
    r = rough_walks(model, params, 0.0, 20, 300, 0, gait=gait)
    e = r.estimate()
    assert (e.mfpt, e.failures, e.censored, e.total_steps) == (None, 0, 20, 6000)
    # The 95 % bound of p is 1 - 0.05^(1/6000), about 3/6000 (the rule of three).
    p_max = 1 - 0.05 ** (1 / 6000)
    assert e.low == pytest.approx((1 - p_max) / p_max, rel=1e-9)
    assert e.low == pytest.approx(6000 / 3, rel=2e-3)
    assert set(r.ended) == {"walked"}
    ks, fraction = r.survival()
    assert ks.tolist() == [0, 300] and fraction.tolist() == [1.0, 1.0]


# --- the estimator ------------------------------------------------------------------------------


@pytest.mark.parametrize("cap", [10_000, 40])
def test_the_interval_covers_a_known_mfpt(cap):
    """Geometric first passages of known MFPT (p = 1/31: MFPT 30), censored at ``cap``
    steps or not: the 95 % interval covers 30 in 93-97 % of 2000 samples of 300 walks,
    and the estimates average to 30 within 1 %."""
    rng = np.random.default_rng(0)
    covered, values = 0, []
    for _ in range(2000):
        t = rng.geometric(1 / 31, size=300) - 1  # steps completed before the failing one
        e = mfpt_estimate(np.minimum(t, cap), t < cap)
        covered += e.low <= 30 <= e.high
        values.append(e.mfpt)
    assert 0.93 <= covered / 2000 <= 0.97
    assert np.mean(values) == pytest.approx(30, rel=0.01)


def test_estimates_by_hand():
    e = mfpt_estimate(np.array([3, 5, 10, 10]), np.array([True, True, False, False]))
    assert (e.mfpt, e.failures, e.censored, e.total_steps) == (14.0, 2, 2, 28)
    assert e.se == pytest.approx(14 * math.sqrt(30 / 56))
    e = mfpt_estimate(np.array([1, 2, 6]), np.ones(3, bool))
    assert e.mfpt == 3.0 and e.se == pytest.approx(math.sqrt(7 / 3))


# --- vsw rough ----------------------------------------------------------------------------------


def test_the_command_json_and_plot_are_the_librarys_and_repeat(walker, capsys, tmp_path):
    argv = ["rough", "--model", "simplest-walker", "--sigma", "0.002", "--walks", "200",
            "--max-steps", "20", "--seed", "4", "--json"]  # fmt: skip
    outputs = []
    for name in ("a.png", "b.png"):
        assert main([*argv, "--plot", str(tmp_path / name)]) == 0
        outputs.append(capsys.readouterr().out.replace(name, ""))
    assert outputs[0] == outputs[1]
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()
    data = json.loads(outputs[0])
    model, params, gait, _ = walker
    e = rough_walks(model, params, 0.002, 200, 20, 4, gait=gait).estimate()
    assert data["mfpt"] == {"value": e.mfpt, "se": e.se, "low": e.low, "high": e.high}
    assert e.censored > 0 and data["estimator"].startswith("geometric")
    quantities = data["units"]["quantities"]
    assert quantities["mfpt"] == "steps" and quantities["sigma"] == "rad"
    assert sum(data["failures_by_kind"].values()) == data["failures"] == 200 - e.censored
    assert data["survival"]["fraction"][0] == 1.0
    assert data["gait_sensitivity"]["gsn"] == gait_sensitivity(model, params, gait).gsn
    assert quantities["gsn_by_indicator.step_time"] == "sqrt(l/g)/rad"


@pytest.mark.parametrize(
    "extra",
    [
        ["--model", "simplest-walker", "--sigma", "-0.001"],
        ["--model", "simplest-walker", "--sigma", "nan"],
        ["--model", "vsw-biped", "--sigma", "0.001"],
        ["--model", "simplest-walker", "--sigma", "0.001", "--walks", "0"],
        ["--model", "simplest-walker", "--sigma", "0.001", "--max-steps", "0"],
        ["--model", "simplest-walker", "--sigma", "0.001", "--seed", "1.5"],
        ["--model", "simplest-walker", "--sigma", "0.001", "--seed", "-1"],
        ["--model", "simplest-walker", "--sigma", "0.001", "--terrain", "height"],
        ["--model", "simplest-walker"],
    ],
)
def test_bad_input_is_one_line_exit_2(extra, capsys):
    assert main(["rough", *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err


def test_walks_step_by_step_keep_walking_states(walker):
    """walk_varying at fixed parameters is walk: the same states after the same steps."""
    model, params, _, start = walker
    sim = simulator(model)
    starts = start + np.linspace(-0.02, 0.02, 9)[:, None] * np.array([1, 2, 0, 0])
    fixed = sim.walk(params, starts, 12, converge_tol=0.0, period_tol=0.0, threads=1)
    varying = sim.walk_varying(lambda rows, k: np.tile(params, (len(rows), 1)), starts, 12,
                               threads=1)  # fmt: skip
    np.testing.assert_array_equal(varying.steps, fixed.steps)
    np.testing.assert_array_equal(varying.outcome, fixed.outcome)
    walked = fixed.outcome == WALKED
    np.testing.assert_array_equal(varying.final[walked], fixed.final[walked])


def test_walks_of_many_steps_a_call_are_steps_one_call_each(walker, monkeypatch):
    """walk_varying walks many steps a call, each walk with its own row of each step: the
    walks are those of one batch step a call from the state the last ended in, bit for bit
    (step counts, endings, the last states), for any steps a call, from the terrain's rows
    of many steps or from its rows of one step, and where the rows' size limits the call."""
    model, params, _, start = walker
    sim = simulator(model)
    terrain = SlopeTerrain(params, slope_index(model), 0.002, 4)
    walks, steps = 150, 45
    x, rows = np.tile(start, (walks, 1)), np.arange(walks)
    count = np.zeros(walks, dtype=np.int64)
    outcome, aux = np.full(walks, WALKED), np.zeros(walks, dtype=np.int64)
    final = x.copy()
    for k in range(steps):
        step = sim.step(terrain(rows, k), x, threads=1, tolerance=1e-10)
        done = step.outcome == WALKED
        final[rows] = step.final
        count[rows[done]] += 1
        outcome[rows[~done]], aux[rows[~done]] = step.outcome[~done], step.aux[~done]
        x, rows = step.final[done], rows[done]
    assert 0 < len(rows) < walks  # some walks fall, some walk every step

    def one_step_rows(walk_rows, k):
        return terrain(walk_rows, k)

    runs = []
    for per_call, size in ((1, None), (7, None), (32, None), (32, 4000)):
        monkeypatch.setattr(vsw.dynamics.batch, "STEPS_PER_CALL", per_call)
        if size is not None:  # room for the rows of 3 steps of the 150 walks, fewer walks more
            monkeypatch.setattr(vsw.dynamics.batch, "VARYING_BYTES", size)
        for rows_of in (terrain, one_step_rows):
            starts = np.tile(start, (walks, 1))
            runs.append(sim.walk_varying(rows_of, starts, steps, threads=2, tolerance=1e-10))
    for run in runs:
        np.testing.assert_array_equal(run.steps, count)
        np.testing.assert_array_equal(run.outcome, outcome)
        np.testing.assert_array_equal(run.aux, aux)
        np.testing.assert_array_equal(run.final, final)


def test_the_terrains_rows_of_many_steps_are_its_rows_of_each():
    model = load("compass-gait")
    params = model.parameters({})
    for distribution in ("gaussian", "uniform"):
        terrain = SlopeTerrain(
            params, slope_index(model), 0.01, 9, first_walk=3, distribution=distribution
        )
        walks = np.array([0, 2, 5, 11])
        many = terrain.of_steps(walks, 6, 5)
        assert many.shape == (4, 5, len(params))
        for j in range(5):
            np.testing.assert_array_equal(many[:, j], terrain(walks, 6 + j))


# --- the gait sensitivity norm ------------------------------------------------------------------


@pytest.mark.parametrize(
    "name",
    [
        "rimless-wheel",
        "simplest-walker",
        "compass-gait",
        pytest.param("kneed-walker", marks=pytest.mark.slow),  # its gait search: 20 s
        pytest.param("torso-walker", marks=pytest.mark.slow),
    ],
)
def test_gsn_is_the_nonlinear_maps_response(name):
    """The H2 norm of the linearised step (Hobbelen & Wisse 2007) against the 2-norm of the
    nonlinear map's response to the first step's slope alone, by central differences over
    120 steps: within 1e-6 relative, each indicator too; the linearisation's eigenvalues
    are the gait's (its monodromy matrix, the orbit solver's exact Jacobian) to 1e-6."""
    model = load(name)
    params = model.parameters({})
    gait = model.stable_gait(params, "the test")
    s = gait_sensitivity(model, params, gait)
    start = [gait.state[n] for n in (*model.coordinates, *model.rates)]
    response = slope_impulse_response(model, params, start, 120, 1e-6)
    assert np.all(np.abs(response[-1]) < 1e-6 * s.gsn)  # the response has died out
    assert s.gsn == pytest.approx(float(np.sqrt(np.sum(response**2))), rel=1e-6)
    for i, indicator in enumerate(INDICATORS):
        expected = float(np.sqrt(np.sum(response[:, i] ** 2)))
        assert s.by_indicator[indicator] == pytest.approx(expected, rel=1e-6, abs=1e-9)
    moduli = np.sort(np.abs(np.linalg.eigvals(s.A)))[::-1][: len(gait.eigenvalues)]
    np.testing.assert_allclose(moduli, [abs(e) for e in gait.eigenvalues], atol=1e-6)


def test_gsn_of_the_rimless_wheel_by_hand():
    """One state, the rate w just after impact: w' = cos(2a) sqrt(w^2 + 4 (g/l) sin(a)
    sin(gamma)), so A = cos^2(2a) at the gait and B = cos^2(2a) 2 (g/l) sin(a) cos(gamma) / w;
    the step time T = integral of dtheta / v over (-a, a), v^2 = w^2 + 2 (g/l) (cos(gamma
    - a) - cos(theta + gamma)) (energy), C = dT/dw, D = dT/dgamma under the integral; the
    step length 2 l sin(a) is constant. GSN^2 = D^2 + C^2 B^2 / (1 - A^2)."""
    from scipy.integrate import quad

    model = load("rimless-wheel")
    params = model.parameters({})
    alpha, gamma, l, g = params
    lam = math.cos(2 * alpha) ** 2
    w = math.sqrt(lam * 4 * (g / l) * math.sin(alpha) * math.sin(gamma) / (1 - lam))

    def v(theta: float) -> float:
        return math.sqrt(w**2 + 2 * (g / l) * (math.cos(gamma - alpha) - math.cos(theta + gamma)))

    def integral(f) -> float:
        return quad(f, -alpha, alpha, epsabs=0, epsrel=1e-13)[0]

    b = lam * 2 * (g / l) * math.sin(alpha) * math.cos(gamma) / w
    c = integral(lambda t: -w / v(t) ** 3)
    d = integral(lambda t: -(g / l) * (math.sin(t + gamma) - math.sin(gamma - alpha)) / v(t) ** 3)
    gait = model.stable_gait(params, "the test")
    assert gait.state["theta_dot"] == pytest.approx(w, rel=1e-10)
    s = gait_sensitivity(model, params, gait)
    assert s.A[1, 1] == pytest.approx(lam, rel=1e-6)
    assert (s.B[1], s.C[0, 1], s.D[0]) == pytest.approx((b, c, d), rel=1e-6)
    assert (s.B[0], s.C[1, 1], s.D[1]) == pytest.approx((0, 0, 0), abs=1e-6)
    assert s.gsn == pytest.approx(math.sqrt(d**2 + c**2 * b**2 / (1 - lam**2)), rel=1e-8)


def test_h2_norm_is_the_summed_impulse_response():
    rng = np.random.default_rng(3)
    for _ in range(20):
        A = rng.standard_normal((4, 4))
        A *= 0.9 / np.max(np.abs(np.linalg.eigvals(A)))
        B, C, D = rng.standard_normal(4), rng.standard_normal((2, 4)), rng.standard_normal(2)
        total, x = float(D @ D), B.copy()
        for _ in range(2000):
            total += float(np.sum((C @ x) ** 2))
            x = A @ x
        assert h2_norm(A, B, C, D) == pytest.approx(math.sqrt(total), rel=1e-10)
    with pytest.raises(VswInputError, match="stable gait"):
        h2_norm(np.eye(2) * 1.01, np.ones(2), np.ones((1, 2)), np.ones(1))


def test_the_run_time_limit_stops_the_walks_while_they_run(walker, monkeypatch, capsys):
    """Walks estimated as free (the estimate is taken as zero, so that what is tested is
    the limit kept while running) that would take hours: stopped at the limit of 2 s, one
    line, exit 2."""
    import time

    import vsw.cli.rough

    monkeypatch.setattr(vsw.cli.rough, "_check_cost", lambda *args: None)
    monkeypatch.setenv("VSW_MAX_SECONDS", "2")
    started = time.monotonic()
    argv = ["rough", "--model", "simplest-walker", "--sigma", "0", "--walks", "100000",
            "--max-steps", "100000"]  # fmt: skip
    assert main(argv) == 2
    assert time.monotonic() - started < 6
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.startswith("vsw: error: stopped after 2")
    assert captured.err.count("\n") == 1


def test_without_a_compiler_the_scipy_route_walks_the_same(monkeypatch):
    """VSW_KERNELS=0: the walks and the gait sensitivity norm by the SciPy route (its own
    tolerance, 1e-12), equal to the compiled ones: the same steps and failures, the norm
    to 1e-6."""
    model = load("rimless-wheel")
    params = model.parameters({})
    gait = model.stable_gait(params, "the test")
    compiled = rough_walks(model, params, 0.05, 3, 20, 2, gait=gait)
    norm = gait_sensitivity(model, params, gait).gsn
    monkeypatch.setenv("VSW_KERNELS", "0")
    scipy_route = rough_walks(model, params, 0.05, 3, 20, 2, gait=gait)
    assert scipy_route.route.startswith("SciPy") and compiled.route == "compiled"
    np.testing.assert_array_equal(scipy_route.steps, compiled.steps)
    assert scipy_route.ended == compiled.ended
    assert gait_sensitivity(model, params, gait).gsn == pytest.approx(norm, rel=1e-6)
