"""``vsw continue``: a model's gait continued in one parameter, its special points located.

The period-one gait at the range's start (the first stable one of the search, or the gait
through ``--state``; with ``--period K`` the period-K gait through it) followed by
pseudo-arclength continuation to the range's end (:mod:`vsw.gaits.continuation`): folds passed,
flips, Neimark-Sacker points and boundaries located, and at each flip the period-doubled
branch followed too (``--no-switch`` stops that), so one command draws the cascade.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from vsw.cli import options
from vsw.cli.output import INTEGRATOR, dump_json, envelope, fmt, progress, unit_text, with_units
from vsw.cli.parser import EXIT_OK
from vsw.gaits import continuation
from vsw.gaits.search import pick, search_seconds
from vsw.models.base import Model
from vsw.plots import plotstyle
from vsw.plots.diagrams import (
    continuation_plot,
    diagram_quantity,
    diagram_units,
    parameter_plane_plot,
)
from vsw.plots.figures import check_save_path, save_figure
from vsw.runtime import limits, stop
from vsw.runtime.errors import ConvergenceError, ModelConditionError, VswInputError

__all__ = ["CONTINUATION", "SYMBOLS", "parse_range", "register", "run"]

CONTINUATION = {
    "continuation": (
        "pseudo-arclength on the multiple-shooting orbit residual (CasADi, CVODES Adams "
        f"1e-13), corrector to {continuation.RESIDUAL_TOL:g} x max(1, |unknowns|); special "
        f"points located to {continuation.LOCATE_TOL:g} of the range along the arclength; "
        f"every point confirmed by the simulated walk to {continuation.CONFIRM_TOL:g}"
    )
}
"""The continuation's tolerances, for the JSON's provenance."""

SYMBOLS = {"fold": "LP", "flip": "PD", "neimark-sacker": "NS", "boundary": "B"}
"""Special points' labels in the text and the plot (AUTO's and MatCont's)."""


def register(subparsers: Any) -> None:
    help_ = ("a gait continued in one parameter: folds, flips, Neimark-Sacker points and "
             "boundaries located, period-doubled branches followed")  # fmt: skip
    p = subparsers.add_parser("continue", help=help_, description=help_ + ".")
    p.add_argument(
        "--over",
        required=True,
        metavar="NAME=START:STOP",
        help="the parameter and its range in the units of 'vsw models' (angles in rad, or "
        "with a deg suffix: gamma=3deg:6deg); the branch starts at START",
    )
    options.add_model_options(p, "continue")
    p.add_argument(
        "--state",
        action="append",
        metavar="NAME=VALUE",
        help="a point of the gait at START (every coordinate and rate, repeated); default: "
        "the first stable gait of the search there, else its first gait",
    )
    p.add_argument("--period", type=int, default=1, metavar="K",
                   help="the gait's period in steps (K > 1 needs --state)")  # fmt: skip
    p.add_argument("--no-switch", action="store_true",
                   help="do not follow the period-doubled branch born at each flip")  # fmt: skip
    p.add_argument("--max-period", type=int, default=16, metavar="K",
                   help="the longest period followed by switching at flips")  # fmt: skip
    p.add_argument("--max-points", type=int, default=400, metavar="N",
                   help="most points of one branch")  # fmt: skip
    p.add_argument(
        "--free",
        metavar="NAME=A:B",
        help="a second parameter and its range: every located fold, flip, Neimark-Sacker "
        "point and phase-duration boundary continued in both parameters (its curve: the "
        "edge of a stability or existence region); --plot then draws the parameter plane",
    )
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="save the diagram (.png/.svg/.pdf): every branch, solid where stable and dashed "
        "where not, special points marked; below, the largest |eigenvalue|",
    )
    p.add_argument("--y", metavar="NAME",
                   help="what the diagram shows: step_length (default where the model has "
                   "one), step_period or a state component; --y=-NAME shows minus it")  # fmt: skip
    p.set_defaults(func=run, parser=p)


def parse_range(model: Model, text: str, option: str = "--over") -> tuple[str, float, float]:
    """``--over NAME=START:STOP`` (or ``--free``): the parameter and its range (START !=
    STOP, both within the parameter's interval)."""
    name, spec = options.split_item(option, text)
    p = options.parameter_named(model, option, name)
    parts = spec.split(":")
    if len(parts) != 2:
        raise VswInputError(f"{option} {text!r}: expected NAME=START:STOP")
    start = options.parameter_value(option, p, parts[0])
    stop = options.parameter_value(option, p, parts[1])
    if start == stop:
        raise VswInputError(f"{option} {text!r}: START and STOP are equal: give a range")
    return name, start, stop


