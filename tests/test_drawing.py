"""``vsw animate`` draws each model's own geometry, phase by phase.

For every model of the registry the drawn points of the frames, with the frame's pixel
transform undone, are the model's generated skeleton and body positions at the state the
frame draws; every segment and body is drawn, inside the frame; a swing foot the model's
own clearance puts above the ground is drawn above the drawn ground line. The kneed
walker's swing foot in its knee-free phase is checked against a hand computation from
its parameter table and the angle conventions of its model file, not the generated code.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from vsw.models import keys, load
from vsw.plots.animate import HEIGHT, WIDTH, _raster, animation_frames

pytest.importorskip("PIL")

TOL = 1e-9  # model lengths


def _search_start(model, params) -> np.ndarray:
    """The middle of the model's search box on its section, completed by the section's
    own relations: a walk that may fall, drawn all the same."""
    names = (*model.coordinates, *model.rates)
    box = model.spec["search"]
    state = np.array([sum(box[n]) / 2 if n in box else 0.0 for n in names])
    complete = getattr(model.module, "section_completion", None)
    if complete is not None:
        state = np.array([float(v) for v in complete(*params, *state)])
    return state


@functools.cache
def _frames(name: str):
    model = load(name)
    params = model.parameters()
    return model, params, animation_frames(model, params, _search_start(model, params), 1,
                                           fps=10)  # fmt: skip


def _chart(frames, k: int, pixels: np.ndarray) -> np.ndarray:
    """Pixels of frame ``k`` back in the first step's chart (model lengths): the documented
    transform, pixel = origin + scale * (X, -Y), (X, Y) the chart point turned by the slope."""
    u = (np.asarray(pixels, float) - frames.origins[k]) / frames.scale
    big_x, big_y = u[..., 0], -u[..., 1]
    c, s = math.cos(frames.slope), math.sin(frames.slope)
    return np.stack([c * big_x - s * big_y, s * big_x + c * big_y], axis=-1)


def _phase(model, name: str) -> dict:
    return next(p for p in model.phases if p["name"] == name)


@pytest.mark.parametrize("name", keys())
def test_drawn_points_are_the_models_geometry(name):
    model, params, frames = _frames(name)
    assert len(frames.t) >= 1
    for k in range(len(frames.t)):
        phase, x = frames.phase[k], frames.states[k]
        drawing = _phase(model, phase)["skeleton"]
        names = list(drawing["points"])
        assert list(frames.point_names[k]) == names
        skeleton = np.asarray(getattr(model.module, f"{phase}_skeleton")(*params, *x), float)
        skeleton = skeleton.reshape(-1, 2)
        drawn = _chart(frames, k, frames.points[k])
        # The phase's chart has its stance foot at the origin: the drawn stance foot tells
        # where that origin is, on the ground (y = 0).
        foot = drawn[names.index("stance_foot")] - skeleton[names.index("stance_foot")]
        assert abs(foot[1]) <= TOL, (k, foot)
        assert np.allclose(drawn - foot, skeleton, rtol=0, atol=TOL), (k, phase)
        # every segment of the phase's drawing is a drawn line between its two points
        for s, (a, b) in enumerate(drawing["segments"]):
            ends = _chart(frames, k, frames.lines[k][s]) - foot
            expected = skeleton[[names.index(a), names.index(b)]]
            assert np.allclose(ends, expected, rtol=0, atol=TOL), (k, a, b)
        # every body is drawn where the model puts it, a dot of positive size
        positions = np.asarray(getattr(model.module, f"{phase}_positions")(*params, *x), float)
        positions = positions.reshape(-1, 3)[:, :2]
        assert len(frames.bodies[k]) == len(positions) == len(drawing["bodies"])
        bodies = _chart(frames, k, frames.bodies[k]) - foot
        assert np.allclose(bodies, positions, rtol=0, atol=TOL), (k, phase)
        assert np.all(frames.radii[k] > 0)


@pytest.mark.parametrize("name", keys())
def test_the_walker_stays_inside_the_frame(name):
    _, _, frames = _frames(name)
    for k in range(len(frames.t)):
        drawn = [frames.points[k], frames.lines[k].reshape(-1, 2)]
        drawn += [frames.bodies[k] + frames.radii[k][:, None] * d for d in (1, -1)]
        for p in np.vstack(drawn):
            assert 0 <= p[0] <= WIDTH and 0 <= p[1] <= HEIGHT, (k, p)
    hip_x = frames.hip[:, 0]
    assert np.ptp(hip_x) <= 1e-6  # the view follows the hip across the ground


@pytest.mark.parametrize("name", keys())
def test_a_foot_above_the_ground_is_drawn_above_it(name):
    """The swing foot's drawn height over the drawn ground line is the model's own
    clearance (``<phase>_swing_foot_clearance``, where the model states it): above the
    line where that is positive, below it where the foot scuffs."""
    model, params, frames = _frames(name)
    checked = 0
    for k in range(len(frames.t)):
        clearance = getattr(model.module, f"{frames.phase[k]}_swing_foot_clearance", None)
        if clearance is None:
            continue
        height = float(clearance(*params, *frames.states[k]))
        foot = frames.points[k][frames.point_names[k].index("swing_foot")]
        (x0, y0), (x1, y1) = frames.ground[k]
        # pixel y grows downwards: above the line is a negative cross product
        cross = (x1 - x0) * (foot[1] - y0) - (y1 - y0) * (foot[0] - x0)
        if height > TOL:
            assert cross < 0, (k, height)
        distance = -cross / math.hypot(x1 - x0, y1 - y0) / frames.scale
        assert distance == pytest.approx(height, abs=1e-6), k
        checked += 1
    if any(hasattr(model.module, f"{p['name']}_swing_foot_clearance") for p in model.phases):
        assert checked


@pytest.mark.parametrize("name", keys())
def test_every_segment_and_body_is_painted(name):
    """The raster paints what the frame data say: a painted pixel at (next to) each
    segment's middle and each body's centre."""
    _, _, frames = _frames(name)
    for k in sorted({0, len(frames.t) // 2, len(frames.t) - 1}):
        rgb = np.asarray(_raster(frames, k).convert("RGB"), dtype=int)
        centres = [0.5 * (a + b) for a, b in frames.lines[k] if np.linalg.norm(a - b) > 3]
        centres += list(frames.bodies[k])
        for x, y in centres:
            # a line 2 pixels wide may fall either side of the rounded pixel
            near = rgb[math.floor(y) - 1 : math.floor(y) + 2, math.floor(x) - 1 : math.floor(x) + 2]
            assert np.any(near != 255), (k, x, y)


def test_the_kneed_walkers_swing_foot_by_hand():
    """In the knee-free phase the swing leg bends at its knee: its foot from the parameter
    table (thigh a2 + b2, shank a1 + b1) and the model file's conventions (angles from the
    slope normal, a leg at angle q points from foot to hip along (sin q, cos q); psi the
    swing thigh's angle, hip downhill of the knee; kappa the shank less the thigh)."""
    model = load("kneed_walker")
    params = model.parameters()
    p = dict(zip(model.spec["parameters"], params))
    # Hsu Chen's gait as the model file states it, just after heelstrike
    start = dict(theta=-0.238, theta_dot=1.10, psi_dot=0.04)
    state = np.array([start.get(n, 0.0) for n in (*model.coordinates, *model.rates)])
    state = np.array([float(v) for v in model.module.section_completion(*params, *state)])
    frames = animation_frames(model, params, state, 1, fps=30)
    names = (*model.coordinates, *model.rates)
    thigh, shank = p["a2"] + p["b2"], p["a1"] + p["b1"]
    bent = 0
    for k in range(len(frames.t)):
        values = dict(zip(names, frames.states[k]))
        if frames.phase[k] != "knee_free" or values["kappa"] < 0.3:
            continue
        theta, psi, kappa = values["theta"], values["psi"], values["kappa"]
        hip = (thigh + shank) * np.array([math.sin(theta), math.cos(theta)])
        knee = hip - thigh * np.array([math.sin(psi), math.cos(psi)])
        foot = knee - shank * np.array([math.sin(psi + kappa), math.cos(psi + kappa)])
        point = dict(zip(frames.point_names[k], _chart(frames, k, frames.points[k])))
        stance = point["stance_foot"]
        assert np.allclose(point["swing_foot"] - stance, foot, rtol=0, atol=TOL), k
        assert np.allclose(point["swing_knee"] - stance, knee, rtol=0, atol=TOL), k
        assert np.allclose(point["hip"] - stance, hip, rtol=0, atol=TOL), k
        # a straight leg to the knee-locked contact point would be drawn elsewhere
        straight = hip - (thigh + shank) * np.array([math.sin(psi), math.cos(psi)])
        assert np.linalg.norm(straight - foot) > 0.1
        bent += 1
    assert bent >= 3, "the gait has no frames with the knee bent"


