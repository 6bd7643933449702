"""The ``vsw`` command line (also ``python -m vsw``).

Subcommands: ``models``, ``analyze``, ``simulate``, ``basin``, ``sweep``, plus any module
that registers itself (``design``; see :func:`build_parser`). The ILE's named options take
angles in degrees; JSON output uses radians and the dimensionless units of the analysis,
with SI values (given a robot scale) under keys of their own (``speed_m_s``,
``energy_added_J``, ...). ``--model NAME`` selects another model and ``--param NAME=VALUE``
sets its parameters in the units of ``vsw models`` (angles in radians); see
:mod:`vsw.models_cli`.

Exit status (:data:`EXIT_STATUS`, also in ``vsw --help``):

* 0 success;
* 2 bad input of any kind, one line on stderr and never a traceback: invalid arguments
  or ``VSW_*`` settings, work beyond the limits of :mod:`vsw.limits`, a plot file or
  standard output that cannot be written;
* 3 a solver did not converge or a design request is infeasible;
* 141 (128 + SIGPIPE) standard output was closed by its reader, as in
  ``vsw basin ... | head``: nothing more is printed, no error message, the status a
  shell reports for a program ended by SIGPIPE (what ``set -o pipefail`` sees from
  ``yes | head`` too);
* 130 interrupted (Ctrl-C).

Standard output failures are handled once, in :func:`main`, for every subcommand: while
a command runs, ``sys.stdout`` is a thin wrapper that remembers the first write error,
and :func:`main` flushes it before returning, so a closed pipe or a full disk is seen
here and not in the interpreter's final flush; afterwards the file descriptor is pointed
at ``os.devnull`` so that flush at exit stays quiet (the recipe of Python's ``signal``
documentation, "Note on SIGPIPE").

Registering a subcommand from another module: define ``register_cli(subparsers)`` that
calls ``subparsers.add_parser(name, help=...)`` (the parser class turns argparse errors
into one-line exit-2 errors and shows defaults in ``--help``), adds its arguments and
calls ``parser.set_defaults(func=handler)`` where ``handler(args) -> int`` returns the
exit status, writes its output to ``sys.stdout`` and raises
:class:`vsw.errors.VswInputError` for bad input.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from collections.abc import Sequence
from typing import Any, NoReturn, TextIO

from vsw.errors import ConvergenceError, InfeasibleError, VswInputError

__all__ = ["EXIT_STATUS", "ArgumentParser", "UsageError", "build_parser", "main"]

EXIT_OK = 0
EXIT_INPUT = 2
EXIT_SOLVER = 3
EXIT_INTERRUPTED = 130
EXIT_CLOSED_PIPE = 141  # 128 + SIGPIPE (13): what a shell reports for a broken pipe

EXIT_STATUS = {
    EXIT_OK: "success",
    EXIT_INPUT: "bad input (one line on stderr): arguments, VSW_* settings, work beyond "
    "the time or memory limit, a plot file or standard output that cannot be written",
    EXIT_SOLVER: "a solver did not converge, or a design request is infeasible",
    EXIT_INTERRUPTED: "interrupted (Ctrl-C)",
    EXIT_CLOSED_PIPE: "standard output closed by its reader (e.g. '| head'): quiet, "
    "as a program ended by SIGPIPE",
}
"""Every exit status of ``vsw`` and its meaning."""

_ENVIRONMENT = (
    ("VSW_THREADS", "worker threads for large evaluations, 1-256 (default: the usable cores)"),
    ("VSW_MAX_SECONDS", "refuse work estimated to take longer, in s (default 3600; inf: none)"),
    (
        "VSW_MAX_MEMORY",
        "refuse work estimated to need more memory, e.g. 8G (default: 80% of the "
        "available memory; inf: none)",
    ),
    ("VSW_KERNELS", "0: use the generated numpy code instead of the compiled C kernels"),
    ("VSW_CACHE_DIR", "where compiled kernels are cached (default ~/.cache/vsw)"),
)

_OPTIONAL_COMMAND_MODULES = ("design",)  # modules of vsw that may define register_cli


class UsageError(VswInputError):
    """An argparse usage error; ``prog`` is the (sub)command it belongs to."""

    def __init__(self, prog: str, message: str) -> None:
        super().__init__(message)
        self.prog = prog


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows ``(default: X)`` after an option's help where there is a default to show.

    Options without a default (None) and flags (False) are left as they are, so help
    never reads ``(default: None)``.
    """

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default is None or isinstance(action.default, bool) or action.required:
            return action.help
        return super()._get_help_string(action)


