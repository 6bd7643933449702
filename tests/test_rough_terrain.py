"""Rough ground beyond one slope: the uniform draw, the height terrain's refusal, the MFPT
over a parameter (``vsw rough --over``), Spearman's rank correlation of the gait
sensitivity norm with the MFPT, and the walks on a Dask cluster."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vsw.cli import main
from vsw.models import load
from vsw.runtime.errors import VswInputError
from vsw.studies.rough import HEIGHT, Terrain, disturbance_index, rough_walks, terrain_noise
from vsw.studies.rough_sweep import parse_over, rough_sweep, spearman

WALKER = ["rough", "--model", "simplest-walker"]

HEIGHT_WHEEL = '''
"""A rimless wheel whose next foot lands on ground step_height above the stance foot."""
import sympy as sm

from derive.engine.model import (
    NORMAL_FORCE, Coordinate, Event, Failure, Impact, Model, Parameter, Phase, PointMass, leg,
)

PARAMETERS = (
    Parameter("alpha", "alpha", 0.0, 1.5707963267948966, "0 < alpha < pi/2", "half spoke angle",
              {"positive": True}, default=0.39269908169872414, unit="rad"),
    Parameter("gamma", "gamma", -1.5, 1.5, "slope", "slope angle", default=0.08, unit="rad"),
    Parameter("step_height", "h", -0.5, 0.5, "|h| < l / 2", "height of the next foothold",
              default=0.0, unit="m"),
    Parameter("l", "l", 0.0, float("inf"), "l > 0", "spoke length", {"positive": True},
              default=1.0, unit="m"),
    Parameter("g", "g", 0.0, float("inf"), "g > 0", "gravity", {"positive": True},
              default=9.81, unit="m/s^2"),
)
alpha, gamma, step_height, l, g = (p.symbol for p in PARAMETERS)
ANGLE = Coordinate("theta", "stance spoke angle", "rad", reference="the slope normal",
                   positive="downhill")
theta = ANGLE.q
ROLLING = Phase(
    "rolling",
    coordinates=(ANGLE,),
    bodies=(PointMass("hub", 1, leg(theta, l)),),
    gravity=(g * sm.sin(gamma), -g * sm.cos(gamma)),
    points={"next_foot": tuple(h - f for h, f in zip(leg(theta, l), leg(theta - 2 * alpha, l)))},
)
MODEL = Model(
    name="height_wheel",
    title="Rimless wheel on footholds of random height",
    description="a user's rimless wheel with the next foothold's height in its guard",
    source="a user's model file",
    parameters=PARAMETERS,
    phases=(ROLLING,),
    events=(Event("touchdown", "rolling", "rolling",
                  guard=ROLLING.points["next_foot"][1] - step_height,
                  direction=-1, reset=Impact("next_foot", {theta: theta - 2 * alpha}),
                  ends_step=True),),
    failures=(Failure("rolled-back", ANGLE.u, -1, "the wheel rolls back"),
              Failure("lift-off", NORMAL_FORCE, -1, "the foot leaves the slope")),
    units={"time": "s", "length": "m", "mass": "kg", "energy": "J/kg", "force": "N/kg"},
    step_length=2 * l * sm.sin(alpha),
    section={"theta": -alpha},
    search={"theta_dot": (0.0, 12.0)},
)
UNITS = "Angles in radians, lengths in m, time in s."
'''
"""A user's model file that takes the height terrain: the rimless wheel (as
tests/test_user_models.py writes it) with the next foothold's height in its guard, the
next foot's height minus step_height, falling (no ``at``: where the guard vanishes depends
on the height)."""


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_uniform_draws_are_uniform_with_unit_variance():
    from scipy import stats

    xi = terrain_noise(3, np.arange(200)[:, None], np.arange(300), "uniform")
    edge = math.sqrt(3.0)
    assert np.all(np.abs(xi) < edge)
    assert stats.kstest(xi.ravel(), stats.uniform(loc=-edge, scale=2 * edge).cdf).pvalue > 0.01
    assert abs(xi.var() - 1) < 4 * math.sqrt(0.8 / xi.size)  # var of x^2 for U: 4/5
    assert abs(np.mean(xi[:, 1:] * xi[:, :-1])) < 4 / math.sqrt(xi[:, 1:].size)
    # A draw is a function of (seed, walk, step) alone, as the Gaussian one.
    np.testing.assert_array_equal(terrain_noise(3, [7, 2], 11, "uniform"), xi[[7, 2], 11])


def test_gaussian_terrain_is_the_default_and_unchanged():
    params = np.array([0.009])
    a = Terrain(params, 0, 0.002, 5)(np.arange(6), 4)
    b = Terrain(params, 0, 0.002, 5, distribution="gaussian")(np.arange(6), 4)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a[:, 0], 0.009 + 0.002 * terrain_noise(5, np.arange(6), 4))


def test_a_model_without_a_ground_height_refuses_the_height_terrain():
    model = load("simplest-walker")
    with pytest.raises(VswInputError, match=HEIGHT):
        disturbance_index(model, "height")
    assert disturbance_index(model, "slope") == 0


@pytest.mark.parametrize(
    ("extra", "needle"),
    [
        (["--sigma", "-0.001"], "sigma"),
        (["--sigma", "0.001", "--terrain", "height"], "cannot take a height terrain"),
        (["--sigma", "0.001", "--walks", "0"], "walks = 0"),
        (["--sigma", "0.001", "--seed", "1.5"], "seed"),
        (["--sigma", "0.001", "--over", "sigma=0.001:0.002:0"], "empty range"),
        (["--sigma", "0.001", "--over", "sigma=0.002:0.002:3"], "empty range"),
        (["--sigma", "0.001", "--over", "sigma=0.001:0.002:1"], "empty range"),
        (["--sigma", "0.001", "--over", "sigma=-0.001:0.002:3"], "sigma"),
        (["--sigma", "0.001", "--over", "beta=0:1:3"], "sweeps one of"),
        (["--sigma", "0.001", "--over", "gamma0=0.01"], "NAME=a:b:n"),
        (["--sigma", "0.001", "--distribution", "uniform", "--method", "chain"], "Gaussian"),
        (["--sigma", "0.001", "--over", "gamma0=-1:0.01:3"], "gamma"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, extra, needle):
    code, out, err = run(capsys, [*WALKER, "--walks", "10", "--max-steps", "10", *extra])
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and needle in err, err


def test_a_vsw_biped_cannot_take_either_terrain(capsys):
    for terrain in ("slope", "height"):
        code, _, err = run(capsys, ["rough", "--model", "vsw-biped", "--sigma", "0.001",
                                    "--terrain", terrain])  # fmt: skip
        assert code == 2 and len(err.strip().splitlines()) == 1


def test_parse_over_gives_both_ends():
    name, values = parse_over("gamma0=0.008:0.011:4")
    assert name == "gamma0"
    np.testing.assert_allclose(values, [0.008, 0.009, 0.010, 0.011], rtol=0, atol=1e-15)


# --- Spearman's rank correlation ----------------------------------------------------------------


@pytest.mark.parametrize("seed", range(6))
def test_spearman_is_scipys(seed):
    from scipy.stats import spearmanr

    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 30))
    x = rng.normal(size=n)
    y = x * rng.normal() + rng.normal(size=n)
    if seed % 2:  # ties, which take their mean rank
        x, y = np.round(x), np.round(y * 2) / 2
    expected = spearmanr(x, y).statistic
    assert spearman(x, y) == pytest.approx(expected, abs=1e-12)


def test_spearman_on_monotone_and_degenerate_data():
    assert spearman([1, 2, 3, 4], [10, 20, 25, 400]) == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    assert spearman([1, 2], [1, 2]) is None
    assert spearman([1, 1, 1], [1, 2, 3]) is None


# --- the sweep ----------------------------------------------------------------------------------


@pytest.mark.slow
def test_a_sweep_point_is_the_walks_at_that_value():
    """Each value's MFPT is rough_walks' at that value from that value's gait, the gait
    continued from the last value's is the one the search finds (the last value, two
    continuations on), and the rank correlation is over the points."""
    model = load("simplest-walker")
    params = model.parameters({})
    sweep = rough_sweep(model, params, 0.0015, "gamma0", [0.009, 0.0095, 0.0105], walks=64,
                        max_steps=200, seed=2)  # fmt: skip
    names = (*model.coordinates, *model.rates)
    for point in sweep.points:
        p = model.parameters({"gamma": point["gamma0"]})
        start = [point["gait"]["state"][n] for n in names]
        alone = rough_walks(model, p, 0.0015, 64, 200, 2, start=start).to_dict()
        assert point["mfpt"]["value"] == pytest.approx(alone["mfpt"]["value"], rel=1e-12)
        assert point["failures"] == alone["failures"]
    searched = model.stable_gait(model.parameters({"gamma": 0.0105}), "the test's gait")
    for name, value in searched.state.items():
        assert sweep.points[-1]["gait"]["state"][name] == pytest.approx(value, abs=1e-9)
    gsn = [p["gsn"] for p in sweep.points]
    mfpt = [p["mfpt"]["value"] for p in sweep.points]
    assert sweep.correlation()["walks"] == {"rho": spearman(gsn, mfpt), "points": 3}


def test_the_sigma_sweep_command(capsys, tmp_path):
    png = tmp_path / "mfpt.png"
    argv = [*WALKER, "--sigma", "0.001", "--walks", "64", "--max-steps", "200", "--seed", "1",
            "--over", "sigma=0.0015:0.0025:3", "--json", "--plot", str(png)]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    data = json.loads(out)
    assert data["over"] == "sigma" and [p["sigma"] for p in data["points"]] == data["values"]
    mfpt = [p["mfpt"]["value"] for p in data["points"]]
    assert mfpt[0] > mfpt[-1]  # more noise, fewer steps
    assert data["units"]["quantities"]["sigma"] == "rad"
    assert data["units"]["quantities"]["mfpt"] == "steps"
    from tests.test_conventions import unlabelled

    assert unlabelled(data) == []
    # One gait at every sigma: its norm is one number, so no rank correlation.
    assert len({p["gsn"] for p in data["points"]}) == 1
    assert data["spearman_gsn_mfpt"]["walks"]["rho"] is None
    assert png.read_bytes().startswith(b"\x89PNG")


@pytest.mark.slow
def test_the_sweep_command_is_identical_run_to_run(capsys, tmp_path):
    argv = [*WALKER, "--sigma", "0.001", "--walks", "64", "--max-steps", "200", "--seed", "1",
            "--over", "sigma=0.0015:0.0025:3", "--json", "--plot"]  # fmt: skip
    outputs = []
    for name in ("a.png", "b.png"):
        code, out, err = run(capsys, [*argv, str(tmp_path / name)])
        assert code == 0, err
        outputs.append(json.loads(out)["points"])
    assert outputs[0] == outputs[1]
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


# --- a Dask cluster -----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes on loopback, one thread each."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address=None,
    ) as local:  # fmt: skip
        yield local.scheduler_address


@pytest.mark.slow
def test_walks_on_a_dask_cluster_are_the_local_ones(capsys, cluster):
    argv = [*WALKER, "--sigma", "0.0015", "--walks", "300", "--max-steps", "400", "--seed",
            "4", "--json"]  # fmt: skip
    code, out, err = run(capsys, argv)
    assert code == 0, err
    local = json.loads(out)
    code, out, err = run(capsys, [*argv, "--scheduler", cluster])
    assert code == 0, err
    remote = json.loads(out)
    assert remote.pop("scheduler") == cluster
    for data in (local, remote):
        data.pop("provenance")
    assert remote == local


def test_rough_walks_split_on_a_cluster_match_in_process(cluster):
    model = load("simplest-walker")
    params = model.parameters({})
    here = rough_walks(model, params, 0.002, 150, 100, seed=9)
    there = rough_walks(model, params, 0.002, 150, 100, seed=9, scheduler=cluster)
    np.testing.assert_array_equal(here.steps, there.steps)
    assert here.ended == there.ended


# --- the height terrain, on a user's model that takes it ----------------------------------------


@pytest.fixture(scope="module")
def height_wheel(tmp_path_factory):
    """The user's model derived into a directory of its own (VSW_MODELS_DIR)."""
    import os
    from pathlib import Path

    base = tmp_path_factory.mktemp("height_wheel")
    path = base / "height_wheel.py"
    path.write_text(HEIGHT_WHEEL)
    root = str(Path(__file__).resolve().parent.parent)
    saved = {k: os.environ.get(k) for k in ("VSW_MODELS_DIR", "PYTHONPATH")}
    os.environ["VSW_MODELS_DIR"] = str(base / "generated_models")
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [root, saved["PYTHONPATH"]]))
    try:
        yield str(path), load(str(path))
    finally:
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@pytest.mark.parametrize("distribution", ["gaussian", "uniform"])
def test_each_step_lands_on_its_drawn_foothold(height_wheel, distribution):
    """The wheel's next foot lands where its height above the stance foot is the step's
    draw: from the state after the impact (theta' = theta - 2 alpha) the foot's height at
    the impact is l (cos theta - cos theta'), which must be h_k, step after step."""
    from vsw.dynamics.batch import WALKED, simulator

    _, model = height_wheel
    params = model.parameters({})
    alpha = params[0]
    index = disturbance_index(model, "height")
    gait = model.stable_gait(params, "the test's start")
    start = np.array([gait.state[n] for n in (*model.coordinates, *model.rates)])
    terrain = Terrain(params, index, 0.01, 11, distribution=distribution)
    sim = simulator(model)
    walks = 40
    x, rows = np.tile(start, (walks, 1)), np.arange(walks)
    for k in range(4):
        step = sim.step(terrain(rows, k), x)
        done = step.outcome == WALKED
        after = step.final[done, 0]
        height = np.cos(after + 2 * alpha) - np.cos(after)
        np.testing.assert_allclose(height, terrain.slopes(rows, k)[done], rtol=0, atol=1e-9)
        x, rows = step.final[done], rows[done]
    # walk_varying's walks are these steps, walk for walk.
    walked = sim.walk_varying(terrain, np.tile(start, (walks, 1)), 4)
    np.testing.assert_array_equal(walked.final[rows], x)