@pytest.mark.parametrize("name", keys())
def test_the_skeletons_feet_and_hip_are_the_models(name):
    """At random states of the step event's source phase: the skeleton's stance foot is
    the chart's origin, its hip is body 0 where that body is the hip (a walker with no mass
    at its hip has none there) and its swing foot is the point the step's impact makes the
    new contact (``event_<step>_contact``)."""
    model = load(name)
    params = model.parameters()
    step = model.step_event
    phase = _phase(model, step["source"])
    names = list(phase["skeleton"]["points"])
    contact = getattr(model.module, f"event_{step['name']}_contact", None)
    rng = np.random.default_rng(7)
    start = _search_start(model, params)
    for _ in range(5):
        x = start + rng.uniform(-0.2, 0.2, size=start.shape)
        xy = np.asarray(getattr(model.module, f"{phase['name']}_skeleton")(*params, *x), float)
        point = dict(zip(names, xy.reshape(-1, 2)))
        positions = getattr(model.module, f"{phase['name']}_positions")(*params, *x)
        assert np.allclose(point["stance_foot"], 0, atol=1e-15)
        if "hip" in point and phase["skeleton"]["bodies"][0] == "hip":
            assert np.allclose(point["hip"], np.asarray(positions[:2], float), rtol=1e-12)
        if "swing_foot" in point and contact is not None:
            assert np.allclose(point["swing_foot"], np.asarray(contact(*params, *x), float),
                               rtol=1e-12, atol=1e-14)  # fmt: skip


def test_a_skeleton_naming_an_unknown_point_is_refused():
    import dataclasses

    from derive.engine.hybrid import hybrid_quantities
    from derive.engine.model import Skeleton
    from derive.models.rimless_wheel import MODEL

    bad = dataclasses.replace(MODEL, skeleton=Skeleton({"hub": (0, 1)}, (("hub", "rim"),)))
    bad = dataclasses.replace(bad, phases=tuple(dataclasses.replace(p, skeleton=None)
                                                for p in bad.phases))  # fmt: skip
    with pytest.raises(ValueError, match="rim"):
        hybrid_quantities(bad)
