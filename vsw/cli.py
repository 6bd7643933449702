"""The ``vsw`` command line (also ``python -m vsw``).

Subcommands: ``analyze``, ``simulate``, ``basin``, plus any module that registers itself
(see :func:`build_parser`). Angles on the command line are in degrees; JSON output uses
radians and the dimensionless units of the analysis.

Exit status: 0 success, 2 bad input of any kind (one line on stderr, never a traceback),
3 a solver did not converge or a design request is infeasible.

Registering a subcommand from another module: define ``register_cli(subparsers)`` that
calls ``subparsers.add_parser(name, help=...)`` (the parser class turns argparse errors
into one-line exit-2 errors), adds its arguments and calls
``parser.set_defaults(func=handler)`` where ``handler(args) -> int`` returns the exit
status and raises :class:`vsw.errors.VswInputError` for bad input.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from typing import Any, NoReturn, TextIO

from vsw.errors import ConvergenceError, InfeasibleError, VswInputError

__all__ = ["ArgumentParser", "UsageError", "build_parser", "main"]

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_SOLVER = 3

_OPTIONAL_COMMAND_MODULES = ("design",)  # modules of vsw that may define register_cli


class UsageError(VswInputError):
    """An argparse usage error; ``prog`` is the (sub)command it belongs to."""

    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


class ArgumentParser(argparse.ArgumentParser):
    """argparse that reports usage errors as one-line :class:`UsageError` (exit 2)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(self.prog, f"{message} (see '{self.prog} --help')")


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _dump_json(data: Any, out: TextIO) -> None:
    # allow_nan=False: the contract is strict JSON; NaN must already be None.
    out.write(json.dumps(data, allow_nan=False, indent=2) + "\n")


