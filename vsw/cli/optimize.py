"""``vsw optimize``: the least-cost powered gait of a model with inputs
(:mod:`vsw.synthesis.powered`).

The model's declared inputs (``vsw models`` lists them: the compass gait's hip torque, the
point-mass biped's leg force) are free functions of time, its impulses at events (the
point-mass biped's push-off and heel-strike) free numbers; the step is periodic and meets
the targets. Statuses as ``vsw design``'s: optimal (exit 0), infeasible (IPOPT found the
constraints locally infeasible) and not-converged (exit 3, with the reason).

Targets are positive and at most :data:`vsw.synthesis.powered.MAX_TARGET` in the model's units; a
run whose estimate (:func:`vsw.synthesis.powered.estimate_seconds`) exceeds ``VSW_MAX_SECONDS`` is
refused before it starts, and one that runs past it anyway is stopped within about a
second, in CasADi's build of the NLP as in IPOPT's iterations (exit 2, one line).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from vsw.cli import options
from vsw.cli.output import (
    dump_json,
    envelope,
    fmt,
    quantity_unit,
    unit_text,
    with_units,
    write_parameters,
)
from vsw.cli.parser import EXIT_OK, EXIT_SOLVER
from vsw.dynamics.quantities import alias_names, objective_names, report, resolve
from vsw.dynamics.quantities import weight as walker_weight
from vsw.plots.figures import check_save_path, save_figure
from vsw.runtime.errors import ConvergenceError, VswInputError
from vsw.studies.gait_file import gait_record, record_quantities
from vsw.synthesis import powered
from vsw.synthesis.powered.plot import powered_figure
from vsw.synthesis.powered.verify import VerifiedGait, verify

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    help_ = "the least-cost periodic gait with the model's inputs (direct collocation, IPOPT)"
    description = help_ + ": Hermite-Simpson on N and 2N intervals a phase, re-simulated."
    p = subparsers.add_parser("optimize", help=help_, description=description)
    options.add_model_options(p, "optimize", named=False)
    p.add_argument("--minimize", default="torque2", metavar="NAME",
                   choices=[*objective_names("optimize"), *alias_names("optimize")],
                   help="torque2: the integral of the squared inputs; work: their positive "
                   "work per step; cost-of-transport (or cot): that work per weight and step "
                   "length; eigenvalue (or stability): the spectral radius of the open-loop "
                   "step map (impulses at zero); the names of vsw design")  # fmt: skip
    p.add_argument("--target-speed", type=float, metavar="V",
                   help="the gait's speed (step length / period, the model's units)")  # fmt: skip
    p.add_argument("--target-step-length", type=float, metavar="S", help="the step length")
    p.add_argument("--target-period", type=float, metavar="T",
                   help="the step's period (at most two of the three targets: the step "
                   "length is the speed times the period)")  # fmt: skip
    p.add_argument("--nodes", type=int, default=20, metavar="N",
                   help="intervals a phase on the coarse mesh (the result is on 2N)")  # fmt: skip
    p.add_argument("--starts", type=int, default=1, metavar="K",
                   help="work, cost-of-transport and eigenvalue: solve the second stage from K "
                   "starts (the least squared-input step, then K - 1 perturbations of its "
                   "inputs), each on N and 2N intervals, and keep the best (optimal first, "
                   "then the least cost; default 1; 1-50)")  # fmt: skip
    p.add_argument("--limit", action="append", metavar="NAME=LOW:HIGH", type=_limit,
                   help="bounds on an input, impulse or chosen parameter beside the model's "
                   "(repeatable; either side may be empty: leg_force=:3)")  # fmt: skip
    p.add_argument("--use", action="append", metavar="NAME",
                   help="an input or impulse the gait may use (repeatable; the others are held "
                   "at zero; default: every one; 'vsw models' lists them)")  # fmt: skip
    p.add_argument(
        "--friction",
        type=float,
        metavar="MU",
        help="the ground's friction coefficient: the stance foot's reaction at every knot "
        "and the impulses at impacts within its cone (default: unbounded; the ground "
        "pushes at impacts whatever this is)",
    )
    p.add_argument(
        "--pushing-locks",
        action="store_true",
        help="the ground must push at locks too (a leg reaches its end stop without "
        "speed; default: reported, not constrained)",
    )
    p.add_argument(
        "--clearance",
        type=float,
        metavar="H",
        help="the swing foot at least H sin(pi s) above the ground, s the fraction of the "
        "step (no scuffing; default: reported, not enforced)",
    )
    p.add_argument(
        "--verify",
        action="store_true",
        help="the periodic step of the walker driven by the optimum's inputs "
        "(open-loop fixed point, SciPy DOP853) and its work along it: the exact "
        "work of a gait at about the targets",
    )
    p.add_argument("--plot", metavar="FILE", help="save the states and inputs over the step")
    p.add_argument(
        "--out",
        metavar="FILE",
        help="write the gait (JSON: the model, its parameters, the start state, each "
        "phase's duration and inputs, the impulses, the cost and statuses) for 'vsw "
        "simulate/animate/explore --gait FILE'; verifies it as --verify does",
    )
    p.set_defaults(func=run, parser=p)


def _limit(text: str) -> tuple[str, float | None, float | None]:
    """``NAME=LOW:HIGH`` (either side may be empty) as (name, low, high)."""
    name, equals, interval = text.partition("=")
    low, colon, high = interval.partition(":")
    if not (name and equals and colon):
        raise argparse.ArgumentTypeError(f"{text!r} is not NAME=LOW:HIGH (e.g. leg_force=:3)")
    try:
        return name, float(low) if low else None, float(high) if high else None
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: LOW and HIGH must be numbers") from None


def run(args: argparse.Namespace) -> int:
    minimize, note = resolve(args.minimize, "optimize")
    code = _optimize(args, minimize.name)
    if note and code == EXIT_OK:  # a refusal or a failure stays one line
        sys.stderr.write(f"vsw optimize: note: {note}\n")
    return code


def _optimize(args: argparse.Namespace, minimize: str) -> int:
    model = args.model_object
    params = model.parameters(args.values)
    request = powered.Request(minimize, args.target_speed, args.target_step_length,
                              args.nodes, use=tuple(args.use or ()), friction=args.friction,
                              pushing_locks=args.pushing_locks,
                              clearance=args.clearance,
                              target_period=args.target_period,
                              limits=tuple(args.limit or ()),
                              starts=args.starts)  # fmt: skip
    request.check()
    if args.plot is not None:
        check_save_path(args.plot)
    if args.out is not None:
        _check_out(args.out)
    gait = powered.optimize(model, params, request)
    # The parameters the optimiser chose with the gait (a push's angle) at its values: the
    # envelope, the text, the plot and the verification are the gait's.
    params = powered.gait_parameters(model, gait, params)
    checked = args.verify or args.out is not None
    verified = _verified(model, params, gait) if checked else None
    tolerances = {"collocation": "Hermite-Simpson", "resimulation": powered.RESIMULATION_TOL}
    data = {**envelope(model, params, args.argv, tolerances), **_to_dict(model, request, gait)}
    data["quantities"] = _quantities(model, params, gait)
    if checked:
        data["verified"] = _verified_dict(model, verified)
    record = gait_record(model, params, request, gait, verified)
    data["gait"] = record
    units = {**_units(model, request), **record_quantities(model)}
    units["gait.cost"] = units["cost"]
    if args.out is not None:
        document = {**envelope(model, params, args.argv, tolerances), "gait": record}
        _write_gait(args.out, with_units(model, document, units))
    if args.plot is not None:
        figure = powered_figure(model, params, gait, cost_unit=cost_unit(model, request))
        save_figure(figure, args.plot)
        data["plot"] = args.plot
    if args.json:
        dump_json(with_units(model, data, units))
    else:
        _write_text(model, params, request, gait)
        if checked:
            _write_verified(model, request, verified)
        if args.out is not None:
            sys.stdout.write(f"gait               {args.out} ({record['status']})\n")
    failed = checked and (isinstance(verified, str) or bool(verified.failure))
    if gait.status == "optimal" and not failed:
        return EXIT_OK
    if gait.status == "optimal":
        reason = verified if isinstance(verified, str) else verified.failure
        sys.stderr.write(f"vsw optimize: verification failed: {' '.join(reason.split())}\n")
        return EXIT_SOLVER
    sys.stderr.write(f"vsw optimize: {gait.status}: {' '.join(gait.reason.split())}\n")
    return EXIT_SOLVER


def _quantities(model, params, gait: powered.PoweredGait) -> dict[str, Any]:
    """The gait's quantities as ``vsw design`` reports them (:mod:`vsw.dynamics.quantities`): the
    actuators' positive work is the energy a step takes in; the eigenvalue is the open-loop
    map's largest (null unless optimal)."""
    eigenvalues = gait.extra.get("eigenvalues")
    work = sum(w["positive"] for w in gait.work.values())
    facts = {"period": gait.period, "step_length": gait.step_length, "actuator_work": work,
             "eigenvalue": abs(eigenvalues[0]) if eigenvalues else None, "energy": work,
             "weight": walker_weight(model, params)}  # fmt: skip
    return report(facts)


