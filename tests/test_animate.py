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
    scale, origins = data["pixels"]["scale"], data["pixels"]["origins"]
    assert data["pixels"]["slope"] == 0.0  # level ground: the chart is not turned

    def pixel(frame, x, y):  # the view follows the hip: each frame has its origin
        x0, y0 = origins[frame]
        return np.array([x0 + scale * x, y0 - scale * y])

    theta_I = float(ile.theta_I(BETA, PHI0))
    theta_IV = float(ile.theta_IV(BETA, PHI0))
    length = float(ile.step_length(BETA, PHI0))
    # the chart's sign of x for a leg at theta (the generated geometry of phase I-II)
    sign = float(np.sign(ile.phase_I_II_positions(BETA, THETA_II, PHI0, 0.1, 0.0)[0]))
    # First frame: the short stance leg (beta) at theta_I; the frame at the first
    # heelstrike: the extended leg (r = 1) at theta_IV; the last frame: the second one.
    heelstrike, last = data["frame_of_events"][1], data["frames"] - 1
    expected = {
        0: pixel(0, sign * BETA * math.sin(theta_I), BETA * math.cos(theta_I)),
        heelstrike: pixel(heelstrike, sign * math.sin(theta_IV), math.cos(theta_IV)),
        last: pixel(last, length + sign * math.sin(theta_IV), math.cos(theta_IV)),
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
    # Two legs (4 coordinates each), the hip and the model's two foot masses (2 each), and
    # the view's motion.
    assert svg.startswith("<svg") and svg.count('<line stroke-width="3"') == 2
    assert svg.count("<circle") == 3 and svg.count("<animateTransform") == 1
    # a leg's colour moves to the other at the swap: colours are animated too
    colours = sum(svg.count(f'<animate attributeName="{a}"') for a in ("fill", "stroke"))
    # ... and the hip's path walked so far, one dash offset
    assert svg.count("<animate ") == 2 * 4 + 3 * 2 + colours + 1


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
    ([*ILE, "--q0", "0.4", "--out", "TMP/missing/dir/x.gif"], ["does not exist"]),
    ([*ILE, "--q0", "0.4", "--steps", "1000", "--out", "x.gif"], ["frames"]),
    (["animate", "--model", "compass-gait", "--leg-length", "1", "--out", "x.gif"],
     ["seconds"]),
    (["animate", "--model", "compass-gait", "--q0", "1", "--out", "x.gif"], ["--q0"]),
]  # fmt: skip


