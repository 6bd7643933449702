"""A powered gait kept and replayed: ``vsw optimize --out FILE`` and ``--gait FILE`` of
``vsw simulate``, ``vsw animate`` and ``vsw explore`` (vsw/studies/gait_file.py).

One optimisation for the module: the compass gait's least squared hip torque at 0.8 m/s on
10 and 20 intervals, whose collocation is not judged optimal (its re-simulation ends 4e-6
from the last knot) while the open-loop step it implies has a fixed point: a gait file of
status ``verified``, never ``optimal``. Checked against what the replay does not share with
the optimiser: the generated energy function (its change over the stance is the torque's
work), the periodicity of the exported trajectory, the model's skeleton drawn by the
animation.
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import headless_page
from vsw.cli import main

pytest.importorskip("casadi")

OPTIMIZE = ["optimize", "--model", "compass-gait", "--target-speed", "0.8", "--nodes", "10"]
NAMES = ["theta", "psi", "theta_dot", "psi_dot"]
PERIODIC = 1e-7
"""The replayed step's return to its start, relative to max(1, |state|): the verification
accepts a fixed point whose step maps it to itself within
:data:`vsw.synthesis.powered.verify.FIXED_POINT_TOL` = 1e-7 (Newton reaches about 4e-10 here, and a
second step adds the first's gap times the open-loop map's largest |eigenvalue|, 1.34)."""


def _main(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


def _optimize_in(directory: Path) -> tuple[int, str]:
    """``vsw optimize ... --out gait.json --json`` run in ``directory`` (one command line
    for every run: the file's provenance names it)."""
    here = Path.cwd()
    os.chdir(directory)
    try:
        code, out, _ = _main([*OPTIMIZE, "--out", "gait.json", "--json"])
    finally:
        os.chdir(here)
    return code, out


@pytest.fixture(scope="module")
def optimized(tmp_path_factory) -> tuple[Path, dict, int]:
    """The gait file, the document ``--json`` printed with it, the exit status."""
    directory = tmp_path_factory.mktemp("gait")
    code, out = _optimize_in(directory)
    return directory / "gait.json", json.loads(out), code


@pytest.fixture(scope="module")
def gait(optimized) -> dict:
    return json.loads(optimized[0].read_text())["gait"]


def _start(gait: dict) -> np.ndarray:
    return np.array([gait["start"]["state"][n] for n in NAMES])


def test_the_file_holds_the_gait_and_is_the_json_documents(optimized, gait):
    """The file: the envelope and the gait (model, parameters, start, phases with their
    durations and inputs at the 2N + 1 knots and midpoints, impulses, cost, statuses,
    units, format version); ``--json`` prints the same record under ``gait``. A collocation
    not judged optimal is not called optimal, even verified; exit 3 as without --out."""
    path, printed, code = optimized
    document = json.loads(path.read_text())
    assert code == 3
    assert list(document) == ["model", "parameters", "units", "provenance", "gait"]
    assert printed["gait"] == gait
    assert gait["format"] == "vsw-gait" and gait["format_version"] == 1
    assert gait["model"] == "compass-gait" == document["model"]
    assert gait["parameters"] == document["parameters"]
    assert gait["collocation"]["status"] == "not-converged"
    assert gait["verification"]["status"] == "verified"
    assert gait["status"] == "verified"
    assert gait["minimize"] == "torque2" and gait["cost"] == printed["cost"]
    assert gait["start"]["from"] == "the open-loop step's fixed point"
    assert _start(gait).tolist() == [printed["verified"]["state"][n] for n in NAMES]
    (phase,) = gait["phases"]
    assert phase["phase"] == "stance" and phase["event"] == "heelstrike"
    assert phase["intervals"] == 20 and len(phase["inputs"]["hip_torque"]) == 41
    assert phase["input_time"] == printed["phases"][0]["input_time"]
    assert phase["inputs"]["hip_torque"] == printed["phases"][0]["inputs"]["hip_torque"]
    assert phase["duration"] == printed["durations"][0]
    assert max(abs(u) for u in phase["inputs"]["hip_torque"]) > 0.1  # a torque at work
    assert gait["units"]["inputs"] == {"hip_torque": "N m"}
    quantities = document["units"]["quantities"]
    assert quantities["hip_torque"] == "N m" and quantities["duration"] == "s"
    assert quantities["gait.cost"] == printed["units"]["quantities"]["cost"] == "(N m)^2 s"


def test_an_unverified_optimum_is_never_called_optimal(gait, tmp_path):
    """The record's status: optimal only for IPOPT's optimum that verified; without a
    verification, or with one that failed, unverified whatever the collocation said."""
    import dataclasses

    from vsw.studies.gait_file import gait_record, load_gait
    from vsw.synthesis.powered import Request
    from vsw.synthesis.powered.verify import VerifiedGait

    path = tmp_path / "g.json"
    path.write_text(json.dumps({"gait": gait}))
    saved = load_gait(str(path))
    optimum = dataclasses.replace(saved.gait, status="optimal")
    request = Request("torque2", target_speed=0.8, nodes=10)
    state = saved.start
    good = VerifiedGait(state, 1e-10, 0.65, 0.52, 0.8, end=state)
    bad = dataclasses.replace(good, failure="lift-off in phase stance at t = 0.1")
    statuses = [gait_record(saved.model, saved.params, request, g, v)["status"]
                for g, v in ((optimum, good), (optimum, bad), (optimum, None),
                             (optimum, "no fixed point"), (saved.gait, good))]  # fmt: skip
    assert statuses == ["optimal", "unverified", "unverified", "unverified", "verified"]


def test_simulate_replays_the_verified_step(optimized, gait):
    """`vsw simulate --gait FILE --json`: the first step ends at the verification's end
    state, period and step length (the same integration: equal to the last bit); the
    second returns to the start within :data:`PERIODIC`; the speed is the target's within
    the collocation's error."""
    path = optimized[0]
    code, out, err = _main(["simulate", "--gait", str(path), "--steps", "2", "--json"])
    assert code == 0 and err == ""
    data = json.loads(out)
    assert data["model"] == "compass-gait" and data["start_from"] == "gait"
    assert data["ended"] == "completed" and data["steps_completed"] == 2
    verification = gait["verification"]
    states = [np.array([s[n] for n in NAMES]) for s in data["section_states"]]
    assert states[0].tolist() == _start(gait).tolist()
    assert states[1].tolist() == [verification["end_state"][n] for n in NAMES]
    assert data["step_periods"][0] == verification["period"]
    assert data["step_lengths"][0] == verification["step_length"]
    scale = max(1.0, float(np.max(np.abs(states[0]))))
    for state in states[1:]:
        assert np.max(np.abs(state - states[0])) / scale <= PERIODIC
    speed = data["step_lengths"][1] / data["step_periods"][1]
    assert speed == pytest.approx(0.8, rel=1e-4)


def _rows(path: Path) -> list[dict]:
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    return list(csv.DictReader(lines))


def test_the_trajectory_is_periodic_and_its_energy_is_the_torques_work(optimized, gait,
                                                                      tmp_path):  # fmt: skip
    """`vsw simulate --gait FILE --trajectory t.csv`: the first row is the gait's start, the
    last (just after the heelstrike) the next step's start, the start again within
    :data:`PERIODIC`; the mechanical energy (the generated T + V) changes over the stance
    by the hip torque's net work, the verification's (Simpson, 64 panels an interval)
    within 1e-7 relative and the optimiser's on its mesh within 1e-3; the stance's normal
    force carries the torque's share (it differs from the passive one where the torque
    acts). Text output names the gait and its status; the figure is written."""
    from vsw.models import load

    path = optimized[0]
    out_file, plot = tmp_path / "t.csv", tmp_path / "walk.png"
    code, out, _ = _main(["simulate", "--gait", str(path), "--steps", "1", "--trajectory",
                          str(out_file), "--rate", "200", "--plot", str(plot)])  # fmt: skip
    assert code == 0 and plot.stat().st_size > 0
    assert f"start: gait {path} (verified); ended: completed after 1 of 1 steps" in out
    rows = _rows(out_file)
    first, last = rows[0], rows[-1]
    assert first["event"] == "" and last["event"] == "heelstrike:after"
    start = _start(gait)
    assert [float(first[n]) for n in NAMES] == start.tolist()
    end = np.array([float(last[n]) for n in NAMES])
    assert end.tolist() == [gait["verification"]["end_state"][n] for n in NAMES]
    assert np.max(np.abs(end - start)) / max(1.0, float(np.max(np.abs(start)))) <= PERIODIC
    (before,) = [r for r in rows if r["event"] == "heelstrike:before"]
    change = float(before["energy"]) - float(first["energy"])
    work = gait["verification"]["work"]["stance.hip_torque"]
    assert change == pytest.approx(work["positive"] + work["negative"], rel=1e-7)
    mesh = optimized[1]["work"]["stance.hip_torque"]  # the optimiser's ledger on its mesh
    assert change == pytest.approx(mesh["positive"] + mesh["negative"], rel=1e-3)
    assert abs(change) > 0.1
    model = load("compass_gait")
    params = list(gait["parameters"].values())
    stance = [r for r in rows if r["event"] == ""]
    states = np.array([[float(r[n]) for n in NAMES] for r in stance])
    passive = np.asarray(model.module.stance_normal_force(*params, *states.T), dtype=float)
    forces = np.array([float(r["normal_force"]) for r in stance])
    assert np.max(np.abs(forces - passive) / np.abs(passive)) > 1e-4  # 1.7e-3 here


def test_animate_draws_the_replayed_walker(optimized, gait, tmp_path):
    """`vsw animate --gait FILE`: the walk from the gait's start, two steps completed, a
    frame at each heelstrike; the frames (vsw.plots.animate) draw the model's own skeleton at
    the replayed states, inside the picture."""
    from vsw.plots.animate import HEIGHT, WIDTH, animation_frames
    from vsw.studies.gait_file import PoweredReplay, load_gait

    path = optimized[0]
    out = tmp_path / "walk.svg"
    code, text, _ = _main(["animate", "--gait", str(path), "--out", str(out), "--steps", "2",
                           "--json"])  # fmt: skip
    assert code == 0 and out.stat().st_size > 0
    data = json.loads(text)
    assert data["start_from"] == "gait" and data["steps_completed"] == 2
    assert [data["start"][n] for n in NAMES] == _start(gait).tolist()
    assert [e["event"] for e in data["events"]] == ["heelstrike", "heelstrike"]
    assert data["events"][0]["t"] == gait["verification"]["period"]
    saved = load_gait(str(path))
    frames = animation_frames(PoweredReplay(saved.model, saved.gait), saved.params,
                              saved.start, 1)  # fmt: skip
    module = saved.model.module
    for k in range(0, len(frames.t), 5):
        skeleton = np.asarray(module.stance_skeleton(*saved.params, *frames.states[k]))
        chart = skeleton.reshape(-1, 2) + np.array([frames.foot[k], 0.0])
        assert np.allclose(frames.to_pixels(chart, k), frames.points[k], atol=1e-9)
        assert np.all((frames.points[k] >= 0) & (frames.points[k] <= [WIDTH, HEIGHT]))


def _spec(page: Path) -> dict:
    text = page.read_text()
    start = text.index("const SPEC = ") + len("const SPEC = ")
    return json.JSONDecoder().raw_decode(text[start:])[0]


def test_explore_plays_the_replayed_step(optimized, gait, tmp_path):
    """`vsw explore --gait FILE`: the page holds the replayed step's samples (from the
    gait's start to the state just before its heelstrike, then just after it), its period
    and step length the verification's, the sliders at the gait's parameters, and says it
    replays (it does not integrate)."""
    path = optimized[0]
    page = tmp_path / "gait.html"
    code, out, _ = _main(["explore", "--gait", str(path), "--out", str(page), "--json"])
    assert code == 0
    data = json.loads(out)
    assert data["gait"]["status"] == "verified" and data["frames"] >= 400
    spec = _spec(page)
    replay = spec["replay"]
    frames = replay["frames"]
    assert frames[0][2] == _start(gait).tolist() and frames[0][0] == 0.0
    assert replay["period"] == gait["verification"]["period"] == frames[-1][0]
    assert replay["length"] == gait["verification"]["step_length"]
    assert replay["end_state"] == [gait["verification"]["end_state"][n] for n in NAMES]
    assert all(a[0] <= b[0] for a, b in itertools.pairwise(frames))
    assert [p["value"] for p in spec["parameters"]] == pytest.approx(
        [v if n != "gamma" else math.degrees(v) for n, v in gait["parameters"].items()]
    )
    assert "A powered gait, replayed." in page.read_text()


@pytest.mark.slow  # a browser
def test_the_replayed_page_draws_the_walker_in_a_browser(optimized, tmp_path):
    """In headless Chromium the page plays the recorded step: no console error, the
    replayed flag, and over two steps the drawn state is a recorded sample, the stance foot
    a step length further each step."""
    page_file = tmp_path / "gait.html"
    assert _main(["explore", "--gait", str(optimized[0]), "--out", str(page_file)])[0] == 0
    replay = _spec(page_file)["replay"]
    with headless_page(page_file.as_uri(), 1100) as (page, errors):
        page.wait_for_function("window.vswLastUpdate !== undefined", timeout=60_000)
        shown = page.evaluate("window.vswLastUpdate")
        pictures = page.evaluate(
            "() => { const u = window.vswLastUpdate, out = [];"
            " for (let i = 0; i < 40; ++i) out.push(window.vswPicture(2 * u.period * i / 40));"
            " return out; }"
        )
    assert errors == [], errors
    assert shown["replayed"] and shown["walks"]
    recorded = [f[2] for f in replay["frames"]]
    for pic in pictures:
        assert pic["state"] in recorded
        assert pic["foot"] == pytest.approx(pic["step"] * replay["length"], abs=1e-12)
        for x, y in pic["points"]:
            assert 0 <= x <= pic["width"] and 0 <= y <= pic["height"]
    assert {pic["step"] for pic in pictures} == {0, 1}


def _mutated(gait_path: Path, tmp_path: Path, change) -> str:
    document = json.loads(gait_path.read_text())
    change(document)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(document))
    return str(path)


