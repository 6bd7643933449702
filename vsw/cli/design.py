"""``vsw design``: constrained gait design with CasADi/IPOPT.

A model with a design of its own (:attr:`vsw.models.base.Model.routes`: the ILE's over
(beta, theta_II, phi0) from its closed forms, :mod:`vsw.cli.ile_design`) designs by it;
every other model designs its free parameters and its gait together, IPOPT on the periodic
orbit (:mod:`vsw.synthesis.design`). Both share the vocabulary: ``--maximize``, ``--minimize``, the
``--target-*`` equalities, ``--fix``, ``--bound``, ``--max-eigenvalue``; the statuses
optimal / not-attained (exit 0) and infeasible / not-converged (exit 3).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from vsw import models
from vsw.cli import options
from vsw.cli.output import (
    dump_json,
    envelope,
    fmt,
    quantity_unit,
    unit_text,
    with_units,
    write_orbit,
    write_parameters,
)
from vsw.cli.parser import option_name
from vsw.dynamics.quantities import alias_names, objective_names, resolve
from vsw.runtime.errors import VswInputError
from vsw.synthesis import design as gait_design

__all__ = ["bound_items", "objective_units", "option_given", "register", "run", "value_items"]


def option_given(args: argparse.Namespace, dest: str) -> bool:
    """Whether an option was on the command line: a value other than its default None or
    False (``parser.given`` counts 0 as not given, and 0 is a value here)."""
    value = getattr(args, dest, None)
    return value is not None and value is not False


ILE_ONLY = (
    "beta_min",
    "beta_max",
    "theta_ii_min",
    "theta_ii_max",
    "phi0_min",
    "phi0_max",
    "min_contact_margin",
    "min_step_length",
    "max_step_length",
    "max_step_frequency",
    "conditions",
    "leg_length",
    "mass",
    "gravity",
    "stepper_2d",
    "target_q_fixed",
)
"""Options of the ILE's closed-form design (its robot scale, its named bounds)."""


def _choices(sense: str) -> list[str]:
    """The objectives of ``--maximize`` (``max``) or ``--minimize`` (``min``), as
    :mod:`vsw.dynamics.quantities` defines them, then their aliases (accepted with a note)."""
    return [*objective_names("design", sense), *alias_names("design", sense)]


GENERIC_ONLY = ("target_period", "min_margin", "weight", "start")
"""Options of the design on the periodic orbit that the ILE's closed forms do not take."""

CONDITIONS = ("exact", "paper")
"""The choices of ``--conditions`` (the ILE's closed-form design checks them)."""


def run(args: argparse.Namespace) -> int:
    model = models.load(args.model)
    options.refuse_powered_only(model, "design")
    notes: list[str] = []
    args.maximize = _objectives(args.maximize, "max", "--maximize", notes)
    args.minimize = _objectives(args.minimize, "min", "--minimize", notes)
    route = model.route("design")
    code = _run_generic(args, model) if route is None else route(args, model)
    if code == 0:  # a refusal or a failure stays one line
        for note in notes:
            sys.stderr.write(f"vsw design: note: {note}\n")
    return code


def _objectives(
    names: list[str] | None, sense: str, option: str, notes: list[str]
) -> list[str] | None:
    """The objectives named, each in its one spelling (an alias read with a note, added to
    ``notes``)."""
    if names is None:
        return None
    out = []
    for name in names:
        quantity, note = resolve(name, "design", sense, option)
        if note:
            notes.append(note)
        out.append(quantity.option)
    return out


# --- every other model: the design on the periodic orbit --------------------------------


