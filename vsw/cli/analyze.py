"""``vsw analyze``: every period-one gait of a model with its conditions, or why there is none."""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any, TextIO

from vsw.cli import options
from vsw.cli.output import (
    INTEGRATOR,
    ORBIT_SOLVER,
    dump_json,
    envelope,
    fmt,
    progress,
    unit_text,
    with_units,
    write_gait_sensitivity,
    write_orbit,
    write_parameters,
)
from vsw.cli.parser import EXIT_OK
from vsw.gaits.search import DISTINCT, SCAN_POINTS
from vsw.models.base import GaitReport, Model
from vsw.runtime.progress import reporting
from vsw.studies.rough import SLOPE, gait_sensitivity, gait_sensitivity_units

__all__ = ["register", "run"]

SCALE_OPTIONS = {"leg_length": "scale", "mass": "scale", "gravity": "scale", "stepper_2d": "scale"}


def register(subparsers: Any) -> None:
    help_ = "every period-one gait with its conditions' margins, or why there is none"
    p = subparsers.add_parser("analyze", help=help_, description=help_ + ".")
    options.add_model_options(p, "analyze", features=SCALE_OPTIONS)
    p.add_argument(
        "--search",
        action="append",
        metavar="NAME=START:STOP",
        help="replace the model's search box for a free section component (see 'vsw "
        "models'); repeatable",
    )
    scale = p.add_argument_group("SI results (the ile: added under keys of their own)")
    scale.add_argument("--leg-length", type=float, help="extended leg length r_e [m]")
    scale.add_argument("--mass", type=float, help="mass [kg]")
    scale.add_argument("--gravity", type=float, help="g [m/s^2] (default 9.81)")
    scale.add_argument(
        "--stepper-2d", action="store_true", help="Stepper-2D preset: r_e 0.25 m, m 0.78 kg"
    )
    p.set_defaults(func=run)


def scale_from(args: argparse.Namespace, model: Model) -> Any:
    """The robot scale of ``--stepper-2d`` or ``--leg-length``/``--mass``/``--gravity``, as
    the model gives it (:meth:`vsw.models.base.Model.robot_scale`)."""
    return model.robot_scale(args.leg_length, args.mass, args.gravity, args.stepper_2d)


def tolerances(model: Model) -> dict[str, Any]:
    if "scale" in model.features:  # closed forms: nothing iterates
        return {"closed_form": "generated numpy code (no solver)"}
    return {
        **INTEGRATOR,
        **ORBIT_SOLVER,
        "newton": "batch simulator (DOP853, rtol = atol = 1e-12), forward differences "
        "1e-7, residual <= 1e-10 x max(1, |state|)",
        "distinct": f"gaits closer than {DISTINCT:g} x max(1, |component|) are one",
        "scan_points": f"{SCAN_POINTS} per free component, by their number",
    }


def run(args: argparse.Namespace) -> int:
    model, params = options.model_and_parameters(args)
    box = options.parse_search(model, args.search)
    with progress("analyze") as bar, reporting(bar), options.solver_errors(model):
        if "scale" in model.features:
            report = model.analyze(params, box, scale=scale_from(args, model))
        else:
            report = model.analyze(params, box)
    data = {**envelope(model, params, args.argv, tolerances(model)), **report.to_dict()}
    sensitivities = _sensitivities(model, params, report)
    for point, gsn in zip(data["fixed_points"], sensitivities):
        point["gait_sensitivity"] = gsn
    if args.json:
        dump_json(with_units(model, data, gait_sensitivity_units(model)))
        return EXIT_OK
    out = sys.stdout
    write_parameters(out, model, params)
    if report.rows:
        _write_rows(out, report)
    else:
        _write_gaits(out, model, report, sensitivities)
    return EXIT_OK


def _sensitivities(model: Model, params: Any, report: GaitReport) -> list[dict | None]:
    """Each gait's gait sensitivity norm to its slope (:func:`vsw.studies.rough.gait_sensitivity`),
    None for an unstable gait (its H2 norm is infinite); none for a model on no slope."""
    if "scale" in model.features or SLOPE not in model.spec["parameters"]:
        return []
    with options.solver_errors(model):
        return [gait_sensitivity(model, params, orbit).to_dict() if orbit.stable else None
                for orbit in report.gaits]  # fmt: skip


def _write_rows(out: TextIO, report: GaitReport) -> None:
    """A closed-form report: its table of values, then every condition (angles in deg)."""
    for name, value, unit in report.rows:
        out.write(f"{name:<16} {fmt(value):>14}  {unit}\n")
    out.write("\nconditions (margin > 0 holds; physical ones decide 'walks'; angles in deg)\n")
    out.write(f"{'name':<36} {'eq.':<12} {'margin':>12} {'unit':<6} {'holds':>5}  "
              f"{'status':<12} physical\n")  # fmt: skip
    for c in report.extra.get("conditions", []):
        value, unit = c["value"], c["unit"]
        if unit == "rad" and value is not None:
            value, unit = math.degrees(value), "deg"
        out.write(f"{c['name']:<36} {c['equation'] or '-':<12} {fmt(value):>12} "
                  f"{unit or '-':<6} {fmt(c['holds']):>5}  {c['status']:<12} "
                  f"{fmt(c['physical'])}\n")  # fmt: skip
    if report.reason:
        out.write(f"\nno gait: {report.reason}\n")