def _check_out(path: str) -> None:
    """``--out``, checked before the optimisation: a file in an existing directory."""
    parent = Path(path).parent
    if Path(path).is_dir() or not parent.is_dir():
        raise VswInputError(f"--out {path}: not a file in an existing directory")


def _write_gait(path: str, document: dict[str, Any]) -> None:
    """The gait file (:mod:`vsw.studies.gait_file`): strict JSON as ``--json`` prints it."""
    try:
        with open(path, "w", encoding="utf-8") as out:
            dump_json(document, out)
    except OSError as exc:
        raise VswInputError(f"--out {path}: cannot write: {exc.strerror or exc}") from None


def _verified(model, params, gait: powered.PoweredGait) -> VerifiedGait | str:
    """The verified gait, or why there is none (one line)."""
    if gait.status == "infeasible":
        return "no gait: the optimisation found the constraints infeasible"
    try:
        return verify(model, params, gait)
    except ConvergenceError as exc:
        return str(exc)


def input_units(model) -> dict[str, str]:
    """Each input's and impulse's unit by name, as 'vsw models' lists them."""
    units = {i["name"]: i["unit"] for p in model.phases for i in p.get("inputs", ())}
    for event in model.spec.get("events", ()):
        units |= {i["name"]: i["unit"] for i in event.get("impulses", ())}
    return units


