"""``vsw sweep``: a model along one parameter.

Every model: the period-one gait continued from value to value (:func:`vsw.studies.sweeps.
continuation`) and, with ``--keep`` or ``--plot``, the map iterated where the gait is
unstable or lost until its orbit repeats (:func:`vsw.studies.sweeps.settle`): the bifurcation
diagram; ``--brute-force`` draws it from the batch simulator (:func:`vsw.studies.sweeps.
brute_force`). ``--state`` or ``--gait-number`` chooses the gait the sweep starts from.
A model with a sweep of its own (:attr:`vsw.models.base.Model.routes`: the ile's
closed forms at every value, :mod:`vsw.cli.ile_sweep`) answers by it.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from vsw.cli import options
from vsw.cli.output import (
    INTEGRATOR,
    ORBIT_SOLVER,
    clean,
    dump_json,
    envelope,
    fmt,
    progress,
    unit_text,
    with_units,
)
from vsw.cli.parser import EXIT_OK, StoreGiven, given
from vsw.dynamics.batch import APART
from vsw.dynamics.hybrid import Orbit
from vsw.gaits.search import search_seconds
from vsw.models.base import Model
from vsw.plots import plotstyle
from vsw.plots.diagrams import bifurcation_plot, diagram_quantity, diagram_units
from vsw.plots.figures import check_save_path, save_figure
from vsw.runtime import limits, stop
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.runtime.threads import default_threads
from vsw.studies import sweeps

__all__ = ["ATTRACTOR", "attractor_label", "register", "run"]

ATTRACTOR = {
    "attractor": (
        "the map iterated by the compiled batch simulator (DOP853, rtol = atol = 1e-12) "
        "until its last --keep steps repeat with a period p: every state within "
        f"{sweeps.SETTLE_TOL:g} x max(1, |x|) of the one p steps before over at least two "
        f"cycles, every shorter lag more than {APART:g} x that apart somewhere; "
        "else not settled after --max-steps"
    )
}
"""The iteration's settling rule, for the JSON's provenance (:func:`vsw.studies.sweeps.settle`)."""

ITERATION_OPTIONS = ("y", "keep", "transient", "max_steps", "brute_force", "state", "gait_number")


def register(subparsers: Any) -> None:
    help_ = "the gait along one parameter (continuation; the bifurcation diagram with --plot)"
    p = subparsers.add_parser("sweep", help=help_, description=help_ + ".")
    p.add_argument(
        "--over",
        required=True,
        metavar="NAME=START:STOP:N",
        help="the parameter swept: N values from START to STOP in the units of 'vsw models' "
        "(angles in rad, or with a deg suffix: theta_II=-10deg:20deg:31)",
    )
    options.add_model_options(p, "sweep")
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="save the figure (.png/.svg/.pdf): the bifurcation diagram of --y with the "
        "largest |eigenvalue| and the special points located by continuation (the JSON's "
        "special_points); the ile: q^f, eigenvalue and speed",
    )
    p.add_argument(
        "--y",
        metavar="NAME",
        help="what the bifurcation diagram shows: step_length (default where the model has "
        "one), step_period or a state component; --y=-NAME shows minus it",
    )
    p.add_argument(
        "--keep",
        type=int,
        metavar="N",
        help="where the period-one gait is unstable or not found, iterate the map and keep "
        "its last N steps (default 32 with --plot or --brute-force, else 0)",
    )
    p.add_argument("--transient", type=int, default=100, action=StoreGiven, metavar="K",
                   help="steps walked before the N kept")  # fmt: skip
    p.add_argument(
        "--max-steps",
        type=int,
        default=sweeps.MAX_STEPS,
        action=StoreGiven,
        metavar="M",
        help="past the transient the map is iterated N steps at a time until the kept steps "
        f"repeat with a period p (every state within {sweeps.SETTLE_TOL:g} x max(1, |x|) of "
        "the one p steps before, over at least two cycles): at most M steps a value (K + N "
        "where that is more and M is not given), after which the value is labelled 'not "
        "settled after M steps'",
    )
    p.add_argument(
        "--brute-force",
        action="store_true",
        help="the classic diagram from the compiled batch simulator: at every value the gait "
        "by Newton on the simulated map and the map iterated from it",
    )
    start = p.add_argument_group(
        "the gait the sweep starts from (default: the first stable gait of the search at "
        "START, else its first)"
    )
    start.add_argument(
        "--state",
        action="append",
        metavar="NAME=VALUE",
        help="a point of the gait at START, every coordinate and rate (the state just after "
        "the step event); the period-one gait is solved from it; repeatable",
    )
    start.add_argument(
        "--gait-number",
        type=int,
        metavar="K",
        help="the K-th gait of the search at START, numbered as 'vsw analyze' lists them",
    )
    p.set_defaults(func=run, parser=p)


def run(args: argparse.Namespace) -> int:
    model = args.model_object
    name, values = options.parse_over(model, args.over)
    if args.plot is not None:
        check_save_path(args.plot)
    route = model.route("sweep")
    if route is not None:
        for dest in ITERATION_OPTIONS:
            if given(args.parser, args, dest):
                option = "--" + dest.replace("_", "-")
                raise VswInputError(f"{option}: the {model.cli_name}'s sweep is in closed form "
                                    "(its map is affine and its fixed point exact): nothing to "
                                    "iterate")  # fmt: skip
        return route(args, model)
    y = diagram_quantity(model, args.y)
    if args.state and args.gait_number is not None:
        raise VswInputError("--state and --gait-number both choose the starting gait: give one")
    if args.gait_number is not None and args.gait_number < 1:
        raise VswInputError(f"--gait-number {args.gait_number}: gaits are numbered from 1 "
                            "(see vsw analyze)")  # fmt: skip
    keep = args.keep if args.keep is not None else (
        32 if (args.plot is not None or args.brute_force) else 0)  # fmt: skip
    if keep == 1 or keep < 0:
        raise VswInputError(f"--keep {keep}: give 0 (no iteration) or at least 2 steps to keep")
    if args.transient < 0:
        raise VswInputError(f"--transient {args.transient} must be >= 0")
    for dest in ("transient", "max_steps"):
        if not keep and given(args.parser, args, dest):
            option = "--" + dest.replace("_", "-")
            raise VswInputError(f"{option} applies to the iterated map: give --keep N or --plot")
    if keep and args.max_steps < args.transient + keep:
        if given(args.parser, args, "max_steps"):
            raise VswInputError(f"--max-steps {args.max_steps} is below --transient + --keep = "
                                f"{args.transient + keep}")  # fmt: skip
        args.max_steps = args.transient + keep  # the default cap gives way to a long transient
    if args.y is not None and args.plot is None:
        raise VswInputError("--y chooses what --plot draws: give --plot FILE")
    fixed = {k: v for k, v in args.values.items() if k != name}
    if args.brute_force and not keep:
        raise VswInputError("--brute-force iterates the map: --keep must be at least 2")
    params = model.parameters(fixed | {name: float(values[0])})
    with options.solver_errors(model):
        first = _first_gait(model, params, args, name, float(values[0]))
    if args.brute_force:
        start = None if first is None else np.array(list(first[0].state.values()))
        points = _brute_force(args, model, fixed, name, values, keep, start)
        method = "brute-force"
    else:
        points = _continuation(model, fixed, name, values, keep, args, first)
        method = None
    swept = sweeps.record(model, fixed, name, points, keep, args.transient, method,
                          args.max_steps)  # fmt: skip
    tolerances = {**INTEGRATOR, **ORBIT_SOLVER, **(ATTRACTOR if keep else {})}
    data = {**envelope(model, params, args.argv, tolerances), **swept}
    if args.plot is not None and not args.brute_force:
        with options.solver_errors(model):
            data["special_points"] = sweeps.located_points(model, fixed, name, points)
    if args.plot is not None:
        title = plotstyle.parameter_text(model, fixed)
        figure = bifurcation_plot(clean(data), y, diagram_units(model.units), title)
        save_figure(figure, args.plot)
        data["plot"] = args.plot
    if args.json:
        dump_json(with_units(model, data))
        return EXIT_OK
    _write_points(model, data, name, keep, options.given_in_degrees(model, name, args.over))
    return EXIT_OK


def _first_gait(
    model: Model, params, args: argparse.Namespace, name: str, value: float
) -> tuple[Orbit, str] | None:
    """The gait ``--state`` or ``--gait-number`` chooses at the range's start (None: the
    search's pick). At a value with two unstable gaits the pick is the first, which for the
    simplest walker is the short gait whose walks fall: the user names the other."""
    where = f"at {name} = {value:g}"
    if args.state:
        state = np.array(options.parse_state(model, args.state))
        step = model.step(params, state)
        if step.ended != "completed":
            raise VswInputError(f"--state: no gait {where}: a step from it ends with "
                                f"{step.ended}")  # fmt: skip
        try:
            return model.periodic_orbit(params, state, step.durations), "--state"
        except ConvergenceError as exc:
            stop.check()
            raise VswInputError(f"--state: no period-one gait through it {where}: {exc}") from exc
    number = args.gait_number
    if number is None:
        return None
    gaits = model.analyze(params).gaits
    if number > len(gaits):
        found = f"1 to {len(gaits)}" if gaits else "none"
        raise VswInputError(f"--gait-number {number}: the search {where} finds {len(gaits)} "
                            f"gait(s): give {found} (see vsw analyze)")  # fmt: skip
    return gaits[number - 1], f"--gait-number {number}"


def _continuation(model, fixed, name, values, keep: int, args, first) -> list[dict]:
    count = len(values)
    size = len(model.phases) * model.n
    # One search to start; where continuation loses the gait, another per point (not
    # counted: the limit is enforced while the sweep runs). The map is iterated by the
    # batch simulator, every value up to --max-steps at worst.
    per_point = limits.HYBRID_SECONDS_PER_ORBIT * count + (
        limits.BATCH_SECONDS_PER_PHASE * count * args.max_steps if keep else 0.0)  # fmt: skip
    seconds = search_seconds(model) + size * per_point
    nbytes = limits.SIMULATE_BYTES_BASE + count * max(keep, 1) * limits.HYBRID_BYTES_PER_STEP
    limits.check(
        f"a sweep of {count} points" + (f" iterating up to {args.max_steps} steps each" if keep
                                        else ""),
        limits.Cost(seconds, nbytes),
        "use fewer points (N of --over)" + (", --keep or --max-steps" if keep else ""),
    )  # fmt: skip
    with progress("sweep") as bar, options.solver_errors(model):
        return sweeps.continuation(model, fixed, name, values, keep, args.transient,
                                   progress=bar, first=first,
                                   max_steps=args.max_steps)  # fmt: skip


def _brute_force(args, model, fixed, name, values, keep: int, start) -> list[dict]:
    count = len(values)
    steps = count * args.max_steps
    seconds = search_seconds(model) + (
        (steps + 40 * count) * limits.BATCH_SECONDS_PER_PHASE * len(model.phases) * model.n
        / default_threads()
    )  # fmt: skip
    limits.check(
        f"a brute-force sweep of {count} points iterating up to {args.max_steps} steps each",
        limits.Cost(seconds, limits.SIMULATE_BYTES_BASE + count * keep * 200),
        "use fewer points (N of --over), --keep or --max-steps",
    )
    if start is None and args.state:
        start = options.parse_state(model, args.state)
    with options.solver_errors(model):
        return sweeps.brute_force(model, fixed, name, values, args.transient, keep, start=start,
                                  max_steps=args.max_steps)  # fmt: skip


def attractor_label(attractor: dict[str, Any]) -> str:
    """What the iterated map did at one value, as the text output says it: the failure
    that ended the walk, ``period-p`` once the orbit has settled, else ``not settled after
    N steps`` (a record without ``settled`` counts as settled where it has a period)."""
    if attractor["ended"] != "completed":
        return attractor["ended"]
    if attractor.get("settled", attractor["period"] is not None):
        return f"period-{attractor['period']}"
    return f"not settled after {attractor['steps_walked']} steps"


def _write_points(model: Model, data: dict, name: str, keep: int, degrees: bool) -> None:
    out = sys.stdout
    unit = " deg" if degrees else unit_text(data["over_unit"])
    brute = data.get("method") == "brute-force"
    how = f"; brute force: {data['transient']} steps then {keep} kept" if brute else ""
    out.write(f"{'model':<12} {model.cli_name} ({model.title}); over {name}{unit}{how}\n")
    state_names = [] if brute else [*model.coordinates, *model.rates]
    out.write(f"{name:>12} " + " ".join(f"{n:>12}" for n in state_names)
              + (f" {'period':>12}" if not brute else "")
              + f" {'max|eig|':>12} {'stable':>6}  {'map' if brute else 'from'}\n")  # fmt: skip
    for p in data["points"]:
        state = p.get("state") or {}
        attractor = p.get("attractor")
        note = ""
        if attractor:
            kind = attractor_label(attractor)
            note = kind if brute else f"; map: {kind}"
        where = "" if brute else (p["from"] or f"no gait: {p.get('reason')}")
        out.write(f"{fmt(options.echo(p[name], degrees)):>12} "
                  + " ".join(f"{fmt(state.get(n)):>12}"
                                                    for n in state_names)
                  + ("" if brute else f" {fmt(p['period']):>12}")
                  + f" {fmt(p['max_abs_eigenvalue']):>12} {fmt(p['stable']):>6}  "
                  f"{where}{note}\n")  # fmt: skip
    if data.get("plot"):
        out.write(f"plot: {data['plot']}\n")