def _write_ledger(out: TextIO, model: Model, ledger: dict[str, Any]) -> None:
    """A gait's energy ledger over a step (:mod:`vsw.dynamics.ledger`) in three lines."""
    unit = unit_text(model.units.get("energy", "")).strip()
    totals = ledger["totals"]
    actuators = ", ".join(
        f"{name} {fmt(w['work'])} (+{fmt(w['positive'])}, {fmt(w['negative'])})"
        for name, w in totals["actuators"].items()
    )
    events = ", ".join(
        f"{e['event']} loss {fmt(e['loss'])}"
        + (f" (the {' and '.join(e['caught_by'])} catching)" if e.get("caught_by") else "")
        + (
            f" {' and '.join(e.get('actuators') or ('actuator',))} {fmt(e['actuator_work'])}"
            if abs(e["actuator_work"]) > 1e-9 * max(e["loss"], abs(e["kinetic_change"]), 1e-300)
            else ""
        )
        for e in ledger["events"]
    )
    raised = totals["potential_raised_at_events"]
    lifted = f", raised at events {fmt(raised)}" if raised else ""
    # A passive walker's events leave rounding as their remainder: no actuator to name.
    acting = totals["actuators"] or any(
        e["reset"] == "jump" or e.get("actuators") for e in ledger["events"]
    )
    work = totals["actuator_work_continuous"] + totals["actuator_work_impulsive"]
    actuated = f", actuators {fmt(work)}" if acting else ""
    out.write(f"  {'energy per step':<16} gravity {fmt(totals['gravity_work'])}{actuated}"
              f", losses {fmt(totals['losses'])}{lifted} {unit}; balance "
              f"{fmt(ledger['balance'])} {unit}\n")  # fmt: skip
    if actuators:
        out.write(f"  {'  in the phases':<16} {actuators} {unit}\n")
    out.write(f"  {'  at events':<16} {events} {unit}\n")
    for e in ledger["events"]:
        if e["reset"] == "jump":
            forward, up = e["ground_impulse"]
            pulled = "; down: the foot is pulled on balance (held, as assumed)" if up < 0 else ""
            out.write(f"  {'  ground impulse':<16} {e['event']} forward {fmt(forward)}, up "
                      f"{fmt(up)} {_impulse_unit(model)}{pulled}\n")  # fmt: skip


def _impulse_unit(model: Model) -> str:
    """Force times time in the model's units (m_H g sqrt(l/g) for the scaled bipeds)."""
    return " ".join(model.units[k] for k in ("force", "time") if model.units.get(k))


def _write_gaits(out: TextIO, model: Model, report: GaitReport,
                 sensitivities: list[dict | None]) -> None:  # fmt: skip
    units = ", ".join(f"{k} {v}" for k, v in model.units.items())
    out.write(f"{'units':<18} {units}\n")
    if report.search is not None:
        s = report.search
        box = ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in s.box.items())
        grid = " x ".join(str(n) for n in s.points.values())
        note = "" if s.complete else " (not the default resolution: the search may miss gaits)"
        out.write(f"{'search':<18} {box}: {grid} cells, Newton from the {s.candidates} that "
                  f"complete a step ({s.route}){note}\n")  # fmt: skip
    out.write(f"\nperiod-one gaits: {len(report.gaits)} (state just after the "
              f"{model.step_event['name']} that starts a step)\n")  # fmt: skip
    for n, (orbit, margins) in enumerate(zip(report.gaits, report.conditions), 1):
        out.write(f"gait {n}\n")
        write_orbit(out, model, orbit)
        for c in margins:
            reported = "" if c.get("ends_walk", True) else " (reported, not enforced)"
            out.write(f"  {c['name'] + ' margin':<16} {fmt(c['margin']):>14} "
                      f"{unit_text(c['unit']).strip():<10} {c['meaning']}{reported}\n")  # fmt: skip
        if n <= len(report.ledgers):
            if report.ledgers[n - 1] is None:
                out.write(f"  {'energy per step':<16} not computed (the step could not be "
                          "simulated again)\n")  # fmt: skip
            else:
                _write_ledger(out, model, report.ledgers[n - 1])
        if n <= len(sensitivities) and sensitivities[n - 1] is not None:
            write_gait_sensitivity(out, model, sensitivities[n - 1], width=16, indent="  ")
    if report.closed_form is not None:
        closed = report.closed_form
        out.write(f"\nclosed form: q^f = {fmt(closed['q_fixed'])}, eigenvalue "
                  f"{fmt(closed['eigenvalue'])}, walks: {fmt(closed['walks'])}\n")  # fmt: skip
        for c in closed["conditions"]:
            out.write(f"  {c['name']:<24} {fmt(c['margin']):>12}{unit_text(c['unit']):<8} "
                      f"{'holds' if c['holds'] else 'FAILS'}  {c['meaning']}\n")  # fmt: skip
    if report.reason:
        out.write(f"\nno gait: {report.reason}\n")
    if report.search is not None and report.search.unconfirmed:
        for u in report.search.unconfirmed:
            out.write(f"note: a Newton solution was no gait when simulated: {u['reason']}\n")
