"""The options every command shares: the model, its parameters, and what takes a model's
names (``--state``, ``--over``, ``--grid``, ``--search``).

``--model NAME`` picks any model of ``vsw models`` (default ``ile``); every parameter has
the default its table states, so no parameter is required. ``--param NAME=VALUE`` sets one
in the table's units, an angle also in degrees (``--param phi0=45deg``); ``--beta``,
``--theta-ii`` and ``--phi0`` (degrees) set the paper's parameters of any model that has
them. Options of a feature a model lacks (:data:`vsw.models.base.FEATURES`) are refused
with the models that have it. The checks that need the model run right after argparse's
own (:func:`after_parse`), so their errors come where argparse's would.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import warnings
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

import numpy as np

from vsw import models
from vsw.cli.parser import given, option_name
from vsw.dynamics.parameters import beyond_computed
from vsw.models.base import FEATURES, Model
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError, InfeasibleError, VswInputError

__all__ = [
    "MAX_GRID",
    "add_model_options",
    "after_parse",
    "parse_grid",
    "parse_over",
    "parse_search",
    "parse_state",
    "solver_errors",
]

MAX_GRID = 100_000
"""Most points of a ``--over`` sweep (before the limits)."""

MAX_GRID_SIDE = 4000
"""Most values along one ``--grid`` axis."""

NAMED = (("beta", "--beta", ""), ("theta_II", "--theta-ii", "deg"), ("phi0", "--phi0", "deg"))
"""The paper's parameters with options of their own: (parameter, option, unit given in)."""