def _fmt(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else f"{value:.6g}"
    return str(value)


def _progress(label: str):
    from vsw.progress import ProgressBar

    return ProgressBar(label)


def _check_plot_path(path: str | None) -> None:
    # Checked before any computation so a bad path fails fast with exit 2.
    if path is not None:
        from vsw.plots import check_save_path

        check_save_path(path)


def _gait_parameters(args: argparse.Namespace):
    from vsw.params import GaitParameters

    return GaitParameters.from_degrees(args.beta, args.theta_ii, args.phi0)


def _add_gait_arguments(parser: argparse.ArgumentParser, theta_ii: bool = True) -> None:
    parser.add_argument("--beta", type=float, required=True, help="length shorten ratio, 0..1")
    if theta_ii:
        parser.add_argument(
            "--theta-ii", type=float, required=True, help="leg extension angle theta_II [deg]"
        )
    parser.add_argument("--phi0", type=float, required=True, help="inter-leg angle [deg]")
    parser.add_argument("--json", action="store_true", help="print one JSON object")


# --- analyze -----------------------------------------------------------------------------


def _scale_from_args(args: argparse.Namespace):
    from vsw.params import STEPPER_2D, RobotScale

    if args.stepper_2d:
        if args.leg_length is not None or args.mass is not None:
            raise VswInputError(
                "--stepper-2d sets the leg length and mass; drop --leg-length/--mass"
            )
        return STEPPER_2D if args.gravity is None else RobotScale(0.25, 0.78, args.gravity)
    if args.leg_length is None and args.mass is None:
        if args.gravity is not None:
            raise VswInputError("--gravity needs --leg-length and --mass (or --stepper-2d)")
        return None
    if args.leg_length is None or args.mass is None:
        raise VswInputError("--leg-length and --mass go together (SI results need both)")
    gravity = 9.81 if args.gravity is None else args.gravity
    return RobotScale(args.leg_length, args.mass, gravity)


def _cmd_analyze(args: argparse.Namespace) -> int:
    from vsw.analysis import analyze

    params = _gait_parameters(args)
    scale = _scale_from_args(args)
    result = analyze(*params.astuple(), scale)
    data = result.to_dict()
    if args.json:
        _dump_json(data, sys.stdout)
        return EXIT_OK
    energy_unit = "J" if scale is not None else "m g r_e"
    rows = [
        ("beta", data["beta"], ""),
        ("theta_II", math.degrees(data["theta_II"]), "deg"),
        ("phi0", math.degrees(data["phi0"]), "deg"),
        ("walks", data["walks"], ""),
        ("q_fixed", data["q_fixed"], "g/r_e"),
        ("omega_I", data["omega_I"], "sqrt(g/r_e)"),
        ("eigenvalue", data["eigenvalue"], ""),
        ("theta_I", math.degrees(data["theta_I"]), "deg"),
        ("theta_IV", math.degrees(data["theta_IV"]), "deg"),
        ("step_length", data["step_length"], "r_e"),
        ("step_period", data["step_period"], "sqrt(r_e/g)"),
        ("speed", data["speed"], "sqrt(g r_e)"),
        ("energy_added", data["energy_added"], energy_unit),
        ("energy_lost", data["energy_lost"], energy_unit),
        ("contact_margin", data["contact_margin"], "m g"),
        ("q_apex_min", data["q_apex_min"], "g/r_e"),
        ("q_liftoff_max", data["q_liftoff_max"], "g/r_e"),
    ]
    if scale is not None:
        rows += [
            ("step_length_m", data["step_length_m"], "m"),
            ("step_period_s", data["step_period_s"], "s"),
            ("speed_m_s", data["speed_m_s"], "m/s"),
            ("speed_leg_s", data["speed_leg_s"], "leg/s"),
        ]
    out = sys.stdout
    for name, value, unit in rows:
        out.write(f"{name:<16} {_fmt(value):>14}  {unit}\n")
    out.write("\nconditions (margin > 0 holds; physical ones decide 'walks')\n")
    out.write(f"{'name':<36} {'eq.':<12} {'margin':>12} {'holds':>6}  {'status':<12} physical\n")
    for c in data["conditions"]:
        out.write(
            f"{c['name']:<36} {c['equation'] or '-':<12} {_fmt(c['value']):>12} "
            f"{_fmt(c['holds']):>6}  {c['status']:<12} {_fmt(c['physical'])}\n"
        )
    return EXIT_OK


# --- simulate ----------------------------------------------------------------------------


def _cmd_simulate(args: argparse.Namespace) -> int:
    from vsw.params import check_positive

    params = _gait_parameters(args)
    q0 = float(check_positive("q0", args.q0, "q = omega_I**2 just after heelstrike, eq. (8)"))
    if args.steps < 1:
        raise VswInputError(f"steps = {args.steps} must be >= 1")
    _check_plot_path(args.plot)
    from generated import ile
    from vsw.simulate import simulate

    with _progress("simulate") as bar:
        result = simulate(
            *params.astuple(), q0, args.steps, record=args.plot is not None, progress=bar
        )
    from vsw.analysis import _jsonable

    q_fixed = float(ile.q_fixed(*params.astuple()))
    data = {
        "beta": params.beta,
        "theta_II": params.theta_II,
        "phi0": params.phi0,
        "q0": q0,
        "steps": args.steps,
        "q": _jsonable(result.q),
        "ended": result.ended,
        "steps_completed": len(result.q) - 1,
        "step_periods": _jsonable(getattr(result, "step_periods", [])),
        "step_lengths": _jsonable(getattr(result, "step_lengths", [])),
        "q_fixed_closed_form": _jsonable(q_fixed),
    }
    if args.plot is not None:
        from vsw.plots import save_figure, simulation_plot

        save_figure(simulation_plot(*params.astuple(), q0, args.steps, result), args.plot)
        data["plot"] = args.plot
    if args.json:
        _dump_json(data, sys.stdout)
        return EXIT_OK
    out = sys.stdout
    out.write(f"ended: {result.ended} after {data['steps_completed']} of {args.steps} steps\n")
    out.write(f"q_fixed (closed form, eq. 10): {_fmt(q_fixed)}\n")
    out.write(f"{'step':>5} {'q':>14}\n")
    for n, q in enumerate(result.q):
        out.write(f"{n:>5} {_fmt(float(q)):>14}\n")
    return EXIT_OK


# --- basin -------------------------------------------------------------------------------


def _cmd_basin(args: argparse.Namespace) -> int:
    import numpy as np

    from vsw.basin import basin, check_edges_by_simulation
    from vsw.params import check_parameter

    check_parameter("beta", args.beta)
    phi0 = math.radians(args.phi0)
    check_parameter("phi0", phi0)
    if not args.theta_step > 0:
        raise VswInputError(f"theta-step = {args.theta_step} must be > 0 deg")
    if not args.theta_min <= args.theta_max:
        raise VswInputError("theta-min must not exceed theta-max")
    if args.n_q < 3:
        raise VswInputError(f"n-q = {args.n_q} must be >= 3")
    if args.check_edges < 0:
        raise VswInputError(f"check-edges = {args.check_edges} must be >= 0")
    _check_plot_path(args.plot)
    n_theta = math.floor((args.theta_max - args.theta_min) / args.theta_step + 1e-9) + 1
    if n_theta > 100_000:
        raise VswInputError(f"{n_theta} theta_II values: use a larger --theta-step (<= 100000)")
    theta_II = np.radians(args.theta_min + args.theta_step * np.arange(n_theta))
    result = basin(args.beta, phi0, theta_II, n_q=args.n_q)
    data = result.to_dict()
    data["theta_II_deg"] = [float(v) for v in np.degrees(result.theta_II)]
    failed = 0
    if args.check_edges:
        with _progress("edge checks") as bar:
            checks = check_edges_by_simulation(result, n_samples=args.check_edges, progress=bar)
        data["edge_checks"] = [
            {
                "theta_II": c.theta_II,
                "edge": c.edge,
                "side": c.side,
                "q0": c.q0,
                "expected": c.expected,
                "ended": c.ended,
                "ok": c.ok,
            }
            for c in checks
        ]
        failed = sum(not c.ok for c in checks)
    if args.plot is not None:
        from vsw.plots import basin_plot, save_figure

        save_figure(basin_plot(result, checks=checks if args.check_edges else None), args.plot)
        data["plot"] = args.plot
    if args.json:
        _dump_json(data, sys.stdout)
    else:
        out = sys.stdout
        out.write(f"basin of attraction, beta={args.beta:g}, phi0={args.phi0:g} deg\n")
        out.write(f"{'theta_II[deg]':>13} {'q_min':>12} {'q_max':>12} {'q_fixed':>12}\n")
        for th, lo, hi, qf in zip(
            data["theta_II_deg"], data["q_min"], data["q_max"], data["q_fixed"]
        ):
            out.write(f"{th:>13.4g} {_fmt(lo):>12} {_fmt(hi):>12} {_fmt(qf):>12}\n")
        if args.check_edges:
            out.write(f"edge checks by simulation: {len(checks) - failed} of {len(checks)} ok\n")
    return EXIT_OK


# --- parser and entry point --------------------------------------------------------------


def build_parser() -> ArgumentParser:
    """The ``vsw`` parser with built-in and registered subcommands."""
    parser = ArgumentParser(
        prog="vsw",
        description="Virtual Slope Walking (instantaneous leg extension model): analysis, "
        "simulation and basin of attraction. Angles in degrees on the command line.",
    )
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = subparsers.add_parser("analyze", help="fixed point, conditions and gait metrics")
    _add_gait_arguments(p)
    scale = p.add_argument_group("SI results")
    scale.add_argument("--leg-length", type=float, help="extended leg length r_e [m]")
    scale.add_argument("--mass", type=float, help="mass [kg]")
    scale.add_argument("--gravity", type=float, help="g [m/s^2] (default 9.81)")
    scale.add_argument(
        "--stepper-2d", action="store_true", help="Stepper-2D preset: r_e 0.25 m, m 0.78 kg"
    )
    p.set_defaults(func=_cmd_analyze)

    p = subparsers.add_parser("simulate", help="time-domain simulation of the hybrid system")
    _add_gait_arguments(p)
    p.add_argument("--q0", type=float, required=True, help="q = omega_I^2 at the first step")
    p.add_argument("--steps", type=int, required=True, help="number of steps")
    p.add_argument("--plot", metavar="FILE", help="save theta, omega and q plots (.png/.svg/.pdf)")
    p.set_defaults(func=_cmd_simulate)

    p = subparsers.add_parser("basin", help="basin of attraction over theta_II (Fig. 9)")
    _add_gait_arguments(p, theta_ii=False)
    p.add_argument("--theta-min", type=float, default=-30.0, help="first theta_II [deg]")
    p.add_argument("--theta-max", type=float, default=40.0, help="last theta_II [deg]")
    p.add_argument("--theta-step", type=float, default=0.5, help="theta_II step [deg]")
    p.add_argument("--n-q", type=int, default=2001, help="initial q grid points")
    p.add_argument(
        "--check-edges",
        type=int,
        default=0,
        metavar="N",
        help="check N sampled theta_II edges by simulation",
    )
    p.add_argument("--plot", metavar="FILE", help="save the basin figure (.png/.svg/.pdf)")
    p.set_defaults(func=_cmd_basin)

    _register_optional_commands(subparsers)
    return parser


def _register_optional_commands(subparsers: Any) -> None:
    """Let optional modules (vsw.design) add their subcommands via ``register_cli``."""
    import importlib

    for name in _OPTIONAL_COMMAND_MODULES:
        try:
            module = importlib.import_module(f"vsw.{name}")
        except ImportError:
            continue
        register = getattr(module, "register_cli", None)
        if register is not None:
            register(subparsers)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (the console script exits with it).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        0 success, 2 bad input, 3 solver failure or infeasible request.
    """
    try:
        parser = build_parser()
        args = parser.parse_args(None if argv is None else list(argv))
        return int(args.func(args))
    except VswInputError as exc:
        prog = exc.prog if isinstance(exc, UsageError) else "vsw"
        sys.stderr.write(f"{prog}: error: {_one_line(exc)}\n")
        return EXIT_INPUT
    except (ConvergenceError, InfeasibleError) as exc:
        sys.stderr.write(f"vsw: {type(exc).__name__}: {_one_line(exc)}\n")
        return EXIT_SOLVER
    except SystemExit as exc:  # --help and --version exit through argparse
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    except KeyboardInterrupt:
        sys.stderr.write("vsw: interrupted\n")
        return 130
