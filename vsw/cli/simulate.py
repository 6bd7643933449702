"""``vsw simulate``: the Poincaré map walked step by step from a gait or a given state.

With ``--gait FILE`` (a powered gait ``vsw optimize --out FILE`` wrote) the walk replays
its inputs open loop from its start state, at its parameters (:mod:`vsw.studies.gait_file`):
``--state`` and ``--q0`` are refused (the gait gives the start), ``--param`` only where it
is the gait's value, ``--model`` only where it is the gait's model (default: the file's).
:func:`add_gait_option` and :func:`saved_gait` are ``vsw animate``'s and ``vsw explore``'s
too."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from vsw.cli import options
from vsw.cli.output import (
    INTEGRATOR,
    dump_json,
    envelope,
    fmt,
    progress,
    unit_text,
    with_units,
    write_parameters,
)
from vsw.cli.parser import EXIT_OK
from vsw.dynamics.trajectories import (
    FORMATS,
    check_rate,
    column_units,
    sample_walk,
    write_trajectory,
)
from vsw.dynamics.walks import walk
from vsw.gaits.search import search_seconds
from vsw.models import key as model_key
from vsw.models.base import PLOT_RATE
from vsw.plots.figures import check_output_path, check_save_path, save_figure
from vsw.plots.walk_plot import walk_figure
from vsw.runtime import limits
from vsw.runtime.errors import VswInputError
from vsw.studies.gait_file import (
    PoweredReplay,
    SavedGait,
    check_parameters,
    load_gait,
    with_input_forces,
)

__all__ = ["add_gait_option", "register", "run", "saved_gait"]

REPLAY = {"integrator": "SciPy DOP853, rtol = atol = 1e-11 (the powered verification's: "
          "each phase to its event's first crossing that counts)"}  # fmt: skip
"""The replay's tolerances (:func:`vsw.synthesis.powered.verify.step_runs`)."""

FEATURES = {"q0": "q0", "plot": "simulation-plot"}


def register(subparsers: Any) -> None:
    help_ = "the Poincaré map walked step by step (time-domain simulation of each step)"
    p = subparsers.add_parser("simulate", help=help_, description=help_ + ".")
    options.add_model_options(p, "simulate", features=FEATURES)
    p.add_argument(
        "--steps",
        type=int,
        default=10,
        help="steps to walk (limited by VSW_MAX_SECONDS and VSW_MAX_MEMORY)",
    )
    start = p.add_argument_group("where the walk starts (default: the first stable gait)")
    start.add_argument(
        "--state",
        action="append",
        metavar="NAME=VALUE",
        help="the state just after the step event, every coordinate and rate; repeatable",
    )
    start.add_argument(
        "--q0", type=float, help="q = rate**2 just after the step event (ile, tle, rimless-wheel)"
    )
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="save the walk's figure (.png/.svg/.pdf): the ile's "
        "theta, omega and q by step; every other model's coordinates, rates and energy over "
        "time",
    )
    p.add_argument(
        "--trajectory", metavar="FILE",
        help="write the time series (state, energy, contact force, events) as .csv, .npz or "
        ".mat, by the extension",
    )  # fmt: skip
    p.add_argument(
        "--rate", type=float, default=100.0,
        help="samples per model time unit in --trajectory, plus each event's instant",
    )  # fmt: skip
    add_gait_option(start)
    p.set_defaults(func=run, parser=p)


def add_gait_option(group: Any) -> None:
    """``--gait FILE``: replay a powered gait that ``vsw optimize --out`` wrote."""
    group.add_argument(
        "--gait", metavar="FILE",
        help="replay the powered gait 'vsw optimize --out FILE' wrote: its inputs open loop "
        "from its start, at its parameters (--model defaults to the file's)",
    )  # fmt: skip