def cost_unit(model, request: powered.Request) -> str:
    """The unit of the cost: torque2 the squared inputs' integral (a sum over inputs of
    different units is a sum of their squares' units), work energy, cost_of_transport and
    eigenvalue 1."""
    if request.minimize == "work":
        return quantity_unit(model, "work")
    if request.minimize != "torque2":
        return "1"
    time = model.units.get("time", "")
    inputs = {i["name"]: i["unit"] for p in model.phases for i in p.get("inputs", ())}
    used = [u for n, u in inputs.items() if not request.use or n in request.use]
    squares = dict.fromkeys(f"{u}^2 {time}" if " " not in u else f"({u})^2 {time}"
                            for u in used)  # fmt: skip
    return " + ".join(squares) or "1"


def _units(model, request: powered.Request) -> dict[str, str]:
    """The units of the keys of optimize's JSON that are its own (an input, an impulse, the
    cost), beside those every command shares (:func:`vsw.cli.output.with_units`)."""
    named = input_units(model)
    impulses = {f"impulses.{e['name']}.{i['name']}": i["unit"]
                for e in model.spec.get("events", ()) for i in e.get("impulses", ())}  # fmt: skip
    table = {p.name: p.unit for p in model.parameter_table}
    limits = {f"limits.{name}": named.get(name, table.get(name, ""))
              for name, _, _ in request.limits}  # fmt: skip
    cost = cost_unit(model, request)
    return {**named, **impulses, **limits, "cost": cost, "objective": cost,
            "starts.coarse": cost, "starts.fine": cost, "best_start": "1", "mesh_change": "1",
            "nodes": "1", "iterations": "1", "input_time": quantity_unit(model, "time"),
            "resimulated_work": quantity_unit(model, "work"), "stance_friction": "1",
            "guard_at_end": "the unit of the model's guard expression"}  # fmt: skip