def test_the_height_terrain_command(height_wheel, capsys):
    path, _ = height_wheel
    argv = ["rough", "--model", path, "--terrain", "height", "--sigma", "0.01", "--walks",
            "100", "--max-steps", "300", "--distribution", "uniform"]  # fmt: skip
    code, out, err = run(capsys, [*argv, "--json"])
    assert code == 0, err
    data = json.loads(out)
    assert data["terrain"] == "height" and data["distribution"] == "uniform"
    assert data["units"]["quantities"]["sigma"] == "m"
    assert data["gait_sensitivity"]["disturbance"] == HEIGHT
    from tests.test_conventions import unlabelled

    assert unlabelled(data) == []
    assert data["units"]["quantities"]["gsn_by_indicator.step_time"] == "s/m"
    assert data["mfpt"]["value"] is not None and data["failures"] > 0
    code, text, err = run(capsys, argv)
    assert code == 0, err
    assert "step_height_k = 0 + 0.01 xi_k m, xi_k uniform" in text
    assert "s/m" in text and "foothold height" in text
    code, out, err = run(capsys, [*argv, "--method", "chain"])
    assert code == 2 and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_a_sweep_with_the_chain_is_the_chain_at_each_value():
    from vsw.studies.rough_chain import rough_chain

    model = load("simplest-walker")
    params = model.parameters({})
    chain = {"noise_nodes": 24, "max_nodes": 3000}
    sweep = rough_sweep(model, params, 0.002, "sigma", [0.0015, 0.002], walks=100,
                        max_steps=400, chain=chain)  # fmt: skip
    gait = model.stable_gait(params, "the test's chain")
    for point in sweep.points:
        alone = rough_chain(model, params, point["sigma"], gait=gait, **chain)
        assert point["chain"]["mfpt_gait"] == pytest.approx(alone.final.mfpt_gait, rel=1e-9)
        low, high = point["mfpt"]["low"], point["mfpt"]["high"]
        assert low <= point["chain"]["mfpt_gait"] <= high  # the walks' interval holds it