class _TopHelpFormatter(argparse.RawDescriptionHelpFormatter, HelpFormatter):
    """The ``vsw`` parser's formatter: its epilog (exit statuses, environment) is a table."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse that reports usage errors as one-line :class:`UsageError` (exit 2).

    Every parser made from it, including subcommand parsers that other modules create
    through ``subparsers.add_parser`` (argparse makes them of the parent's class), shows
    defaults in its help (:class:`HelpFormatter`) unless given another formatter.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        raise UsageError(self.prog, f"{message} (see '{self.prog} --help')")

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:
        # A subcommand may set ``after_parse(parser, namespace)``: checks that need several
        # options (the model and its parameters), made where argparse makes its own, so
        # that their errors come in the same order (before an unrecognized argument).
        namespace, extras = super().parse_known_args(args, namespace)
        check = getattr(self, "after_parse", None)
        if check is not None:
            check(self, namespace)
        return namespace, extras

    def _get_values(self, action: argparse.Action, arg_strings: list[str]) -> Any:
        # Python 3.11's argparse drops a "--" value, so "--beta=--" gives beta = [] (not
        # a float, past the type check): refuse it as the missing value it has become.
        value = super()._get_values(action, arg_strings)
        if action.nargs is None and action.option_strings and value == []:
            self.error(f"argument {'/'.join(action.option_strings)}: expected one argument")
        return value


def _version() -> str:
    """The installed distribution's version, else the package's own ``__version__``."""
    try:
        from importlib.metadata import PackageNotFoundError, version

        return version("vsw")
    except (ImportError, PackageNotFoundError):
        from vsw import __version__

        return __version__


class _VersionAction(argparse.Action):
    """``--version``: looks the version up only when asked (importlib.metadata is slow)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS, **kw):
        kw.setdefault("help", "show the version and exit")
        super().__init__(option_strings, dest=dest, default=argparse.SUPPRESS, nargs=0, **kw)

    def __call__(self, parser, namespace, values, option_string=None) -> NoReturn:
        sys.stdout.write(f"vsw {_version()}\n")
        parser.exit()


class _GuardedStdout:
    """``sys.stdout`` while a command runs: remembers the first OSError of a write.

    Some writers swallow errors (argparse's help does); remembering the first one lets
    :func:`main` tell a failing standard output from any other OSError (a plot file) and
    handle it in one place for every subcommand.
    """

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.error: OSError | None = None

    def _call(self, method: str, *args: Any) -> Any:
        try:
            return getattr(self.stream, method)(*args)
        except OSError as exc:
            if self.error is None:
                self.error = exc
            raise

    def write(self, text: str) -> int:
        return self._call("write", text)

    def writelines(self, lines: Any) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        self._call("flush")

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


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


def _degrees(radians: float | None) -> float | None:
    return None if radians is None else math.degrees(radians)


def _progress(label: str):
    from vsw.progress import ProgressBar

    return ProgressBar(label)


def _check_plot_path(path: str | None) -> None:
    # Checked before any computation so a bad path fails fast with exit 2.
    if path is not None:
        from vsw.figures import check_save_path

        check_save_path(path)


