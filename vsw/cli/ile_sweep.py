"""``vsw sweep`` of the ile: the closed forms at every value of the swept parameter.

The route of :attr:`vsw.models.ile.model.IleModel.routes`, imported only when a sweep of
the ile runs (:meth:`vsw.models.base.Model.route`); :mod:`vsw.cli.sweep` registers the
options, checks ``--plot``'s path and refuses the options of an iterated map first.
"""

from __future__ import annotations

import argparse
import math
import sys

from vsw.cli import options
from vsw.cli.output import clean, dump_json, envelope, fmt, progress, unit_text, with_units
from vsw.cli.parser import EXIT_OK
from vsw.models.base import Model
from vsw.models.ile.analysis import FIELDS
from vsw.models.ile.plots import ile_sweep_plot
from vsw.models.ile.sweep import sweep as closed_form_sweep
from vsw.plots import plotstyle
from vsw.plots.figures import save_figure
from vsw.runtime import limits

__all__ = ["run"]


def run(args: argparse.Namespace, model: Model) -> int:
    """The sweep in closed form (:func:`vsw.models.ile.sweep.sweep`)."""
    name, values = options.parse_over(model, args.over)
    names = [p.name for p in model.parameter_table]
    fixed = {k: v for k, v in zip(names, model.parameters(args.values)) if k != name}
    cost = limits.Cost(
        len(values) * limits.ILE_SWEEP_SECONDS_PER_POINT,
        limits.SIMULATE_BYTES_BASE + len(values) * limits.ILE_SWEEP_BYTES_PER_POINT,
    )
    limits.check(f"a sweep of {len(values)} points", cost, "use fewer points (N of --over)")
    axes = {**fixed, name: values}
    with progress("sweep") as bar:
        result = closed_form_sweep(list(FIELDS), *(axes[n] for n in names), progress=bar)
    columns = {field: result[field].reshape(-1) for field in FIELDS}
    points = [{name: float(v), **{f: columns[f][i] for f in FIELDS}}
              for i, v in enumerate(values)]  # fmt: skip
    unit = next(p.unit for p in model.parameter_table if p.name == name)
    data = {**envelope(model, None, args.argv, {"closed_form": "generated numpy code"}),
            "parameters": fixed, "over": name, "over_unit": unit,
            "points": points}  # fmt: skip
    if args.plot is not None:
        label = plotstyle.state_label(name, unit or "1")
        title = plotstyle.parameter_text(model, fixed)
        save_figure(ile_sweep_plot(clean(data), label, title), args.plot)
        data["plot"] = args.plot
    if args.json:
        dump_json(with_units(model, data))
        return EXIT_OK
    out = sys.stdout
    shown = ("walks", "q_fixed", "eigenvalue", "step_length", "step_period", "speed")
    degrees = options.parameters_in_degrees(args)
    units = {p.name: p.unit for p in model.parameter_table}
    text = ", ".join(f"{k} = {math.degrees(v):.6g} deg" if k in degrees
                     else f"{k} = {v:.6g}{unit_text(units[k])}"
                     for k, v in fixed.items())  # fmt: skip
    over_degrees = options.given_in_degrees(model, name, args.over)
    over_unit = unit_text("deg" if over_degrees else unit)
    out.write(f"{model.cli_name} over {name}{over_unit}; {text} (the other columns in the "
              "model's units, see 'vsw models')\n")  # fmt: skip
    out.write(f"{name:>12} " + " ".join(f"{f:>12}" for f in shown) + "\n")
    for p in points:
        out.write(f"{fmt(options.echo(p[name], over_degrees)):>12} "
                  + " ".join(f"{fmt(p[f]):>12}" for f in shown) + "\n")  # fmt: skip
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
    return EXIT_OK
