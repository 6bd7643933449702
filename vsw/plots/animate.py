"""``vsw animate``: the gait as a moving stick figure, for every model of the engine.

The frames come from the model's time-domain simulation (:meth:`vsw.dynamics.hybrid.HybridModel.
simulate`, SciPy DOP853 with the model's events), sampled at the frame rate and at every
event instant (an extra frame there, so an extension or heelstrike is shown where it
happens). The picture is the derivation's, phase by phase: every segment of the current
phase's drawing (``<phase>_skeleton``: the points the model file's
:class:`~derive.engine.model.Skeleton` names, or the engine's stick figure from the stance
foot, the hip and the step's contact point), every body as a dot whose area grows with its
mass (``<phase>_positions``, ``<phase>_inertias``) and, for a wheel, its spokes. Each
phase's chart has its stance foot at the origin; the stance foot moves on by the step
length at every step event. The ground runs along the slope (turned so it descends to the
right) with marks that scroll by as the view follows the hip across it; the whole walk
fits the frame at one scale. Also drawn: the hip's path, a marker and label at each event,
and the time and step counters. A leg keeps its colour for the whole walk, whichever
stands (a point named ``stance_*`` or ``swing_*`` says which leg it is on).

Formats: GIF through Pillow (default), an animated SVG (SMIL, no dependency) and MP4
when ``ffmpeg`` is on the PATH. Frames and the output size are bounded before drawing.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import shutil
import subprocess
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsw.runtime.errors import VswInputError

__all__ = ["MAX_FRAMES", "Animation", "animation_frames", "write_animation"]

MAX_FRAMES = 3000
"""Most frames of one animation (100 s at 30 frames a second)."""
MAX_BYTES = 64 * 1024 * 1024
"""Largest estimated output."""
WIDTH, HEIGHT = 480, 270
COLORS = {  # Okabe-Ito, as vsw.plots.plotstyle
    "ground": (140, 140, 140),
    "leg_a": (0, 114, 178),  # one colour per leg for the whole walk, whichever stands
    "leg_b": (213, 94, 0),
    "spoke": (120, 120, 120),
    "body": (60, 60, 60),  # a segment on neither leg: a torso
    "hip": (0, 0, 0),
    "path": (86, 180, 233),
    "event": (0, 158, 115),
    "text": (0, 0, 0),
}
FORMATS = (".gif", ".svg", ".mp4")


@dataclass
class Animation:
    """The frames of a walk in the drawing's pixel frame.

    Per frame ``k``: ``t`` its model time, ``phase`` and ``states`` the phase and state it
    draws, ``step`` the steps completed, ``event`` the event that happens at it ('' for
    none), ``foot`` the stance foot's x in the first step's chart (model lengths), and
    ``origins[k]`` the pixel of that chart's origin (the view follows the hip: it moves). A
    point (x, y) of the first step's chart is drawn at ``origins[k] + scale * (X, -Y)``,
    (X, Y) the point turned by ``slope`` so that the ground descends to the right
    (:meth:`to_pixels`; a phase's chart is the first step's moved by ``foot[k]`` along x).

    Drawn per frame, in pixels: ``point_names`` and ``points`` (the phase's skeleton,
    ``<phase>_skeleton`` in its order), ``lines`` ((L, 2, 2): the skeleton's segments in
    its order, then a wheel's other spokes) with ``line_colors`` (keys of ``COLORS``),
    ``bodies`` ((B, 2): each body's position, ``<phase>_positions``' order) with ``radii``
    and ``body_colors``, ``ground`` (the ground line's ends) and ``ticks`` ((T, 2, 2): the
    marks on the ground). ``hip``: (frames, 2) pixels of the hip (the skeleton's ``hip``,
    else body 0), ``hip_world`` the same in the first step's chart.
    """

    t: np.ndarray
    phase: list[str]
    states: np.ndarray
    step: np.ndarray
    event: list[str]
    foot: np.ndarray
    scale: float
    origins: np.ndarray
    slope: float
    fps: float
    time_unit: str
    ended: str
    title: str
    point_names: list[tuple[str, ...]]
    points: list[np.ndarray]
    lines: list[np.ndarray]
    line_colors: list[tuple[str, ...]]
    bodies: list[np.ndarray]
    radii: list[np.ndarray]
    body_colors: list[tuple[str, ...]]
    hip: np.ndarray
    hip_world: np.ndarray
    ground: list[np.ndarray]
    ticks: list[np.ndarray]
    leg_a_stands: np.ndarray
    tick_spacing: float

    def to_world(self, xy: np.ndarray) -> np.ndarray:
        """Points of the first step's chart turned so that the slope descends to the right
        and scaled to pixels, before the frame's origin is added (y up)."""
        c, s = math.cos(self.slope), math.sin(self.slope)
        xy = np.asarray(xy, dtype=float)
        turned_x = c * xy[..., 0] + s * xy[..., 1]
        turned_y = -s * xy[..., 0] + c * xy[..., 1]
        return np.stack([self.scale * turned_x, -self.scale * turned_y], axis=-1)

    def to_pixels(self, xy: np.ndarray, k: int = 0) -> np.ndarray:
        """Points of the first step's chart as pixels of frame ``k``."""
        return self.origins[k] + self.to_world(xy)


def _frame_times(t_end: float, fps: float, speed: float, events: Sequence[float]) -> np.ndarray:
    dt = speed / fps  # model time per frame
    regular = np.arange(0.0, t_end + 0.5 * dt, dt)
    regular = regular[regular <= t_end]
    return np.unique(np.concatenate([regular, np.asarray(events, float), [t_end]]))


def _leg_of(name: str) -> str:
    """Which leg a point or body is on, by its name: ``stance``, ``swing`` or ''."""
    for side in ("stance", "swing"):
        if name.startswith(side):
            return side
    return ""


def _color(side: str, leg_a_stands: bool, other: str) -> str:
    if not side:
        return other
    return "leg_a" if (side == "stance") == leg_a_stands else "leg_b"


def _nice(value: float) -> float:
    """1, 2 or 5 times a power of ten, near ``value``."""
    power = 10.0 ** math.floor(math.log10(value))
    return min((1.0, 2.0, 5.0, 10.0), key=lambda m: abs(math.log(m * power / value))) * power


@dataclass
class _Drawn:
    """One frame in the first step's chart (model lengths), before the pixel transform."""

    names: tuple[str, ...]
    points: np.ndarray
    segments: list[tuple[int, int]]
    segment_colors: list[str]
    spokes: np.ndarray  # (S, 2, 2)
    bodies: np.ndarray
    masses: np.ndarray
    body_colors: tuple[str, ...]
    hip: np.ndarray


def _draw_state(model, params, phase: dict, x: np.ndarray, foot: float, a_stands: bool) -> _Drawn:
    """The drawing of one state of ``phase``: its skeleton, bodies and spokes, the stance
    foot at (``foot``, 0) of the first step's chart."""
    module, name, drawing = model.module, phase["name"], phase["skeleton"]
    shift = np.array([foot, 0.0])
    xy = np.asarray(getattr(module, f"{name}_skeleton")(*params, *x), float).reshape(-1, 2)
    xy = xy + shift
    names = tuple(drawing["points"])
    where = {n: k for k, n in enumerate(names)}
    segments, colors = [], []
    for a, b in drawing["segments"]:
        segments.append((where[a], where[b]))
        colors.append(_color(_leg_of(a) or _leg_of(b), a_stands, "body"))
    spokes = np.zeros((0, 2, 2))
    if "spokes" in drawing:
        center, end, angle_fn = drawing["spokes"]
        angle = float(getattr(module, angle_fn)(*params, *x))
        count = max(3, round(2 * math.pi / angle))
        hub, arm = xy[where[center]], xy[where[end]] - xy[where[center]]
        ends = []
        for k in range(1, count):
            c, s = math.cos(k * angle), math.sin(k * angle)
            ends.append(hub + np.array([c * arm[0] - s * arm[1], s * arm[0] + c * arm[1]]))
        spokes = np.array([[hub, e] for e in ends])
    positions = np.asarray(getattr(module, f"{name}_positions")(*params, *x), float)
    bodies = positions.reshape(-1, 3)[:, :2] + shift
    inertias = np.asarray(getattr(module, f"{name}_inertias")(*params, *x), float)
    masses = inertias.reshape(-1, 2)[:, 0]
    body_colors = tuple(_color(_leg_of(b), a_stands, "hip") for b in drawing["bodies"])
    hip = xy[where["hip"]] if "hip" in where else bodies[0]
    return _Drawn(names, xy, segments, colors, spokes, bodies, masses, body_colors, hip)


def animation_frames(
    model,
    params: Sequence[float],
    state: Sequence[float],
    steps: int,
    fps: float = 30.0,
    speed: float = 1.0,
    title: str = "",
) -> Animation:
    """Simulate ``steps`` steps of ``model`` from the section state ``state`` and sample
    the stick figure at ``fps`` frames per second of playback, ``speed`` model time units
    per second (and at every event)."""
    _check_playback(steps, fps, speed)
    trajectory = _simulated_walk(model, params, state, steps, speed / fps)
    t_end = float(trajectory.t[-1])
    ts, xs, ph = trajectory.t, trajectory.states, trajectory.phase
    boundaries = _event_boundaries(ts, xs, ph)
    times = _frame_times(t_end, fps, speed, [float(ts[i]) for i in boundaries])
    sample_step, offsets, names = _steps_walked(model, params, trajectory, boundaries)
    # Frame states: the last sample at or before each frame time, linearly interpolated
    # within a phase (samples are at most half a frame apart).
    index = np.searchsorted(ts, times, side="right") - 1
    index = np.clip(index, 0, len(ts) - 1)
    leg_a_stands = sample_step[index] % 2 == 0
    states, drawn = [], []
    for k, i in enumerate(index):
        x = xs[i]
        if i + 1 < len(ts) and ts[i + 1] > ts[i] and ph[i + 1] == ph[i]:
            w = (times[k] - ts[i]) / (ts[i + 1] - ts[i])
            x = (1 - w) * xs[i] + w * xs[i + 1]
        states.append(np.asarray(x, float))
        phase = model.phases[ph[i]]
        drawn.append(_draw_state(model, params, phase, x, float(offsets[i]),
                                 bool(leg_a_stands[k])))  # fmt: skip
    labels = [""] * len(times)
    for t_event, name in names:
        labels[int(np.searchsorted(times, t_event))] = name
    frames = Animation(
        t=times, phase=[model.phases[ph[i]]["name"] for i in index], states=np.array(states),
        step=sample_step[index], event=labels, foot=offsets[index], scale=1.0,
        origins=np.zeros((len(times), 2)), slope=model.slope(params), fps=fps,
        time_unit=model.units.get("time", ""), ended=trajectory.ended, title=title,
        point_names=[d.names for d in drawn], points=[], lines=[], line_colors=[], bodies=[],
        radii=[], body_colors=[d.body_colors for d in drawn], hip=np.zeros((len(times), 2)),
        hip_world=np.array([d.hip for d in drawn]), ground=[], ticks=[],
        leg_a_stands=leg_a_stands, tick_spacing=1.0,
    )  # fmt: skip
    _lay_out(frames, drawn)
    return frames


def _check_playback(steps: int, fps: float, speed: float) -> None:
    """The steps, frame rate and playback speed of an animation, within their bounds."""
    if not 1 <= steps <= 1000:
        raise VswInputError(f"--steps = {steps} must be from 1 to 1000")
    if not (math.isfinite(fps) and 1 <= fps <= 120):
        raise VswInputError(f"--fps = {fps:g} must be from 1 to 120")
    if not (math.isfinite(speed) and 0 < speed <= 1000):
        raise VswInputError(f"the playback speed {speed:g} must lie in (0, 1000]")


def _simulated_walk(
    model: Any, params: Sequence[float], state: Sequence[float], steps: int, dt: float
) -> Any:
    """The walk of ``steps`` steps sampled at most ``dt / 2`` (model time) apart, refused
    before it is simulated when it would make too many frames."""
    # The frame count from the first step's duration, before simulating them all.
    first = model.simulate(params, np.asarray(state, float), 1)
    estimate = steps * (float(first.t[-1]) / dt + 2 * len(model.phases))
    if estimate > MAX_FRAMES:
        raise VswInputError(
            f"the animation would have about {estimate:.0f} frames, more than {MAX_FRAMES}: "
            "use fewer --steps, a higher --speed or a lower --fps"
        )
    trajectory = model.simulate(params, np.asarray(state, float), steps, max_step=dt / 2)
    if len(np.unique(trajectory.t)) > 50 * MAX_FRAMES:  # a walk far slower than its first step
        raise VswInputError("the walk slowed down too much to animate: use fewer --steps")
    return trajectory


def _event_boundaries(ts: np.ndarray, xs: np.ndarray, ph: np.ndarray) -> list[int]:
    """The samples at which an event happens: the second of two samples at one time."""
    # Event instants: two samples at one time with different states (a reset) or phases;
    # repeated samples of one state (a phase's last step and its event point, an event
    # that did not count) are not events.
    return [
        i for i in range(1, len(ts))
        if ts[i] == ts[i - 1] and (ph[i] != ph[i - 1] or np.any(xs[i] != xs[i - 1]))
    ]  # fmt: skip


def _steps_walked(
    model: Any, params: Sequence[float], trajectory: Any, boundaries: list[int]
) -> tuple[np.ndarray, np.ndarray, list[tuple[float, str]]]:
    """Each sample's count of steps completed and its stance foot's x in the first step's
    chart, and each event's time and name."""
    ts, xs, ph = trajectory.t, trajectory.states, trajectory.phase
    step_event = model.step_event
    contact_fn = getattr(model.module, f"event_{step_event['name']}_contact", None)
    sample_step = np.zeros(len(ts), dtype=int)
    offsets = [0.0]
    names = []
    count, offset = 0, 0.0
    is_boundary = set(boundaries)
    for i in range(1, len(ts)):
        if i in is_boundary:
            before, after = xs[i - 1], xs[i]
            event = _which_event(model, ph[i - 1], ph[i], before, after, params)
            names.append((float(ts[i]), event["name"]))
            if event["ends_step"]:
                count += 1
                length = model.step_length(params, before)
                if length is None and contact_fn is not None:
                    length = float(contact_fn(*params, *before)[0])
                offset += length or 0.0
        sample_step[i] = count
        offsets.append(offset)
    if trajectory.steps_completed > count:  # the last step event ends the samples (no reset)
        names.append((float(trajectory.t[-1]), step_event["name"]))
        sample_step[-1] = trajectory.steps_completed
    return sample_step, np.array(offsets), names


BOTTOM, SIDE = 14, 14
"""Pixels kept free below the walker and at its sides (above it: :func:`top_margin`)."""
LINE = 12
"""Pixels from one line of text to the next (Pillow's default font, 10 px)."""
TITLE_WIDTH = WIDTH - 6 - 40
"""Pixels a line of the title may take: from its left margin to left of the gravity arrow."""


def _font(size: int = 10):
    from PIL import ImageFont

    return ImageFont.load_default(size=size)


def title_lines(title: str, size: int = 10) -> list[str]:
    """The title broken between its ``name = value`` items (after a comma or colon) into
    lines that each fit :data:`TITLE_WIDTH` in Pillow's default font of ``size`` px; an
    item longer than a line is broken between characters."""
    font = _font(size)
    items = [piece for piece in re.split(r"(?<=[,:]) ", title) if piece]
    lines: list[str] = []
    for item in items:
        joined = f"{lines[-1]} {item}" if lines else item
        if lines and font.getlength(joined) <= TITLE_WIDTH:
            lines[-1] = joined
            continue
        while font.getlength(item) > TITLE_WIDTH and len(item) > 1:
            cut = max(k for k in range(1, len(item)) if font.getlength(item[:k]) <= TITLE_WIDTH)
            lines.append(item[:cut])
            item = item[cut:]
        lines.append(item)
    return lines or [""]


def top_margin(title: str) -> int:
    """Pixels kept free above the walker: the title's lines, the counters and an event."""
    return LINE * (len(title_lines(title)) + 2) + 8


def _lay_out(frames: Animation, drawn: list[_Drawn]) -> None:
    """One scale for the whole walk and a view that follows the hip along the ground: the
    hip stays in the middle of the frame, the ground under it at one height."""
    tan = math.tan(frames.slope)
    # Turned (unscaled) positions relative to the view's centre: the hip's x, the ground's
    # height there.
    unit = dataclasses.replace(frames, scale=1.0)
    centres = []
    spans = []
    for d in drawn:
        hip_x, _ = unit.to_world(d.hip)
        centre = np.array([hip_x, tan * hip_x])  # pixel y down: the ground below the hip
        centres.append(centre)
        everything = [d.points, d.bodies, d.spokes.reshape(-1, 2), d.hip[None]]
        spans.append(unit.to_world(np.vstack(everything)) - centre)
    spans = np.vstack([*spans, np.zeros((1, 2))])
    half_width = max(float(np.max(np.abs(spans[:, 0]))), 1e-9)
    low, high = float(np.min(spans[:, 1])), float(np.max(spans[:, 1]))  # pixel y: down
    top = top_margin(frames.title)
    scale = min((WIDTH / 2 - SIDE) / half_width, (HEIGHT - top - BOTTOM) / max(high - low, 1e-9))
    frames.scale = scale
    centre_y = top - scale * low
    frames.origins = np.array([[WIDTH / 2, centre_y]]) - scale * np.array(centres)
    heaviest = max(max((float(np.max(d.masses)) for d in drawn if len(d.masses)), default=1.0),
                   1e-300)  # fmt: skip
    reach = max(float(np.max(np.linalg.norm(d.hip - d.points, axis=1))) for d in drawn)
    frames.tick_spacing = _nice(0.25 * reach) if reach > 0 else 1.0
    c = math.cos(frames.slope)
    for k, d in enumerate(drawn):
        pts = frames.to_pixels(d.points, k)
        frames.points.append(pts)
        lines = [np.array([pts[a], pts[b]]) for a, b in d.segments]
        lines += [frames.to_pixels(spoke, k) for spoke in d.spokes]
        frames.lines.append(np.array(lines).reshape(-1, 2, 2))
        frames.line_colors.append(tuple(d.segment_colors) + ("spoke",) * len(d.spokes))
        frames.bodies.append(frames.to_pixels(d.bodies, k))
        # A dot's area grows with its mass; a massless body is still marked.
        frames.radii.append(2.0 + 5.0 * np.sqrt(np.clip(d.masses, 0, None) / heaviest))
        frames.hip[k] = frames.to_pixels(d.hip, k)
        # The ground across the frame: chart x where it leaves each side.
        ox = frames.origins[k, 0]
        s0, s1 = (-10 - ox) / (scale * c), (WIDTH + 10 - ox) / (scale * c)
        frames.ground.append(frames.to_pixels(np.array([[s0, 0.0], [s1, 0.0]]), k))
        frames.ticks.append(_ticks(frames, k, s0, s1))


def _ticks(frames: Animation, k: int | None, s0: float, s1: float) -> np.ndarray:
    """Marks below the ground every ``tick_spacing`` from chart x ``s0`` to ``s1``: in
    frame ``k``'s pixels, or unshifted (``k`` None) for a drawing that moves them all."""
    spacing = frames.tick_spacing
    marks = np.arange(math.ceil(s0 / spacing), math.floor(s1 / spacing) + 1) * spacing
    depth = 6.0 / frames.scale
    top = np.column_stack([marks, np.zeros_like(marks)])
    ends = np.stack([top, top - depth], axis=1)  # down and back from the ground
    return frames.to_world(ends) if k is None else frames.to_pixels(ends, k)


def _which_event(model, phase_before: int, phase_after: int, before, after, params) -> dict:
    """The event between two samples at one instant: the one from the phase before whose
    reset maps ``before`` to ``after`` (for one event per phase, the phase's event)."""
    source = model.phases[phase_before]["name"]
    target = model.phases[phase_after]["name"]
    candidates = [e for e in model.events if e["source"] == source and e["target"] == target]
    if len(candidates) > 1:
        candidates.sort(key=lambda e: float(np.max(np.abs(model.reset(e["name"], params, before)
                                                          - after))))  # fmt: skip
    return candidates[0] if candidates else model.step_event


def _check_output(path: str) -> Path:
    out = Path(path)
    if out.suffix.lower() not in FORMATS:
        raise VswInputError(f"--out {path}: the file must end in {', '.join(FORMATS)}")
    if out.suffix.lower() == ".mp4" and shutil.which("ffmpeg") is None:
        raise VswInputError(f"--out {path}: MP4 needs ffmpeg on the PATH (not found); "
                            "write .gif (Pillow) or .svg instead")  # fmt: skip
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise VswInputError(f"--out {path}: the directory {parent} does not exist")
    return out


def check_output(path: str) -> Path:
    """The output path, checked before any work: its format and directory."""
    return _check_output(path)


def write_animation(frames: Animation, path: str) -> Path:
    """Write ``frames`` as GIF, SVG or MP4 by the file's extension."""
    out = _check_output(path)
    n = len(frames.t)
    if n > MAX_FRAMES:
        raise VswInputError(f"{n} frames are more than {MAX_FRAMES}")
    suffix = out.suffix.lower()
    per_frame = {".gif": 6_000, ".svg": 700, ".mp4": 3_000}[suffix]
    if n * per_frame > MAX_BYTES:
        raise VswInputError(
            f"the {suffix[1:].upper()} would be about {n * per_frame / 2**20:.0f} MiB, more "
            f"than {MAX_BYTES / 2**20:.0f} MiB: use fewer --steps or a lower --fps"
        )
    if suffix == ".svg":
        out.write_text(_svg(frames))
    elif suffix == ".gif":
        images = [_raster(frames, k) for k in range(n)]
        images[0].save(out, save_all=True, append_images=images[1:], optimize=False,
                       duration=round(1000 / frames.fps), loop=0, disposal=1)  # fmt: skip
    else:
        _mp4(frames, out)
    return out


def _raster(frames: Animation, k: int):
    from PIL import Image, ImageDraw

    image = Image.new("RGB", (WIDTH, HEIGHT), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    draw.line([tuple(p) for p in frames.ground[k]], fill=COLORS["ground"], width=2)
    for a, b in frames.ticks[k]:
        draw.line([tuple(a), tuple(b)], fill=COLORS["ground"], width=1)
    _gravity(draw)
    # The hip's path so far and the events' markers, where the view now puts them.
    shift = frames.origins[k] - frames.origins[: k + 1]
    path = frames.hip[: k + 1] + shift
    if k > 0:
        draw.line([tuple(p) for p in path], fill=COLORS["path"], width=1)
    for j in range(k + 1):
        if frames.event[j]:
            x, y = path[j]
            draw.rectangle([x - 2, y - 2, x + 2, y + 2], outline=COLORS["event"])
    for (a, b), color in zip(frames.lines[k], frames.line_colors[k]):
        draw.line([tuple(a), tuple(b)], fill=COLORS[color], width=2 if color == "spoke" else 3)
    for (x, y), r, color in zip(frames.bodies[k], frames.radii[k], frames.body_colors[k]):
        draw.ellipse([x - r, y - r, x + r, y + r], fill=COLORS[color], outline=(0, 0, 0))
    unit = f" {frames.time_unit}" if frames.time_unit else ""
    font = _font()
    lines = title_lines(frames.title)
    for i, line in enumerate(lines):
        draw.text((6, 4 + LINE * i), line, fill=COLORS["text"], font=font)
    below = 4 + LINE * len(lines)
    draw.text((6, below), f"t = {frames.t[k]:.3f}{unit}   steps: {frames.step[k]}",
              fill=COLORS["text"], font=font)  # fmt: skip
    if frames.event[k]:
        draw.text((6, below + LINE), frames.event[k], fill=COLORS["event"], font=font)
    return image


_ARROW = ((WIDTH - 16, 8), (WIDTH - 16, 38))  # gravity: down, top right


def _gravity(draw) -> None:
    (x, y0), (_, y1) = _ARROW
    draw.line([(x, y0), (x, y1)], fill=COLORS["text"], width=2)
    draw.polygon([(x - 4, y1 - 6), (x + 4, y1 - 6), (x, y1 + 1)], fill=COLORS["text"])
    draw.text((x - 14, y0 + 8), "g", fill=COLORS["text"])


def _mp4(frames: Animation, out: Path) -> None:
    command = ["ffmpeg", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24",
               "-s", f"{WIDTH}x{HEIGHT}", "-r", f"{frames.fps:g}", "-i", "-",
               "-pix_fmt", "yuv420p", "-vcodec", "libx264", str(out)]  # fmt: skip
    with subprocess.Popen(command, stdin=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
        assert proc.stdin is not None
        try:
            for k in range(len(frames.t)):
                proc.stdin.write(_raster(frames, k).tobytes())
        except BrokenPipeError:
            pass
        _, err = proc.communicate()
    if proc.returncode != 0:
        first = (err.decode(errors="replace").strip().splitlines() or ["failed"])[0]
        raise VswInputError(f"ffmpeg could not write {out}: {first}")


def _padded(rows: list[np.ndarray], fill: np.ndarray) -> np.ndarray:
    """Per-frame arrays of varying length stacked to the longest, short ones padded with
    ``fill`` (per frame) so that an SVG element can stand for one slot in every frame."""
    most = max(len(r) for r in rows)
    out = np.repeat(fill[:, None], most, axis=1).astype(float)
    for k, r in enumerate(rows):
        out[k, : len(r)] = r
    return out


def _svg(frames: Animation) -> str:
    """An animated SVG that plays once and stays on the last frame: each drawn element's
    coordinates as SMIL ``values`` (discrete, one per frame), the ground, its marks, the
    hip's path and the event markers in a group the view's motion moves, the counters and
    event markers as ``set`` on their frames."""
    values = functools.partial(_smil, len(frames.t) * (1.0 / frames.fps))
    lines = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" '
        f'viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="11">',
        f"<title>{_escape(frames.title)}</title>",
        f'<rect width="{WIDTH}" height="{HEIGHT}" fill="white"/>',
        *_svg_moving_group(frames, values),
        _svg_gravity(),
        *_svg_segments(frames, values),
        *_svg_bodies(frames, values),
        *_svg_text(frames),
        "</svg>",
    ]
    return "\n".join(lines) + "\n"


def _smil(
    duration: float, attribute: str, items: Iterable[str], tag: str = "animate", extra: str = ""
) -> str:
    """A SMIL animation of ``attribute`` through ``items``, one per frame, over the
    animation's ``duration`` (seconds); it stays on the last."""
    return (f'<{tag} attributeName="{attribute}" dur="{duration:.3f}s" fill="freeze" '
            f'calcMode="discrete"{extra} values="{";".join(items)}"/>')  # fmt: skip


def _svg_numbers(values: Callable[..., str], attribute: str, column: np.ndarray) -> str:
    """A numeric attribute per frame (pixels to 0.01)."""
    return values(attribute, (f"{v:.2f}" for v in column))


def _svg_paint(values: Callable[..., str], attribute: str, keys: list[str]) -> str:
    """A colour: fixed where it never changes, else animated."""
    colors = [f"rgb{COLORS[key]}".replace(" ", "") for key in keys]
    if len(set(colors)) == 1:
        return f' {attribute}="{colors[0]}">'
    return ">" + values(attribute, colors)


def _svg_moving_group(frames: Animation, values: Callable[..., str]) -> list[str]:
    """The group the view's motion moves: the ground across every frame's view, its
    marks, the hip's path and the event markers (each shown from its frame on)."""
    frame = 1.0 / frames.fps
    world_hip = frames.hip - frames.origins  # in the moving group's coordinates
    gx = frames.origins[:, 0]
    c = math.cos(frames.slope)
    s0 = float(np.min((-10 - gx) / (frames.scale * c)))
    s1 = float(np.max((WIDTH + 10 - gx) / (frames.scale * c)))
    (gx0, gy0), (gx1, gy1) = frames.to_world(np.array([[s0, 0.0], [s1, 0.0]]))
    ticks = _ticks(frames, None, s0, s1)
    move = values("transform", (f"{x:.2f},{y:.2f}" for x, y in frames.origins),
                  tag="animateTransform", extra=' type="translate"')  # fmt: skip
    lines = [
        f'<g transform="translate({frames.origins[0, 0]:.2f},{frames.origins[0, 1]:.2f})">'
        + move,
        f'<line x1="{gx0:.2f}" y1="{gy0:.2f}" x2="{gx1:.2f}" y2="{gy1:.2f}" '
        f'stroke="rgb{COLORS["ground"]}" stroke-width="2"/>',
        *(
            f'<line x1="{a[0]:.2f}" y1="{a[1]:.2f}" x2="{b[0]:.2f}" y2="{b[1]:.2f}" '
            f'stroke="rgb{COLORS["ground"]}" stroke-width="1"/>'
            for a, b in ticks
        ),
        _walked_path(world_hip, values),
    ]  # fmt: skip
    for k in range(len(frames.t)):
        if frames.event[k]:
            x, y = world_hip[k]
            lines.append(
                f'<rect x="{x - 2:.2f}" y="{y - 2:.2f}" width="4" height="4" fill="none" '
                f'stroke="rgb{COLORS["event"]}" visibility="hidden"><set attributeName='
                f'"visibility" to="visible" begin="{k * frame:.4f}s" fill="freeze"/>'
                f"<title>{_escape(frames.event[k])} at t = {frames.t[k]:.4f}</title></rect>"
            )
    lines.append("</g>")
    return lines


def _svg_gravity() -> str:
    """The gravity arrow, fixed at the top right."""
    (ax, ay0), (_, ay1) = _ARROW
    return (
        f'<line x1="{ax}" y1="{ay0}" x2="{ax}" y2="{ay1 - 6}" stroke="black" stroke-width="2"/>'
        f'<polygon points="{ax - 4},{ay1 - 6} {ax + 4},{ay1 - 6} {ax},{ay1 + 1}" fill="black"/>'
        f'<text x="{ax - 14}" y="{ay0 + 16}">g</text>'
    )


def _svg_segments(frames: Animation, values: Callable[..., str]) -> list[str]:
    """One line per segment slot of the frames (the skeleton's segments, then spokes)."""
    # A segment's slot where a frame has fewer is a point at the hip: nothing is drawn.
    ends = _padded([f.reshape(-1, 4) for f in frames.lines], np.tile(frames.hip, 2))
    lines = []
    for j in range(ends.shape[1]):
        keys = [cs[j] if j < len(cs) else "spoke" for cs in frames.line_colors]
        width = 2 if set(keys) == {"spoke"} else 3
        lines.append(
            f'<line stroke-width="{width}"' + _svg_paint(values, "stroke", keys)
            + "".join(_svg_numbers(values, a, ends[:, j, m])
                      for m, a in enumerate(("x1", "y1", "x2", "y2")))
            + "</line>"
        )  # fmt: skip
    return lines


def _svg_bodies(frames: Animation, values: Callable[..., str]) -> list[str]:
    """One circle per body slot of the frames, its radius fixed where it never changes."""
    n = len(frames.t)
    centres = _padded(frames.bodies, frames.hip)
    radii = _padded([r[:, None] for r in frames.radii], np.zeros((n, 1)))[..., 0]
    lines = []
    for j in range(centres.shape[1]):
        keys = [cs[j] if j < len(cs) else "hip" for cs in frames.body_colors]
        r = radii[:, j]
        size = f' r="{r[0]:.2f}"' if np.all(r == r[0]) else ""
        lines.append(
            f'<circle{size} stroke="black"' + _svg_paint(values, "fill", keys)
            + ("" if size else _svg_numbers(values, "r", r))
            + _svg_numbers(values, "cx", centres[:, j, 0])
            + _svg_numbers(values, "cy", centres[:, j, 1]) + "</circle>"
        )  # fmt: skip
    return lines


def _svg_text(frames: Animation) -> list[str]:
    """The title's lines, and the time and step counters shown one frame at a time."""
    n = len(frames.t)
    frame = 1.0 / frames.fps
    unit = f" {frames.time_unit}" if frames.time_unit else ""
    lines = []
    rows = title_lines(frames.title, size=11)
    for i, row in enumerate(rows):
        lines.append(f'<text x="6" y="{14 + 13 * i}">{_escape(row)}</text>')
    at = 14 + 13 * len(rows)
    for k in range(n):
        last = k == n - 1
        timing = f'begin="{k * frame:.4f}s"' + ("" if last else f' dur="{frame:.4f}s"')
        lines.append(
            f'<text x="6" y="{at}" visibility="hidden">t = {frames.t[k]:.3f}{unit}   steps: '
            f'{frames.step[k]}<set attributeName="visibility" to="visible" {timing}'
            + (' fill="freeze"' if last else "")
            + "/></text>"
        )
    return lines


def _walked_path(hip: np.ndarray, values: Callable[[str, Iterable[str]], str]) -> str:
    """The hip's path as far as it has walked at each frame: the whole polyline dashed by
    one dash as long as the path so far, then a gap longer than the path (the dash's offset
    per frame as SMIL ``values``, lengths of the polyline as written)."""
    written = np.round(hip, 2)
    walked = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(written, axis=0).T))])
    total = float(walked[-1]) + 1.0
    points = " ".join(f"{x:.2f},{y:.2f}" for x, y in written)
    return (f'<polyline points="{points}" fill="none" stroke="rgb{COLORS["path"]}" '
            f'stroke-width="1" stroke-dasharray="{total:.2f} {total:.2f}" '
            f'stroke-dashoffset="{total:.2f}">'
            + values("stroke-dashoffset", (f"{total - s:.2f}" for s in walked))
            + "</polyline>")  # fmt: skip


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace(
        '"', "&quot;")  # fmt: skip