def _gait_parameters(args: argparse.Namespace):
    from vsw.models.ile.params import GaitParameters

    if not args.params:
        return GaitParameters.from_degrees(args.beta, args.theta_ii, args.phi0)
    from vsw.models_cli import ile_values

    values = ile_values(args, ("beta", "theta_II", "phi0"))
    return GaitParameters(values["beta"], values["theta_II"], values["phi0"])


def _add_state_argument(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--state",
        action="append",
        metavar="NAME=VALUE",
        help="other models: the start just after the step event, every coordinate and rate "
        "(default: the first period-one gait); repeatable",
    )


def _add_gait_arguments(
    parser: argparse.ArgumentParser, command: str, theta_ii: bool = True
) -> None:
    """The ILE's named parameters (each required for the ILE unless given by --param, a
    check of :func:`vsw.models_cli.after_parse`), ``--model``, ``--param`` and ``--json``."""
    from vsw.models_cli import add_model_options

    parser.add_argument("--beta", type=float, help="length shorten ratio, 0..1")
    if theta_ii:
        parser.add_argument("--theta-ii", type=float, help="leg extension angle theta_II [deg]")
    parser.add_argument("--phi0", type=float, help="inter-leg angle [deg]")
    add_model_options(parser, command)
    parser.add_argument("--json", action="store_true", help="print one JSON object")


# --- analyze -----------------------------------------------------------------------------


def _scale_from_args(args: argparse.Namespace):
    from vsw.models.ile.params import STEPPER_2D, RobotScale

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
    from vsw.models.ile.analysis import analyze
    from vsw.models_cli import ILE, cmd_analyze

    if args.model != ILE:
        return cmd_analyze(args)
    params = _gait_parameters(args)
    scale = _scale_from_args(args)
    result = analyze(*params.astuple(), scale)
    data = result.to_dict()
    if args.json:
        _dump_json(data, sys.stdout)
        return EXIT_OK
    rows = [
        ("beta", data["beta"], ""),
        ("theta_II", math.degrees(data["theta_II"]), "deg"),
        ("phi0", math.degrees(data["phi0"]), "deg"),
        ("walks", data["walks"], ""),
        ("q_fixed", data["q_fixed"], "g/r_e"),
        ("omega_I", data["omega_I"], "sqrt(g/r_e)"),
        ("eigenvalue", data["eigenvalue"], ""),
        ("theta_I", _degrees(data["theta_I"]), "deg"),
        ("theta_IV", _degrees(data["theta_IV"]), "deg"),
        ("step_length", data["step_length"], "r_e"),
        ("step_period", data["step_period"], "sqrt(r_e/g)"),
        ("speed", data["speed"], "sqrt(g r_e)"),
        ("energy_added", data["energy_added"], data["energy_unit"]),
        ("energy_lost", data["energy_lost"], data["energy_unit"]),
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
            ("energy_added_J", data["energy_added_J"], "J"),
            ("energy_lost_J", data["energy_lost_J"], "J"),
        ]
    out = sys.stdout
    for name, value, unit in rows:
        out.write(f"{name:<16} {_fmt(value):>14}  {unit}\n")
    out.write("\nconditions (margin > 0 holds; physical ones decide 'walks'; angles in deg)\n")
    out.write(
        f"{'name':<36} {'eq.':<12} {'margin':>12} {'unit':<6} {'holds':>5}  "
        f"{'status':<12} physical\n"
    )
    for c in data["conditions"]:
        # The command line speaks degrees: angle margins (rad in JSON) are shown in deg.
        value, unit = c["value"], c["unit"]
        if unit == "rad":
            value, unit = _degrees(value), "deg"
        out.write(
            f"{c['name']:<36} {c['equation'] or '-':<12} {_fmt(value):>12} {unit or '-':<6} "
            f"{_fmt(c['holds']):>5}  {c['status']:<12} {_fmt(c['physical'])}\n"
        )
    return EXIT_OK


# --- simulate ----------------------------------------------------------------------------