def _drop(key: str):
    def change(document: dict) -> None:
        del document["gait"][key]

    return change


def _set(key: str, value):
    def change(document: dict) -> None:
        document["gait"][key] = value

    return change


@pytest.mark.parametrize(
    ("make", "extra", "words"),
    [
        (lambda g, t: str(t / "none.json"), [], "cannot read"),
        (lambda g, t: _text(t, "{not json"), [], "not JSON"),
        (lambda g, t: _text(t, '{"model": "compass-gait"}'), [], "not a gait file"),
        (lambda g, t: _mutated(g, t, _set("format_version", 2)), [], "format version 2"),
        (lambda g, t: _mutated(g, t, _drop("phases")), [], "phases is missing"),
        (lambda g, t: _mutated(g, t, _set("status", "optimal?")), [], "status must be one of"),
        (lambda g, t: _mutated(g, t, _drop("impulses")), [], "impulses must name"),
        (lambda g, t: _mutated(g, t, _set("model", "level-compass-gait")), [],
         "not a gait of this model"),
        (lambda g, t: str(g), ["--model", "simplest-walker"], "is a gait of compass-gait, "
         "not of simplest-walker"),
        (lambda g, t: str(g), ["--model", "compass-gait", "--param", "m=6"], "contradicts the "
         "gait's m = 5.0"),
        (lambda g, t: str(g), ["--state", "theta=0.1"], "--gait and --state both give"),
    ],
)  # fmt: skip
def test_a_gait_the_command_cannot_replay_is_one_line(optimized, tmp_path, make, extra, words):
    """Each refusal: one line on stderr, exit 2, no traceback, nothing on stdout; the same
    for simulate, animate and explore."""
    path = make(optimized[0], tmp_path)
    outs = {"simulate": [], "animate": ["--out", str(tmp_path / "a.gif")],
            "explore": ["--out", str(tmp_path / "e.html")]}  # fmt: skip
    for command, out in outs.items():
        if command == "explore" and "--state" in extra:
            continue  # explore has no --state
        code, text, err = _main([command, "--gait", path, *extra, *out])
        lines = err.strip().splitlines()
        assert code == 2 and text == "", (command, err)
        assert len(lines) == 1 and words in lines[0], (command, err)
        assert lines[0].startswith("vsw: error: ")


