"""``vsw animate``: the frames are the simulated walk.

The ILE's first heelstrike is checked against its closed forms, not against the
simulation the animation draws from: the time from the phase durations in Carlson form,
the hip from the heelstrike geometry (stance leg of length r at theta_IV, eq. (5), (11)),
the second stance foot one step length (closed form) ahead.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vsw.cli import main

pytest.importorskip("PIL")

BETA, THETA_II, PHI0 = 0.8, 0.0, math.pi / 4
ILE = ["animate", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45"]


def run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _hip_pixel(image, near, radius=12):
    """The centroid of the hip's black disc near ``near`` (pixels)."""
    rgb = np.asarray(image.convert("RGB"), dtype=int)
    ys, xs = np.nonzero(np.all(rgb == 0, axis=2))
    keep = (np.abs(xs - near[0]) <= radius) & (np.abs(ys - near[1]) <= radius)
    assert keep.sum() >= 30, "no hip disc near the expected pixel"
    return np.array([xs[keep].mean(), ys[keep].mean()])


@pytest.fixture(scope="module")
def ile_gif(tmp_path_factory):
    import contextlib
    import io

    import generated.ile as ile

    q_f = float(ile.q_fixed(BETA, THETA_II, PHI0))
    out = tmp_path_factory.mktemp("animate") / "ile.gif"
    buffer = io.StringIO()
    with contextlib.redirect_stdout(buffer):
        code = main([*ILE, "--q0", repr(q_f), "--steps", "2", "--out", str(out), "--json"])
    assert code == 0
    return json.loads(buffer.getvalue()), out


def test_gif_frames_are_the_walk(ile_gif):
    from PIL import Image

    import generated.ile as ile

    data, path = ile_gif
    image = Image.open(path)
    assert image.n_frames == data["frames"]
    q_f = float(ile.q_fixed(BETA, THETA_II, PHI0))
    tau = [float(v) for v in ile.phase_durations(BETA, THETA_II, PHI0, q_f)]
    heelstrikes = [e["t"] for e in data["events"] if e["event"] == "heelstrike"]
    assert heelstrikes[0] == pytest.approx(sum(tau), abs=1e-8)
    assert heelstrikes[1] == pytest.approx(2 * sum(tau), abs=1e-8)
    assert data["steps_completed"] == 2 and data["ended"] == "completed"
    scale, (x0, y0) = data["pixels"]["scale"], data["pixels"]["origin"]

    def pixel(x, y):
        return np.array([x0 + scale * x, y0 - scale * y])

    theta_I = float(ile.theta_I(BETA, PHI0))
    theta_IV = float(ile.theta_IV(BETA, PHI0))
    length = float(ile.step_length(BETA, PHI0))
    # the chart's sign of x for a leg at theta (the generated geometry of phase I-II)
    sign = float(np.sign(ile.phase_I_II_positions(BETA, THETA_II, PHI0, 0.1, 0.0)[0]))
    # First frame: the short stance leg (beta) at theta_I; the frame at the first
    # heelstrike: the extended leg (r = 1) at theta_IV; the last frame: the second one.
    expected = {
        0: pixel(sign * BETA * math.sin(theta_I), BETA * math.cos(theta_I)),
        data["frame_of_events"][1]: pixel(sign * math.sin(theta_IV), math.cos(theta_IV)),
        data["frames"] - 1: pixel(length + sign * math.sin(theta_IV), math.cos(theta_IV)),
    }
    for frame, where in expected.items():
        image.seek(frame)
        found = _hip_pixel(image, where)
        assert np.max(np.abs(found - where)) <= 1.0, (frame, found, where)


@pytest.mark.slow
def test_every_model_animates_to_svg_and_gif(capsys, tmp_path):
    for model in ("simplest-walker", "compass-gait", "rimless-wheel", "tle", "vsw-biped"):
        extra = ["--param", "beta=0.97", "--param", "theta_II=-0.2", "--param", "mu=0.3"] if (
            model == "vsw-biped") else []  # fmt: skip
        for suffix in ("svg", "gif") if model == "simplest-walker" else ("gif",):
            out = tmp_path / f"{model}.{suffix}"
            # One step at 10 frames a second: the pipeline is the same, with fewer frames.
            code, text, err = run(capsys, ["animate", "--model", model, *extra, "--steps", "1",
                                           "--fps", "10", "--out", str(out), "--json"])  # fmt: skip
            assert code == 0, err
            data = json.loads(text)
            assert data["steps_completed"] == 1 and out.stat().st_size > 1000
    svg = (tmp_path / "simplest-walker.svg").read_text()
    # Two legs (4 coordinates each), the hip (2) and the model's two foot masses (2 each).
    assert svg.startswith("<svg") and svg.count("<animate ") == 14


