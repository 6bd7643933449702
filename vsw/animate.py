"""``vsw animate``: the gait as a moving stick figure, for every model of the engine.

The frames come from the model's time-domain simulation (:meth:`vsw.hybrid.HybridModel.
simulate`, SciPy DOP853 with the model's events), sampled at the frame rate and at every
event instant (an extra frame there, so an extension or heelstrike is shown where it
happens). The geometry is the derivation's: each phase's body positions
(``<phase>_positions``, stance foot at the origin, body 0 the hip) and the swing foot from
the step event's contact point (``event_<e>_contact``), carried to the current phase as
the vector from the hip; the stance foot moves on by the step length at every step event.
Drawn: the ground (the model's chart: along the slope for the passive walkers), both legs
at their current lengths, the hip's path so far, a marker and label at each event, and the
time and step counters.

Formats: GIF through Pillow (default), an animated SVG (SMIL, no dependency) and MP4
when ``ffmpeg`` is on the PATH. Frames and the output size are bounded before drawing.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsw.errors import VswInputError

__all__ = ["MAX_FRAMES", "Animation", "animation_frames", "write_animation"]

MAX_FRAMES = 3000
"""Most frames of one animation (100 s at 30 frames a second)."""
MAX_BYTES = 64 * 1024 * 1024
"""Largest estimated output."""
WIDTH, HEIGHT = 480, 270
COLORS = {  # Okabe-Ito, as vsw.plotstyle
    "ground": (140, 140, 140),
    "leg_a": (0, 114, 178),  # one colour per leg for the whole walk, whichever stands
    "leg_b": (213, 94, 0),
    "spoke": (120, 120, 120),
    "hip": (0, 0, 0),
    "path": (86, 180, 233),
    "event": (0, 158, 115),
    "text": (0, 0, 0),
}
FORMATS = (".gif", ".svg", ".mp4")


@dataclass
class Animation:
    """The frames of a walk in the drawing's pixel frame.

    ``t``: model time of each frame; ``stance_foot``, ``hip``, ``swing_foot``: (frames, 2)
    pixel positions; ``step``: steps completed; ``event``: the event that happens at the
    frame ('' for none); ``hip_world``: the hip in the model's chart (model lengths), for
    checks; ``scale``: pixels per model length; ``origin``: pixel of the chart's origin.
    """

    t: np.ndarray
    stance_foot: np.ndarray
    hip: np.ndarray
    swing_foot: np.ndarray
    step: np.ndarray
    event: list[str]
    hip_world: np.ndarray
    scale: float
    origin: tuple[float, float]
    fps: float
    time_unit: str
    ended: str
    title: str
    leg_a_stands: np.ndarray | None = None  # per frame: leg A is the stance leg
    masses_a: np.ndarray | None = None  # (frames, m, 2) pixels: leg A's point masses
    masses_b: np.ndarray | None = None
    spokes: np.ndarray | None = None  # (frames, s, 2) pixels: the other spokes' ends
    ground: np.ndarray | None = None  # (2, 2) pixels: the ground line's ends
    slope: float = 0.0  # rad, downhill to the right

    def to_pixels(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        return np.stack([self.origin[0] + self.scale * xy[..., 0],
                         self.origin[1] - self.scale * xy[..., 1]], axis=-1)  # fmt: skip


def _frame_times(t_end: float, fps: float, speed: float, events: Sequence[float]) -> np.ndarray:
    dt = speed / fps  # model time per frame
    regular = np.arange(0.0, t_end + 0.5 * dt, dt)
    regular = regular[regular <= t_end]
    return np.unique(np.concatenate([regular, np.asarray(events, float), [t_end]]))


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
    if not 1 <= steps <= 1000:
        raise VswInputError(f"--steps = {steps} must be from 1 to 1000")
    if not (math.isfinite(fps) and 1 <= fps <= 120):
        raise VswInputError(f"--fps = {fps:g} must be from 1 to 120")
    if not (math.isfinite(speed) and 0 < speed <= 1000):
        raise VswInputError(f"the playback speed {speed:g} must lie in (0, 1000]")
    dt = speed / fps
    # The frame count from the first step's duration, before simulating them all.
    first = model.simulate(params, np.asarray(state, float), 1)
    estimate = steps * (float(first.t[-1]) / dt + 2 * len(model.phases))
    if estimate > MAX_FRAMES:
        raise VswInputError(
            f"the animation would have about {estimate:.0f} frames, more than {MAX_FRAMES}: "
            "use fewer --steps, a higher --speed or a lower --fps"
        )
    trajectory = model.simulate(params, np.asarray(state, float), steps, max_step=dt / 2)
    t_end = float(trajectory.t[-1])
    if len(np.unique(trajectory.t)) > 50 * MAX_FRAMES:  # a walk far slower than its first step
        raise VswInputError("the walk slowed down too much to animate: use fewer --steps")
    step_event = model.step_event
    contact_fn = getattr(model.module, f"event_{step_event['name']}_contact", None)
    source = step_event["source"]
    # Event instants: two samples at one time with different states (a reset) or phases;
    # repeated samples of one state (a phase's last step and its event point, an event
    # that did not count) are not events.
    ts, xs, ph = trajectory.t, trajectory.states, trajectory.phase
    boundaries = [
        i for i in range(1, len(ts))
        if ts[i] == ts[i - 1] and (ph[i] != ph[i - 1] or np.any(xs[i] != xs[i - 1]))
    ]  # fmt: skip
    event_times = [float(ts[i]) for i in boundaries]
    times = _frame_times(t_end, fps, speed, event_times)
    # Each sample's step count and world offset of the stance foot.
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
        names.append((t_end, step_event["name"]))
        sample_step[-1] = trajectory.steps_completed
    offsets = np.array(offsets)
    # Frame states: the last sample at or before each frame time, linearly interpolated
    # within a phase (samples are at most half a frame apart).
    index = np.searchsorted(ts, times, side="right") - 1
    index = np.clip(index, 0, len(ts) - 1)
    stance, hip, swing, hip_world, bodies = [], [], [], [], []
    for k, i in enumerate(index):
        x = xs[i]
        if i + 1 < len(ts) and ts[i + 1] > ts[i] and ph[i + 1] == ph[i]:
            w = (times[k] - ts[i]) / (ts[i + 1] - ts[i])
            x = (1 - w) * xs[i] + w * xs[i + 1]
        phase = model.phases[ph[i]]["name"]
        positions = np.asarray(getattr(model.module, f"{phase}_positions")(*params, *x), float)
        foot = np.array([offsets[i], 0.0])
        h = positions[:2] + foot
        if contact_fn is not None:
            hip_src = np.asarray(getattr(model.module, f"{source}_positions")(*params, *x), float)
            vec = np.asarray(contact_fn(*params, *x), float) - hip_src[:2]
            sw = h + vec
        else:
            sw = h
        stance.append(foot)
        hip.append(h)
        swing.append(sw)
        hip_world.append(h)
        bodies.append(positions.reshape(-1, 3)[1:, :2] + foot)
    stance, hip, swing, hip_world = map(np.array, (stance, hip, swing, hip_world))
    leg_a_stands = sample_step[index] % 2 == 0
    masses_a, masses_b = _masses_by_leg(np.array(bodies), stance, hip, swing, leg_a_stands)
    spokes = _spokes(model, params, hip, stance)
    slope = model.slope(params)
    turn = np.array([[math.cos(slope), math.sin(slope)], [-math.sin(slope), math.cos(slope)]])

    def world(points):  # the chart turned so that the slope descends to the right
        return None if points is None else np.asarray(points) @ turn.T

    stance, hip, swing = world(stance), world(hip), world(swing)
    masses_a, masses_b, spokes = world(masses_a), world(masses_b), world(spokes)
    labels = [""] * len(times)
    for t_event, name in names:
        labels[int(np.searchsorted(times, t_event))] = name
    parts = [stance, hip, swing] + [p.reshape(-1, 2) for p in (spokes,) if p is not None]
    everything = np.vstack(parts)
    lo, hi = everything.min(axis=0), everything.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    scale = 0.8 * min(WIDTH / span[0], (HEIGHT - 40) / span[1])
    origin = (0.1 * WIDTH - scale * lo[0], HEIGHT - 20 + scale * lo[1])
    frames = Animation(
        t=times, stance_foot=stance, hip=hip, swing_foot=swing,
        step=sample_step[index], event=labels, hip_world=hip_world, scale=scale,
        origin=origin, fps=fps, time_unit=model.units.get("time", ""),
        ended=trajectory.ended, title=title, leg_a_stands=leg_a_stands, slope=slope,
    )  # fmt: skip
    frames.stance_foot = frames.to_pixels(stance)
    frames.hip = frames.to_pixels(hip)
    frames.swing_foot = frames.to_pixels(swing)
    if masses_a is not None:
        frames.masses_a, frames.masses_b = frames.to_pixels(masses_a), frames.to_pixels(masses_b)
    if spokes is not None:
        frames.spokes = frames.to_pixels(spokes)
    reach = 4 * (span[0] + span[1])  # the ground well past both edges of the picture
    frames.ground = frames.to_pixels(world(np.array([[lo[0] - reach, 0.0],
                                                     [hi[0] + reach, 0.0]])))  # fmt: skip
    return frames


def _masses_by_leg(bodies, stance, hip, swing, leg_a_stands):
    """The point masses below the hip (bodies 1..), each given to the leg it lies on
    (nearer segment), as leg A's and leg B's per frame; None where there are none or a
    mass changes legs."""
    if bodies.ndim != 3 or bodies.shape[1] == 0:
        return None, None

    def distance(points, a, b):
        ab = b - a
        w = np.clip(np.sum((points - a[:, None]) * ab[:, None], axis=2)
                    / np.maximum(np.sum(ab * ab, axis=1), 1e-300)[:, None], 0, 1)  # fmt: skip
        return np.linalg.norm(points - (a[:, None] + w[..., None] * ab[:, None]), axis=2)

    on_stance = distance(bodies, stance, hip) <= distance(bodies, hip, swing)
    on_a = on_stance == leg_a_stands[:, None]
    counts = on_a.sum(axis=1)
    if np.any(counts != counts[0]):
        return None, None
    order = np.argsort(~on_a, axis=1, kind="stable")  # leg A's masses first
    ranked = np.take_along_axis(bodies, order[..., None], axis=1)
    return ranked[:, : counts[0]], ranked[:, counts[0] :]


_SPOKED = {"rimless_wheel": "alpha"}
"""Models drawn with all their spokes: the parameter that is half the angle between two."""


def _spokes(model, params: Sequence[float], hub: np.ndarray, foot: np.ndarray):
    """The ends of the spokes other than the stance one, per frame (the next one is drawn
    again as the swing leg)."""
    name = _SPOKED.get(model.name)
    if name is None:
        return None
    alpha = float(dict(zip(model.spec["parameters"], params))[name])
    count = max(3, round(math.pi / alpha))
    base = foot - hub
    ends = []
    for k in range(1, count):
        angle = 2 * alpha * k
        c, s = math.cos(angle), math.sin(angle)
        turned = np.column_stack([c * base[:, 0] - s * base[:, 1], s * base[:, 0] + c * base[:, 1]])
        ends.append(hub + turned)
    return np.stack(ends, axis=1)


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
    draw.line([tuple(p) for p in _ground(frames)], fill=COLORS["ground"], width=2)
    _gravity(draw)
    if frames.spokes is not None:
        for end in frames.spokes[k]:
            draw.line([tuple(frames.hip[k]), tuple(end)], fill=COLORS["spoke"], width=2)
    if k > 0:
        path = [tuple(p) for p in frames.hip[: k + 1]]
        draw.line(path, fill=COLORS["path"], width=1)
    for j in range(k + 1):
        if frames.event[j]:
            x, y = frames.hip[j]
            draw.rectangle([x - 2, y - 2, x + 2, y + 2], outline=COLORS["event"])
    (a0, a1), (b0, b1) = _legs(frames, k)
    draw.line([tuple(a0), tuple(a1)], fill=COLORS["leg_a"], width=3)
    draw.line([tuple(b0), tuple(b1)], fill=COLORS["leg_b"], width=3)
    hip = tuple(frames.hip[k])
    for masses, color in ((frames.masses_a, COLORS["leg_a"]), (frames.masses_b, COLORS["leg_b"])):
        for x, y in masses[k] if masses is not None else ():
            draw.ellipse([x - 3.5, y - 3.5, x + 3.5, y + 3.5], fill=color, outline=(0, 0, 0))
    r = 5
    draw.ellipse([hip[0] - r, hip[1] - r, hip[0] + r, hip[1] + r], fill=COLORS["hip"])
    unit = f" {frames.time_unit}" if frames.time_unit else ""
    draw.text((6, 4), f"{frames.title}", fill=COLORS["text"])
    draw.text((6, 16), f"t = {frames.t[k]:.3f}{unit}   steps: {frames.step[k]}",
              fill=COLORS["text"])  # fmt: skip
    if frames.event[k]:
        draw.text((6, 28), frames.event[k], fill=COLORS["event"])
    return image


def _legs(frames: Animation, k: int) -> tuple[tuple, tuple]:
    """Leg A's and leg B's (foot, hip) ends in frame ``k``: whichever stands, a leg keeps
    its colour for the whole walk."""
    stance = (frames.stance_foot[k], frames.hip[k])
    swing = (frames.swing_foot[k], frames.hip[k])
    stands = frames.leg_a_stands is None or bool(frames.leg_a_stands[k])
    return (stance, swing) if stands else (swing, stance)


def _ground(frames: Animation) -> np.ndarray:
    if frames.ground is not None:
        return frames.ground
    return np.array([[0.0, frames.origin[1]], [WIDTH, frames.origin[1]]])


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


def _svg(frames: Animation) -> str:
    """An animated SVG that plays once and stays on the last frame: each drawn element's
    coordinates as SMIL ``values`` (discrete, one per frame), the counters and event
    markers as ``set`` on their frames."""
    n = len(frames.t)
    frame = 1.0 / frames.fps
    duration = n * frame

    def anim(attribute: str, column: np.ndarray) -> str:
        values = ";".join(f"{v:.2f}" for v in column)
        return (f'<animate attributeName="{attribute}" dur="{duration:.3f}s" fill="freeze" '
                f'calcMode="discrete" values="{values}"/>')  # fmt: skip

    hip = frames.hip
    legs = [_legs(frames, k) for k in range(n)]
    a0, a1 = np.array([leg[0][0] for leg in legs]), np.array([leg[0][1] for leg in legs])
    b0, b1 = np.array([leg[1][0] for leg in legs]), np.array([leg[1][1] for leg in legs])
    (gx0, gy0), (gx1, gy1) = _ground(frames)
    (ax, ay0), (_, ay1) = _ARROW
    path = " ".join(f"{x:.2f},{y:.2f}" for x, y in hip)
    unit = f" {frames.time_unit}" if frames.time_unit else ""
    lines = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{HEIGHT}" '
        f'viewBox="0 0 {WIDTH} {HEIGHT}" font-family="sans-serif" font-size="11">',
        f"<title>{_escape(frames.title)}</title>",
        f'<rect width="{WIDTH}" height="{HEIGHT}" fill="white"/>',
        f'<line x1="{gx0:.2f}" y1="{gy0:.2f}" x2="{gx1:.2f}" y2="{gy1:.2f}" '
        f'stroke="rgb{COLORS["ground"]}" stroke-width="2"/>',
        f'<line x1="{ax}" y1="{ay0}" x2="{ax}" y2="{ay1 - 6}" stroke="black" stroke-width="2"/>'
        f'<polygon points="{ax - 4},{ay1 - 6} {ax + 4},{ay1 - 6} {ax},{ay1 + 1}" fill="black"/>'
        f'<text x="{ax - 14}" y="{ay0 + 16}">g</text>',
        f'<polyline points="{path}" fill="none" stroke="rgb{COLORS["path"]}" stroke-width="1"/>',
        *(
            f'<line stroke="rgb{COLORS["spoke"]}" stroke-width="2">'
            + anim("x1", hip[:, 0]) + anim("y1", hip[:, 1])
            + anim("x2", frames.spokes[:, j, 0]) + anim("y2", frames.spokes[:, j, 1])
            + "</line>"
            for j in range(0 if frames.spokes is None else frames.spokes.shape[1])
        ),
        f'<line stroke="rgb{COLORS["leg_a"]}" stroke-width="3">'
        + anim("x1", a0[:, 0]) + anim("y1", a0[:, 1])
        + anim("x2", a1[:, 0]) + anim("y2", a1[:, 1]) + "</line>",
        f'<line stroke="rgb{COLORS["leg_b"]}" stroke-width="3">'
        + anim("x1", b0[:, 0]) + anim("y1", b0[:, 1])
        + anim("x2", b1[:, 0]) + anim("y2", b1[:, 1]) + "</line>",
        *(
            f'<circle r="3.5" fill="rgb{color}" stroke="black">'
            + anim("cx", masses[:, j, 0]) + anim("cy", masses[:, j, 1]) + "</circle>"
            for masses, color in ((frames.masses_a, COLORS["leg_a"]),
                                  (frames.masses_b, COLORS["leg_b"]))
            if masses is not None
            for j in range(masses.shape[1])
        ),
        f'<circle r="5" fill="rgb{COLORS["hip"]}">'
        + anim("cx", hip[:, 0]) + anim("cy", hip[:, 1]) + "</circle>",
        f'<text x="6" y="14">{_escape(frames.title)}</text>',
    ]  # fmt: skip
    for k in range(n):
        last = k == n - 1
        timing = f'begin="{k * frame:.4f}s"' + ("" if last else f' dur="{frame:.4f}s"')
        lines.append(
            f'<text x="6" y="28" visibility="hidden">t = {frames.t[k]:.3f}{unit}   steps: '
            f'{frames.step[k]}<set attributeName="visibility" to="visible" {timing}'
            + (' fill="freeze"' if last else "")
            + "/></text>"
        )
        if frames.event[k]:
            x, y = hip[k]
            lines.append(
                f'<rect x="{x - 2:.2f}" y="{y - 2:.2f}" width="4" height="4" fill="none" '
                f'stroke="rgb{COLORS["event"]}" visibility="hidden"><set attributeName='
                f'"visibility" to="visible" begin="{k * frame:.4f}s" fill="freeze"/>'
                f"<title>{_escape(frames.event[k])} at t = {frames.t[k]:.4f}</title></rect>"
            )
    lines.append("</svg>")
    return "\n".join(lines) + "\n"


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace(
        '"', "&quot;")  # fmt: skip
