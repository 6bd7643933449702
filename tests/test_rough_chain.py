"""The meshed Markov chain of walking on rough ground (vsw.studies.rough_chain): its pieces on a
map with a known answer, and its MFPT against the Monte Carlo walks' 95 % interval on the
simplest walker and the compass gait (Byl & Tedrake, "Metastable walking machines",
IJRR 28(8), 2009, Sec. 4)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.sparse import csr_matrix

from vsw.cli import main
from vsw.models import load
from vsw.runtime.errors import VswInputError
from vsw.studies.rough import rough_walks
from vsw.studies.rough_chain import Mesh, chain_solve, noise_quadrature, rough_chain

A, SIGMA, BOUND = 0.8, 0.3, 1.0
"""The 1-D map x' = A x + SIGMA xi, a fall when |x'| > BOUND."""


def _linear_chain(nodes: int, noise: int) -> tuple[float, float, float]:
    """The chain of the 1-D map on ``nodes`` mesh nodes over [-BOUND, BOUND] and ``noise``
    Gauss-Hermite nodes: (lambda_2, the quasi-stationary mean |x|, steps completed from 0)."""
    mesh = Mesh((np.linspace(-BOUND, BOUND, nodes),))
    xi, w = noise_quadrature(noise)
    starts = np.append(mesh.axes[0], 0.0)
    y = (A * starts[:, None] + SIGMA * xi[None, :]).reshape(-1, 1)
    index, weight, _ = mesh.interpolation(y)
    p = np.tile(w, len(starts)) * (np.abs(y[:, 0]) <= BOUND)
    start = np.repeat(np.arange(len(starts)), len(xi))
    M = csr_matrix(((p[:, None] * weight).ravel(), (np.repeat(start, 2), index.ravel())),
                   shape=(len(starts), nodes)).tocsr()  # fmt: skip
    lam, pi, steps = chain_solve(M[:-1], M[-1].toarray().ravel())
    return lam, float(pi @ np.abs(mesh.axes[0])), steps


def _nystrom(nodes: int = 400) -> float:
    """Steps completed from 0 by the integral equation n(x) = 1 + int_{-B}^{B} k(x, y) n(y) dy
    (k the normal density of y about A x), Gauss-Legendre on [-B, B] (Nystrom's method;
    Atkinson, "The numerical solution of integral equations of the second kind", 1997,
    ch. 4): no mesh and no noise quadrature."""
    t, v = np.polynomial.legendre.leggauss(nodes)
    x, wx = BOUND * t, BOUND * v
    kernel = np.exp(-0.5 * ((x[None, :] - A * x[:, None]) / SIGMA) ** 2) / (
        SIGMA * math.sqrt(2 * math.pi)
    )
    n = np.linalg.solve(np.eye(nodes) - kernel * wx[None, :], np.ones(nodes))
    density = np.exp(-0.5 * (x / SIGMA) ** 2) / (SIGMA * math.sqrt(2 * math.pi))
    return float(density @ (wx * n))  # n(0) - 1: the failing step not counted


def test_linear_map_against_nystrom_and_sampling() -> None:
    """The chain's steps from 0 within 1 % of Nystrom's, which 10000 sampled walks confirm
    within three standard errors; the coarse mesh is further off than the fine one."""
    exact = _nystrom()
    rng = np.random.default_rng(5)
    x, steps, alive = np.zeros(10000), np.zeros(10000), np.ones(10000, dtype=bool)
    while alive.any():
        x[alive] = A * x[alive] + SIGMA * rng.standard_normal(alive.sum())
        fell = alive & (np.abs(x) > BOUND)
        alive &= ~fell
        steps[alive] += 1
    se = steps.std(ddof=1) / math.sqrt(len(steps))
    assert abs(steps.mean() - exact) < 3 * se
    _, _, fine = _linear_chain(801, 40)
    _, _, coarse = _linear_chain(21, 40)
    assert abs(fine - exact) < 0.01 * exact
    assert abs(coarse - exact) > abs(fine - exact)


def test_mesh_pieces() -> None:
    """Multilinear weights sum to 1 and reproduce a linear function; refinement keeps the
    box, grows the nodes and puts more of them where the mass is; quadrature moments."""
    mesh = Mesh((np.linspace(-1, 1, 5), np.array([0.0, 0.1, 0.5, 2.0])))
    rng = np.random.default_rng(0)
    y = np.column_stack([rng.uniform(-1, 1, 50), rng.uniform(0, 2, 50)])
    index, weight, outside = mesh.interpolation(y)
    nodes = mesh.nodes()
    assert np.allclose(weight.sum(axis=1), 1) and not outside.any()
    f = 3 * nodes[:, 0] - 2 * nodes[:, 1] + 1
    assert np.allclose((weight * f[index]).sum(axis=1), 3 * y[:, 0] - 2 * y[:, 1] + 1)
    _, _, out = mesh.interpolation(np.array([[1.5, 1.0]]))
    assert out[0]
    mass = np.zeros(mesh.shape)
    mass[2, 1] = 1.0
    finer = mesh.refined(mass.ravel())
    assert finer.axes[0][0] == -1 and finer.axes[0][-1] == 1 and finer.size > mesh.size
    assert np.sum(np.abs(finer.axes[0]) < 0.25) > np.sum(np.abs(mesh.axes[0]) < 0.25)
    for kind in ("gauss-hermite", "quantile"):
        xi, w = noise_quadrature(40, kind)
        assert abs(w.sum() - 1) < 1e-12 and abs(w @ xi) < 1e-12
        assert abs(w @ xi**2 - 1) < (1e-10 if kind == "gauss-hermite" else 0.05)
    with pytest.raises(VswInputError):
        noise_quadrature(0)


def _problem(name: str, slope: float) -> tuple:
    model = load(name)
    params = np.array([p.default for p in model.parameter_table])
    params[list(model.spec["parameters"]).index("gamma")] = slope
    return model, params


def _agree(name: str, slope: float, sigma: float, walks: int, max_nodes: int) -> None:
    model, params = _problem(name, slope)
    gait = model.stable_gait(params, "test")
    mc = rough_walks(model, params, sigma, walks, 5000, 0, gait=gait).estimate()
    chain = rough_chain(model, params, sigma, gait=gait, max_nodes=max_nodes,
                        check_quadrature=False)  # fmt: skip
    value = chain.final.mfpt_gait
    assert mc.low <= value <= mc.high, (value, mc.low, mc.high, chain.converged)


def test_simplest_walker_chain_agrees_cheap() -> None:
    """Sigma 0.002 on a mesh of at most 3000 nodes: inside the walks' 95 % interval."""
    _agree("simplest-walker", 0.009, 0.002, 2000, 3000)