def _curves(model, params, name, start, stop_value, branches, free, config, bar) -> list:
    """Every located special point of every branch continued in (``name``, ``free``); a
    point that cannot be (a boundary found by simulation) is listed with the reason."""
    out = []
    specials = [(b, s) for b in branches for s in b.special_points]
    for k, (branch, special) in enumerate(specials):
        try:
            curve = continuation.continue_special_point(
                model, params, name, start, stop_value, special, branch.period, *free,
                options=config,
            )  # fmt: skip
            out.append(curve.to_dict())
        except (VswInputError, ConvergenceError) as exc:
            stop.check()
            out.append({"type": special.type, "condition": special.condition,
                        "from": special.to_dict(), "skipped": str(exc)})  # fmt: skip
        bar(k + 1, len(specials))
    return out


def run(args: argparse.Namespace) -> int:
    model = args.model_object
    name, start, stop_value = parse_range(model, args.over)
    if args.period < 1:
        raise VswInputError(f"--period {args.period}: the period is a number of steps, >= 1")
    if args.period > 1 and not args.state:
        raise VswInputError(f"--period {args.period}: give a point of the period-"
                            f"{args.period} gait with --state")  # fmt: skip
    if args.max_period < args.period:
        raise VswInputError(f"--max-period {args.max_period} is below --period {args.period}")
    if not 2 <= args.max_points <= 100_000:
        raise VswInputError(f"--max-points {args.max_points}: give 2 to 100000")
    if args.plot is not None:
        check_save_path(args.plot)
    y = diagram_quantity(model, args.y)
    if args.y is not None and args.plot is None:
        raise VswInputError("--y chooses what --plot draws: give --plot FILE")
    free = None
    if args.free is not None:
        free = parse_range(model, args.free, "--free")
        if free[0] == name:
            raise VswInputError(f"--free {free[0]}: the second parameter must differ from --over's")
        value = model.parameters(args.values)[
            [p.name for p in model.parameter_table].index(free[0])
        ]
        if not min(free[1:]) <= value <= max(free[1:]):
            raise VswInputError(f"--free {args.free}: the range must contain {free[0]}'s value "
                                f"{value:g} (give it with --param)")  # fmt: skip
    fixed = {k: v for k, v in args.values.items() if k != name}
    params = model.parameters({**fixed, name: start})
    config = continuation.Options(max_points=args.max_points, switch=not args.no_switch,
                                  max_period=args.max_period)  # fmt: skip
    per_branch = args.max_points * limits.HYBRID_SECONDS_PER_ORBIT * len(model.phases) * model.n
    limits.check(
        f"continuation of up to {args.max_points} points a branch",
        limits.Cost(search_seconds(model) + per_branch, limits.SIMULATE_BYTES_BASE),
        "give fewer --max-points",
    )
    with options.solver_errors(model):
        state, durations = _start(model, params, args)
        with progress("continue") as bar:
            branches = continuation.continue_gaits(
                model, params, name, start, stop_value, state, durations,
                period=args.period, options=config, progress=bar,
            )  # fmt: skip
    data = {
        **envelope(model, params, args.argv, {**INTEGRATOR, **CONTINUATION}),
        "over": name,
        "over_unit": next(p.unit for p in model.parameter_table if p.name == name),
        "range": [start, stop_value],
        "branches": [b.to_dict() for b in branches],
    }
    if free is not None:
        data["free"] = free[0]
        data["free_unit"] = next(p.unit for p in model.parameter_table if p.name == free[0])
        data["free_range"] = [free[1], free[2]]
        with options.solver_errors(model), progress("curves") as bar:
            data["curves"] = _curves(model, params, name, start, stop_value, branches, free,
                                     config, bar)  # fmt: skip
    if args.plot is not None:
        title = plotstyle.parameter_text(model, {k: v for k, v in fixed.items()
                                                 if free is None or k != free[0]})  # fmt: skip
        figure = (continuation_plot(data, y, diagram_units(model.units), title) if free is None
                  else parameter_plane_plot(data, title))  # fmt: skip
        save_figure(figure, args.plot)
        data["plot"] = args.plot
    if args.json:
        # A branch's period is its number of steps (a point's period in time: period_time).
        over = {"parameter": data["over_unit"], "range": data["over_unit"], "period": "steps"}
        if free is not None:
            over |= {"second_parameter": data["free_unit"], "free_range": data["free_unit"]}
        dump_json(with_units(model, data, over))
        return EXIT_OK
    degrees = options.given_in_degrees(model, name, args.over)
    free_degrees = free is not None and options.given_in_degrees(model, free[0], args.free)
    _write(model, data, degrees, free_degrees)
    return EXIT_OK


