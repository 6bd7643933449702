"""``vsw rough``: the mean first-passage time (MFPT) on a random terrain, by Monte Carlo.

Walks from the model's stable period-one gait (or ``--state``) on the slope
gamma_k = gamma + sigma xi_k drawn per step (``--terrain height``: the next foothold's
height; :mod:`vsw.studies.rough`; Byl & Tedrake 2009), each until its first failure or
``--max-steps`` steps: the MFPT with its standard error and 95 % interval, the failures by
kind and the survival curve (``--plot``); with ``--over``, the MFPT over the mean slope or
the noise (:mod:`vsw.studies.rough_sweep`).
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from vsw.cli import options
from vsw.cli.output import (
    INTEGRATOR,
    dump_json,
    envelope,
    fmt,
    progress,
    with_units,
    write_gait_sensitivity,
    write_parameters,
)
from vsw.cli.parser import EXIT_OK
from vsw.dynamics.batch import simulator
from vsw.gaits.search import search_seconds
from vsw.plots import plotstyle
from vsw.plots.figures import check_save_path, save_figure
from vsw.runtime import limits
from vsw.runtime.errors import VswInputError
from vsw.runtime.progress import reporting
from vsw.runtime.threads import default_threads
from vsw.studies.cluster import check_scheduler
from vsw.studies.rough import (
    DISTRIBUTIONS,
    SLOPE,
    TERRAINS,
    check_inputs,
    disturbance_index,
    gait_sensitivity,
    gait_sensitivity_units,
    rough_walks,
    survival_plot,
)
from vsw.studies.rough_chain import chain_steps, check_chain_inputs, rough_chain
from vsw.studies.rough_sweep import parse_over, rough_sweep, sweep_plot, sweep_units

__all__ = ["register", "run"]

METHODS = ("monte-carlo", "chain", "both")
"""What ``--method`` takes."""


def register(subparsers: Any) -> None:
    help_ = "mean first-passage time (steps before a fall) on a random terrain, by Monte Carlo"
    text = (f": the slope {SLOPE} + sigma * xi drawn per step (or the next foothold's height), "
            "xi standard normal or uniform.")  # fmt: skip
    p = subparsers.add_parser("rough", help=help_, description=help_ + text)
    options.add_model_options(p, "rough")
    p.add_argument("--sigma", type=float, required=True, metavar="S",
                   help="standard deviation of the per-step slope [rad] or foothold height "
                   "[the model's length] (>= 0)")  # fmt: skip
    p.add_argument("--terrain", choices=tuple(TERRAINS), default="slope",
                   help="the terrain model: a slope drawn per step, or the next foothold's "
                   "height (a model with the parameter step_height)")  # fmt: skip
    p.add_argument("--distribution", choices=DISTRIBUTIONS, default="gaussian",
                   help="the per-step draw: gaussian, or uniform with the same standard "
                   "deviation sigma")  # fmt: skip
    p.add_argument("--over", metavar="NAME=a:b:n",
                   help="the MFPT at n values from a to b of gamma0 (the terrain parameter's "
                   "mean) or sigma, with the gait sensitivity norm and their rank "
                   "correlation; --plot draws MFPT against it")  # fmt: skip
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="walk on this Dask scheduler (default: VSW_DASK_SCHEDULER if set); "
                   "the results are the in-process ones")  # fmt: skip
    p.add_argument("--walks", type=int, default=1000, help="walks (Monte Carlo samples)")
    p.add_argument("--max-steps", type=int, default=1000,
                   help="most steps a walk takes (a walk still walking is censored)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the terrain (each walk's slopes follow from it and the "
                   "walk's index alone)")  # fmt: skip
    p.add_argument("--state", action="append", metavar="NAME=VALUE",
                   help="start here (the state just after the step event, every coordinate "
                   "and rate) instead of the stable gait; repeatable")  # fmt: skip
    p.add_argument("--plot", metavar="FILE",
                   help="save the survival curve, or with --over the MFPT against the swept "
                   "value (.png/.svg/.pdf)")  # fmt: skip
    p.add_argument("--method", choices=METHODS, default="monte-carlo",
                   help="monte-carlo: the walks; chain: the meshed Markov chain on the "
                   "section (Byl & Tedrake); both: each, and whether the chain's MFPT lies "
                   "in the walks' 95 %% interval")  # fmt: skip
    p.add_argument("--noise-nodes", type=int, default=24, metavar="N",
                   help="the chain's Gauss-Hermite nodes in the slope's noise")  # fmt: skip
    p.add_argument("--max-nodes", type=int, default=100_000, metavar="N",
                   help="the chain's largest mesh (nodes)")  # fmt: skip
    p.set_defaults(func=run, parser=p)


def _check_cost(model: Any, args: argparse.Namespace, search: bool, points: int = 1,
                threads: int | None = None) -> None:  # fmt: skip
    """Refuse walks beyond the limits before they start (every walk taking every step, at
    each of ``points`` values of a sweep)."""
    threads = threads or default_threads()
    seconds = search_seconds(model, default_threads()) if search else 0.0
    seconds += (points * args.walks * args.max_steps * limits.BATCH_SECONDS_PER_PHASE
                * len(model.phases) * model.n / threads)  # fmt: skip
    nbytes = limits.SIMULATE_BYTES_BASE + args.walks * limits.BATCH_BYTES_PER_CELL
    sweep = f" at {points} values" if points > 1 else ""
    limits.check(f"{args.walks} walks x up to {args.max_steps} steps{sweep}",
                 limits.Cost(seconds, nbytes), "use fewer --walks or --max-steps")  # fmt: skip


def _check_chain_cost(model: Any, args: argparse.Namespace, points: int = 1) -> None:
    """Refuse a chain beyond the limits before it starts (every mesh up to --max-nodes)."""
    steps = points * chain_steps(len(model.spec["search"]), args.noise_nodes, args.max_nodes)
    seconds = (steps * limits.BATCH_SECONDS_PER_PHASE * len(model.phases) * model.n
               / default_threads())  # fmt: skip
    nbytes = limits.SIMULATE_BYTES_BASE + 64 * args.max_nodes * args.noise_nodes
    what = f"a chain of up to {args.max_nodes} nodes x {args.noise_nodes} noise nodes"
    limits.check(what, limits.Cost(seconds, nbytes), "use fewer --max-nodes or --noise-nodes")


def _verdict(mc: dict, chain: dict) -> dict:
    """Whether the chain's MFPT from the gait lies in the walks' 95 % interval, and why not."""
    value, low, high = chain["mfpt_gait"], mc["low"], mc["high"]
    inside = low <= value and (high is None or value <= high)
    if inside:
        text = "the chain's MFPT lies inside the Monte Carlo 95 % interval"
    else:
        side = "below" if value < low else "above"
        why = ("the chain is too coarse: its mesh did not settle within --max-nodes"
               if not chain["converged"] else
               "the settled chain and the walks disagree: the mesh's refinement error is not "
               "the whole of the chain's error")  # fmt: skip
        text = f"the chain's MFPT lies {side} the Monte Carlo 95 % interval: {why}"
    return {"inside": bool(inside), "verdict": text}


def _checked(model: Any, args: argparse.Namespace) -> tuple[Any, Any, str | None]:
    """Every refusal before the work: the start state, the sweep (name, values) or None,
    the Dask scheduler or None."""
    disturbance_index(model, args.terrain)
    check_inputs(args.sigma, args.walks, args.max_steps, args.seed)
    check_chain_inputs(args.noise_nodes, args.max_nodes)
    walks, chain = args.method != "chain", args.method != "monte-carlo"
    if chain and (args.terrain != "slope" or args.distribution != "gaussian"):
        raise VswInputError("--method chain meshes the slope terrain with Gaussian draws (its "
                            "Gauss-Hermite quadrature): use --method monte-carlo")  # fmt: skip
    if chain and args.state:
        raise VswInputError("--state: the chain meshes the section around the stable gait; "
                            "use --method monte-carlo to walk from a given state")  # fmt: skip
    over = parse_over(args.over) if args.over is not None else None
    sigmas = over[1] if over is not None and over[0] == "sigma" else [args.sigma]
    for sigma in sigmas:
        check_inputs(float(sigma), args.walks, args.max_steps, args.seed)
        if chain and sigma <= 0:
            raise VswInputError(f"sigma {sigma:g}: the chain needs sigma > 0")
    if over is not None and args.state:
        raise VswInputError("--over walks from each value's stable gait: not with --state")
    scheduler = args.scheduler or os.environ.get("VSW_DASK_SCHEDULER", "").strip() or None
    if scheduler and not walks:
        raise VswInputError("--scheduler runs the walks: not with --method chain")
    start = options.parse_state(model, args.state) if args.state else None
    if args.plot is not None:
        if not walks and over is None:
            raise VswInputError("--plot draws the walks' survival: not with --method chain")
        check_save_path(args.plot)
    return start, over, scheduler


def run(args: argparse.Namespace) -> int:
    model, params = options.model_and_parameters(args)
    options.refuse_powered_only(model, "rough")
    start, over, scheduler = _checked(model, args)
    walks, chain = args.method != "chain", args.method != "monte-carlo"
    threads = check_scheduler(scheduler) if scheduler else None
    points = 1 if over is None else len(over[1])
    if walks:
        _check_cost(model, args, start is None, points, threads)
    if chain:
        _check_chain_cost(model, args, points)
    if over is not None:
        return _run_sweep(model, params, args, over, scheduler)
    # The bar before the solvers' stderr is set aside (options.solver_errors)
    with progress("rough") as bar, reporting(bar):
        data = _compute(model, params, args, start, walks, chain, scheduler)
    unit = _terrain_unit(model, args.terrain)
    if args.plot is not None:
        noise = (f"{args.terrain} drawn per step ({args.distribution}): $\\sigma$ = "
                 f"{args.sigma:g} {unit}")  # fmt: skip
        title = plotstyle.parameter_text(model, params) + "\n" + noise
        save_figure(survival_plot(data, title), args.plot)
        data["plot"] = args.plot
    if args.json:
        extra = {"sigma": unit, "seed": "1", "walks": "1", "failures": "1", "censored": "1",
                 "mfpt": "steps", "failures_by_kind": "1", "survival.steps": "steps",
                 "survival.fraction": "1", **gait_sensitivity_units(model, args.terrain),
                 "mfpt_qsd": "steps", "mfpt_gait": "steps", "byl_tedrake": "steps",
                 "lambda2": "1", "nodes": "1", "nodes_per_axis": "1", "escaped": "1",
                 "noise_nodes": "1", "refinements": "1", "quadrature_change": "1",
                 "gait_failure": "1", "steps_simulated": "steps"}  # fmt: skip
        dump_json(with_units(model, data, extra))
        return EXIT_OK
    _write_text(model, params, args, data)
    return EXIT_OK


def _terrain_unit(model: Any, terrain: str) -> str:
    """The unit of the terrain's drawn parameter and of sigma."""
    return "rad" if terrain == "slope" else model.units.get("length", "")