def _verified_dict(model, verified: VerifiedGait | str) -> dict[str, Any]:
    if isinstance(verified, str):
        return {"status": "failed", "reason": verified}
    return {
        **verified.summary(),
        "ground_impulses": _ground_dict(verified.ground_impulses),
        "stance_friction": verified.stance_friction,
        "state": dict(zip([*model.coordinates, *model.rates], verified.state.tolist())),
    }


def _write_verified(model, request: powered.Request, verified: VerifiedGait | str) -> None:
    out = sys.stdout
    if isinstance(verified, str):
        out.write(f"verified           failed: {verified}\n")
        return
    status = f"failed: {verified.failure}" if verified.failure else "verified"
    energy = unit_text(quantity_unit(model, "work"))
    out.write(f"verified           {status}; positive work {fmt(verified.positive_work)}{energy} "
              f"(step maps to itself within {fmt(verified.residual)})\n")  # fmt: skip
    out.write(f"  period {_motion(model, verified.period, verified.step_length, verified.speed)}; "
              f"stance friction needed {fmt(verified.stance_friction)}\n")  # fmt: skip
    _write_ledger(out, model, verified.work, verified.ground_impulses, "  ")


def _motion(model, period: float, step_length: float | None, speed: float | None) -> str:
    """'P s; step length L m; speed V m/s' (after a 'period' label) in the model's units."""

    def unit(key: str) -> str:
        return unit_text(quantity_unit(model, key))

    return (f"{fmt(period)}{unit('period')}; step length {fmt(step_length)}"
            f"{unit('step_length')}; speed {fmt(speed)}{unit('speed')}")  # fmt: skip


def _ground_dict(impulses: dict[str, tuple[float, float]]) -> dict[str, dict[str, float]]:
    return {k: {"tangential": t, "normal": n} for k, (t, n) in impulses.items()}


def _write_ledger(out, model, work: dict, ground: dict, indent: str) -> None:
    """Each input's and impulse's work, then each ground impulse, a line each."""
    energy = unit_text(quantity_unit(model, "work"))
    impulse = unit_text(quantity_unit(model, "impulses"))
    for key, value in work.items():
        out.write(f"{indent}work of {key:<11} +{fmt(value['positive'])} / "
                  f"{fmt(value['negative'])}{energy}\n")  # fmt: skip
    for key, (tangential, normal) in ground.items():
        out.write(f"{indent}ground at {key:<9} normal {fmt(normal)}, tangential "
                  f"{fmt(tangential)}{impulse}\n")  # fmt: skip