def saved_gait(args: argparse.Namespace) -> SavedGait:
    """The gait of ``--gait``, refused in one line where the command line contradicts it:
    another ``--model`` than the file's, ``--state`` or ``--q0`` (the gait gives the start),
    a ``--param`` (or named parameter) other than the gait's value."""
    if getattr(args, "state", None) or getattr(args, "q0", None) is not None:
        option = "--state" if args.state else "--q0"
        raise VswInputError(f"--gait and {option} both give the start: a gait starts where it "
                            f"was found (drop {option})")  # fmt: skip
    named = any(a == "--model" or a.startswith("--model=") for a in args.argv)
    saved = load_gait(args.gait, model_key(args.model) if named else None)
    if saved.model.name != args.model_object.name and args.values:
        raise VswInputError(f"--gait {args.gait} is a gait of {saved.model.cli_name}: give "
                            f"--model {saved.model.cli_name} with --param")  # fmt: skip
    check_parameters(saved, args.values)
    return saved


def check_cost(model, steps: int, search: bool, records: int, what: str, remedy: str) -> None:
    """Refuse a walk beyond the limits (vsw.runtime.limits) before it starts: per-step costs
    measured on the rimless wheel, scaled by the model's phases x coordinates."""
    size = len(model.phases) * model.n
    seconds = size * limits.HYBRID_SECONDS_PER_PHASE * steps
    seconds += search_seconds(model) if search else 0.0
    nbytes = limits.SIMULATE_BYTES_BASE + records * limits.HYBRID_BYTES_PER_STEP
    limits.check(what, limits.Cost(seconds, nbytes), remedy)


def run(args: argparse.Namespace) -> int:
    model, params = options.model_and_parameters(args)
    if args.steps < 1:
        raise VswInputError(f"--steps = {args.steps} must be >= 1")
    if args.gait is not None:
        return _run_gait(args, saved_gait(args))
    if args.state and args.q0 is not None:
        raise VswInputError("--state and --q0 both give the start: give one")
    state = options.parse_state(model, args.state) if args.state else None
    if args.plot is not None:
        check_save_path(args.plot)
    if args.trajectory is not None:
        check_output_path(args.trajectory, FORMATS, "trajectory file")
        check_rate(args.rate)
    search = state is None and args.q0 is None
    check_cost(model, args.steps, search, args.steps, f"simulating {args.steps} steps",
               "use fewer --steps")  # fmt: skip
    with options.solver_errors(model):
        start = model.start(params, state, args.q0)
    with progress("simulate") as bar, options.solver_errors(model):
        result = walk(model, params, start.state, args.steps, progress=bar)
    data = {
        **envelope(model, params, args.argv, INTEGRATOR),
        **model.walk_keys(params, result, start),
        "start_from": start.source,
        "start_gait": None if start.gait is None else {
            "max_abs_eigenvalue": start.gait.max_abs_eigenvalue, "stable": start.gait.stable},
        "steps": args.steps,
        **result.to_dict(),
        "note": start.note(),
    }  # fmt: skip
    if args.plot is not None:
        model.save_simulation_plot(params, start.state, args.steps, args.plot)
        data["plot"] = args.plot
    if args.trajectory is not None:
        with options.solver_errors(model):
            sampled = sample_walk(model, params, start.state, args.steps, args.rate)
        data["trajectory"] = _export(args.trajectory, model, params, sampled)
    if args.json:
        dump_json(with_units(model, data))
        if start.note():
            sys.stderr.write(f"vsw simulate: note: {start.note()}\n")
        return EXIT_OK
    _write_walk(args, model, params, result, start.source, start.note(),
                sampled if args.trajectory is not None else None, data)  # fmt: skip
    return EXIT_OK


def _export(path: str, model: Any, params: Any, sampled: Any) -> dict[str, Any]:
    """``--trajectory``: the sampled walk written to ``path``, and what the JSON says of it."""
    write_trajectory(path, model, params, sampled)
    return {"path": path, "rows": len(sampled.t), "rate": sampled.rate,
            "units": column_units(model, sampled)}  # fmt: skip