def _cmd_simulate(args: argparse.Namespace) -> int:
    from vsw.models.ile.params import check_positive
    from vsw.models_cli import ILE, cmd_simulate

    if args.model != ILE:
        return cmd_simulate(args)
    params = _gait_parameters(args)
    q0 = float(check_positive("q0", args.q0, "q = omega_I**2 just after heelstrike, eq. (8)"))
    if args.steps < 1:
        raise VswInputError(f"steps = {args.steps} must be >= 1")
    _check_plot_path(args.plot)
    from vsw import limits
    from vsw.models.ile.simulate import simulate, simulate_cost

    record = args.plot is not None
    limits.check(
        f"simulating {args.steps} steps", simulate_cost(args.steps, record), "use fewer --steps"
    )
    from generated import ile

    with _progress("simulate") as bar:
        result = simulate(
            *params.astuple(), q0, args.steps, record=record, progress=lambda i, n: bar(i + 1, n)
        )
    from vsw.models.ile.analysis import _jsonable

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
        from vsw.figures import save_figure
        from vsw.models.ile.plots import simulation_plot

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

MAX_THETA_VALUES = 100_000
"""Most theta_II values ``vsw basin`` accepts (each is a row of the grid)."""


def _theta_grid(args: argparse.Namespace):
    """The theta_II grid (rad) of ``vsw basin`` from --theta-min/--theta-max/--theta-step."""
    import numpy as np

    from vsw.models.ile.params import PARAMETER_BY_NAME

    for flag in ("theta_min", "theta_max", "theta_step"):
        value = getattr(args, flag)
        if not math.isfinite(value):
            raise VswInputError(f"--{flag.replace('_', '-')} = {value} must be finite")
    if not args.theta_step > 0:
        raise VswInputError(f"--theta-step = {args.theta_step:g} must be > 0 deg")
    if not args.theta_min <= args.theta_max:
        raise VswInputError(
            f"--theta-min = {args.theta_min:g} must not exceed --theta-max = {args.theta_max:g}"
        )
    p = PARAMETER_BY_NAME["theta_II"]
    low, high = math.degrees(p.lower), math.degrees(p.upper)
    if not (low < args.theta_min and args.theta_max < high):
        raise VswInputError(
            f"--theta-min/--theta-max = {args.theta_min:g}/{args.theta_max:g} deg must lie "
            f"within ({low:g}, {high:g}) deg: {p.reason}"
        )
    # A float count first: a tiny step would overflow an int conversion.
    count = (args.theta_max - args.theta_min) / args.theta_step
    if not count < MAX_THETA_VALUES:
        raise VswInputError(
            f"--theta-step {args.theta_step:g} gives more than {MAX_THETA_VALUES} theta_II "
            "values: use a larger --theta-step or a narrower range"
        )
    n_theta = math.floor(count + 1e-9) + 1
    return np.radians(args.theta_min + args.theta_step * np.arange(n_theta))


def _cmd_explore(args: argparse.Namespace) -> int:
    from vsw.models.ile.explore import write_page

    out = write_page(args.out, beta=args.beta, theta_II_deg=args.theta_ii, phi0_deg=args.phi0,
                     leg=args.leg_length)  # fmt: skip
    sys.stdout.write(f"{out}: open it in a browser (no server needed)\n")
    return EXIT_OK


