"""``vsw design``: constrained gait design with CasADi/IPOPT (:mod:`vsw.models.ile.design`).

A model with the ``design`` feature (the ile) designs its parameters for an objective and
targets under its existence conditions and the robot's limits; for any other model the
command says so in one line.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from vsw import models
from vsw.cli import options
from vsw.cli.output import dump_json, envelope
from vsw.errors import VswInputError
from vsw.models.ile.design import CONDITION_SETS, DesignResult, _finite, _parse_fix, design
from vsw.models.ile.params import STEPPER_2D, RobotScale

__all__ = ["register", "run"]


def _design_from_args(args: argparse.Namespace) -> tuple[DesignResult, RobotScale | None, bool]:
    mass_given = args.mass is not None or args.stepper_2d
    if args.stepper_2d:
        if args.leg_length is not None or args.mass is not None:
            raise VswInputError(
                "--stepper-2d sets the leg length and mass; drop --leg-length/--mass"
            )
        gravity = STEPPER_2D.gravity if args.gravity is None else args.gravity
        scale: RobotScale | None = RobotScale(STEPPER_2D.leg_length, STEPPER_2D.mass, gravity)
    elif args.leg_length is not None:
        # SI targets need only r_e and g; without --mass energies are per kg (mass 1 kg).
        gravity = 9.81 if args.gravity is None else args.gravity
        scale = RobotScale(args.leg_length, 1.0 if args.mass is None else args.mass, gravity)
    else:
        if args.mass is not None or args.gravity is not None:
            raise VswInputError("--mass/--gravity need --leg-length (or --stepper-2d)")
        scale = None
    si = scale is not None

    objective: dict[str, float] = {}
    if args.maximize is not None:
        objective["speed"] = 1.0
    for name in args.minimize or []:
        objective[name.replace("-", "_")] = 1.0
    targets: dict[str, float] = {}
    if args.target_speed is not None:
        targets["speed_m_s" if si else "speed"] = args.target_speed
    if args.target_q_fixed is not None:
        targets["q_fixed"] = args.target_q_fixed
    if args.target_step_length is not None:
        targets["step_length_m" if si else "step_length"] = args.target_step_length
    if args.target_step_frequency is not None:
        if not si:
            raise VswInputError("--target-step-frequency is in Hz and needs --leg-length")
        targets["step_frequency_hz"] = args.target_step_frequency
    if args.max_step_frequency is not None and not si:
        raise VswInputError("--max-step-frequency is in Hz and needs --leg-length")

    def deg(name: str, v: float | None) -> float | None:
        return None if v is None else math.radians(_finite(name, v))

    bounds: dict[str, tuple[float | None, float | None]] = {
        "beta": (args.beta_min, args.beta_max),
        "theta_II": (deg("--theta-ii-min", args.theta_ii_min),
                     deg("--theta-ii-max", args.theta_ii_max)),
        "phi0": (deg("--phi0-min", args.phi0_min), deg("--phi0-max", args.phi0_max)),
    }  # fmt: skip
    if args.min_step_length is not None or args.max_step_length is not None:
        bounds["step_length_m" if si else "step_length"] = (
            args.min_step_length,
            args.max_step_length,
        )
    if args.max_step_frequency is not None:
        bounds["step_frequency_hz"] = (None, args.max_step_frequency)
    result = design(
        objective=objective or None,
        targets=targets,
        bounds=bounds,
        fixed=_parse_fix(args.fix or []),
        min_contact_margin=args.min_contact_margin,
        max_eigenvalue=args.max_eigenvalue,
        scale=scale,
        conditions=args.conditions,
        n_starts=args.starts,
    )
    return result, scale, mass_given


def run(args: argparse.Namespace) -> int:
    model = models.load(args.model)
    if "design" not in model.features:
        having = [models.cli_name(k) for k in models.keys() if "design" in models.load(k).features]
        raise VswInputError(f"vsw design --model {model.cli_name}: design is not available for "
                            f"this model yet (models with it: {', '.join(having)})")  # fmt: skip
    result, scale, mass_given = _design_from_args(args)
    found_params = None
    if result.status in ("optimal", "not-attained"):
        found_params = (result.beta, result.theta_II, result.phi0)
    data = {**envelope(model, found_params, args.argv, {"ipopt": "tol 1e-8 (CasADi nlpsol); "
                                                        "each solve confirmed by the numpy "
                                                        "closed forms"}),
            **result.to_dict()}  # fmt: skip
    if scale is not None and not mass_given and result.analysis is not None:
        # Without --mass the energies are those of a 1 kg walker: say so in the key.
        for key in ("energy_added_J", "energy_lost_J"):
            data[f"{key}_per_kg"] = data.pop(key)
    found = result.status in ("optimal", "not-attained")
    exit_code = 0 if found else 3
    out = sys.stdout
    if args.json:
        dump_json(data)
        if not found:
            sys.stderr.write(f"vsw design: {' '.join(result.message.split())}\n")
        return exit_code
    out.write(f"status           {result.status}\n")
    if not found:
        if result.conflicting_constraints:
            out.write(f"conflicting      {', '.join(result.conflicting_constraints)}\n")
        sys.stderr.write(f"vsw design: {' '.join(result.message.split())}\n")
        return exit_code

    def fmt(value: Any) -> str:
        if value is None:
            return "-"
        if isinstance(value, bool):
            return "yes" if value else "no"
        return f"{value:.8g}" if isinstance(value, float) else str(value)

    rows = [
        ("beta", data["beta"], ""),
        ("theta_II", math.degrees(data["theta_II"]), "deg"),
        ("phi0", math.degrees(data["phi0"]), "deg"),
        ("q_fixed", data["q_fixed"], "g/r_e"),
        ("eigenvalue", data["eigenvalue"], ""),
        ("step_length", data["step_length"], "r_e"),
        ("step_period", data["step_period"], "sqrt(r_e/g)"),
        ("speed", data["speed"], "sqrt(g r_e)"),
        ("cost_of_transport", data["cost_of_transport"], "E_c/(m g L), L = step length"),
        ("energy_added", data["energy_added"], "m g r_e"),
        ("contact_margin", data["contact_margin"], "m g"),
    ]
    if scale is not None:
        rows += [
            ("step_length_m", data["step_length_m"], "m"),
            ("step_period_s", data["step_period_s"], "s"),
            ("step_frequency", 1.0 / data["step_period_s"], "Hz"),
            ("speed_m_s", data["speed_m_s"], "m/s"),
        ]
        if mass_given:
            rows.append(("energy_added_J", data["energy_added_J"], "J"))
        else:
            rows.append(("energy_added_J_per_kg", data["energy_added_J_per_kg"], "J/kg"))
    for name, value, unit in rows:
        out.write(f"{name:<18} {fmt(value):>16}  {unit}\n")
    out.write(f"conditions       {result.conditions}\n")
    out.write(f"active           {', '.join(result.active_constraints) or '-'}\n")
    out.write(f"simulation check relative error {fmt(result.simulation_rel_error)}\n")
    out.write(f"{result.message}\n")
    return exit_code


def register(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "design",
        help="constrained gait design with CasADi/IPOPT",
        description="Find (beta, theta_II, phi0) for an objective and targets under the "
        "existence conditions and your robot's limits. Angles in degrees. Exit 0 for an "
        "optimal design or a not-attained optimum (the best design near the limit, with the "
        "limiting value), 3 when the request is infeasible or the solver does not converge.",
    )
    goal = p.add_argument_group("objective and targets")
    goal.add_argument("--maximize", choices=["speed"], help="maximise the walking speed")
    goal.add_argument(
        "--minimize",
        choices=["eigenvalue", "cost-of-transport"],
        action="append",
        help="minimise the eigenvalue or the cost of transport (repeat for a sum)",
    )
    goal.add_argument(
        "--target-speed", type=float, help="speed: m/s with --leg-length, else sqrt(g r_e)"
    )
    goal.add_argument("--target-q-fixed", type=float, help="fixed point q^f [g/r_e]")
    goal.add_argument(
        "--target-step-length", type=float, help="step length: m with --leg-length, else r_e"
    )
    goal.add_argument(
        "--target-step-frequency", type=float, help="step frequency [Hz] (needs --leg-length)"
    )
    lim = p.add_argument_group("bounds and constraints")
    lim.add_argument("--beta-min", type=float)
    lim.add_argument("--beta-max", type=float)
    lim.add_argument("--theta-ii-min", type=float, help="[deg]")
    lim.add_argument("--theta-ii-max", type=float, help="[deg]")
    lim.add_argument("--phi0-min", type=float, help="[deg]")
    lim.add_argument("--phi0-max", type=float, help="[deg]")
    lim.add_argument(
        "--fix", action="append", metavar="NAME=VALUE", help="fix beta, theta_II or phi0 [deg]"
    )
    lim.add_argument("--min-contact-margin", type=float, default=0.0, help="min normal force [m g]")
    lim.add_argument("--max-eigenvalue", type=float)
    lim.add_argument("--min-step-length", type=float, help="m with --leg-length, else r_e")
    lim.add_argument("--max-step-length", type=float, help="m with --leg-length, else r_e")
    lim.add_argument("--max-step-frequency", type=float, help="[Hz] (needs --leg-length)")
    lim.add_argument(
        "--conditions",
        choices=CONDITION_SETS,
        default="exact",
        help="existence conditions: every physical one in its exact form, or also the "
        "paper's (15) and (17) as printed",
    )
    sc = p.add_argument_group("robot scale")
    sc.add_argument("--leg-length", type=float, help="extended leg length r_e [m]")
    sc.add_argument("--mass", type=float, help="mass [kg]")
    sc.add_argument("--gravity", type=float, help="g [m/s^2] (default 9.81)")
    sc.add_argument(
        "--stepper-2d", action="store_true", help="Stepper-2D preset: r_e 0.25 m, m 0.78 kg"
    )
    p.add_argument("--starts", type=int, default=2, help="IPOPT starts per region (1-50)")
    p.add_argument("--model", type=options.model_type, default="ile", metavar="NAME",
                   help="the model (design: the ile)")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)
