"""``vsw basin --model NAME --grid ... --grid ...``: basins of any model by the batch
simulator, locally and on a Dask cluster of two worker processes on this machine."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vsw.cli import main
from vsw.gaits.search import search

pytest.importorskip("casadi")

WALKER = ["basin", "--model", "simplest-walker"]
GRID = ["--grid", "theta=-0.36:-0.1:24", "--grid", "theta_dot=0.1:0.36:20"]


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def local_basin():
    import contextlib
    import io

    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        assert main([*WALKER, *GRID, "--json"]) == 0
    return json.loads(buffer.getvalue())


def test_basin_json_has_the_documented_fields(local_basin):
    data = local_basin
    for key in ("model", "parameters", "x_name", "y_name", "x", "y", "outcome", "steps",
                "fixed_point"):  # fmt: skip
        assert key in data, key
    assert data["model"] == "simplest-walker" and data["parameters"] == {"gamma": 0.009}
    assert (data["x_name"], data["y_name"]) == ("theta", "theta_dot")
    assert len(data["x"]) == 24 and len(data["y"]) == 20
    assert len(data["outcome"]) == 20 and all(len(row) == 24 for row in data["outcome"])
    labels = {c for row in data["outcome"] for c in row}
    assert labels <= {"converged", "fell", "other"} | {f"period-{k}" for k in range(2, 9)}
    assert {"converged", "fell"} <= labels
    # Garcia et al. 1998's stable gait at gamma = 0.009 (their signs are the opposite).
    assert data["fixed_point"]["theta"] == pytest.approx(-0.200310900, abs=1e-8)
    assert data["fixed_point"]["theta_dot"] == pytest.approx(0.199832473, abs=1e-8)
    steps = np.array(data["steps"])
    assert steps.shape == (20, 24) and steps.min() >= 0 and steps.max() <= 50
    counts = data["counts"]
    assert sum(counts.values()) == 480


def test_the_cell_at_the_gait_converges_at_once(capsys):
    gait = ["--grid", "theta=-0.200310900542987:-0.1:2", "--grid",
            "theta_dot=0.199832473003709:0.3:2"]  # fmt: skip
    code, out, _ = run(capsys, [*WALKER, *gait, "--json"])
    assert code == 0
    data = json.loads(out)
    assert data["outcome"][0][0] == "converged" and data["steps"][0][0] == 1


def test_outcome_rows_run_over_y_and_columns_over_x(capsys):
    """A 3 x 5 grid (x has 5 values, y 3): cell [i][j] is the walk from (x[j], y[i])."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    grid = ["--grid", "theta=-0.3:-0.1:5", "--grid", "theta_dot=0.15:0.25:3"]
    code, out, _ = run(capsys, [*WALKER, *grid, "--json"])
    assert code == 0
    data = json.loads(out)
    assert len(data["outcome"]) == 3 and len(data["outcome"][0]) == 5
    model = load("simplest_walker")
    params = model.parameters()
    target = np.array(list(data["fixed_point"].values()))
    sim = simulator(load("simplest_walker"))
    for i, y in enumerate(data["y"]):
        for j, x in enumerate(data["x"]):
            state = target.copy()
            state[0], state[2] = x, y
            state = np.array(model.module.section_completion(*params, *state), float)
            walk = sim.walk(params, state[None], 50, target=target)
            assert walk.labels()[0] == data["outcome"][i][j]
            assert int(walk.steps[0]) == data["steps"][i][j]
    assert len({c for row in data["outcome"] for c in row}) >= 1


def test_basin_plot_is_written_and_deterministic(capsys, tmp_path):
    first, second = tmp_path / "a.png", tmp_path / "b.png"
    small = ["--grid", "theta=-0.3:-0.1:8", "--grid", "theta_dot=0.1:0.3:8"]
    for path in (first, second):
        code, out, err = run(capsys, [*WALKER, *small, "--plot", str(path)])
        assert code == 0 and err == "" and f"plot: {path}" in out
    assert first.read_bytes() == second.read_bytes()
    assert first.stat().st_size > 10_000


def test_compass_gait_basin_over_the_rates(capsys):
    """The compass gait's section fixes psi = -theta; a grid over the two rates at the
    gait's theta holds the gait's own cell."""
    grid = ["--grid", "theta_dot=0.5:2.5:6", "--grid", "psi_dot=-1:3:6"]
    code, out, _ = run(capsys, ["basin", "--model", "compass-gait", *grid, "--json"])
    assert code == 0
    data = json.loads(out)
    assert "fell" in data["counts"] and data["fixed_point"]["psi"] == pytest.approx(
        -data["fixed_point"]["theta"], abs=1e-12
    )