def _run_sweep(model: Any, params: Any, args: argparse.Namespace, over: tuple[str, Any],
               scheduler: str | None) -> int:  # fmt: skip
    """``--over``: the MFPT at each value, as text, JSON and a figure."""
    name, values = over
    chain = None
    if args.method != "monte-carlo":
        chain = {"noise_nodes": args.noise_nodes, "max_nodes": args.max_nodes}
    with progress("rough") as bar, reporting(bar), options.solver_errors(model):
        simulator(model).library()
        sweep = rough_sweep(model, params, args.sigma, name, values, walks=args.walks,
                            max_steps=args.max_steps, seed=args.seed, terrain=args.terrain,
                            distribution=args.distribution,
                            monte_carlo=args.method != "chain", chain=chain,
                            scheduler=scheduler)  # fmt: skip
    data = {**envelope(model, params, args.argv, INTEGRATOR), "model": model.cli_name,
            "method": args.method, "seed": args.seed, "walks": args.walks,
            "max_steps": args.max_steps, "sigma": args.sigma, **sweep.to_dict()}  # fmt: skip
    if scheduler:
        data["scheduler"] = scheduler
    unit = _terrain_unit(model, args.terrain)
    if args.plot is not None:
        swept = sweep.parameter if name == "gamma0" else "sigma"
        label = f"{swept} [{unit}]" if name == "gamma0" else f"$\\sigma$ [{unit}]"
        held = (f"$\\sigma$ = {args.sigma:g} {unit}" if name == "gamma0"
                else plotstyle.parameter_text(model, params))  # fmt: skip
        title = f"{model.cli_name}: {args.terrain} drawn per step ({args.distribution})\n{held}"
        save_figure(sweep_plot(data, label, title), args.plot)
        data["plot"] = args.plot
    if args.json:
        extra = {**sweep_units(model, args.terrain), "seed": "1", "walks": "1",
                 "max_steps": "steps"}  # fmt: skip
        dump_json(with_units(model, data, extra))
        return EXIT_OK
    _write_sweep(model, params, args, data, unit)
    return EXIT_OK