def _write_walk(args: argparse.Namespace, model, params, result, source: str, note: str | None,
                sampled, data: dict[str, Any]) -> None:  # fmt: skip
    """The text output: the parameters, where the walk started and how it ended, the
    section state after each step, and the files written."""
    out = sys.stdout
    write_parameters(out, model, params)
    if note:
        out.write(f"note: {note}\n")
    out.write(f"start: {source}; ended: {result.ended} after {result.steps_completed} of "
              f"{args.steps} steps\n")  # fmt: skip
    closed = data.get("q_fixed_closed_form")
    if closed is not None:
        out.write(f"q_fixed (closed form): {fmt(closed)}\n")
    names = [*model.coordinates, *model.rates]
    units = {s["name"]: s["unit"] for s in model.spec["state"]}
    out.write(f"{'step':>5} " + " ".join(f"{n:>14}" for n in names) + f" {'step_length':>14}\n")
    out.write(f"{'':>5} " + " ".join(f"{'[' + units[n] + ']':>14}" for n in names)
              + f" {'[' + model.units.get('length', '') + ']':>14}\n")  # fmt: skip
    for n, x in enumerate(result.states):
        length = result.step_lengths[n - 1] if n else None
        out.write(f"{n:>5} " + " ".join(f"{fmt(float(v)):>14}" for v in x)
                  + f" {fmt(length):>14}\n")  # fmt: skip
    if args.plot is not None:
        out.write(f"plot: {args.plot}{unit_text(None)}\n")
    if sampled is not None:
        per = model.units.get("time", "time unit")
        rows = f"{len(sampled.t)} row{'s' if len(sampled.t) != 1 else ''}"
        out.write(f"trajectory: {args.trajectory} ({rows}, {sampled.rate:g} "
                  f"samples per {per} and each event)\n")  # fmt: skip


def _run_gait(args: argparse.Namespace, saved: SavedGait) -> int:
    """``vsw simulate --gait FILE``: the saved gait's inputs replayed, step after step."""
    model, params, start = saved.model, saved.params, saved.start
    replay = PoweredReplay(model, saved.gait)
    if args.plot is not None:
        check_save_path(args.plot)
    if args.trajectory is not None:
        check_output_path(args.trajectory, FORMATS, "trajectory file")
        check_rate(args.rate)
    check_cost(model, args.steps, False, args.steps, f"simulating {args.steps} steps",
               "use fewer --steps")  # fmt: skip
    with progress("simulate") as bar, options.solver_errors(model):
        result = walk(replay, params, start, args.steps, progress=bar)
    note = _gait_note(saved)
    data = {
        **envelope(model, params, args.argv, REPLAY),
        "start_from": "gait",
        "gait": {"file": args.gait, "status": saved.status,
                 "verification": saved.record.get("verification")},
        "steps": args.steps,
        **result.to_dict(),
        "note": note,
    }  # fmt: skip
    if args.plot is not None:
        with options.solver_errors(model):
            sampled = with_input_forces(replay, sample_walk(replay, params, start, args.steps,
                                                            PLOT_RATE))  # fmt: skip
        save_figure(walk_figure(model, params, sampled), args.plot)
        data["plot"] = args.plot
    if args.trajectory is not None:
        with options.solver_errors(model):
            sampled = with_input_forces(replay, sample_walk(replay, params, start, args.steps,
                                                            args.rate))  # fmt: skip
        data["trajectory"] = _export(args.trajectory, model, params, sampled)
    if args.json:
        dump_json(with_units(model, data))
        if note:
            sys.stderr.write(f"vsw simulate: note: {note}\n")
        return EXIT_OK
    _write_walk(args, model, params, result, f"gait {args.gait} ({saved.status})", note,
                sampled if args.trajectory is not None else None, data)  # fmt: skip
    return EXIT_OK


def _gait_note(saved: SavedGait) -> str | None:
    """What to know before trusting a replay: a gait the verification did not confirm."""
    if saved.status != "unverified":
        return None
    reason = (saved.record.get("verification") or {}).get("reason") or "not verified"
    return f"the gait is unverified ({reason}): its inputs may not repeat the step"
