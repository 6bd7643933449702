"""``vsw basin`` of the ile without ``--grid``: its basin over theta_II and q0 in closed form.

The stride map (9) iterated from every q0 of a grid per theta_II (Fig. 9), with
``--check-edges N`` sampled edges checked by simulation. :mod:`vsw.cli.basin` registers the
options; the route of :attr:`vsw.models.ile.model.IleModel.routes`, imported only when this
basin is asked for (:meth:`vsw.models.base.Model.route`).
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from vsw.cli.output import dump_json, envelope, fmt, progress, with_units
from vsw.cli.parser import EXIT_OK, given, option_name
from vsw.models.base import Model
from vsw.models.ile.basin import basin, basin_cost, check_edges_by_simulation, edge_check_cost
from vsw.models.ile.params import PARAMETER_BY_NAME
from vsw.models.ile.plots import basin_plot
from vsw.plots.figures import check_save_path, save_figure
from vsw.runtime import limits
from vsw.runtime.errors import VswInputError

__all__ = ["MAX_THETA_VALUES", "run"]

MAX_THETA_VALUES = 100_000
"""Most theta_II values of the closed-form basin (each is a row of its grid)."""


def _theta_grid(args: argparse.Namespace) -> np.ndarray:
    """The theta_II grid (rad) from --theta-min/--theta-max/--theta-step (deg)."""
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


def run(args: argparse.Namespace, model: Model) -> int:
    """The ile's basin over theta_II and q0 (``vsw basin`` without ``--grid``)."""
    for dest in ("steps", "tol", "scheduler"):
        if given(args.parser, args, dest):
            raise VswInputError(f"{option_name(args.parser, dest)} belongs to the basin over a "
                                "slice of the section: give --grid")  # fmt: skip
    if "theta_II" in args.values:
        raise VswInputError("theta_II is the basin's axis: give --theta-min/--theta-max/"
                            "--theta-step (deg) instead")  # fmt: skip
    params = model.parameters(args.values)
    beta, phi0 = params[0], params[2]
    theta_II = _theta_grid(args)
    if args.n_q < 3:
        raise VswInputError(f"--n-q = {args.n_q} must be >= 3")
    if args.check_edges < 0:
        raise VswInputError(f"--check-edges = {args.check_edges} must be >= 0")
    if args.plot is not None:
        check_save_path(args.plot)
    # The whole run is estimated before any of it starts: the grid, then the edge checks.
    cost = basin_cost(beta, phi0, theta_II.size, args.n_q)
    if args.check_edges:
        cost = cost + edge_check_cost(beta, phi0, min(args.check_edges, theta_II.size))
    limits.check(
        f"a basin of {theta_II.size} theta_II x {args.n_q} q values"
        + (f" with {args.check_edges} edge checks" if args.check_edges else ""),
        cost,
        "use a larger --theta-step, a smaller --n-q"
        + (" or fewer --check-edges" if args.check_edges else ""),
    )
    with progress("basin") as bar:
        result = basin(beta, phi0, theta_II, n_q=args.n_q, progress=bar)
    parameters = {"beta": beta, "phi0": phi0}
    data = {**envelope(model, None, args.argv, {"closed_form": "stride map (9) iterated"}),
            "parameters": parameters, **result.to_dict()}  # fmt: skip
    data["theta_II_deg"] = [float(v) for v in np.degrees(result.theta_II)]
    data["fields"]["theta_II_deg"] = "deg: theta_II in degrees"
    checks, failed = None, 0
    if args.check_edges:
        with progress("edge checks") as bar:
            checks = check_edges_by_simulation(result, n_samples=args.check_edges, progress=bar)
        data["edge_checks"] = [
            {"theta_II": c.theta_II, "edge": c.edge, "side": c.side, "q0": c.q0,
             "expected": c.expected, "ended": c.ended, "ok": c.ok}
            for c in checks
        ]  # fmt: skip
        data["fields"]["edge_checks"] = (
            "simulations just inside and outside sampled edges: expected and actual end"
        )
        failed = sum(not c.ok for c in checks)
    if args.plot is not None:
        save_figure(basin_plot(result, checks=checks), args.plot)
        data["plot"] = args.plot
    if args.json:
        dump_json(with_units(model, data))
        return EXIT_OK
    out = sys.stdout
    out.write(f"basin of attraction, beta={beta:g}, phi0={math.degrees(phi0):g} deg\n")
    out.write(
        f"q_min < q0 <= q_max (q = omega_I^2 in g/r_e); each q0 walked {result.n_steps} "
        "stride-map steps, until eigenvalue^n (1.5/beta) < 1e-12\n"
    )
    out.write(f"{'theta_II[deg]':>13} {'q_min':>12} {'q_max':>12} {'q_fixed':>12}\n")
    for th, lo, hi, qf in zip(data["theta_II_deg"], data["q_min"], data["q_max"],
                              data["q_fixed"]):  # fmt: skip
        out.write(f"{th:>13.4g} {fmt(lo):>12} {fmt(hi):>12} {fmt(qf):>12}\n")
    if args.check_edges:
        out.write(f"edge checks by simulation: {len(checks) - failed} of {len(checks)} ok\n")
    return EXIT_OK