def _write_sweep(model: Any, params: Any, args: argparse.Namespace, data: dict, unit: str
                 ) -> None:  # fmt: skip
    """The sweep's text: one row a value, then the rank correlation."""
    out = sys.stdout
    write_parameters(out, model, params)
    swept = TERRAINS[args.terrain]
    out.write(f"{'terrain':<18} {args.terrain} ({TERRAINS[args.terrain]}), {args.distribution} "
              f"draws, seed {args.seed}, {args.walks} walks of up to {args.max_steps} "
              "steps at each value\n")  # fmt: skip
    what = f"gamma0 (the mean of {swept})" if data["over"] == "gamma0" else "sigma"
    out.write(f"{'over':<18} {what}, {len(data['values'])} values [{unit}]\n")
    out.write(f"  {swept:>12} {'sigma':>10} {'MFPT':>10} {'95 % interval':>24} "
              f"{'chain MFPT':>11} {'GSN':>10}\n")  # fmt: skip
    for p in data["points"]:
        m = p.get("mfpt") or {}
        if m.get("value") is not None:
            mfpt, interval = f"{m['value']:.4g}", f"[{m['low']:.4g}, {m['high']:.4g}]"
        elif m:
            mfpt, interval = f">= {m['low']:.4g}", "no walk fell"
        else:
            mfpt, interval = "-", "-" if "reason" not in p else "no stable gait"
        chain = f"{p['chain']['mfpt_gait']:.4g}" if p.get("chain") else "-"
        gsn = f"{p['gsn']:.5g}" if p.get("gsn") is not None else "-"
        out.write(f"  {fmt(p[swept]):>12} {fmt(p['sigma']):>10} {mfpt:>10} {interval:>24} "
                  f"{chain:>11} {gsn:>10}\n")  # fmt: skip
    for key, c in data["spearman_gsn_mfpt"].items():
        rho = "undefined (fewer than 3 values, or one constant)" if c["rho"] is None else (
            f"{c['rho']:.4f}")  # fmt: skip
        whose = "walks'" if key == "walks" else "chain's"
        out.write(f"{'spearman':<18} GSN against the {whose} MFPT: rho = {rho} over "
                  f"{c['points']} values\n")  # fmt: skip
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")