@pytest.mark.parametrize("argv, words", BAD, ids=[" ".join(a[1:]) for a, _ in BAD])
def test_bad_animate_input_is_one_line(capsys, argv, words, tmp_path, monkeypatch):
    """TMP: the test's own temporary directory, where missing/ is sure to be missing."""
    monkeypatch.chdir(tmp_path)
    argv = [a.replace("TMP", str(tmp_path)) for a in argv]
    assert not (tmp_path / "missing").exists()
    code, out, err = run(capsys, argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    for word in words:
        assert word in err, err


def test_each_leg_keeps_its_colour_and_the_slope_descends(capsys, tmp_path):
    """One colour per leg for the whole walk (the stance and swing legs swap at every
    heelstrike, the colours stay with the legs), the leg masses coloured as their legs,
    the passive walker's slope descending to the right, the rimless wheel's every spoke."""
    from tests.conftest import gait_start
    from vsw.models import load
    from vsw.plots.animate import animation_frames

    model, params, start = gait_start("compass_gait")  # the gait model.start walks from
    frames = animation_frames(model, params, start, 2, fps=10)
    stands = frames.leg_a_stands
    assert stands[frames.step == 0].all() and not stands[frames.step == 1].any()
    first_swap = int(np.argmax(~stands))

    def world(k, name):  # a skeleton point in the moving view's fixed coordinates
        return frames.points[k][frames.point_names[k].index(name)] - frames.origins[k]

    # leg A stands first, then swings: its foot stays put while it stands and is where
    # the swing foot leaves from after the swap
    for k in range(first_swap):
        assert frames.line_colors[k] == ("leg_a", "leg_b")
        assert np.allclose(world(k, "stance_foot"), world(0, "stance_foot"), atol=1e-9)
    assert frames.line_colors[first_swap] == ("leg_b", "leg_a")
    assert np.allclose(world(first_swap, "swing_foot"), world(0, "stance_foot"), atol=1e-6)
    assert frames.body_colors[0] == ("hip", "leg_a", "leg_b")
    assert frames.body_colors[first_swap] == ("hip", "leg_b", "leg_a")
    # the ground descends to the right by gamma (pixels: y grows downwards)
    (x0, y0), (x1, y1) = frames.ground[0]
    assert math.atan2(y1 - y0, x1 - x0) == pytest.approx(params[4], abs=1e-9)
    wheel = load("rimless_wheel")
    wp = wheel.parameters()
    spun = animation_frames(wheel, wp, wheel.start(wp, None, None).state, 1, fps=10)
    count = round(math.pi / wp[0])
    assert spun.line_colors[0] == ("leg_a",) + ("spoke",) * (count - 1)  # every spoke
    hub = spun.points[0][spun.point_names[0].index("hub")]
    # each line's end away from the hub: a spoke's foot
    arms = spun.lines[0] - hub
    arms = np.where((np.linalg.norm(arms[:, 0], axis=1) > np.linalg.norm(arms[:, 1], axis=1))
                    [:, None], arms[:, 0], arms[:, 1])  # fmt: skip
    assert np.allclose(np.linalg.norm(arms, axis=1), wp[2] * spun.scale, rtol=1e-9)
    # neighbouring spokes 2 alpha apart: every spoke end on the circle's 2 alpha grid
    angles = np.sort(np.mod(np.arctan2(arms[:, 1], arms[:, 0]) - math.atan2(*arms[0][::-1]),
                            2 * math.pi))  # fmt: skip
    assert np.allclose(angles, 2 * wp[0] * np.arange(count), atol=1e-9)


@pytest.fixture(scope="module")
def ile_walk():
    import generated.ile as ile
    from vsw.models import load

    model = load("ile")
    params = model.parameters({"beta": BETA, "theta_II": THETA_II, "phi0": PHI0})
    start = model.start(params, None, float(ile.q_fixed(BETA, THETA_II, PHI0)))
    return model, params, start.state


# A title as long as a model with many parameters makes (`vsw animate`: "model: name = value, ...").
LONG_TITLE = "torso-walker: " + ", ".join(f"parameter_{i} = {1.234567 * i:.6g}" for i in range(14))


def test_a_long_title_fits_the_gif(ile_walk):
    """Every line of the title lies inside the frame and left of the gravity arrow, in
    Pillow's measure of the font it is drawn in and in the drawn pixels."""
    from vsw.plots import animate

    model, params, state = ile_walk
    frames = animate.animation_frames(model, params, state, 1, fps=10, speed=1.0,
                                      title=LONG_TITLE)  # fmt: skip
    lines = animate.title_lines(LONG_TITLE)
    assert len(lines) > 1 and " ".join(lines) == LONG_TITLE
    font = animate._font()
    arrow_left = animate._ARROW[0][0] - 14
    for i, line in enumerate(lines):
        left, top, right, bottom = font.getbbox(line)
        y = 4 + animate.LINE * i
        assert 0 <= 6 + left and 6 + right < arrow_left, line
        assert 0 <= y + top and y + bottom <= animate.top_margin(LONG_TITLE), line
    rgb = np.asarray(animate._raster(frames, 0).convert("RGB"), dtype=int)
    band = rgb[: 4 + animate.LINE * len(lines), :arrow_left]
    ink = np.nonzero(np.any(band < 128, axis=2))
    assert ink[1].size and ink[1].max() < arrow_left - 1  # the title ends before the arrow
    # The walker stays below the title and counters.
    assert np.min(frames.hip[:, 1]) >= animate.top_margin(LONG_TITLE)
    svg = animate._svg(frames)
    assert svg.count('<text x="6" y=') == len(animate.title_lines(LONG_TITLE, size=11)) + len(
        frames.t
    )


def test_svg_draws_the_path_walked_so_far(ile_walk):
    """The SVG's hip path shows, at each frame, the path up to that frame's hip and no
    further: one dash as long as the path so far (the dash's offset per frame), nothing at
    the first frame, the whole path at the last."""
    import xml.etree.ElementTree as ET

    from vsw.plots import animate

    model, params, state = ile_walk
    frames = animate.animation_frames(model, params, state, 1, fps=10, speed=1.0, title="ile")
    ns = {"s": "http://www.w3.org/2000/svg"}
    root = ET.fromstring(animate._svg(frames))
    (path,) = root.findall(".//s:polyline", ns)
    points = np.array([[float(v) for v in p.split(",")] for p in path.get("points").split()])
    hip = frames.hip - frames.origins
    np.testing.assert_allclose(points, hip, atol=0.006)
    dash, gap = (float(v) for v in path.get("stroke-dasharray").split())
    along = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    assert dash >= along[-1] and gap >= along[-1]
    offsets = [a for a in path.findall("s:animate", ns) if a.get("attributeName") ==
               "stroke-dashoffset"]  # fmt: skip
    assert len(offsets) == 1 and offsets[0].get("calcMode") == "discrete"
    shown = dash - np.array([float(v) for v in offsets[0].get("values").split(";")])
    assert len(shown) == len(frames.t)
    np.testing.assert_allclose(shown, along, atol=0.02)  # the length walked by each frame
    assert shown[0] <= 0.01 and shown[-1] == pytest.approx(along[-1], abs=0.02)
    assert float(path.get("stroke-dashoffset")) == dash  # before the animation: nothing
