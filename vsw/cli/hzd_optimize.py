"""``vsw hzd --optimize``: the Bezier coefficients of a constraints file chosen for a speed
(and step length) by IPOPT on the hybrid zero dynamics (:mod:`vsw.synthesis.hzd.optimize`), the
optimum verified on the full-order closed loop."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any, TextIO

from vsw.cli import options
from vsw.cli.output import dump_json, envelope, fmt, with_units
from vsw.cli.parser import EXIT_OK, EXIT_SOLVER
from vsw.plots.figures import check_save_path
from vsw.runtime.errors import VswInputError

__all__ = ["constraints_source", "run_optimize"]


def _request(args: argparse.Namespace) -> Any:
    from vsw.dynamics.quantities import resolve
    from vsw.synthesis.hzd.optimize import OBJECTIVES, HzdRequest

    if args.speed is None:
        raise VswInputError("vsw hzd --optimize needs --speed V")
    quantity, _note = resolve(args.minimize, "optimize")
    if quantity.name not in OBJECTIVES:
        raise VswInputError(f"--minimize {args.minimize}: vsw hzd --optimize minimises one of "
                            f"{', '.join(OBJECTIVES)}")  # fmt: skip
    request = HzdRequest(speed=args.speed, step_length=args.step_length,
                         minimize=quantity.name, mu=args.mu, max_torque=args.max_torque,
                         clearance=args.clearance, nodes=args.nodes)  # fmt: skip
    request.check()
    if args.out is not None and not str(args.out).endswith(".py"):
        raise VswInputError(f"--out {args.out}: the optimum is written as a constraints file "
                            "(.py)")  # fmt: skip
    return request


def constraints_source(original: str, names: list[str], alphas: list[float],
                       layout: list[dict], note: str) -> str:  # fmt: skip
    """A constraints file: ``original``'s text with its outputs replaced by impact-invariant
    Bezier polynomials of the coefficients ``alphas`` (alpha_2 .. alpha_M of each)."""
    later, start = [], 0
    for out in layout:
        later.append(tuple(float(a) for a in alphas[start + 2 : start + out["count"]]))
        start += out["count"]
    body = ",\n".join(f"        _InvariantBezier({tuple(c)!r})" for c in later)
    return (f"{original.rstrip()}\n\n# {note}\n"
            "import dataclasses as _dataclasses  # noqa: E402\n\n"
            "from derive.hzd import InvariantBezier as _InvariantBezier  # noqa: E402\n\n"
            "CONSTRAINTS = _dataclasses.replace(CONSTRAINTS, outputs=dict(zip(\n"
            f"    CONSTRAINTS.outputs,\n    (\n{body},\n    ),\n)))"
            f"  # outputs {', '.join(names)}\n")  # fmt: skip


def run_optimize(args: argparse.Namespace, model: Any, params: Any) -> int:
    """``vsw hzd --optimize``: exit 0 when optimal (converged and verified), else 3 with
    one line on stderr saying which."""
    from vsw.synthesis.hzd.optimize import optimize

    request = _request(args)
    if args.plot is not None:
        check_save_path(args.plot)
    with options.solver_errors(model):
        result = optimize(model, args.model, args.constraints, args.values, request, args.gains)
    status = ("optimal" if result.optimal else
              "not-converged" if not result.converged else "unverified")  # fmt: skip
    data = {
        **envelope(model, params, args.argv, {"ipopt_tol": 1e-10}),
        "constraints": args.constraints,
        "status": status,
        **_body(result, request),
    }
    spec = None if result.report is None else result.report.samples["surface"].package.HZD
    if args.out is not None and result.optimal:
        note = f"The optimum of: {' '.join(['vsw', *args.argv])}"
        text = constraints_source(Path(args.constraints).read_text(), spec["outputs"],
                                  result.alphas, spec["layout"], note)  # fmt: skip
        Path(args.out).write_text(text)
        data["out"] = args.out
    if args.plot is not None and result.report is not None:
        from vsw.synthesis.hzd.plot import save_hzd_plot

        surface = result.report.samples["surface"]
        save_hzd_plot(result.report, surface, spec["phase"], model.units["time"], args.plot)
        data["plot"] = args.plot
    if args.json:
        dump_json(with_units(model, data, _units(model, request)))
    else:
        _write(sys.stdout, data)
    if result.optimal:
        return EXIT_OK
    why = result.status if not result.converged else "; ".join(result.failures)
    sys.stderr.write(f"vsw hzd --optimize: {status}: {' '.join(why.split())}\n")
    return EXIT_SOLVER


def _body(result: Any, request: Any) -> dict[str, Any]:
    """The JSON's keys besides the envelope."""
    gait = None if result.report is None else result.report.to_dict()
    return {
        "request": {
            key: getattr(request, key)
            for key in (
                "speed",
                "step_length",
                "minimize",
                "mu",
                "max_torque",
                "clearance",
                "nodes",
            )
        },
        "cost": result.objective,
        "ipopt": {"status": result.status, "iterations": result.iterations},
        "cpu_seconds": {"build": result.build_seconds, "solve": result.solve_seconds},
        "alphas": result.alphas,
        "verified": result.verified,
        "failures": result.failures,
        "checks": result.checks,
        "gait": gait,
    }


def _units(model: Any, request: Any) -> dict[str, str]:
    u = model.units
    phase = model.phases[model.phase_index[model.step_event["target"]]]
    torque = phase["inputs"][0]["unit"] if phase["inputs"] else "1"
    cost = f"({torque})^2 {u['time']}" if request.minimize == "torque2" else u["energy"]
    force = u.get("force", "1")
    return {
        "cost": cost, "request.speed": f"{u['length']}/{u['time']}",
        "request.step_length": u["length"], "request.mu": "1", "request.max_torque": torque,
        "request.clearance": u["length"], "request.nodes": "1", "ipopt.iterations": "1",
        "cpu_seconds": "s", "alphas": "the controlled functions' unit (rad)",
        "checks.speed": f"{u['length']}/{u['time']}", "checks.step_length": u["length"],
        "checks.mismatch": "1", "checks.peak_torque": torque,
        "checks.least_normal_force": force, "checks.friction_ratio": "1",
        "checks.clearance_margin": u["length"], "checks.full_order_return": "1",
        "checks.max_abs_eigenvalue": "1",
        "checks.full_order_theta_dot_minus": f"rad/{u['time']}",
    }  # fmt: skip


def _write(out: TextIO, data: dict) -> None:
    def line(name: str, value: Any, unit: str = "") -> None:
        out.write(f"{name:<24} {fmt(value):>14}{'  ' + unit if unit else ''}\n")

    request = data["request"]
    out.write(f"model              {data['model']}; constraints {data['constraints']}\n")
    out.write(f"status             {data['status']} (IPOPT {data['ipopt']['status']}, "
              f"{data['ipopt']['iterations']} iterations)\n")  # fmt: skip
    line(f"cost ({request['minimize']})", data["cost"])
    line("CPU build + solve", data["cpu_seconds"]["build"] + data["cpu_seconds"]["solve"], "s")
    for key, value in data["checks"].items():
        line(key, value)
    for failure in data["failures"]:
        out.write(f"not verified: {failure}\n")
    if "out" in data:
        out.write(f"constraints        {data['out']}\n")