FIELDS = {
    "cost": "the named cost on the fine mesh (work and cost_of_transport without "
    "the regularization; eigenvalue: the spectral radius of the collocated step map, "
    "its Hermite-Simpson equations differentiated); objective: the NLP's (work, "
    "cost_of_transport and eigenvalue: plus the regularization times the squared "
    "inputs' integral)",
    "mesh_change": "relative change of the cost from the coarse to the fine mesh (a "
    "cost zero within 1e-9 on both agrees whatever this is)",
    "starts": "with --starts above 1: each start's cost on the coarse and the fine mesh, "
    "its fine solve's IPOPT status, its status as judged on both meshes and why it is "
    "not optimal (the first from the least squared-input step, the others from its "
    "inputs perturbed; status failed: IPOPT stopped, reason why); best_start: the one "
    "reported, an index into starts (0-based): optimal first, then IPOPT's success, "
    "then the least cost",
    "work": "per phase.input: positive and negative work over the step (Simpson); "
    "per event.impulse: its positive and negative work (its net work the impulse "
    "times the mean of its along's rate before and after it; its positive work "
    "exact, in the two parts the optimiser split it into; c impulse^2 / 2 for one "
    "applied with an impact)",
    "impulses": "per event.impulse: the impulse, applied at the event (before its "
    "reset, with its impact or after it, as the model declares)",
    "ground_impulses": "per event.foot: the ground's impulse on the walker through "
    "that foot over the event (the momentum's change), along the ground and normal "
    "to it; at an impact, and where impulses act at a change of phase, constrained to "
    "push (normal >= 0), at a lock reported (tangential / normal is the friction the "
    "foot needs)",
    "chosen_parameters": "the parameters the model names as the gait's own (an angle "
    "at which an impulse acts), at the optimiser's values (also in parameters); null "
    "for a model without, or under torque2 and eigenvalue, which hold them at the "
    "given values",
    "resimulation_error": "largest gap between a re-simulated phase's end and its "
    "last knot, relative to max(1, |state|)",
    "resimulated_work": "work and cost_of_transport: the positive work along the "
    "re-simulated step (the inputs' by Simpson on 16 panels an interval, the "
    "impulses' as the mesh's); optimal needs it within 1e-4 of the mesh's",
    "eigenvalues": "of the open-loop Poincare map (inputs as functions of the time "
    "since each phase began), by modulus; null unless optimal",
}
"""What each field of the JSON record of a powered gait means (its ``fields``)."""


def _phases(model, gait: powered.PoweredGait) -> list[dict[str, Any]]:
    """Each phase of the gait on its knots: times, states and inputs by name."""
    names = [*model.coordinates, *model.rates]
    phases = []
    for (phase, _), times, states, inputs, input_times in zip(
        model.phase_sequence(), gait.times, gait.states, gait.inputs, gait.input_times
    ):
        inputs_named = powered.input_names(model)[phase]
        phases.append({
            "phase": phase,
            "time": times.tolist(),
            "state": {n: states[:, j].tolist() for j, n in enumerate(names)},
            "input_time": input_times.tolist(),
            "inputs": {n: inputs[:, j].tolist() for j, n in enumerate(inputs_named)},
        })  # fmt: skip
    return phases


def _to_dict(model, request: powered.Request, gait: powered.PoweredGait) -> dict[str, Any]:
    phases = _phases(model, gait)
    eigenvalues = gait.extra.get("eigenvalues")
    return {
        "status": gait.status,
        "reason": gait.reason or None,
        "minimize": request.minimize,
        "targets": {
            "speed": request.target_speed,
            "step_length": request.target_step_length,
            "period": request.target_period,
        },
        "use": list(request.use) or None,
        "chosen_parameters": _chosen(model, request, gait),
        "limits": {name: [low, high] for name, low, high in request.limits} or None,
        "cost": gait.cost,
        "objective": gait.extra.get("objective"),
        "nodes": {"coarse": request.nodes, "fine": 2 * request.nodes},
        "mesh_change": gait.extra.get("mesh_change"),
        "starts": gait.extra.get("starts"),
        "best_start": gait.extra.get("best_start"),
        "period": gait.period,
        "durations": list(gait.durations),
        "step_length": gait.step_length,
        "speed": gait.speed,
        "work": gait.work,
        "impulses": gait.impulses,
        "ground_impulses": _ground_dict(gait.ground_impulses),
        "resimulation_error": gait.resimulation_error,
        "resimulated_work": gait.extra.get("resimulated_work"),
        "guard_at_end": gait.guard_at_end,
        "eigenvalues": None if eigenvalues is None else [[e.real, e.imag] for e in eigenvalues],
        "max_abs_eigenvalue": None if not eigenvalues else abs(eigenvalues[0]),
        "eigenvalues_note": gait.extra.get("eigenvalues_note"),
        "ipopt": {"status": gait.ipopt_status, "iterations": gait.iterations},
        "phases": phases,
        "fields": dict(FIELDS),
    }