def _start(model: Model, params, args: argparse.Namespace) -> tuple[np.ndarray, list[float]]:
    """The gait to start from: its state and phase durations (a guess the corrector
    refines)."""
    if args.state:
        state = np.array(options.parse_state(model, args.state))
        durations: list[float] = []
        x = state
        for _ in range(args.period):
            step = model.step(params, x)
            if step.ended != "completed":
                raise VswInputError(f"--state: no gait: a step from it ends with "
                                    f"{step.ended}")  # fmt: skip
            durations += list(step.durations)
            x = step.state
        return state, durations
    report = model.analyze(params)
    orbit = pick(report.gaits)
    if orbit is None:
        raise ModelConditionError(f"{model.cli_name}: no gait at the range's start to "
                                  f"continue: {report.reason}")  # fmt: skip
    return np.array(list(orbit.state.values())), list(orbit.durations)


def _write(model: Model, data: dict, degrees: bool, free_degrees: bool) -> None:
    """The text report; a parameter whose range was given in degrees is shown in degrees."""
    out = sys.stdout
    name = data["over"]
    unit = " deg" if degrees else unit_text(data["over_unit"])

    def shown(value: float | None) -> str:
        return fmt(options.echo(value, degrees))

    out.write(f"{'model':<12} {model.cli_name} ({model.title}); {name}{unit} from "
              f"{shown(data['range'][0])} to {shown(data['range'][1])}\n")  # fmt: skip
    for branch in data["branches"]:
        points = branch["points"]
        born = ("" if branch["from_flip"] is None
                else f", born at the flip at {name} = {shown(branch['from_flip'])}")  # fmt: skip
        stable = sum(1 for p in points if p["stable"])
        out.write(f"\nperiod-{branch['period']} branch{born}: {len(points)} points "
                  f"({stable} stable), {name} {shown(points[0]['parameter'])} to "
                  f"{shown(points[-1]['parameter'])}, ended: {branch['ended']}\n")  # fmt: skip
        specials = branch["special_points"]
        if not specials:
            out.write("  no special point\n")
            continue
        out.write(f"  {'type':<16} {name:>14} {'defining eq.':>12}  eigenvalue / condition\n")
        for s in specials:
            eig = [complex(*e) for e in s["eigenvalues"]]
            near = _critical(s["type"], eig)
            what = s["condition"] or (f"{near.real:.10g}{near.imag:+.3g}j" if near.imag
                                      else f"{near.real:.10g}")  # fmt: skip
            label = f"{s['type']} ({SYMBOLS[s['type']]})"
            value = options.echo(s["parameter"], degrees)
            out.write(f"  {label:<16} {value:>14.10g} {fmt(s['defining_equation']):>12}"
                      f"  {what}\n")  # fmt: skip
    for curve in data.get("curves", ()):
        start = curve["from"]
        what = f"{curve['type']} at {name} = {shown(start['parameter'])}"
        if "skipped" in curve:
            out.write(f"\n{what}: not continued ({curve['skipped']})\n")
            continue
        pts = curve["points"]
        first, last = pts[0], pts[-1]
        free_unit = " deg" if free_degrees else unit_text(data["free_unit"])
        second = [fmt(options.echo(p["second_parameter"], free_degrees)) for p in (first, last)]
        out.write(f"\n{what} continued in {data['free']}{free_unit}: {len(pts)} points from "
                  f"({shown(first['parameter'])}, {second[0]}) to "
                  f"({shown(last['parameter'])}, {second[1]}); ends: "
                  f"{', '.join(curve['ended'])}\n")  # fmt: skip
    if data.get("plot"):
        out.write(f"plot: {data['plot']}\n")


def _critical(kind: str, eigenvalues: list[complex]) -> complex:
    """The eigenvalue a special point is about (nearest +1, -1 or the unit circle)."""
    if not eigenvalues:
        return complex("nan")
    if kind == "fold":
        return min(eigenvalues, key=lambda mu: abs(mu - 1))
    if kind == "flip":
        return min(eigenvalues, key=lambda mu: abs(mu + 1))
    return min(eigenvalues, key=lambda mu: abs(abs(mu) - 1) - (mu.imag > 0))
