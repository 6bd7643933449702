"""A walk that ends before its first event (a start already past a failure): the
trajectory file and the plot hold the start state alone, and the run reports the failure
with the exit status it has without them."""

from __future__ import annotations

import contextlib
import csv
import io
import json

import numpy as np
import pytest

from vsw.cli import main
from vsw.dynamics.trajectories import sample_walk
from vsw.models import load

FALLING = {
    "compass-gait": ["--state", "theta=0.5", "--state", "psi=0.3", "--state", "theta_dot=-1.1",
                     "--state", "psi_dot=-3.14"],
    "rimless-wheel": ["--state", "theta=0.5", "--state", "theta_dot=-5"],
}  # fmt: skip


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_sampling_a_walk_that_ends_at_once_gives_the_start_alone():
    model = load("compass_gait")
    params = model.parameters()
    start = np.array([0.5, 0.3, -1.1, -3.14])
    walk = sample_walk(model, params, start, 2, 100.0)
    assert walk.ended != "completed" and walk.steps_completed == 0
    assert walk.t.tolist() == [0.0] and walk.event == ("",)
    np.testing.assert_array_equal(walk.states, start[None, :])
    assert np.isfinite(walk.energy).all()


@pytest.mark.parametrize("model", sorted(FALLING))
@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_simulate_writes_the_start_row_of_a_walk_that_ends_at_once(tmp_path, model, suffix):
    argv = ["simulate", "--model", model, *FALLING[model], "--steps", "2", "--json"]
    plain_code, plain_out, _ = _run(argv)
    path = tmp_path / f"walk{suffix}"
    code, out, err = _run([*argv, "--trajectory", str(path)])
    assert (code, err) == (plain_code, ""), err
    report = json.loads(out)
    assert report["ended"] == json.loads(plain_out)["ended"] != "completed"
    assert report["steps_completed"] == 0
    assert report["trajectory"]["rows"] == 1 and path.stat().st_size > 0
    if suffix == ".csv":
        names, units, *body = path.read_text().splitlines()
        assert units.startswith("#"), "the line after the header is the columns' units"
        rows = list(csv.DictReader([names, *body]))
        assert len(rows) == 1 and float(rows[0]["t"]) == 0.0


@pytest.mark.parametrize("model", sorted(FALLING))
def test_simulate_plots_a_walk_that_ends_at_once(tmp_path, model):
    path = tmp_path / "walk.png"
    argv = ["simulate", "--model", model, *FALLING[model], "--steps", "2"]
    code, out, err = _run([*argv, "--plot", str(path)])
    assert (code, err) == (0, ""), err
    assert "after 0 of 2 steps" in out and f"plot: {path}" in out
    assert path.read_bytes().startswith(b"\x89PNG")