def _text(tmp_path: Path, text: str) -> str:
    path = tmp_path / "text.json"
    path.write_text(text)
    return str(path)


def test_a_parameter_equal_to_the_gaits_is_accepted(optimized, gait):
    """``--param`` at the gait's own value is no contradiction: the same walk."""
    path = str(optimized[0])
    code, out, _ = _main(["simulate", "--gait", path, "--model", "compass-gait", "--param",
                          "m=5", "--steps", "1", "--json"])  # fmt: skip
    assert code == 0
    assert json.loads(out)["section_states"][1] == gait["verification"]["end_state"]


@pytest.mark.slow  # a second optimisation
def test_the_gait_file_is_byte_identical_from_run_to_run(optimized, tmp_path):
    """The same command line writes the same bytes (and prints the same document)."""
    code, out = _optimize_in(tmp_path)
    assert code == 3 and json.loads(out) == optimized[1]
    assert (tmp_path / "gait.json").read_bytes() == optimized[0].read_bytes()


def test_a_failure_on_the_way_ends_the_replayed_walk(optimized, tmp_path):
    """The hip torque 30 times the gait's lifts the stance foot off before heelstrike:
    the walk ends there ('lift-off' after 0 steps, exit 0 as any walk that falls), no
    event row in the trajectory, whose last row (sampled 1e4 times a second) has the
    normal force with the torque's share near zero: the failure's guard and the reaction
    agree."""

    def stronger(document: dict) -> None:
        inputs = document["gait"]["phases"][0]["inputs"]
        inputs["hip_torque"] = [30 * u for u in inputs["hip_torque"]]

    path = _mutated(optimized[0], tmp_path, stronger)
    out_file = tmp_path / "fall.csv"
    code, out, _ = _main(["simulate", "--gait", path, "--steps", "2", "--trajectory",
                          str(out_file), "--rate", "10000", "--json"])  # fmt: skip
    data = json.loads(out)
    assert code == 0 and data["ended"] == "lift-off" and data["steps_completed"] == 0
    rows = _rows(out_file)
    assert all(r["event"] == "" for r in rows)
    forces = [float(r["normal_force"]) for r in rows]
    assert 0 <= forces[-1] < 1e-2 * max(forces)


def test_an_unverified_gait_replays_with_a_note(optimized, tmp_path):
    """A gait whose verification failed is replayed, and the text says so first."""

    def unverified(document: dict) -> None:
        document["gait"]["status"] = "unverified"
        document["gait"]["verification"] = {"status": "failed", "reason": "no fixed point"}

    path = _mutated(optimized[0], tmp_path, unverified)
    code, out, _ = _main(["simulate", "--gait", path, "--steps", "1"])
    assert code == 0
    assert out.splitlines()[2] == ("note: the gait is unverified (no fixed point): its inputs "
                                   "may not repeat the step")  # fmt: skip


def test_optimize_out_in_a_missing_directory_is_one_line_before_the_work(tmp_path):
    code, out, err = _main([*OPTIMIZE, "--out", str(tmp_path / "missing" / "gait.json")])
    assert code == 2 and out == ""
    assert err.strip().splitlines() == [
        f"vsw: error: --out {tmp_path / 'missing' / 'gait.json'}: not a file in an existing "
        "directory"
    ]