def test_animation_is_deterministic(capsys, tmp_path):
    outputs = []
    for k in range(2):
        out = tmp_path / f"{k}.gif"
        assert run(capsys, ["animate", "--model", "compass-gait", "--steps", "1",
                            "--out", str(out)])[0] == 0  # fmt: skip
        outputs.append(out.read_bytes())
    assert outputs[0] == outputs[1]


BAD = [
    ([*ILE, "--q0", "0.4", "--out", "x.txt"], [".gif"]),
    ([*ILE, "--q0", "0.4", "--out", "x.mp4"], ["ffmpeg"]) if __import__("shutil").which(
        "ffmpeg") is None else ([*ILE, "--q0", "0.4", "--out", "x.bmp"], [".gif"]),
    ([*ILE, "--q0", "-1", "--out", "x.gif"], ["--q0"]),
    ([*ILE, "--q0", "0.4", "--state", "theta=0", "--out", "x.gif"], ["--state and --q0"]),
    ([*ILE, "--q0", "0.4", "--steps", "0", "--out", "x.gif"], ["--steps"]),
    ([*ILE, "--q0", "0.4", "--fps", "0", "--out", "x.gif"], ["--fps"]),
    ([*ILE, "--q0", "0.4", "--out", "/nonexistent/dir/x.gif"], ["does not exist"]),
    ([*ILE, "--q0", "0.4", "--steps", "1000", "--out", "x.gif"], ["frames"]),
    (["animate", "--model", "compass-gait", "--leg-length", "1", "--out", "x.gif"],
     ["seconds"]),
    (["animate", "--model", "compass-gait", "--q0", "1", "--out", "x.gif"], ["--q0"]),
]  # fmt: skip


@pytest.mark.parametrize("argv, words", BAD, ids=[" ".join(a[1:]) for a, _ in BAD])
def test_bad_animate_input_is_one_line(capsys, argv, words, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = run(capsys, argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    for word in words:
        assert word in err, err


def test_each_leg_keeps_its_colour_and_the_slope_descends(capsys, tmp_path):
    """Issue 22: one colour per leg for the whole walk (the stance and swing legs swap at
    every heelstrike, the colours stay with the legs), leg masses drawn on their legs, the
    passive walker's slope descending to the right, the rimless wheel's every spoke."""
    from vsw.animate import _legs, animation_frames
    from vsw.models import load

    model = load("compass_gait")
    params = model.parameters()
    start = model.start(params, None, None).state
    frames = animation_frames(model, params, start, 2, fps=10)
    stands = frames.leg_a_stands
    assert stands[frames.step == 0].all() and not stands[frames.step == 1].any()
    # leg A's foot stays put while it stands and is the old stance foot after the swap
    first_swap = int(np.argmax(~stands))
    assert np.allclose(frames.stance_foot[:first_swap], frames.stance_foot[0])
    # a mass on each leg, halfway along it (a = b = 0.5 m)
    for k in (0, first_swap + 1):
        for legs, masses in ((0, frames.masses_a), (1, frames.masses_b)):
            foot, hip = _legs(frames, k)[legs]
            assert np.allclose(masses[k, 0], 0.5 * (np.asarray(foot) + hip), atol=0.6)
    # the ground descends to the right by gamma (pixels: y grows downwards)
    (x0, y0), (x1, y1) = frames.ground
    assert math.atan2(y1 - y0, x1 - x0) == pytest.approx(params[4], abs=1e-9)
    wheel = load("rimless_wheel")
    wp = wheel.parameters()
    spun = animation_frames(wheel, wp, wheel.start(wp, None, None).state, 1, fps=10)
    count = round(math.pi / wp[0])
    assert spun.spokes.shape[1] == count - 1  # every spoke but the stance one
    hub = spun.hip[0]
    lengths = np.linalg.norm(spun.spokes[0] - hub, axis=1)
    assert np.allclose(lengths, np.linalg.norm(spun.stance_foot[0] - hub), rtol=1e-9)