@pytest.mark.slow
def test_the_vsw_biped_with_a_foothold_height_walks_as_the_vsw_biped_at_height_0(
    monkeypatch, tmp_path
):
    """docs/guide/rough-models/vsw_biped_height.py at step_height 0: every walk the VSW
    biped's, bit for bit (its guard less 0)."""
    from pathlib import Path

    from vsw.dynamics.batch import simulator

    root = Path(__file__).resolve().parent.parent
    monkeypatch.setenv("VSW_MODELS_DIR", str(tmp_path))
    monkeypatch.setenv("PYTHONPATH", str(root))
    plain = load("vsw-biped")
    height = load(str(root / "docs/guide/rough-models/vsw_biped_height.py"))
    values = {"beta": 0.97, "theta_II": -0.2}
    p, q = plain.parameters(values), height.parameters(values)
    assert tuple(q) == (*p, 0.0)
    gait = plain.stable_gait(p, "the test's starts")
    x = np.array([gait.state[n] for n in (*plain.coordinates, *plain.rates)])
    starts = x * (1 + 0.01 * np.random.default_rng(0).normal(size=(100, len(x))))
    a = simulator(plain).walk(p, starts, 40, converge_tol=0, period_tol=0)
    b = simulator(height).walk(q, starts, 40, converge_tol=0, period_tol=0)
    np.testing.assert_array_equal(a.steps, b.steps)
    np.testing.assert_array_equal(a.final, b.final)
    assert a.ended() == b.ended()
    assert disturbance_index(height, "height") == 4


def test_progress_is_drawn_on_a_terminal(monkeypatch, capsys):
    """A bar by steps on a terminal's stderr (made before the solvers' stderr is set
    aside), for the walks and for a sweep."""
    import io

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    for extra in ([], ["--over", "sigma=0.0015:0.002:2"]):
        terminal = Terminal()
        monkeypatch.setattr("sys.stderr", terminal)
        argv = [*WALKER, "--sigma", "0.0015", "--walks", "50", "--max-steps", "40", *extra]
        assert main(argv) == 0
        assert "rough pass 1 [" in terminal.getvalue() and "/40 " in terminal.getvalue()
    capsys.readouterr()