def _chosen(model, request: powered.Request, gait: powered.PoweredGait) -> dict[str, float] | None:
    """The parameters the optimiser chose with the gait, by name (None: the model has none,
    or ``torque2`` or ``eigenvalue`` held them at their given values: they price no
    impulse)."""
    if not powered.prices_work(request):
        return None
    table = model.parameter_table
    return {table[i].name: gait.parameters[i] for i in powered.chosen_indices(model)} or None


def _write_text(model, params, request: powered.Request, gait: powered.PoweredGait) -> None:
    out = sys.stdout
    write_parameters(out, model, params)
    chosen = [model.parameter_table[i].name for i in powered.chosen_indices(model)]
    if chosen and not powered.prices_work(request):
        out.write(f"held               {', '.join(chosen)} at the given value ({request.minimize} "
                  "prices no impulse, so not where one acts)\n")  # fmt: skip
    elif chosen:
        out.write(f"chosen             {', '.join(chosen)} (by the optimiser, with the gait)\n")
    out.write(f"status             {gait.status}" + (f": {gait.reason}" if gait.reason else "")
              + "\n")  # fmt: skip
    cost = unit_text(cost_unit(model, request))
    out.write(f"minimized          {request.minimize} = {fmt(gait.cost)}{cost} (Hermite-Simpson, "
              f"{2 * request.nodes} intervals a phase; {fmt(gait.extra.get('mesh_change'))} "
              f"relative change from {request.nodes})\n")  # fmt: skip
    if gait.extra.get("starts"):
        costs = ", ".join("failed" if t["fine"] is None else f"{fmt(t['fine'])} ({t['status']})"
                          for t in gait.extra["starts"])  # fmt: skip
        out.write(f"starts             {len(gait.extra['starts'])}, each on {request.nodes} and "
                  f"{2 * request.nodes} intervals a phase: {costs}; the best is start "
                  f"{gait.extra['best_start'] + 1} (counted from 1)\n")  # fmt: skip
    out.write(f"period             {_motion(model, gait.period, gait.step_length, gait.speed)}\n")
    _write_ledger(out, model, gait.work, {}, "")
    units = input_units(model)
    for key, impulse in gait.impulses.items():
        out.write(f"impulse {key:<11} {fmt(impulse)}{unit_text(units.get(key.split('.')[-1]))}\n")
    _write_ledger(out, model, {}, gait.ground_impulses, "")
    moved = gait.extra.get("resimulated_work")
    energy = unit_text(quantity_unit(model, "work"))
    along = "" if moved is None else f"; positive work along it {fmt(moved)}{energy}"
    out.write(f"re-simulation      {fmt(gait.resimulation_error)} (relative), guard at the end "
              f"{fmt(gait.guard_at_end)}{along}\n")  # fmt: skip
    eigenvalues = gait.extra.get("eigenvalues")
    if gait.extra.get("eigenvalues_note"):
        out.write(f"open-loop map      not computed: {gait.extra['eigenvalues_note']}\n")
    if eigenvalues:
        out.write(f"open-loop map      max |eigenvalue| {fmt(abs(eigenvalues[0]))} ("
                  + ("stable" if abs(eigenvalues[0]) < 1 else "unstable") + ")\n")  # fmt: skip