def _cmd_basin(args: argparse.Namespace) -> int:
    import numpy as np

    from vsw import limits
    from vsw.models.ile.basin import basin, basin_cost, check_edges_by_simulation, edge_check_cost
    from vsw.models.ile.params import check_parameter
    from vsw.models_cli import ILE, cmd_basin, ile_values

    if args.model != ILE:
        return cmd_basin(args)
    values = ile_values(args, ("beta", "phi0"))
    beta = float(check_parameter("beta", values["beta"]))
    phi0 = float(check_parameter("phi0", values["phi0"]))
    theta_II = _theta_grid(args)
    if args.n_q < 3:
        raise VswInputError(f"--n-q = {args.n_q} must be >= 3")
    if args.check_edges < 0:
        raise VswInputError(f"--check-edges = {args.check_edges} must be >= 0")
    _check_plot_path(args.plot)
    # The whole run is estimated before any of it starts: the grid, then the edge checks.
    cost = basin_cost(beta, phi0, theta_II.size, args.n_q)
    if args.check_edges:
        samples = min(args.check_edges, theta_II.size)
        cost = cost + edge_check_cost(beta, phi0, samples)
    limits.check(
        f"a basin of {theta_II.size} theta_II x {args.n_q} q values"
        + (f" with {args.check_edges} edge checks" if args.check_edges else ""),
        cost,
        "use a larger --theta-step, a smaller --n-q"
        + (" or fewer --check-edges" if args.check_edges else ""),
    )
    with _progress("basin") as bar:
        result = basin(beta, phi0, theta_II, n_q=args.n_q, progress=bar)
    data = result.to_dict()
    data["theta_II_deg"] = [float(v) for v in np.degrees(result.theta_II)]
    data["fields"]["theta_II_deg"] = "deg: theta_II in degrees"
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
        data["fields"]["edge_checks"] = (
            "simulations just inside and outside sampled edges: expected and actual end"
        )
        failed = sum(not c.ok for c in checks)
    if args.plot is not None:
        from vsw.figures import save_figure
        from vsw.models.ile.plots import basin_plot

        save_figure(basin_plot(result, checks=checks if args.check_edges else None), args.plot)
        data["plot"] = args.plot
    if args.json:
        _dump_json(data, sys.stdout)
    else:
        out = sys.stdout
        phi0_deg = math.degrees(phi0) if args.phi0 is None else args.phi0
        out.write(f"basin of attraction, beta={beta:g}, phi0={phi0_deg:g} deg\n")
        out.write(
            f"q_min < q0 <= q_max (q = omega_I^2 in g/r_e); each q0 walked {result.n_steps} "
            "stride-map steps, until eigenvalue^n (1.5/beta) < 1e-12\n"
        )
        out.write(f"{'theta_II[deg]':>13} {'q_min':>12} {'q_max':>12} {'q_fixed':>12}\n")
        for th, lo, hi, qf in zip(
            data["theta_II_deg"], data["q_min"], data["q_max"], data["q_fixed"]
        ):
            out.write(f"{th:>13.4g} {_fmt(lo):>12} {_fmt(hi):>12} {_fmt(qf):>12}\n")
        if args.check_edges:
            out.write(f"edge checks by simulation: {len(checks) - failed} of {len(checks)} ok\n")
    return EXIT_OK


# --- parser and entry point --------------------------------------------------------------


def _epilog() -> str:
    import textwrap

    def table(rows) -> list[str]:
        width = max(len(str(key)) for key, _ in rows)
        wrap = textwrap.TextWrapper(79, subsequent_indent=" " * (width + 4))
        return [wrap.fill(f"  {key!s:<{width}}  {text}") for key, text in rows]

    lines = ["exit status:", *table(EXIT_STATUS.items()), "", "environment:"]
    lines += [*table(_ENVIRONMENT), ""]
    lines.append("Angles in degrees on the command line; JSON in radians (see README.md).")
    return "\n".join(lines)


