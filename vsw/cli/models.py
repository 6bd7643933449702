"""``vsw models``: every model, its parameters, state, section, failures and units."""

from __future__ import annotations

import argparse
import shlex
import sys
from typing import Any

from vsw import models
from vsw.cli.options import model_type
from vsw.cli.output import dump_json, fmt, git_commit, version
from vsw.cli.parser import EXIT_OK

__all__ = ["register", "run"]

_APPLIED = {"before": "before the reset", "with": "with the impact (the held coordinate "
            "free for the instant)", "after": "after the reset"}  # fmt: skip


def register(subparsers: Any) -> None:
    help_ = "the models: parameters, state (meaning, reference, sign), section, units"
    p = subparsers.add_parser("models", help=help_, description=help_ + ".")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--model", type=model_type, action="append", metavar="NAME",
                   help="only this model (repeatable): a name, or a model file of yours "
                   "(path/to/model.py, derived on first use)")  # fmt: skip
    p.set_defaults(func=run)


def _bounds(p: dict[str, Any]) -> str:
    low = "-inf" if p["lower"] is None else f"{p['lower']:.6g}"
    high = "inf" if p["upper"] is None else f"{p['upper']:.6g}"
    return f"({low}, {high})"


def run(args: argparse.Namespace) -> int:
    described = [models.load(k).describe() for k in (args.model or models.keys())]
    if args.json:
        provenance = {"vsw": version(), "commit": git_commit(),
                      "command": shlex.join(["vsw", *args.argv])}  # fmt: skip
        dump_json({"provenance": provenance, "models": described})
        return EXIT_OK
    out = sys.stdout
    for n, m in enumerate(described):
        if n:
            out.write("\n")
        units = m["units"]
        out.write(f"{m['name']}: {m['title']}\n  {m['description']}\n")
        out.write("  units: " + ", ".join(f"{k} {v}" for k, v in units.items() if v) + "\n")
        out.write("  parameters (--param NAME=VALUE, angles in rad or NAME=45deg; defaults "
                  "apply to any not given):\n")  # fmt: skip
        out.write(f"    {'name':<10} {'default':>10} {'unit':<7} {'open interval':<22} meaning\n")
        for p in m["parameters"]:
            out.write(f"    {p['name']:<10} {fmt(p['default']):>10} {p['unit'] or '-':<7} "
                      f"{_bounds(p):<22} {p['meaning']}\n")  # fmt: skip
        narrower: dict[str, list[str]] = {}
        for p in m["parameters"]:
            low, high = p["computed"]
            if [low, high] != [p["lower"], p["upper"]]:
                end = ")" if p["upper"] is not None and high >= p["upper"] else "]"
                shown = f"{low:.3g}, {p['upper'] if end == ')' else high:.3g}{end}"
                narrower.setdefault(p["computed_reason"], []).append(f"{p['name']} in [{shown}")
        for reason, ranges in narrower.items():
            out.write(f"  computed only for {', '.join(ranges)}: {reason}\n")
        section = m["section"]
        out.write(f"  state (--state NAME=VALUE), {section['when']}:\n")
        for s in m["state"]:
            if s["kind"] == "coordinate":
                out.write(f"    {s['name']:<10} [{s['unit']}] {s['meaning']}, from "
                          f"{s['reference']}, positive with {s['positive']}; rate "
                          f"{s['rate']}\n")  # fmt: skip
            else:
                out.write(f"    {s['name']:<10} [{s['unit']}] {s['meaning']}\n")
        determined = ", ".join(section["determined"]) or "none"
        box = ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in
                        section["search_box"].items())  # fmt: skip
        out.write(f"  section: {determined} determined by the others there; gaits searched in "
                  f"{box}\n")  # fmt: skip
        out.write("  failures: " + "; ".join(
            f"{f['name']} ({f['meaning']}; margin in {f['unit']})" for f in m["failures"]
        ) + "\n")  # fmt: skip
        if m["conditions"]:
            out.write("  reported, not enforced: " + "; ".join(
                f"{c['name']} ({c['meaning']}; margin in {c['unit']})" for c in m["conditions"]
            ) + "\n")  # fmt: skip
        held = [f"{', '.join(_actuator(m, h) for h in names)} in {phase}"
                for phase, names in m["actuators"].items()]  # fmt: skip
        for event in m["jumps"]:  # a package derived before `actuated` names no coordinate
            acting = ", ".join(_actuator(m, h) for h in m["actuated"].get(event, ()))
            held.append(f"{acting or 'an actuator'} at the jump at {event}")
        for event, coordinates in m["actuated"].items():
            named = [h for h in coordinates if h in m["actuator_names"]]
            if event not in m["jumps"] and named:  # a lock an actuator catches (its work)
                held.append(f"{', '.join(_actuator(m, h) for h in named)} catching at {event}")
        if held:
            out.write(f"  actuators doing work: "
                      f"{'; '.join(held)}\n")  # fmt: skip
        for phase, inputs in m["inputs"].items():
            out.write(f"  inputs in {phase} (zero when walking passively): " + "; ".join(
                f"{i['name']} [{i['unit']}] by the {i['actuator']}, along {i['along']} "
                f"({i['description']})" for i in inputs
            ) + "\n")  # fmt: skip
        for event, impulses in m.get("impulses", {}).items():
            out.write(f"  impulses at {event} (zero when walking passively): " + "; ".join(
                f"{i['name']} [{i['unit']}] by the {i['actuator']}, along {i['along']}, "
                f"{_APPLIED[i['applied']]} ({i['description']})" for i in impulses
            ) + "\n")  # fmt: skip
        if m["features"]:
            out.write(f"  also: {', '.join(m['features'])}\n")
    return EXIT_OK


def _actuator(description: dict, coordinate: str) -> str:
    """An actuator by the model's name for it and the coordinate it holds: ``leg (r)``."""
    name = description["actuator_names"].get(coordinate)
    return f"{name} ({coordinate})" if name else coordinate
