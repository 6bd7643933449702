"""``vsw explore``: one self-contained HTML page to explore a model in a browser (the ILE's
closed forms; any other model's walk integrated in the page: :mod:`vsw.plots.explore_page`); with
``--gait FILE`` a saved powered gait's step, replayed by vsw and played in the page."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from vsw import models
from vsw.cli import options
from vsw.cli.output import dump_json, envelope, with_units
from vsw.cli.parser import EXIT_OK
from vsw.cli.simulate import add_gait_option, saved_gait
from vsw.plots.explore_page import check_html_path, write_page
from vsw.runtime.errors import VswInputError
from vsw.studies.gait_file import replay_frames

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    help_ = "write the explorer: one self-contained HTML page (sliders, conditions, map)"
    p = subparsers.add_parser("explore", help=help_, description=help_ + "; the sliders start "
                              "at the model's parameters (its defaults unless given).")  # fmt: skip
    p.add_argument("--out", required=True, metavar="FILE", help="the page, e.g. explore.html")
    options.add_model_options(p, "explore")
    p.add_argument("--leg-length", type=float, default=0.25, help="start r_e [m]")
    add_gait_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    if args.gait is not None:
        return _run_gait(args)
    model, params = options.model_and_parameters(args)
    options.refuse_powered_only(model, "explore")
    if "explorer" not in model.features:
        having = [models.cli_name(k) for k in models.keys()
                  if "explorer" in models.load(k).features]  # fmt: skip
        raise VswInputError(f"vsw explore --model {model.cli_name}: the explorer is not "
                            f"available for this model yet (models with it: "
                            f"{', '.join(having)})")  # fmt: skip
    with options.solver_errors(model):
        out = model.write_explorer(args.out, params, leg_length=args.leg_length)
    if args.json:
        page = f"generated/{model.name}/js/{model.name}.js"
        data = envelope(model, params, args.argv, {"page": page})
        data = {**data, "out": str(out), "leg_length": args.leg_length}
        dump_json(with_units(model, data, {"leg_length": "m"}))
        return EXIT_OK
    sys.stdout.write(f"{out}: open it in a browser (no server needed)\n")
    return EXIT_OK


def _run_gait(args: argparse.Namespace) -> int:
    """``vsw explore --gait FILE``: the page plays the saved gait's replayed step."""
    saved = saved_gait(args)
    model, params = saved.model, saved.params
    check_html_path(args.out)
    with options.solver_errors(model):
        replay = replay_frames(saved)
    out = write_page(args.out, model, params, saved.start, replay)
    if args.json:
        data = envelope(model, params, args.argv, {"page": f"generated/{model.name}/js/"
                                                   f"{model.name}.js", "replay": "SciPy "
                                                   "DOP853, rtol = atol = 1e-11"})  # fmt: skip
        dump_json(with_units(model, {
            **data, "out": str(out), "gait": {"file": args.gait, "status": saved.status},
            "frames": len(replay["frames"]), "period": replay["period"],
            "step_length": replay["length"]}, {"frames": "1"}))  # fmt: skip
        return EXIT_OK
    sys.stdout.write(f"{out}: open it in a browser (no server needed); it plays the gait's "
                     f"step as vsw replayed it ({saved.status})\n")  # fmt: skip
    return EXIT_OK
