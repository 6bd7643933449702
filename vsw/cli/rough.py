"""``vsw rough``: the mean first-passage time (MFPT) on a random slope, by Monte Carlo.

Walks from the model's stable period-one gait (or ``--state``) on the slope
gamma_k = gamma + sigma xi_k drawn per step (:mod:`vsw.rough`; Byl & Tedrake 2009), each
until its first failure or ``--max-steps`` steps: the MFPT with its standard error and
95 % interval, the failures by kind and the survival curve (``--plot``).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from vsw import limits, plotstyle
from vsw.batch import simulator
from vsw.cli import options
from vsw.cli.output import INTEGRATOR, dump_json, envelope, fmt, with_units, write_parameters
from vsw.cli.parser import EXIT_OK
from vsw.figures import check_save_path, save_figure
from vsw.gaits import search_seconds
from vsw.rough import (
    SLOPE,
    check_inputs,
    gait_sensitivity,
    rough_walks,
    slope_index,
    survival_plot,
)
from vsw.vectorize import default_threads

__all__ = ["register", "run"]

TERRAINS = ("slope",)
"""Terrain models ``--terrain`` takes."""


def register(subparsers: Any) -> None:
    help_ = "mean first-passage time (steps before a fall) on a random slope, by Monte Carlo"
    text = f": the slope {SLOPE} + sigma * xi drawn per step, xi standard normal."
    p = subparsers.add_parser("rough", help=help_, description=help_ + text)
    options.add_model_options(p, "rough")
    p.add_argument("--sigma", type=float, required=True, metavar="S",
                   help="standard deviation of the per-step slope [rad] (>= 0)")  # fmt: skip
    p.add_argument("--terrain", choices=TERRAINS, default="slope",
                   help="the terrain model: a slope drawn per step")  # fmt: skip
    p.add_argument("--walks", type=int, default=1000, help="walks (Monte Carlo samples)")
    p.add_argument("--max-steps", type=int, default=1000,
                   help="most steps a walk takes (a walk still walking is censored)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the terrain (each walk's slopes follow from it and the "
                   "walk's index alone)")  # fmt: skip
    p.add_argument("--state", action="append", metavar="NAME=VALUE",
                   help="start here (the state just after the step event, every coordinate "
                   "and rate) instead of the stable gait; repeatable")  # fmt: skip
    p.add_argument("--plot", metavar="FILE", help="save the survival curve (.png/.svg/.pdf)")
    p.set_defaults(func=run, parser=p)


def _check_cost(model: Any, args: argparse.Namespace, search: bool) -> None:
    """Refuse walks beyond the limits before they start (every walk taking every step)."""
    threads = default_threads()
    seconds = search_seconds(model, threads) if search else 0.0
    seconds += (args.walks * args.max_steps * limits.BATCH_SECONDS_PER_PHASE
                * len(model.phases) * model.n / threads)  # fmt: skip
    nbytes = limits.SIMULATE_BYTES_BASE + args.walks * limits.BATCH_BYTES_PER_CELL
    limits.check(f"{args.walks} walks x up to {args.max_steps} steps",
                 limits.Cost(seconds, nbytes), "use fewer --walks or --max-steps")  # fmt: skip


def run(args: argparse.Namespace) -> int:
    model, params = options.model_and_parameters(args)
    options.refuse_powered_only(model, "rough")
    slope_index(model)
    check_inputs(args.sigma, args.walks, args.max_steps, args.seed)
    start = options.parse_state(model, args.state) if args.state else None
    if args.plot is not None:
        check_save_path(args.plot)
    _check_cost(model, args, start is None)
    with options.solver_errors(model):
        simulator(model).library()
        result = rough_walks(model, params, args.sigma, args.walks, args.max_steps, args.seed,
                             start=start)  # fmt: skip
        gsn = None if result.gait is None else gait_sensitivity(model, params, result.gait)
    data = {**envelope(model, params, args.argv, INTEGRATOR), **result.to_dict(),
            "model": model.cli_name,
            "gait_sensitivity": None if gsn is None else gsn.to_dict()}  # fmt: skip
    if args.plot is not None:
        noise = f"slope drawn per step: $\\sigma$ = {args.sigma:g} rad"
        title = plotstyle.parameter_text(model, params) + "\n" + noise
        save_figure(survival_plot(data, title), args.plot)
        data["plot"] = args.plot
    if args.json:
        time, length = model.units.get("time", ""), model.units.get("length", "")
        extra = {"sigma": "rad", "seed": "1", "walks": "1", "failures": "1", "censored": "1",
                 "mfpt": "steps", "failures_by_kind": "1", "survival.steps": "steps",
                 "survival.fraction": "1", "gsn": f"{time}/rad and {length}/rad together",
                 "gsn_by_indicator.step_time": f"{time}/rad",
                 "gsn_by_indicator.step_length": f"{length}/rad", "A": "state/state",
                 "B": "state/rad", "C": "indicator/state", "D": "indicator/rad"}  # fmt: skip
        dump_json(with_units(model, data, extra))
        return EXIT_OK
    _write_text(model, params, args, data)
    return EXIT_OK


def _write_text(model: Any, params: Any, args: argparse.Namespace, data: dict) -> None:
    out = sys.stdout
    write_parameters(out, model, params)
    start = ", ".join(f"{k} = {fmt(v)}" for k, v in data["start"].items())
    origin = "given" if data["gait"] is None else "the stable gait"
    out.write(f"{'start':<18} {start} ({origin})\n")
    out.write(f"{'terrain':<18} {SLOPE}_k = {fmt(data['parameters'][SLOPE])} + "
              f"{fmt(args.sigma)} xi_k rad, xi_k standard normal, seed {args.seed}\n")  # fmt: skip
    out.write(f"{'walks':<18} {data['walks']}, up to {data['max_steps']} steps each\n")
    m = data["mfpt"]
    if m["value"] is None:
        out.write(f"{'MFPT':<18} no walk failed: at least {fmt(m['low'])} steps (95 %)\n")
    else:
        out.write(f"{'MFPT':<18} {fmt(m['value'])} steps, standard error {fmt(m['se'])}, "
                  f"95 % interval [{fmt(m['low'])}, {fmt(m['high'])}]\n")  # fmt: skip
    out.write(f"{'estimator':<18} {data['estimator']}\n")
    out.write(f"{'failures':<18} {data['failures']} of {data['walks']} walks, "
              f"{data['censored']} censored, {data['steps_walked']} steps walked\n")  # fmt: skip
    for kind, count in data["failures_by_kind"].items():
        out.write(f"  {kind:<16} {count}\n")
    gsn = data["gait_sensitivity"]
    if gsn is not None:
        units = dict(model.units)
        parts = ", ".join(f"{k.replace('_', ' ')} {fmt(v)} {units[k.split('_')[1]]}/rad"
                          for k, v in gsn["gsn_by_indicator"].items())  # fmt: skip
        out.write(f"{'gait sensitivity':<18} {fmt(gsn['gsn'])} ({parts}; the H2 norm of the "
                  "indicators' response to one step's slope)\n")  # fmt: skip
    if data["simulator"] != "compiled":
        out.write(f"note: the walks took the {data['simulator']} route\n")
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