BAD = [
    ([*WALKER, "--grid", "theta=-0.3:-0.1:5"], ["twice"]),
    ([*WALKER, "--grid", "theta=-0.3:-0.1", "--grid", "theta_dot=0:1:3"], ["START:STOP:N"]),
    ([*WALKER, "--grid", "theta=-0.1:-0.3:5", "--grid", "theta_dot=0:1:3"], ["below"]),
    ([*WALKER, "--grid", "theta=-0.3:-0.1:1", "--grid", "theta_dot=0:1:3"], ["N = 1"]),
    ([*WALKER, "--grid", "theta=-0.3:inf:5", "--grid", "theta_dot=0:1:3"], ["finite"]),
    ([*WALKER, "--grid", "theta=a:b:5", "--grid", "theta_dot=0:1:3"], ["theta=a:b:5", "finite"]),
    ([*WALKER, "--grid", "theta=0:1:x", "--grid", "theta_dot=0:1:3"], ["integer"]),
    ([*WALKER, "--grid", "psi=0:1:3", "--grid", "theta_dot=0:1:3"],
     ["psi", "theta, phi, theta_dot, phi_dot"]),
    ([*WALKER, "--grid", "phi=0:1:3", "--grid", "theta_dot=0:1:3"], ["phi", "follows from"]),
    ([*WALKER, "--grid", "theta=0:1:3", "--grid", "theta=0:1:3"], ["twice"]),
    ([*WALKER, *GRID, "--steps", "0"], ["--steps"]),
    ([*WALKER, *GRID, "--tol", "2"], ["--tol"]),
    ([*WALKER, *GRID, "--n-rates", "4"], ["unrecognized arguments: --n-rates"]),
    ([*WALKER, *GRID, "--plot", "x.txt"], [".png"]),
    ([*WALKER, "--plot", "x.png"], ["--grid", "theta=START:STOP:N"]),
    ([*WALKER], ["--grid", "theta=START:STOP:N"]),
    ([*WALKER, *GRID, "--theta-step", "5"], ["--theta-step", "ile"]),
    (["basin", "--beta", "0.8", "--phi0", "45", "--steps", "5"], ["--steps", "give --grid"]),
    (["basin", "--beta", "0.8", "--phi0", "45", "--grid", "theta=0:1:3"],
     ["theta follows from theta_dot"]),
    (["basin", "--grid", "theta_dot=0.1:1:3", "--theta-step", "5"], ["--theta-step", "drop"]),
    ([*WALKER, *GRID, "--scheduler", "tcp://127.0.0.1:1"], ["no Dask scheduler"]),
    ([*WALKER, *GRID, "--scheduler", "notanaddress"], ["not a Dask address"]),
    ([*WALKER, *GRID, "--scheduler", "tcp://"], ["not a Dask address"]),
]  # fmt: skip


@pytest.mark.parametrize("argv, words", BAD, ids=[" ".join(a[2:]) for a, _ in BAD])
def test_bad_grid_input_is_one_line_exit_2(capsys, argv, words):
    code, out, err = run(capsys, argv)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    for word in words:
        assert word in err, err


def test_large_grid_is_refused_at_once(capsys, monkeypatch):
    monkeypatch.setenv("VSW_MAX_SECONDS", "30")
    code, _, err = run(capsys, [*WALKER, "--grid", "theta=-1:0:4000", "--grid",
                                  "theta_dot=0:1:4000", "--steps", "1000"])  # fmt: skip
    assert code == 2 and "VSW_MAX_SECONDS" in err and err.count("\n") == 1


