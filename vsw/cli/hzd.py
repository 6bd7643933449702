"""``vsw hzd``: walking by hybrid zero dynamics: a model with one degree of underactuation
under virtual constraints (a constraints file), its restricted Poincaré map and the
full-order closed loop of the computed-torque controller."""

from __future__ import annotations

import argparse
import sys
from typing import Any, TextIO

from vsw.cli import options
from vsw.cli.output import INTEGRATOR, ORBIT_SOLVER, dump_json, envelope, fmt, with_units
from vsw.cli.parser import EXIT_OK
from vsw.plots.figures import check_save_path
from vsw.runtime.errors import VswInputError

__all__ = ["register", "run"]


def _gains(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        kp, kd = (float(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--gains takes KP,KD (two numbers), not {text!r}"
                                         ) from None  # fmt: skip
    if not (0 < kp <= 1e5 and 0 < kd <= 1e3):
        raise argparse.ArgumentTypeError(
            f"--gains {text}: 0 < KP <= 1e5 and 0 < KD <= 1e3 (a stiffer loop is not integrated)"
        )
    return kp, kd


def register(subparsers: Any) -> None:
    help_ = ("walking by hybrid zero dynamics: virtual constraints, the restricted Poincaré "
             "map and the full-order closed loop")  # fmt: skip
    p = subparsers.add_parser("hzd", help=help_, description=help_ + ".")
    options.add_model_options(p, "hzd", named=False)
    p.add_argument("--constraints", required=True, metavar="FILE.py",
                   help="the virtual constraints (a file in derive.hzd's language; derived "
                   "on first use, then cached)")  # fmt: skip
    p.add_argument(
        "--gains",
        type=_gains,
        default=(400.0, 40.0),
        metavar="KP,KD",
        help="the computed-torque controller's gains, 1/s^2 and 1/s",
    )
    p.add_argument("--plot", metavar="FILE", help="the phase portrait, the outputs and the "
                   "torques over a step (.png, .svg or .pdf)")  # fmt: skip
    _register_optimize(p)
    p.set_defaults(func=run)


def _register_optimize(p: argparse.ArgumentParser) -> None:
    """The options of ``--optimize`` (:mod:`vsw.synthesis.hzd.optimize`)."""
    g = p.add_argument_group("gait optimisation (--optimize)")
    g.add_argument("--optimize", action="store_true", help="choose the Bezier coefficients "
                   "(alpha_2 .. alpha_M; alpha_0, alpha_1 by the impact map) that minimise "
                   "--minimize at --speed, verified on the full-order closed loop")  # fmt: skip
    g.add_argument("--speed", type=float, metavar="V", help="the gait's speed (required)")
    g.add_argument("--step-length", type=float, metavar="L", help="the step length (the "
                   "constraints' theta_plus and theta_minus may fix it already)")  # fmt: skip
    g.add_argument("--minimize", default="torque2", metavar="NAME",
                   help="torque2 (the integral of the squared inputs over the step) or work "
                   "(the inputs' positive work per step)")  # fmt: skip
    g.add_argument("--mu", type=float, metavar="MU", help="the friction coefficient: the "
                   "stance foot's |tangential| <= MU normal (default: unbounded)")  # fmt: skip
    g.add_argument("--max-torque", type=float, metavar="T", help="|u| <= T for every input")
    g.add_argument("--clearance", type=float, default=0.0, metavar="H",
                   help="the swing foot at least H sin(pi s) above the ground away from "
                   "mid-stance (default 0: above it)")  # fmt: skip
    g.add_argument(
        "--nodes",
        type=int,
        default=32,
        metavar="N",
        help="Chebyshev points of the phase the NLP evaluates the zero dynamics at",
    )
    g.add_argument("--out", metavar="FILE.py", help="write the optimum as a constraints file")


def tolerances() -> dict[str, Any]:
    from vsw.synthesis.hzd.zero import NODES

    return {
        "quadrature": f"Fejér's first rule on {NODES} Chebyshev points (error estimated against "
        f"{NODES // 2})",
        **INTEGRATOR,
        **ORBIT_SOLVER,
    }


def run(args: argparse.Namespace) -> int:
    from vsw.synthesis import hzd

    model, params = options.model_and_parameters(args)
    if args.optimize:
        from vsw.cli.hzd_optimize import run_optimize

        return run_optimize(args, model, params)
    given = [
        f"--{k.replace('_', '-')}"
        for k in ("speed", "step_length", "mu", "max_torque", "out")
        if getattr(args, k) is not None
    ]
    if given:
        raise VswInputError(f"{given[0]} is an option of vsw hzd --optimize")
    if args.plot is not None:
        check_save_path(args.plot)
    with options.solver_errors(model):
        report = hzd.analyze(model, args.model, args.constraints, args.values, args.gains)
    surface = report.samples["surface"]
    phase = surface.package.HZD["phase"]
    if args.plot is not None:
        from vsw.synthesis.hzd.plot import save_hzd_plot

        save_hzd_plot(report, surface, phase, model.units["time"], args.plot)
    data = {**envelope(model, params, args.argv, tolerances()), "constraints": args.constraints,
            "phase": phase, **report.to_dict()}  # fmt: skip
    if args.plot is not None:
        data["plot"] = args.plot
    if args.json:
        dump_json(with_units(model, data, _units(report, model, surface)))
        return EXIT_OK
    _write(sys.stdout, data, _units(report, model, surface))
    return EXIT_OK


def _units(report: Any, model: Any, surface: Any) -> dict[str, str]:
    """Every key's unit for :func:`vsw.cli.output.with_units`, flattened."""
    out: dict[str, str] = {}

    def visit(tree: dict, parent: str) -> None:
        for key, unit in tree.items():
            if isinstance(unit, dict):
                visit(unit, key)
            elif unit is not None:
                out[f"{parent}.{key}" if parent else key] = unit

    visit(report.units(model, "rad"), "")
    for name in report.output_names:
        out[f"mismatch_per_rate.{name}"] = "1"
    phase = model.phases[model.phase_index[model.step_event["target"]]]
    for record in phase["inputs"]:
        out[f"peak_torques.{record['name']}"] = record["unit"]
    return out


def _write(out: TextIO, data: dict, units: dict) -> None:
    def line(name: str, value: Any, unit: str | None) -> None:
        shown = "" if unit in (None, "1") else f"  {unit}"
        out.write(f"{name:<24} {fmt(value):>14}{shown}\n")

    out.write(f"model              {data['model']}; constraints {data['constraints']}\n")
    out.write(f"phase              {data['phase']}\n")
    for key in ("delta", "delta_squared", "V", "zeta_star", "theta_dot_minus",
                "theta_dot_plus", "period", "step_length", "speed", "work_per_step",
                "impact_loss", "surface_jump"):  # fmt: skip
        line(key, data[key], units[key])
    for name, value in data["impact_invariance"]["mismatch_per_rate"].items():
        line(f"mismatch {name}", value, "per unit theta_dot")
    for name, value in data["peak_torques"].items():
        line(f"peak {name}", value, units.get(f"peak_torques.{name}"))
    full = data["full_order"]
    if full is None:
        out.write(f"full order: {data['full_order_error']}\n")
        return
    line("full theta_dot_minus", full["theta_dot_minus"], units["theta_dot_minus"])
    line("full period", full["period"], units["period"])
    line("full max |eigenvalue|", full["max_abs_eigenvalue"], "1")
    out.write(
        f"full-order gait          {'stable' if full['max_abs_eigenvalue'] < 1 else 'unstable'}\n"
    )
