"""Trajectories out (``vsw simulate --trajectory``): sampled at the rate asked, events exact,
physics the sampling does not assume, and the three file types read back as written."""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math

import numpy as np
import pytest

from tests.conftest import gait_start, passive_keys
from vsw.cli import main
from vsw.dynamics.trajectories import sample_walk, write_trajectory
from vsw.dynamics.walks import walk

RATE = 200.0
STEPS = 3
PASSIVE = ("rimless_wheel", "simplest_walker", "compass_gait")


@pytest.fixture(scope="module")
def sampled():
    """Every model's walk of three steps from its start (its stable gait, or the closed
    form's), sampled at 200 per time unit. The starts are the kept gaits, confirmed
    (tests.conftest.gait_start): a search of every model's section is the gait search's
    tests' work, not this module's."""
    out = {}
    for key in passive_keys():
        model, params, start = gait_start(key)
        out[key] = (model, params, start, sample_walk(model, params, start, STEPS, RATE))
    return out


@pytest.mark.parametrize("key", passive_keys())
def test_regular_samples_are_at_the_rate_and_events_come_in_pairs(sampled, key):
    w = sampled[key][3]
    assert w.ended == "completed" and w.steps_completed == STEPS
    regular = np.array([e == "" for e in w.event])
    k = w.t[regular] * RATE
    assert np.allclose(k, np.round(k), atol=1e-6), "regular samples off the grid k / rate"
    assert np.all(np.diff(np.round(k)) == 1), "a regular sample missing or repeated"
    assert np.all(np.diff(w.t) >= 0), "rows out of time order"
    events = [(i, e) for i, e in enumerate(w.event) if e]
    names = [e for _, e in events]
    assert names[0::2] == [n.replace(":after", ":before") for n in names[1::2]]
    for (i, _), (j, _) in zip(events[0::2], events[1::2]):
        assert j == i + 1 and w.t[i] == w.t[j]  # before and after at one instant


@pytest.mark.parametrize("key", passive_keys())
def test_the_step_events_land_on_the_walks_section_states(sampled, key):
    """The state just after each step event equals the Poincaré map's (vsw.dynamics.walks)."""
    model, params, start, w = sampled[key]
    step_event = model.step_event["name"]
    after = w.states[[i for i, e in enumerate(w.event) if e == f"{step_event}:after"]]
    expected = np.array(walk(model, params, start, STEPS).states[1:])
    assert after.shape == expected.shape
    assert np.max(np.abs(after - expected)) <= 1e-9 * max(1.0, np.max(np.abs(expected)))


@pytest.mark.parametrize("key", PASSIVE)
def test_passive_walkers_keep_their_energy_between_impacts_and_per_step(sampled, key):
    """Physics the sampling does not use: a passive phase conserves T + V (to the
    integrator's 1e-12 tolerance, relative), and on the periodic gait the energy in each
    step's own chart is the same at every step's start (impact loss = slope's gain)."""
    w = sampled[key][3]
    scale = np.max(np.abs(w.energy))
    for step in range(STEPS):
        rows = w.step == step
        assert np.ptp(w.energy[rows]) <= 1e-8 * scale, (step, np.ptp(w.energy[rows]))
    starts = w.energy[[i for i, e in enumerate(w.event) if e.endswith(":after")]]
    assert np.ptp(np.concatenate([[w.energy[0]], starts])) <= 1e-8 * scale


def test_the_biped_extension_adds_what_the_heelstrike_takes(sampled):
    """The VSW biped on its gait: over a step the energy the extension adds equals what
    the heelstrike dissipates (energy balance of a periodic gait; both from the rows)."""
    w = sampled["vsw_biped"][3]
    jumps = {}
    for i, e in enumerate(w.event):
        if e.endswith(":after"):
            jumps.setdefault(e.split(":")[0], []).append(w.energy[i] - w.energy[i - 1])
    added, lost = np.array(jumps["extension"]), np.array(jumps["heelstrike"])
    assert np.all(added > 0) and np.all(lost < 0)
    # level ground: the chart's potential is the same after the heelstrike
    assert np.allclose(added, -lost, rtol=1e-6)


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".mat"])
def test_files_read_back_as_written_and_are_byte_identical(sampled, tmp_path, suffix):
    model, params, _, w = sampled["compass_gait"]
    first, second = tmp_path / f"a{suffix}", tmp_path / f"b{suffix}"
    write_trajectory(first, model, params, w)
    write_trajectory(second, model, params, w)
    assert first.read_bytes() == second.read_bytes()
    if suffix == ".csv":
        rows = list(csv.reader(io.StringIO(first.read_text())))
        header, units, body = rows[0], rows[1], rows[2:]
        assert units[0].startswith("#"), "the second line is the columns' units, commented"
        assert header == ["t", "step", "phase", *w.names, "energy", "normal_force", "event"]
        assert np.array_equal(np.array([float(r[0]) for r in body]), w.t)
        states = np.array([[float(v) for v in r[3 : 3 + len(w.names)]] for r in body])
        assert np.array_equal(states, w.states)
        assert [r[-1] for r in body] == list(w.event)
        return
    if suffix == ".npz":
        data = dict(np.load(first))
        names = [str(n) for n in data["state_names"]]
        events = [str(e) for e in data["event"]]
    else:
        scipy_io = pytest.importorskip("scipy.io")
        data = scipy_io.loadmat(first)
        names = [str(n).strip() for n in data["state_names"]]
        events = [str(e).strip() for e in data["event"]]
        data = {k: np.squeeze(v) for k, v in data.items() if not k.startswith("__")}
    assert np.array_equal(data["t"], w.t)
    assert np.array_equal(data["state"], w.states)
    assert np.array_equal(data["energy"], w.energy)
    assert np.array_equal(data["normal_force"], w.normal_force)
    assert names == list(w.names) and events == list(w.event)
    units = json.loads(str(data["units"]))
    assert units["t"] == "s" and units["energy"] == "J" and units["theta"] == "rad"


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def test_simulate_writes_a_trajectory_and_reports_it(tmp_path):
    path = tmp_path / "walk.csv"
    code, out, err = _run(["simulate", "--model", "rimless-wheel", "--steps", "2",
                           "--trajectory", str(path), "--rate", "50", "--json"])  # fmt: skip
    assert code == 0, err
    report = json.loads(out)["trajectory"]
    assert report["path"] == str(path) and report["rate"] == 50.0
    assert report["rows"] == len(path.read_text().splitlines()) - 2  # names, units
    assert report["units"]["theta_dot"] == "rad/s"


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (["--trajectory", "walk.txt"], "must end in one of .csv, .npz, .mat"),
        (["--trajectory", "/no/such/dir/walk.csv"], "does not exist"),
        (["--trajectory", "walk.csv", "--rate", "0"], "--rate = 0 must be"),
        (["--trajectory", "walk.csv", "--rate", "nan"], "--rate = nan must be"),
    ],
)
def test_bad_trajectory_options_are_one_line(tmp_path, monkeypatch, option, message):
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(["simulate", "--model", "rimless-wheel", "--steps", "1", *option])
    assert code == 2 and out == "" and err.count("\n") == 1 and message in err, err


def test_a_huge_rate_is_refused_by_the_limits(tmp_path, monkeypatch):
    monkeypatch.setenv("VSW_MAX_MEMORY", "64M")
    code, _, err = _run(["simulate", "--model", "rimless-wheel", "--steps", "3",
                         "--trajectory", str(tmp_path / "w.npz"), "--rate", "1e6"])  # fmt: skip
    assert code == 2 and "samples" in err and "--rate" in err and not math.isnan(len(err))