# --- Dask ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def cluster():
    """Two worker processes on loopback, one thread each (the CI's cluster)."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
        dashboard_address=None,
    ) as local:  # fmt: skip
        yield local.scheduler_address


def test_basin_on_a_dask_cluster_is_the_local_one_byte_for_byte(capsys, cluster, local_basin):
    code, out, err = run(capsys, [*WALKER, *GRID, "--json", "--scheduler", cluster])
    assert code == 0, err
    data = json.loads(out)
    assert data.pop("scheduler") == cluster
    assert data.pop("provenance")["command"].endswith(f"--scheduler {cluster}")
    local = {k: v for k, v in local_basin.items() if k != "provenance"}
    assert json.dumps(data, sort_keys=True) == json.dumps(local, sort_keys=True)


def test_dask_blocks_do_not_change_the_walks(cluster, monkeypatch):
    import vsw.studies.cluster
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    sim = simulator(load("compass_gait"))
    params = sim.model.parameters()
    state = np.array([-0.2, 0.2, 1.2, 0.5])
    starts = state * (1 + 0.05 * np.random.default_rng(9).standard_normal((50, 4)))
    local = sim.walk(params, starts, 10, keep=2)
    monkeypatch.setattr(vsw.studies.cluster, "BLOCK", 7)
    remote = sim.walk(
        params, starts, 10, keep=2, runner=vsw.studies.cluster.runner(cluster, sim.model.name)
    )
    fields = ("outcome", "aux", "steps", "final", "kept_states", "kept_lengths",
              "kept_durations")  # fmt: skip
    for field in fields:
        assert getattr(local, field).tobytes() == getattr(remote, field).tobytes(), field
    assert remote.route == "compiled"


def test_scheduler_from_the_environment(capsys, cluster, monkeypatch):
    monkeypatch.setenv("VSW_DASK_SCHEDULER", cluster)
    small = ["--grid", "theta=-0.3:-0.1:4", "--grid", "theta_dot=0.1:0.3:4", "--json"]
    code, out, _ = run(capsys, [*WALKER, *small])
    assert code == 0 and json.loads(out)["scheduler"] == cluster


# --- brute-force bifurcation diagrams -------------------------------------------------------


@pytest.fixture(scope="module")
def brute_force():
    import contextlib
    import io

    buffer = io.StringIO()
    argv = ["sweep", "--model", "simplest-walker", "--over", "gamma=0.0145:0.0165:5",
            "--brute-force", "--transient", "300", "--keep", "8", "--json"]  # fmt: skip
    with contextlib.redirect_stdout(buffer):
        assert main(argv) == 0
    return json.loads(buffer.getvalue())


def test_brute_force_gaits_are_the_rootfinders(brute_force):
    """Each value's period-one gait (batch Newton) is the CasADi rootfinder's to 1e-10, and
    its max |eigenvalue| (differences of batch steps) the rootfinder's to 1e-5."""
    from vsw.models import load

    model = load("simplest_walker")
    assert brute_force["method"] == "brute-force"
    for point in brute_force["points"]:
        params = model.parameters({"gamma": point["gamma"]})
        # the rootfinder from its own scan (a coarse one: the gaits are near the middle of
        # wide bands of states that complete a step), not from the batch result
        found = search(model, params, cells=240**2).gaits
        orbit = sorted(found, key=lambda o: o.period)[1]  # Garcia's long gait
        ours = np.array(list(point["state"].values()))
        theirs = np.array(list(orbit.state.values()))
        assert np.max(np.abs(ours - theirs)) <= 1e-10
        assert point["max_abs_eigenvalue"] == pytest.approx(orbit.max_abs_eigenvalue, rel=1e-5)


def test_brute_force_attractor_is_the_scipy_routes(brute_force):
    """Past the flip (gamma = 0.015089) the iterated map settles on the period-two gait:
    the batch walk's kept steps equal HybridModel.attractor's (SciPy) from the same start."""
    from vsw.models import load

    model = load("simplest_walker")
    periods = {p["gamma"]: p["attractor"]["period"] for p in brute_force["points"]}
    assert periods[0.0145] == 1 and periods[0.0165] == 2, periods
    point = brute_force["points"][-1]
    params = model.parameters({"gamma": point["gamma"]})
    start = np.array(list(point["state"].values())) * (1 + 1e-6)
    scipy_route = model.attractor(params, start, 300, 8)
    assert scipy_route.period == 2
    ours = np.array([list(s.values()) for s in point["attractor"]["states"]])
    assert np.max(np.abs(ours - scipy_route.states)) <= 1e-8
    assert point["attractor"]["step_lengths"] == pytest.approx(
        list(scipy_route.step_lengths), abs=1e-8
    )


@pytest.mark.parametrize(
    "argv, words",
    [
        (["sweep", "--model", "simplest-walker", "--over", "gamma=0.01:0.02:3", "--state",
          "theta=0"], ["--state", "phi"]),
        (["sweep", "--beta", "0.8", "--phi0", "45", "--over", "theta_II=0:0.1:3",
          "--brute-force"], ["--brute-force", "ile"]),
        (["sweep", "--model", "simplest-walker", "--over", "gamma=0.01:0.02:3",
          "--brute-force", "--keep", "0"], ["--keep"]),
        (["sweep", "--model", "simplest-walker", "--over", "gamma=0.01:0.02:3",
          "--brute-force", "--state", "theta=0"], ["--state", "phi"]),
    ],
)  # fmt: skip
def test_bad_brute_force_input_is_one_line(capsys, argv, words):
    code, out, err = run(capsys, argv)
    assert code == 2 and out == "" and err.count("\n") == 1
    for word in words:
        assert word in err, err