def bound_items(
    model: models.Model, items: list[str]
) -> dict[str, tuple[float | None, float | None]]:
    """``--bound NAME=A:B`` (either end may be empty): a parameter in its table's units (an
    angle in rad, or with a deg suffix) or a quantity in the model's units."""
    table = {p.name: p for p in model.parameter_table}
    out: dict[str, tuple[float | None, float | None]] = {}
    for item in items:
        name, text = options.split_item("--bound", item)
        low_text, sep, high_text = text.partition(":")
        degrees = name in table and table[name].unit == "rad"
        if not sep:
            raise VswInputError(f"--bound {item!r}: expected NAME=A:B (either end may be empty)")
        ends = []
        for part in (low_text, high_text):
            value = None if not part.strip() else options.number(part, degrees)
            if value is not None and not math.isfinite(value):
                raise VswInputError(f"--bound {item!r}: {part!r} is not a number")
            ends.append(value)
        low, high = ends
        if low is not None and high is not None and not low <= high:
            raise VswInputError(f"--bound {item!r}: the lower end exceeds the upper")
        if name in out:
            raise VswInputError(f"--bound {name} given twice: give each bound once")
        out[name] = (low, high)
    return out


def value_items(model: models.Model, option: str, items: list[str]) -> dict[str, float]:
    """``NAME=VALUE`` items of ``--fix`` or ``--start``, in the table's units."""
    table = {p.name: p for p in model.parameter_table}
    out: dict[str, float] = {}
    for item in items:
        name, text = options.split_item(option, item)
        if name not in table:
            raise VswInputError(f"{option} {name}: not a parameter of {model.cli_name} (its "
                                f"parameters: {', '.join(table)})")  # fmt: skip
        if name in out:
            raise VswInputError(f"{option} {name} given twice; give each parameter once")
        out[name] = options.parameter_value(option, table[name], text)
    return out


def _request(args: argparse.Namespace, model: models.Model) -> gait_design.DesignRequest:
    for dest in ILE_ONLY:
        if option_given(args, dest):
            raise VswInputError(f"{option_name(args.parser, dest)} is an option of the ILE's "
                                f"design; {model.cli_name}: use --bound NAME=A:B, --fix and "
                                "targets in the model's units")  # fmt: skip
    objective: dict[str, float] = {}
    for name in args.maximize or []:
        objective[name.replace("-", "_")] = 1.0
    for name in args.minimize or []:
        objective[name.replace("-", "_")] = 1.0
    for item in args.weight or []:
        name, text = options.split_item("--weight", item)
        key = name.replace("-", "_")
        if key not in objective:
            raise VswInputError(f"--weight {name}: not a term of the objective "
                                f"({', '.join(objective) or 'none given'})")  # fmt: skip
        weight = options.number(text)
        if not (math.isfinite(weight) and weight > 0):
            raise VswInputError(f"--weight {item!r}: the weight must be a positive number")
        objective[key] = weight
    targets = {
        key: float(value)
        for key, value in (("speed", args.target_speed), ("step_length", args.target_step_length),
                           ("step_frequency", args.target_step_frequency),
                           ("period", args.target_period))
        if value is not None
    }  # fmt: skip
    for key, value in targets.items():
        if not (math.isfinite(value) and value > 0):
            raise VswInputError(f"--target-{key.replace('_', '-')} {value:g}: must be positive")
    margin = 0.0 if args.min_margin is None else float(args.min_margin)
    if not (math.isfinite(margin) and margin >= 0):
        raise VswInputError(f"--min-margin {margin:g}: must be a number >= 0")
    return gait_design.DesignRequest(
        objective=objective, targets=targets, fixed=value_items(model, "--fix", args.fix or []),
        bounds=bound_items(model, args.bound or []), max_eigenvalue=args.max_eigenvalue,
        min_margin=margin, starts=4 if args.starts is None else args.starts,
        start=value_items(model, "--start", args.start or []),
    )  # fmt: skip