def _compute(model: Any, params: Any, args: argparse.Namespace, start: Any, walks: bool,
             chain: bool, scheduler: str | None = None) -> dict:  # fmt: skip
    """The walks, the chain or both, as the JSON's keys."""
    with options.solver_errors(model):
        simulator(model).library()
        gait = None if start is not None else model.stable_gait(params, "no gait to start from")
        data = {**envelope(model, params, args.argv, INTEGRATOR), "model": model.cli_name,
                "method": args.method}  # fmt: skip
        if walks:
            result = rough_walks(model, params, args.sigma, args.walks, args.max_steps,
                                 args.seed, start=start, gait=gait, terrain=args.terrain,
                                 distribution=args.distribution, scheduler=scheduler)  # fmt: skip
            data.update(result.to_dict())
            data["model"] = model.cli_name
        else:
            data.update({"terrain": args.terrain, "distribution": args.distribution,
                         "sigma": args.sigma, "gait": gait.to_dict()})  # fmt: skip
        if scheduler:
            data["scheduler"] = scheduler
        data["method"] = args.method
        if chain:
            found = rough_chain(model, params, args.sigma, gait=gait,
                                noise_nodes=args.noise_nodes, max_nodes=args.max_nodes)  # fmt: skip
            data["chain"] = found.to_dict()
            if walks and data["mfpt"]["value"] is not None:
                data["agreement"] = _verdict(data["mfpt"], data["chain"])
        gsn = None if gait is None else gait_sensitivity(model, params, gait, args.terrain)
        data["gait_sensitivity"] = None if gsn is None else gsn.to_dict()
    return data


