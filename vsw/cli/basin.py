"""``vsw basin``: the states that walk into the stable gait.

Every model: a slice of the section (``--grid`` once where the section has one free
component, twice otherwise), each cell walked by the batch simulator until it converges to
the stable gait, repeats with a period, falls, or walks ``--steps`` steps; without
``--grid``, a model whose section has one free component gets 41 values over its search
box. A model with a basin of its own (:attr:`vsw.models.base.Model.routes`: the ile's over
theta_II and q0 in closed form, Fig. 9, :mod:`vsw.cli.ile_basin`) answers by it without
``--grid``.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from typing import Any

import numpy as np

from vsw.cli import options
from vsw.cli.output import (
    INTEGRATOR,
    dump_json,
    envelope,
    fmt,
    progress,
    with_units,
    write_parameters,
)
from vsw.cli.parser import EXIT_OK, StoreGiven, given, option_name
from vsw.dynamics.batch import simulator
from vsw.gaits.search import search_seconds
from vsw.models.base import Model
from vsw.plots import plotstyle
from vsw.plots.figures import check_save_path, save_figure
from vsw.runtime import limits
from vsw.runtime.errors import VswInputError
from vsw.runtime.progress import reporting
from vsw.runtime.threads import default_threads
from vsw.studies.cluster import check_scheduler, runner
from vsw.studies.grid_basin import basin_plot, check_grid_names, grid_basin

__all__ = ["register", "run"]

FEATURES = {dest: "parameter-basin" for dest in
            ("theta_min", "theta_max", "theta_step", "n_q", "check_edges")}  # fmt: skip
DEFAULT_POINTS = 41
"""Grid values over the search box of a one-component section when no --grid is given."""


def register(subparsers: Any) -> None:
    help_ = "basin of attraction of the stable gait over a slice of the section (--grid)"
    p = subparsers.add_parser("basin", help=help_, description=help_ + "; the ile without "
                              "--grid: over theta_II and q0 in closed form (Fig. 9).")  # fmt: skip
    options.add_model_options(p, "basin", features=FEATURES)
    p.add_argument("--plot", metavar="FILE", help="save the basin figure (.png/.svg/.pdf)")
    grid = p.add_argument_group("a slice of the section, by the compiled batch simulator")
    grid.add_argument(
        "--grid",
        action="append",
        metavar="NAME=START:STOP:N",
        help="a free component of the state just after the step event and its N values; "
        "twice for a section with several (see 'vsw models'); default: 41 values over the "
        "search box of a one-component section",
    )
    grid.add_argument("--steps", type=int, default=50, action=StoreGiven,
                      help="most steps walked from a cell; it stops early once converged, "
                      "periodic or fallen")  # fmt: skip
    grid.add_argument("--tol", type=float, default=1e-6, action=StoreGiven,
                      help="converged: every state component within tol * max(1, |gait "
                      "state|)")  # fmt: skip
    grid.add_argument("--scheduler", metavar="ADDRESS",
                      help="run the cells on this Dask scheduler (default: VSW_DASK_SCHEDULER "
                      "if set, else threads here); needs the extra vsw[dask]")  # fmt: skip
    ile = p.add_argument_group("the closed-form basin over theta_II (the ile, without --grid)")
    ile.add_argument("--theta-min", type=float, default=-30.0, action=StoreGiven,
                     help="first theta_II [deg]")  # fmt: skip
    ile.add_argument("--theta-max", type=float, default=40.0, action=StoreGiven,
                     help="last theta_II [deg]")  # fmt: skip
    ile.add_argument("--theta-step", type=float, default=0.5, action=StoreGiven,
                     help="theta_II step [deg]")  # fmt: skip
    ile.add_argument("--n-q", type=int, default=2001, action=StoreGiven,
                     help="initial q grid points in (0, 1.5/beta] (limited by VSW_MAX_MEMORY "
                     "and VSW_MAX_SECONDS)")  # fmt: skip
    ile.add_argument("--check-edges", type=int, default=0, action=StoreGiven, metavar="N",
                     help="check N sampled theta_II edges by simulation")  # fmt: skip
    p.set_defaults(func=run, parser=p)


def run(args: argparse.Namespace) -> int:
    model = args.model_object
    route = model.route("basin")
    if not args.grid and route is not None:
        return route(args, model)
    for dest in FEATURES:
        if given(args.parser, args, dest):
            raise VswInputError(f"{option_name(args.parser, dest)} belongs to the closed-form "
                                "basin over theta_II: drop --grid")  # fmt: skip
    return _grid_basin(args, model)


# --- a slice of the section --------------------------------------------------------------------


def _grid(args: argparse.Namespace, model: Model) -> list[tuple[str, np.ndarray]]:
    if args.grid:
        if len(args.grid) > 2:
            raise VswInputError(f"--grid given {len(args.grid)} times: give it once or twice")
        axes = [options.parse_grid(model, item) for item in args.grid]
        check_grid_names(model, *(name for name, _ in axes))
        return axes
    free = list(model.spec["search"])
    if len(free) != 1:
        raise VswInputError(
            f"vsw basin --model {model.cli_name}: give the slice of the section with --grid "
            f"twice, e.g. --grid {free[0]}=START:STOP:N --grid {free[1]}=START:STOP:N "
            f"(free components: {', '.join(free)})"
        )
    low, high = model.spec["search"][free[0]]
    values = np.linspace(low, high, DEFAULT_POINTS + 1)[1:] if low == 0 else np.linspace(
        low, high, DEFAULT_POINTS)  # fmt: skip
    return [(free[0], values)]


def _grid_basin(args: argparse.Namespace, model: Model) -> int:
    axes = _grid(args, model)
    if not 1 <= args.steps <= 100_000:
        raise VswInputError(f"--steps = {args.steps} must be from 1 to 100000")
    if not math.isfinite(args.tol) or not 0 < args.tol < 1:
        raise VswInputError(f"--tol = {args.tol:g} must lie in (0, 1)")
    scheduler = args.scheduler or os.environ.get("VSW_DASK_SCHEDULER", "").strip() or None
    if args.plot is not None:
        check_save_path(args.plot)
    params = model.parameters(args.values)
    threads = check_scheduler(scheduler) if scheduler else default_threads()
    cells = math.prod(len(v) for _, v in axes)
    # Upper bound: every cell walks every step (most fall or converge much earlier).
    seconds = search_seconds(model, threads) + (cells * args.steps * limits.BATCH_SECONDS_PER_PHASE
                                            * len(model.phases) * model.n / threads)  # fmt: skip
    nbytes = limits.SIMULATE_BYTES_BASE + cells * limits.BATCH_BYTES_PER_CELL
    shape = " x ".join(str(len(v)) for _, v in axes)
    limits.check(f"a basin of {shape} cells x up to {args.steps} steps",
                 limits.Cost(seconds, nbytes), "use a coarser --grid or fewer --steps")  # fmt: skip
    flat = [item for axis in axes for item in axis]
    remote = runner(scheduler, model.name) if scheduler else None
    with progress("basin") as bar, reporting(bar), options.solver_errors(model):
        simulator(model).library()
        result = grid_basin(model, params, *flat, steps=args.steps, tol=args.tol, runner=remote)
    # The record only where it is shown: its envelope looks up the installed version
    # (importlib.metadata, 10-20 ms of a run), which the text does not print.
    if args.json or args.plot is not None:
        data = {**envelope(model, params, args.argv, {**INTEGRATOR, "converged": args.tol}),
                **result.to_dict(), "model": model.cli_name, "simulator": result.route}  # fmt: skip
        if scheduler:
            data["scheduler"] = scheduler
        if args.plot is not None:
            units = {s["name"]: s["unit"] for s in model.spec["state"]}
            title = plotstyle.parameter_text(model, params)
            save_figure(basin_plot(data, units, title), args.plot)
            data["plot"] = args.plot
        if args.json:
            state = {s["name"]: s["unit"] for s in model.spec["state"]}
            axes = {"x": state.get(data.get("x_name"), ""), "y": state.get(data.get("y_name"), "")}
            dump_json(with_units(model, data, axes))
            return EXIT_OK
    out = sys.stdout
    write_parameters(out, model, params)
    gait = ", ".join(f"{k} = {fmt(v)}" for k, v in result.fixed_point.items())
    out.write(f"stable gait (max |eigenvalue| {fmt(result.gait.max_abs_eigenvalue)}): "
              f"{gait}\n")  # fmt: skip
    text = ", ".join(f"{name} {fmt(float(v[0]))} .. {fmt(float(v[-1]))} ({len(v)})"
                     for name, v in axes)  # fmt: skip
    out.write(f"grid: {text}; up to {args.steps} steps\n")
    for label, count in result.counts().items():
        out.write(f"{label:>12}: {count} cells ({100 * count / cells:.2f} %)\n")
    if result.route != "compiled":
        out.write(f"note: the walks took the {result.route} route\n")
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
    return EXIT_OK