def build_parser() -> ArgumentParser:
    """The ``vsw`` parser with built-in and registered subcommands."""
    from vsw import models_cli
    from vsw.limits import SIMULATE_SECONDS_PER_STEP
    from vsw.models_cli import StoreGiven

    parser = ArgumentParser(
        prog="vsw",
        description="Virtual Slope Walking (instantaneous leg extension model):\n"
        "analysis, simulation, basin of attraction and gait design;\n"
        "other walking models with --model NAME (see 'vsw models').",
        epilog=_epilog(),
        formatter_class=_TopHelpFormatter,
    )
    parser.add_argument("--version", action=_VersionAction)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    help_ = "the models, their units and parameters"
    p = subparsers.add_parser("models", help=help_, description=help_ + ".")
    p.add_argument("--json", action="store_true", help="print one JSON list")
    p.set_defaults(func=models_cli.cmd_models)

    help_ = "fixed point, conditions and gait metrics (other models: period-one gaits)"
    p = subparsers.add_parser("analyze", help=help_, description=help_ + ".")
    _add_gait_arguments(p, "analyze")
    scale = p.add_argument_group(
        "SI results of the ile model (added under keys of their own: speed_m_s, ...)"
    )
    scale.add_argument("--leg-length", type=float, help="extended leg length r_e [m]")
    scale.add_argument("--mass", type=float, help="mass [kg]")
    scale.add_argument("--gravity", type=float, help="g [m/s^2] (default 9.81)")
    scale.add_argument(
        "--stepper-2d", action="store_true", help="Stepper-2D preset: r_e 0.25 m, m 0.78 kg"
    )
    p.set_defaults(func=_cmd_analyze)

    help_ = "time-domain simulation of the hybrid system"
    p = subparsers.add_parser("simulate", help=help_, description=help_ + ".")
    _add_gait_arguments(p, "simulate")
    p.add_argument("--q0", type=float, help="ile: q = omega_I^2 at the first step")
    p.add_argument(
        "--steps",
        type=int,
        help=f"number of steps (ile: about {SIMULATE_SECONDS_PER_STEP * 1e3:g} ms each; "
        "limited by VSW_MAX_SECONDS and VSW_MAX_MEMORY)",
    )
    p.add_argument(
        "--plot", metavar="FILE", help="ile: save theta, omega and q plots (.png/.svg/.pdf)"
    )
    _add_state_argument(p)
    p.set_defaults(func=_cmd_simulate)

    help_ = "the walk as a moving stick figure (GIF, SVG or MP4)"
    p = subparsers.add_parser("animate", help=help_, description=help_ + ".")
    _add_gait_arguments(p, "animate")
    p.add_argument("--q0", type=float, help="ile: q = omega_I^2 at the first step")
    _add_state_argument(p)
    p.add_argument("--steps", type=int, default=3, help="steps to walk (default: 3)")
    p.add_argument(
        "--out", required=True, metavar="FILE", help="gait.gif (Pillow), gait.svg or gait.mp4"
    )
    p.add_argument("--fps", type=float, default=30.0, help="frames per second (default: 30)")
    p.add_argument(
        "--speed",
        type=float,
        default=1.0,
        help="model time units per second of playback (default: 1)",
    )
    p.add_argument(
        "--leg-length",
        type=float,
        metavar="L",
        help="real time for a robot with legs of L m (models in units of sqrt(l/g))",
    )
    p.set_defaults(func=models_cli.cmd_animate)

    help_ = "write the ILE explorer: one self-contained HTML page (sliders, conditions, map)"
    p = subparsers.add_parser("explore", help=help_, description=help_ + ".")
    p.add_argument("--out", required=True, metavar="FILE", help="the page, e.g. explore.html")
    p.add_argument("--beta", type=float, default=0.8, help="start value of beta (default 0.8)")
    p.add_argument("--theta-ii", type=float, default=0.0, help="start theta_II [deg] (default 0)")
    p.add_argument("--phi0", type=float, default=45.0, help="start phi0 [deg] (default 45)")
    p.add_argument("--leg-length", type=float, default=0.25, help="start r_e [m] (default 0.25)")
    p.set_defaults(func=_cmd_explore)

    help_ = "basin of attraction over theta_II (Fig. 9); other models: over a 2-D --grid slice"
    p = subparsers.add_parser("basin", help=help_, description=help_ + ".")
    _add_gait_arguments(p, "basin", theta_ii=False)
    ile = p.add_argument_group("the ile model")
    ile.add_argument(
        "--theta-min", type=float, default=-30.0, action=StoreGiven, help="first theta_II [deg]"
    )
    ile.add_argument(
        "--theta-max", type=float, default=40.0, action=StoreGiven, help="last theta_II [deg]"
    )
    ile.add_argument(
        "--theta-step", type=float, default=0.5, action=StoreGiven, help="theta_II step [deg]"
    )
    ile.add_argument(
        "--n-q",
        type=int,
        default=2001,
        action=StoreGiven,
        help="initial q grid points in (0, 1.5/beta] (grid size limited by VSW_MAX_MEMORY "
        "and VSW_MAX_SECONDS)",
    )
    ile.add_argument(
        "--check-edges",
        type=int,
        default=0,
        action=StoreGiven,
        metavar="N",
        help="check N sampled theta_II edges by simulation",
    )
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="save the basin figure (.png/.svg/.pdf); other models: with --grid",
    )
    grid = p.add_argument_group(
        "other models: a 2-D slice of the section, by the compiled batch simulator"
    )
    grid.add_argument(
        "--grid",
        action="append",
        metavar="NAME=START:STOP:N",
        help="a coordinate or rate just after the step event and its N grid values; give "
        "two (the other components: the gait's, or what the model's section makes them)",
    )
    grid.add_argument(
        "--steps",
        type=int,
        default=50,
        action=StoreGiven,
        help="most steps walked from a cell; it stops early once converged, periodic or "
        "fallen (default: 50)",
    )
    grid.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the cells on this Dask scheduler (default: VSW_DASK_SCHEDULER if set, "
        "else threads here); needs the extra vsw[dask]",
    )
    other = p.add_argument_group("other models (one coordinate)")
    other.add_argument(
        "--rate-min", type=float, help="first section rate (default: the model's rate range)"
    )
    other.add_argument(
        "--rate-max", type=float, help="last section rate (default: the model's rate range)"
    )
    other.add_argument(
        "--n-rates", type=int, default=30, action=StoreGiven, help="section rates in the grid"
    )
    other.add_argument(
        "--max-steps",
        type=int,
        default=100,
        action=StoreGiven,
        help="steps walked from each rate before it counts as 'other'",
    )
    other.add_argument(
        "--tol",
        type=float,
        default=1e-6,
        action=StoreGiven,
        help="converged: every state component within tol * max(1, |gait state|)",
    )
    p.set_defaults(func=_cmd_basin)

    help_ = "outputs along one parameter (other models: the gait by continuation)"
    p = subparsers.add_parser("sweep", help=help_, description=help_ + ".")
    p.add_argument(
        "--over",
        required=True,
        metavar="NAME=START:STOP:N",
        help="the parameter swept: N values from START to STOP in the units of 'vsw models' "
        "(angles in rad)",
    )
    _add_gait_arguments(p, "sweep")
    p.add_argument(
        "--plot",
        metavar="FILE",
        help="save the figure (.png/.svg/.pdf): other models, the bifurcation diagram of "
        "--y with the largest |eigenvalue|; ile, q^f, eigenvalue and speed",
    )
    p.add_argument(
        "--y",
        metavar="NAME",
        help="other models: the quantity the bifurcation diagram shows: step_length "
        "(default where the model has one), step_period or a state component; --y=-NAME "
        "shows minus it",
    )
    p.add_argument(
        "--keep",
        type=int,
        metavar="N",
        help="other models: where the period-one gait is unstable or not found, iterate the "
        "map and keep its last N steps (default 32 with --plot, else 0)",
    )
    p.add_argument(
        "--transient",
        type=int,
        default=100,
        action=StoreGiven,
        metavar="K",
        help="other models: steps walked before the N kept (default: 100)",
    )
    p.add_argument(
        "--brute-force",
        action="store_true",
        help="other models: the classic diagram from the compiled batch simulator: at every "
        "value the gait by Newton on the simulated map and the map iterated from it (--keep "
        "default 32)",
    )
    p.add_argument(
        "--state",
        action="append",
        metavar="NAME=VALUE",
        help="other models, with --brute-force: where the first value's Newton starts "
        "(default: its first stable gait); repeatable",
    )
    p.set_defaults(func=models_cli.cmd_sweep)

    _register_optional_commands(subparsers)
    return parser


