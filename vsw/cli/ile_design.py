"""``vsw design`` of the ILE: (beta, theta_II, phi0) from its closed forms.

The route of :attr:`vsw.models.ile.model.IleModel.routes` (:mod:`vsw.models.ile.design`),
imported only when the ile is designed (:meth:`vsw.models.base.Model.route`);
:mod:`vsw.cli.design` registers the options, those of the robot scale and the named bounds
among them.
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from vsw.cli.design import (
    GENERIC_ONLY,
    ROBOT_SCALE,
    bound_items,
    objective_units,
    option_given,
    value_items,
)
from vsw.cli.output import dump_json, envelope, with_units
from vsw.cli.parser import option_name
from vsw.models.base import Model
from vsw.models.ile.design import DesignResult, design, finite
from vsw.models.ile.params import STEPPER_2D, RobotScale
from vsw.runtime.errors import VswInputError

__all__ = ["run"]


def _scale(args: argparse.Namespace) -> tuple[RobotScale | None, bool]:
    """The robot scale of ``--stepper-2d`` or ``--leg-length`` (with ``--mass`` and
    ``--gravity``), and whether a mass was given (else energies are per kg)."""
    mass_given = args.mass is not None or args.stepper_2d
    if args.stepper_2d:
        if args.leg_length is not None or args.mass is not None:
            raise VswInputError(
                "--stepper-2d sets the leg length and mass; drop --leg-length/--mass"
            )
        gravity = STEPPER_2D.gravity if args.gravity is None else args.gravity
        return RobotScale(STEPPER_2D.leg_length, STEPPER_2D.mass, gravity), mass_given
    if args.leg_length is not None:
        # SI targets need only r_e and g; without --mass energies are per kg (mass 1 kg).
        gravity = 9.81 if args.gravity is None else args.gravity
        mass = 1.0 if args.mass is None else args.mass
        return RobotScale(args.leg_length, mass, gravity), mass_given
    if args.mass is not None or args.gravity is not None:
        raise VswInputError("--mass/--gravity need --leg-length (or --stepper-2d)")
    return None, mass_given


def _design_from_args(
    args: argparse.Namespace, model: Model
) -> tuple[DesignResult, RobotScale | None, bool]:
    scale, mass_given = _scale(args)
    si = scale is not None

    objective: dict[str, float] = {}
    if args.maximize:
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
        return None if v is None else math.radians(finite(name, v))

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
    for name, (low, high) in bound_items(model, args.bound or []).items():
        key = (
            ("step_length_m" if si else "step_length") if name == "step_length"
            else ("step_frequency_hz" if si else "step_frequency") if name == "step_frequency"
            else name
        )  # fmt: skip
        if key in bounds and any(v is not None for v in bounds[key]):
            raise VswInputError(f"--bound {name} and the option of the same bound: give one")
        if key not in ("beta", "theta_II", "phi0", "step_length", "step_length_m",
                       "step_frequency", "step_frequency_hz"):  # fmt: skip
            raise VswInputError(f"--bound {name}: the ILE's design bounds beta, theta_II, phi0, "
                                "step_length and step_frequency")  # fmt: skip
        bounds[key] = (low, high)
    if args.target_period is not None:
        raise VswInputError("--target-period is not an option of the ILE's design")
    # --fix in the table's units (an angle also with a deg suffix), as for every model.
    fixed = value_items(model, "--fix", args.fix or [])
    result = design(
        objective=objective or None,
        targets=targets,
        bounds=bounds,
        fixed=fixed,
        min_contact_margin=args.min_contact_margin or 0.0,
        max_eigenvalue=args.max_eigenvalue,
        scale=scale,
        conditions=args.conditions or "exact",
        n_starts=2 if args.starts is None else args.starts,
    )
    return result, scale, mass_given


def run(args: argparse.Namespace, model: Model) -> int:
    """``vsw design`` of the ile: its options checked, the closed-form design, its report."""
    for dest in GENERIC_ONLY:
        if option_given(args, dest):
            raise VswInputError(f"{option_name(args.parser, dest)} is not an option of the "
                                "ILE's closed-form design")  # fmt: skip
    for name in args.maximize or []:
        if name != "speed":
            raise VswInputError(f"--maximize {name}: the ILE's design maximises speed only")
    for name in args.minimize or []:
        if name not in ("eigenvalue", "cost-of-transport"):
            raise VswInputError(f"--minimize {name}: the ILE's design minimises eigenvalue or "
                                "cost-of-transport")  # fmt: skip
    result, scale, mass_given = _design_from_args(args, model)
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
        terms = [*(["speed"] if args.maximize else []),
                 *(n.replace("-", "_") for n in args.minimize or [])]  # fmt: skip
        dump_json(with_units(model, data, {**objective_units(model, terms or ["eigenvalue"]),
                                           **ROBOT_SCALE}))  # fmt: skip
        if not found:
            sys.stderr.write(f"vsw design: {' '.join(result.message.split())}\n")
        return exit_code
    out.write(f"status           {result.status}\n")
    if not found:
        if result.conflicting_constraints:
            out.write(f"conflicting      {', '.join(result.conflicting_constraints)}\n")
        sys.stderr.write(f"vsw design: {' '.join(result.message.split())}\n")
        return exit_code
    _write_text(data, result, scale, mass_given)
    return exit_code


def _write_text(
    data: dict[str, Any], result: DesignResult, scale: RobotScale | None, mass_given: bool
) -> None:
    """The text report of a found design: the values with their units, then how it holds."""
    out = sys.stdout

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