def _run_generic(args: argparse.Namespace, model: models.Model) -> int:
    request = _request(args, model)
    result = gait_design.design(model, request)
    params = None if result.parameters is None else list(result.parameters.values())
    tolerances = {"ipopt": "tol 1e-8, constraints 1e-9 (CasADi nlpsol); each design "
                  "confirmed by the periodic-orbit solver and a simulated step"}  # fmt: skip
    data = {**envelope(model, params, args.argv, tolerances), **result.to_dict()}
    if result.found:
        data["units"]["quantities"] = {k: quantity_unit(model, k) for k in result.quantities}
    exit_code = 0 if result.found else 3
    if args.json:
        dump_json(with_units(model, data, objective_units(model, list(request.objective))))
        if not result.found:
            sys.stderr.write(f"vsw design: {result.message}\n")
        return exit_code
    out = sys.stdout
    out.write(f"{'status':<18} {result.status}\n")
    if not result.found:
        sys.stderr.write(f"vsw design: {result.message}\n")
        return exit_code
    write_parameters(out, model, params)
    out.write("gait\n")
    write_orbit(out, model, result.orbit)
    out.write("quantities\n")
    for name, value in result.quantities.items():
        out.write(f"  {name:<16} {fmt(value):>14}{unit_text(quantity_unit(model, name))}\n")
    out.write("conditions (least margin over the step)\n")
    for c in result.margins:
        out.write(f"  {c['name']:<16} {fmt(c['margin']):>14}{unit_text(c['unit'])}\n")
    out.write(f"{'active':<18} {', '.join(result.active_constraints) or '-'}\n")
    out.write(f"simulation check relative error {fmt(result.simulation_rel_error)}\n")
    out.write(f"{result.message}\n")
    return exit_code


ROBOT_SCALE = {"scale.leg_length": "m", "scale.mass": "kg", "scale.gravity": "m/s^2"}
"""The units of the ILE's robot scale in its JSON."""


def objective_units(model: models.Model, terms: list[str]) -> dict[str, str]:
    """The units of the design's objective (the signed, weighted sum of its terms) and of
    what the JSON reports with it: a term's unit where all terms share it, else 'mixed'."""
    units = {quantity_unit(model, term) or "1" for term in terms}
    objective = units.pop() if len(units) == 1 else f"mixed: a weighted sum of {', '.join(terms)}"
    return {"objective": objective, "limit.uncertainty": objective, "distance_scale": "1",
            "simulation_rel_error": "1", "starts": "1"}  # fmt: skip


def _goal_options(p: Any) -> None:
    """The objective and the targets."""
    goal = p.add_argument_group("objective and targets (summed when repeated)")
    goal.add_argument("--maximize", choices=_choices("max"),
                      action="append",
                      help="maximise the speed or the step length")  # fmt: skip
    goal.add_argument(
        "--minimize",
        choices=_choices("min"),
        action="append",
        help="minimise the largest |eigenvalue| (or stability), the cost of transport (or cot: "
        "energy dissipated per step over weight x step length), the energy per step or the "
        "step frequency; the names of vsw optimize",
    )
    goal.add_argument("--weight", action="append", metavar="NAME=W",
                      help="weight of an objective term in the sum (default 1; not the "
                      "ile)")  # fmt: skip
    goal.add_argument("--target-speed", type=float,
                      help="speed (the model's units; ile: m/s with --leg-length, else "
                      "sqrt(g r_e))")  # fmt: skip
    goal.add_argument("--target-q-fixed", type=float, help="ile: fixed point q^f [g/r_e]")
    goal.add_argument("--target-step-length", type=float,
                      help="step length (the model's units; ile: m with --leg-length, else "
                      "r_e)")  # fmt: skip
    goal.add_argument("--target-step-frequency", type=float,
                      help="steps per time unit (ile: Hz, needs --leg-length)")  # fmt: skip
    goal.add_argument("--target-period", type=float, help="step period (the model's time unit)")