def model_type(name: str) -> str:
    """argparse ``type`` of ``--model``: the package key of a model name."""
    try:
        return models.key(name)
    except VswInputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_model_options(
    parser: argparse.ArgumentParser,
    command: str,
    *,
    named: bool = True,
    features: Mapping[str, str] | None = None,
) -> None:
    """``--model``, ``--param``, the named parameters and ``--json`` of a command, and its
    check after parsing. ``features``: option dest -> the feature it needs."""
    names = ", ".join(models.cli_name(k) for k in models.keys())
    parser.add_argument("--model", type=model_type, default="ile", metavar="NAME",
                        help=f"the model: {names} (see 'vsw models'), or a model file of "
                        "yours, path/to/model.py (derived on first use)")  # fmt: skip
    parser.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="a model parameter in the units of 'vsw models' (an angle in rad, or with a deg "
        "suffix: phi0=45deg); repeatable; parameters not given take their defaults",
    )
    if named:
        bipeds = "vsw-biped, vsw-biped-fte, vsw-biped-phi0"
        parser.add_argument("--beta", type=float, help=f"beta (ile, tle, {bipeds})")
        parser.add_argument("--theta-ii", type=float, help=f"theta_II [deg] (ile, tle, {bipeds})")
        parser.add_argument("--phi0", type=float, help="phi0 [deg] (ile, tle, vsw-biped-phi0)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    needs = dict(features or {})
    parser.after_parse = lambda p, args: after_parse(p, args, command, needs)


def after_parse(
    parser: argparse.ArgumentParser, args: argparse.Namespace, command: str,
    features: Mapping[str, str],
) -> None:  # fmt: skip
    """Checks that need the model, made right after argparse's own (same message form).

    Sets ``args.model_object`` and ``args.values`` (validated parameter values by name, in
    the table's units). Refuses a parameter given twice, one that is also swept by
    ``--over``, a named option of a parameter the model lacks, and an option of a feature
    the model does not have.
    """
    model = models.load(args.model)
    args.model_object = model
    over = getattr(args, "over", None)
    swept = over.partition("=")[0].strip() if over else None
    values: dict[str, float] = {}
    table = {p.name: p for p in model.parameter_table}
    for item in args.param or ():
        name, text = split_item("--param", item)
        p = parameter_named(model, "--param", name)
        if name in values:
            parser.error(f"--param {name} given twice: give each parameter once")
        values[name] = parameter_value("--param", p, text)
    for name, option, unit in NAMED if hasattr(args, "beta") else ():
        dest = option[2:].replace("-", "_")
        flag = getattr(args, dest, None)
        if flag is None:
            continue
        if name not in table:
            parser.error(f"{option}: {model.cli_name} has no parameter {name} (its parameters: "
                         f"{', '.join(table)}; see 'vsw models')")  # fmt: skip
        if name in values:
            parser.error(f"{name} given twice, as {option} and as --param {name}: give it once")
        text = f"{flag!r}{unit}"
        given_as = f"{option} {flag:g}" + (f" {unit} = {math.radians(flag):.6g} rad" if unit
                                           else "")  # fmt: skip
        values[name] = parameter_value(option, table[name], text, given_as)
    if swept is not None and swept in values:
        parser.error(f"{swept} is swept by --over: do not also give it as a parameter")
    for dest, feature in features.items():
        if given(parser, args, dest) and feature not in model.features:
            having = [models.cli_name(k) for k in models.keys()
                      if feature in models.load(k).features]  # fmt: skip
            parser.error(f"{option_name(parser, dest)} needs {FEATURES[feature].split(':')[0]}"
                         f", which {model.cli_name} does not have (models with it: "
                         f"{', '.join(having) or 'none'})")  # fmt: skip
    args.values = values


def refuse_powered_only(model: Model, command: str) -> None:
    """A command that works on passive gaits refuses a model that has none (one line)."""
    if model.spec.get("powered_only"):
        raise VswInputError(f"vsw {command} --model {model.cli_name}: it walks only powered "
                            "(no passive gait to work on): 'vsw optimize' finds its "
                            "gaits")  # fmt: skip


def model_and_parameters(args: argparse.Namespace) -> tuple[Model, tuple[float, ...]]:
    """The model and its full parameter vector (defaults for what was not given)."""
    return args.model_object, args.model_object.parameters(args.values)


# --- NAME=VALUE items -------------------------------------------------------------------------


def split_item(option: str, item: str) -> tuple[str, str]:
    name, sep, value = item.partition("=")
    if not sep or not name.strip():
        raise VswInputError(f"{option} {item!r}: expected NAME=VALUE")
    return name.strip(), value.strip()


def number(text: str, degrees: bool = False) -> float:
    """``text`` as a float (NaN when it is none); with ``degrees`` a ``deg`` suffix turns
    degrees into radians."""
    text = text.strip()
    scale = 1.0
    if degrees and text.lower().endswith("deg"):
        text, scale = text[:-3].strip(), math.pi / 180.0
    try:
        return float(text) * scale
    except ValueError:
        return math.nan


def _interval(p: Any) -> str:
    unit = "" if p.unit in ("", "1") else f" {p.unit}"
    return f"({p.lower:.6g}, {p.upper:.6g}){unit}"


def parameter_value(option: str, p: Any, text: str, given: str | None = None) -> float:
    """``text`` as a value of parameter ``p``: a number in the table's open interval (an
    angle's also with a ``deg`` suffix). ``given``: how the command line gave it, for the
    message (default ``OPTION NAME=TEXT``)."""
    value = number(text, degrees=p.unit == "rad")
    if not p.lower < value < p.upper:
        shown = f" = {math.degrees(value):.6g} deg" if p.unit == "rad" and "deg" in text else ""
        where = given or f"{option} {p.name}={text.strip()}{shown}"
        raise VswInputError(
            f"{where}: {p.name} must be a number in the open interval {_interval(p)}: {p.reason}"
        )
    computed = p.computed
    if computed is not None and not computed[0] <= value <= computed[1]:
        where = given or f"{option} {p.name}={text.strip()}"
        raise VswInputError(f"{where}: {p.name} {beyond_computed(p)}")
    return value


def parameter_named(model: Model, option: str, name: str) -> Any:
    """The model's parameter ``name`` given to ``option``; one line naming the choices if
    it has none."""
    table = {p.name: p for p in model.parameter_table}
    if name not in table:
        raise VswInputError(
            f"{option}: {name!r} is not a parameter of {model.cli_name}: choose from "
            f"{', '.join(table)} (see 'vsw models')"
        )
    return table[name]


def parse_over(model: Model, text: str) -> tuple[str, np.ndarray]:
    """``--over NAME=START:STOP:N``: the parameter and its N values (table units; angles
    also with ``deg``)."""
    name, spec = split_item("--over", text)
    p = parameter_named(model, "--over", name)
    parts = spec.split(":")
    if len(parts) != 3:
        raise VswInputError(f"--over {text!r}: expected NAME=START:STOP:N")
    start = parameter_value("--over", p, parts[0])
    stop = parameter_value("--over", p, parts[1])
    try:
        count = int(parts[2].strip())
    except ValueError:
        count = 0
    if not 1 <= count <= MAX_GRID:
        raise VswInputError(
            f"--over {text!r}: N = {parts[2].strip()!r} must be an integer from 1 to {MAX_GRID}"
        )
    return name, np.linspace(start, stop, count)


def given_in_degrees(model: Model, name: str, text: str | None) -> bool:
    """Whether a range of parameter ``name`` (``NAME=START:STOP[:N]`` of ``--over`` or
    ``--free``) was given in degrees: an angle's text with a ``deg`` suffix. Its text output
    then shows it in degrees too (its JSON stays in the table's unit, rad)."""
    if not text:
        return False
    unit = next((p.unit for p in model.parameter_table if p.name == name), None)
    return unit == "rad" and "deg" in text.partition("=")[2].lower()


def parameters_in_degrees(args: argparse.Namespace) -> set[str]:
    """The parameters the command line gave in degrees: ``--param NAME=VALUEdeg`` of an
    angle, and the named ``--theta-ii`` and ``--phi0``."""
    table = {p.name: p for p in args.model_object.parameter_table}
    names = {
        name
        for name, text in (split_item("--param", item) for item in args.param or ())
        if name in table and table[name].unit == "rad" and "deg" in text.lower()
    }
    for name, option, unit in NAMED:
        if unit == "deg" and getattr(args, option[2:].replace("-", "_"), None) is not None:
            names.add(name)
    return names


def echo(value: float | None, degrees: bool) -> float | None:
    """A value in rad as the text output shows it: in degrees where given in degrees."""
    return value if value is None or not degrees else math.degrees(value)


def _state_units(model: Model) -> dict[str, str]:
    return {s["name"]: s["unit"] for s in model.spec["state"]}


def parse_state(model: Model, items: Sequence[str]) -> list[float]:
    """``--state NAME=VALUE`` items: every coordinate and rate (angles also with ``deg``)."""
    names = [*model.coordinates, *model.rates]
    units = _state_units(model)
    values: dict[str, float] = {}
    for item in items:
        name, text = split_item("--state", item)
        if name not in names:
            raise VswInputError(
                f"--state: {name!r} is not a coordinate or rate of {model.cli_name}: choose "
                f"from {', '.join(names)}"
            )
        if name in values:
            raise VswInputError(f"--state {name} given twice: give each once")
        value = number(text, degrees=units.get(name) == "rad")
        if not math.isfinite(value):
            raise VswInputError(f"--state {name}={text}: {name} must be a finite number")
        values[name] = value
    missing = [n for n in names if n not in values]
    if missing:
        raise VswInputError(
            f"--state: give every coordinate and rate ({', '.join(names)}); missing "
            f"{', '.join(missing)}"
        )
    return [values[n] for n in names]


def _interval_values(option: str, item: str, text: str, degrees: bool) -> tuple[float, float]:
    parts = text.split(":")
    if len(parts) < 2:
        raise VswInputError(f"{option} {item!r}: expected NAME=START:STOP")
    start, stop = number(parts[0], degrees), number(parts[1], degrees)
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise VswInputError(f"{option} {item!r}: START and STOP must be finite numbers")
    if not start < stop:
        raise VswInputError(f"{option} {item!r}: START = {start:g} must be below STOP = {stop:g}")
    if not math.isfinite(stop - start):
        raise VswInputError(
            f"{option} {item!r}: STOP - START = {stop:g} - ({start:g}) overflows double "
            "precision: give a narrower interval"
        )
    return start, stop


def parse_grid(model: Model, item: str) -> tuple[str, np.ndarray]:
    """``--grid NAME=START:STOP:N``: a section component and its N evenly spaced values."""
    name, text = split_item("--grid", item)
    parts = text.split(":")
    if len(parts) != 3:
        raise VswInputError(f"--grid {item!r}: expected NAME=START:STOP:N")
    start, stop = _interval_values("--grid", item, text, _state_units(model).get(name) == "rad")
    try:
        count = int(parts[2])
    except ValueError:
        raise VswInputError(f"--grid {item!r}: N = {parts[2]!r} must be an integer") from None
    if not 2 <= count <= MAX_GRID_SIDE:
        raise VswInputError(f"--grid {item!r}: N = {count} must be from 2 to {MAX_GRID_SIDE}")
    return name, np.linspace(start, stop, count)


def parse_search(model: Model, items: Sequence[str] | None) -> dict[str, tuple[float, float]]:
    """``--search NAME=START:STOP`` items: intervals replacing the model's search box."""
    box: dict[str, tuple[float, float]] = {}
    units = _state_units(model)
    for item in items or ():
        name, text = split_item("--search", item)
        if name not in model.spec["search"]:
            raise VswInputError(
                f"--search {name}: not a free component of the {model.cli_name} model's "
                f"section: choose from {', '.join(model.spec['search'])}"
            )
        if name in box:
            raise VswInputError(f"--search {name} given twice: give each once")
        box[name] = _interval_values("--search", item, text, units.get(name) == "rad")
    return box


# --- running the models' solvers under the CLI's contract --------------------------------------


@contextlib.contextmanager
def solver_errors(model: Model) -> Iterator[None]:
    """Model work under the CLI's contract: one line on stderr, exit 3 for a solver.

    CasADi writes its diagnostics through Python's ``sys.stderr`` and SciPy/numpy warn
    about overflow at extreme parameters; the commands report non-finite results as
    failures or missing gaits, so both are kept off stderr here. A CasADi error (a plain
    RuntimeError, e.g. CVODES failing on non-finite values) becomes a ConvergenceError
    with its last line. Progress bars made before entering keep the real stderr.
    """
    with (
        contextlib.redirect_stderr(io.StringIO()),
        warnings.catch_warnings(),
        np.errstate(all="ignore"),
    ):
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            yield
        except (ConvergenceError, InfeasibleError):
            stop.check()  # a solver's failure may be a stop that a library turned into one
            raise
        except (OverflowError, ZeroDivisionError) as exc:
            # Generated code on Python floats raises where IEEE arithmetic would overflow
            # (the parameter tables' computed ranges keep this away from their edges).
            raise ConvergenceError(
                f"{model.cli_name}: double precision overflows at these parameters ({exc}); "
                "bring them closer to the defaults"
            ) from None
        except RuntimeError as exc:
            stop.check()
            last = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
            raise ConvergenceError(
                f"{model.cli_name}: a CasADi solver failed: {last.rsplit(': ', 1)[-1]}"
            ) from None
