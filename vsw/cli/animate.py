"""``vsw animate``: the stick figure of a simulated walk as GIF, SVG or MP4; with ``--gait
FILE`` the walk replays a saved powered gait (:func:`vsw.cli.simulate.saved_gait`)."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from vsw.cli import options
from vsw.cli.output import INTEGRATOR, dump_json, envelope, with_units
from vsw.cli.parser import EXIT_OK
from vsw.cli.simulate import REPLAY, add_gait_option, saved_gait
from vsw.plots.animate import animation_frames, check_output, write_animation
from vsw.runtime.errors import VswInputError
from vsw.studies.gait_file import PoweredReplay

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    help_ = "the walk as a moving stick figure (GIF, SVG or MP4)"
    p = subparsers.add_parser("animate", help=help_, description=help_ + ".")
    options.add_model_options(p, "animate", features={"q0": "q0"})
    p.add_argument("--out", required=True, metavar="FILE",
                   help="gait.gif (Pillow), gait.svg or gait.mp4")  # fmt: skip
    p.add_argument("--steps", type=int, default=3, help="steps to walk")
    start = p.add_argument_group("where the walk starts (default: the first stable gait)")
    start.add_argument("--state", action="append", metavar="NAME=VALUE",
                       help="the state just after the step event, every coordinate and rate; "
                       "repeatable")  # fmt: skip
    start.add_argument(
        "--q0", type=float, help="q = rate**2 just after the step event (ile, tle, rimless-wheel)"
    )
    add_gait_option(start)
    p.add_argument("--fps", type=float, default=30.0, help="frames per second")
    p.add_argument("--speed", type=float, default=1.0,
                   help="model time units per second of playback")  # fmt: skip
    p.add_argument("--leg-length", type=float, metavar="L",
                   help="real time for a robot with legs of L m (models in units of "
                   "sqrt(l/g))")  # fmt: skip
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    model, params = options.model_and_parameters(args)
    out = check_output(args.out)
    saved = saved_gait(args) if args.gait is not None else None
    if saved is not None:
        model, params = saved.model, saved.params
    if args.state and args.q0 is not None:
        raise VswInputError("--state and --q0 both give the start: give one")
    state = options.parse_state(model, args.state) if args.state else None
    if args.leg_length is not None:
        leg = float(args.leg_length)
        if not (math.isfinite(leg) and leg > 0):
            raise VswInputError(f"--leg-length = {args.leg_length} must be a positive number")
        if model.units.get("time", "") == "s":
            raise VswInputError(f"{model.cli_name} is in seconds already: drop --leg-length "
                                "(--speed 1 is real time)")  # fmt: skip
        speed = math.sqrt(9.81 / leg)  # model time units per second of the robot's time
    else:
        speed = float(args.speed)
    if saved is None:
        with options.solver_errors(model):
            start = model.start(params, state, args.q0)
        walker, begin, source, note = model, start.state, start.source, start.note()
    else:
        walker, begin, source = PoweredReplay(model, saved.gait), saved.start, "gait"
        note = None if saved.status != "unverified" else "the gait is unverified"
    fixed = ", ".join(f"{k} = {v:.6g}" for k, v in zip(model.spec["parameters"], params))
    title = f"{model.cli_name}: {fixed}"
    with options.solver_errors(model):
        frames = animation_frames(walker, params, begin, args.steps, fps=args.fps,
                                  speed=speed, title=title)  # fmt: skip
    write_animation(frames, str(out))
    events = [(float(t), e) for t, e in zip(frames.t, frames.event) if e]
    data = {
        **envelope(model, params, args.argv, INTEGRATOR if saved is None else REPLAY),
        "start": dict(zip((*model.coordinates, *model.rates), (float(v) for v in begin))),
        "start_from": source,
        "note": note,
        "out": str(out),
        "frames": len(frames.t),
        "fps": frames.fps,
        "model_time_per_second": speed,
        "duration": float(frames.t[-1]),
        "steps_completed": int(frames.step[-1]),
        "ended": frames.ended,
        "events": [{"t": t, "event": e} for t, e in events],
        "frame_of_events": [k for k, e in enumerate(frames.event) if e],
        "pixels": {
            "scale": frames.scale,
            "slope": frames.slope,
            "origins": [[float(x), float(y)] for x, y in frames.origins],
        },
        "fields": {
            "events": "each event's model time; the animation has a frame at each",
            "pixels": "pixel = (origin x + scale * X, origin y - scale * Y) in each frame, its "
            "origin in origins (the view follows the hip), for a point (x, y) of the first "
            "step's chart (the first stance foot at (0, 0)) turned by the slope: X = x cos "
            "slope + y sin slope, Y = y cos slope - x sin slope",
        },
    }
    if args.json:
        time, length = model.units.get("time", ""), model.units.get("length", "")
        units = {"frames": "1", "fps": "1/s", "model_time_per_second": f"{time}/s",
                 "duration": time, "steps_completed": "1", "events.t": time,
                 "frame_of_events": "1", "pixels.scale": f"px/{length}", "pixels.slope": "rad",
                 "pixels.origins": "px"}  # fmt: skip
        dump_json(with_units(model, data, units))
        return EXIT_OK
    if note:
        sys.stdout.write(f"note: {note}\n")
    sys.stdout.write(
        f"{out}: {len(frames.t)} frames at {frames.fps:g} per second, {data['duration']:.4g} "
        f"{model.units.get('time', '')} of model time, {data['steps_completed']} steps "
        f"({frames.ended})\n"
    )
    return EXIT_OK