def _register_optional_commands(subparsers: Any) -> None:
    """Let optional modules (vsw.models.ile.design) add their subcommands via ``register_cli``."""
    import importlib

    for name in _OPTIONAL_COMMAND_MODULES:
        try:
            module = importlib.import_module(f"vsw.{name}")
        except ImportError:
            continue
        register = getattr(module, "register_cli", None)
        if register is not None:
            register(subparsers)


def _check_environment() -> None:
    """Every ``VSW_*`` setting read as the commands will, before any of them starts.

    One rule for every subcommand and input size: an invalid setting is bad input even
    where the command would not have needed it.
    """
    from vsw.limits import max_memory, max_seconds
    from vsw.vectorize import default_threads

    default_threads()
    max_seconds()
    max_memory()


def _say(line: str) -> None:
    """One line on stderr; silent when stderr itself is closed or broken."""
    try:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
    except (AttributeError, OSError):
        pass


def _silence(stream: TextIO) -> None:
    """Point the file descriptor of a failed ``stream`` at os.devnull.

    What is still buffered then goes nowhere at the interpreter's final flush instead of
    failing again there with "Exception ignored ...". Streams without a descriptor (a
    test's capture) are not flushed at exit, so there is nothing to do.
    """
    try:
        fd = stream.fileno()
    except (AttributeError, OSError, ValueError):
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, fd)
    finally:
        os.close(devnull)