def _write_text(model: Any, params: Any, args: argparse.Namespace, data: dict) -> None:
    out = sys.stdout
    write_parameters(out, model, params)
    name = TERRAINS[args.terrain]
    draw = "standard normal" if args.distribution == "gaussian" else "uniform, variance 1"
    unit = _terrain_unit(model, args.terrain)
    out.write(f"{'terrain':<18} {name}_k = {fmt(data['parameters'][name])} + "
              f"{fmt(args.sigma)} xi_k {unit}, xi_k {draw}\n")  # fmt: skip
    if "mfpt" in data:
        _write_walks(out, args, data)
    if "chain" in data:
        _write_chain(out, data["chain"])
    if "agreement" in data:
        out.write(f"{'agreement':<18} {data['agreement']['verdict']}\n")
    gsn = data["gait_sensitivity"]
    if gsn is not None and args.terrain == "slope":
        write_gait_sensitivity(out, model, gsn, width=18)
    elif gsn is not None:  # per unit of foothold height
        length = model.units.get("length", "")
        parts = ", ".join(f"{k.replace('_', ' ')} {fmt(v)} {model.units[k.split('_')[1]]}/"
                          f"{length}" for k, v in gsn["gsn_by_indicator"].items())  # fmt: skip
        out.write(f"{'gait sensitivity':<18} {fmt(gsn['gsn'])} ({parts}; the H2 norm of the "
                  "indicators' response to one step's foothold height)\n")  # fmt: skip
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")


def _write_chain(out: Any, c: dict) -> None:
    """The chain's lines of the text output."""
    shape = " x ".join(str(n) for n in c["nodes_per_axis"])
    settled = ("settled: both MFPTs within 1 % on two refinements in a row" if c["converged"]
               else "not settled within --max-nodes")  # fmt: skip
    out.write(
        f"{'chain mesh':<18} {c['nodes']} nodes ({shape} over "
        f"{', '.join(c['components'])}), {c['refinements']} refinements, {settled}\n"
    )
    for level in c["levels"]:
        out.write(f"  {level['nodes']:>8} nodes    lambda2 {fmt(level['lambda2'])}, MFPT "
                  f"{fmt(level['mfpt_gait'])} from the gait, {fmt(level['mfpt_qsd'])} "
                  "quasi-stationary\n")  # fmt: skip
    out.write(
        f"{'chain lambda2':<18} {fmt(c['lambda2'])} (Byl & Tedrake's MFPT "
        f"1/(1 - lambda2) = {fmt(c['byl_tedrake'])} steps, the failing one counted)\n"
    )
    out.write(f"{'chain MFPT':<18} {fmt(c['mfpt_gait'])} steps from the gait ((I - T) n = 1), "
              f"{fmt(c['mfpt_qsd'])} from the quasi-stationary distribution "
              "(lambda2/(1 - lambda2))\n")  # fmt: skip
    out.write(f"{'chain noise':<18} {c['quadrature']}, {c['noise_nodes']} nodes; twice the "
              f"nodes change the MFPT by {fmt(100 * c['quadrature_change'])} %; "
              f"mass leaving the mesh {fmt(c['escaped'])} per step\n")  # fmt: skip


def _write_walks(out: Any, args: argparse.Namespace, data: dict) -> None:
    """The walks' lines of the text output."""
    start = ", ".join(f"{k} = {fmt(v)}" for k, v in data["start"].items())
    origin = "given" if data["gait"] is None else "the stable gait"
    out.write(f"{'start':<18} {start} ({origin}), seed {args.seed}\n")
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
    if data["simulator"] != "compiled":
        out.write(f"note: the walks took the {data['simulator']} route\n")