def _limit_options(p: Any) -> None:
    """Fixed values, bounds and constraints (the ILE's named ones too)."""
    lim = p.add_argument_group("bounds and constraints")
    lim.add_argument("--fix", action="append", metavar="NAME=VALUE",
                     help="hold a parameter in the table's units, an angle in rad or with a "
                     "deg suffix: theta_II=5deg (ile: beta, theta_II or phi0)")  # fmt: skip
    lim.add_argument("--bound", action="append", metavar="NAME=A:B",
                     help="bound a parameter (table units, an angle also in deg: "
                     "theta_II=-10deg:5deg) or a quantity (speed, step_length, step_frequency, "
                     "period); either end may be empty")  # fmt: skip
    lim.add_argument("--max-eigenvalue", type=float, help="largest |eigenvalue| allowed")
    lim.add_argument("--min-margin", type=float,
                     help="every condition's least margin over the step at least this (in its "
                     "unit; default: > 0)")  # fmt: skip
    lim.add_argument("--beta-min", type=float, help="ile")
    lim.add_argument("--beta-max", type=float, help="ile")
    # Named options of the paper's angles take degrees in every command (--theta-ii,
    # --phi0); these are the ILE's named duplicates of --bound, in the same unit.
    lim.add_argument("--theta-ii-min", type=float,
                     help="ile: theta_II >= this [deg] (as --bound theta_II=Adeg:)")  # fmt: skip
    lim.add_argument("--theta-ii-max", type=float,
                     help="ile: theta_II <= this [deg] (as --bound theta_II=:Bdeg)")  # fmt: skip
    lim.add_argument("--phi0-min", type=float,
                     help="ile: phi0 >= this [deg] (as --bound phi0=Adeg:)")  # fmt: skip
    lim.add_argument("--phi0-max", type=float,
                     help="ile: phi0 <= this [deg] (as --bound phi0=:Bdeg)")  # fmt: skip
    lim.add_argument("--min-contact-margin", type=float, default=None,
                     help="ile: min normal force [m g] (default 0)")  # fmt: skip
    lim.add_argument("--min-step-length", type=float, help="ile: m with --leg-length, else r_e")
    lim.add_argument("--max-step-length", type=float, help="ile: m with --leg-length, else r_e")
    lim.add_argument("--max-step-frequency", type=float, help="ile: [Hz] (needs --leg-length)")
    lim.add_argument(
        "--conditions",
        choices=CONDITIONS,
        default=None,
        help="ile: existence conditions: every physical one in its exact form (default), or "
        "also the paper's (15) and (17) as printed",
    )


def _scale_options(p: Any) -> None:
    """The ILE's robot scale."""
    sc = p.add_argument_group("robot scale (ile)")
    sc.add_argument("--leg-length", type=float, help="extended leg length r_e [m]")
    sc.add_argument("--mass", type=float, help="mass [kg]")
    sc.add_argument("--gravity", type=float, help="g [m/s^2] (default 9.81)")
    sc.add_argument(
        "--stepper-2d", action="store_true", help="Stepper-2D preset: r_e 0.25 m, m 0.78 kg"
    )


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "design",
        help="constrained gait design with CasADi/IPOPT, for every model",
        description="Find a model's parameters and its gait for an objective and targets "
        "under its conditions and your limits. The ILE designs (beta, theta_II, phi0) from "
        "its closed forms (the angles of its named bounds --theta-ii-min ... --phi0-max in "
        "degrees, as --theta-ii and --phi0 of the other commands); every other "
        "model designs each parameter that is not fixed, within its table's interval (a "
        "scale such as a mass or g only within a --bound you give), and its gait together: "
        "IPOPT on the periodic orbit (multiple shooting), values in the model's units (see "
        "'vsw models'). Exit 0 for an optimal design or a not-attained optimum (the best "
        "design at an open limit), 3 when the request is infeasible or the solver does not "
        "converge, 2 for a malformed request.",
    )
    _goal_options(p)
    _limit_options(p)
    _scale_options(p)
    p.add_argument("--start", action="append", metavar="NAME=VALUE",
                   help="not the ile: where a free parameter's search for starting gaits "
                   "begins (default: its default, or its interval's middle)")  # fmt: skip
    p.add_argument("--starts", type=int, default=None,
                   help="IPOPT starts: ile per region (default 2), other models the gaits at "
                   "the start parameters tried (default 4); 1-50")  # fmt: skip
    p.add_argument("--model", type=options.model_type, default="ile", metavar="NAME",
                   help="the model (see 'vsw models')")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run, parser=p)