def _run(argv: Sequence[str] | None) -> int:
    """Parse and run one command; every error but a failing standard output is mapped here."""
    try:
        parser = build_parser()
        args = parser.parse_args(None if argv is None else list(argv))
        _check_environment()
        return int(args.func(args))
    except VswInputError as exc:
        prog = exc.prog if isinstance(exc, UsageError) else "vsw"
        _say(f"{prog}: error: {_one_line(exc)}")
        return EXIT_INPUT
    except (ConvergenceError, InfeasibleError) as exc:
        _say(f"vsw: {type(exc).__name__}: {_one_line(exc)}")
        return EXIT_SOLVER
    except SystemExit as exc:  # --help and --version exit through argparse
        return exc.code if isinstance(exc.code, int) else EXIT_OK
    except MemoryError:
        _say(
            "vsw: error: out of memory; use a smaller problem, or lower VSW_MAX_MEMORY so "
            "that such work is refused before it starts"
        )
        return EXIT_INPUT
    except KeyboardInterrupt:
        _say("vsw: interrupted")
        return EXIT_INTERRUPTED


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (the console script exits with it).

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        One of :data:`EXIT_STATUS`: 0 success, 2 bad input (one line on stderr), 3 solver
        failure or infeasible request, 141 standard output closed by its reader (quiet),
        130 interrupted.
    """
    stdout = sys.stdout
    if stdout is None:  # started with standard output closed (">&-")
        _say("vsw: error: standard output is closed; redirect it (e.g. >/dev/null) instead")
        return EXIT_INPUT
    guard = _GuardedStdout(stdout)
    sys.stdout = guard
    try:
        code = _run(argv)
        # Flushed here, not at exit, so that a closed pipe or a full disk is seen here.
        guard.flush()
    except OSError as exc:
        if guard.error is None:  # a file the command writes (a plot), not standard output
            where = f" {exc.filename!r}" if exc.filename else ""
            _say(f"vsw: error: cannot write{where}: {exc.strerror or _one_line(exc)}")
            code = EXIT_INPUT
    finally:
        sys.stdout = stdout
    if guard.error is not None:
        _silence(stdout)
        if isinstance(guard.error, BrokenPipeError):
            return EXIT_CLOSED_PIPE  # the reader has all it wanted: no message
        _say(f"vsw: error: cannot write standard output: {guard.error.strerror or guard.error}")
        return EXIT_INPUT
    return code