@pytest.mark.slow
@pytest.mark.parametrize("sigma", [0.001, 0.0015, 0.002])
def test_simplest_walker_chain_agrees(sigma: float) -> None:
    _agree("simplest-walker", 0.009, sigma, 2000, 100_000)


@pytest.mark.slow
@pytest.mark.parametrize("sigma", [0.01, 0.0125, 0.015])
def test_compass_gait_chain_agrees(sigma: float) -> None:
    _agree("compass-gait", 0.0525, sigma, 1000, 100_000)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the chain is too coarse at sigma 0.0075: 119.9 steps "
                   "on 64 000 nodes, 124.1 on 216 000, still rising, the walks' interval "
                   "[125.5, 142.2]; 126.9 on 729 000 nodes, past this budget (4 min of CPU, "
                   "4.4 GB)")  # fmt: skip
def test_compass_gait_chain_agrees_at_the_lowest_noise() -> None:
    _agree("compass-gait", 0.0525, 0.0075, 1000, 100_000)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="at sigma 0.02 the chain gives 6.62 steps on its budget of "
                   "100 000 nodes, below the walks' interval [7.14, 7.83]")  # fmt: skip
def test_compass_gait_chain_agrees_at_the_highest_noise() -> None:
    _agree("compass-gait", 0.0525, 0.02, 1000, 100_000)


def test_chain_refuses_zero_noise() -> None:
    model, params = _problem("simplest-walker", 0.009)
    with pytest.raises(VswInputError):
        rough_chain(model, params, 0.0)


# --- vsw rough --method chain -------------------------------------------------------------------


def test_the_command_chain_json_repeats(capsys):
    """--method chain --json twice: byte-identical, the chain's keys with their units."""
    argv = ["rough", "--model", "simplest-walker", "--param", "gamma=0.009", "--sigma", "0.002",
            "--method", "chain", "--max-nodes", "1100", "--noise-nodes", "8", "--json"]  # fmt: skip
    outputs = []
    for _ in range(2):
        assert main(argv) == 0
        outputs.append(capsys.readouterr().out)
    assert outputs[0] == outputs[1]
    data = json.loads(outputs[0])
    chain = data["chain"]
    assert chain["nodes"] == 1024 and chain["refinements"] == 0 and not chain["converged"]
    assert chain["components"] == ["theta", "theta_dot"] and "mfpt" not in data
    assert 0 < chain["lambda2"] < 1 and chain["mfpt_gait"] > chain["mfpt_qsd"] > 0
    assert chain["byl_tedrake"] == pytest.approx(1 / (1 - chain["lambda2"]))
    units = data["units"]["quantities"]
    assert units["mfpt_gait"] == units["mfpt_qsd"] == "steps" and units["lambda2"] == "1"


@pytest.mark.parametrize(
    "extra",
    [
        ["--noise-nodes", "0"],
        ["--max-nodes", "5"],
        ["--method", "chain", "--sigma", "0"],
        ["--method", "chain", "--state", "theta=-0.2"],
        ["--method", "chain", "--plot", "x.png"],
        ["--method", "markov"],
    ],
)
def test_chain_bad_input_is_one_line_exit_2(extra, capsys):
    argv = ["rough", "--model", "simplest-walker", "--sigma", "0.002", *extra]
    if "--sigma" in extra:
        argv = ["rough", "--model", "simplest-walker", *extra]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1, captured.err
