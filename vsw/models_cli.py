"""Models on the command line: ``vsw models``, ``--model``, ``--param`` and ``vsw sweep``.

Every generated package (``generated.MODELS``) is a model of the command line, named with
``-`` (``rimless-wheel``; ``_`` is accepted too). The ILE keeps its own commands (its closed
forms, conditions and compiled kernels in :mod:`vsw.cli`); every other model with a
``HYBRID`` descriptor runs through the generic runtime :mod:`vsw.hybrid`:

* ``analyze``: the distinct period-one gaits from a scan of starts
  (:meth:`vsw.hybrid.HybridModel.fixed_points`);
* ``simulate``: the Poincaré map iterated from the first gait or from ``--state``;
* ``basin``: for models of one coordinate, the section rates whose walk converges to the
  stable gait, from a grid of rates;
* ``sweep``: the gait continued along one parameter (each point's orbit solved from the
  previous one with :meth:`~vsw.hybrid.HybridModel.periodic_orbit`).

Parameters come as ``--param NAME=VALUE`` in the units of the model's parameter table
(angles in radians), validated against its open intervals; the ILE's ``--beta``,
``--theta-ii``, ``--phi0`` (degrees) stay and combine with ``--param``. The checks that
need the model (names, conflicts, options of the other kind of model) run when the
arguments are parsed (:func:`after_parse`), so their errors come where argparse's would.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import math
import sys
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

from vsw.errors import ConvergenceError, InfeasibleError, ModelConditionError, VswInputError

__all__ = [
    "ILE",
    "MAX_GRID",
    "add_model_options",
    "after_parse",
    "cli_name",
    "describe",
    "model_keys",
    "parse_params",
]

ILE = "ile"
"""The model whose commands are the closed-form ones of :mod:`vsw.cli`."""

MAX_GRID = 100_000
"""Most rates of a ``vsw basin`` grid and points of a ``vsw sweep`` (before the limits)."""


# --- the models and their parameter tables ------------------------------------------------


def model_keys() -> tuple[str, ...]:
    """The generated model packages (``generated.<key>``)."""
    import generated

    return tuple(generated.MODELS)


def cli_name(key: str) -> str:
    """A model's name on the command line: ``rimless_wheel`` -> ``rimless-wheel``."""
    return key.replace("_", "-")


def model_type(name: str) -> str:
    """argparse ``type`` of ``--model``: the package key of a model name."""
    key = name.strip().replace("-", "_")
    if key not in model_keys():
        names = ", ".join(cli_name(k) for k in model_keys())
        raise argparse.ArgumentTypeError(f"{name!r} is not a model: choose from {names}")
    return key


def _module(key: str):
    return importlib.import_module(f"generated.{key}")


def parameter_table(key: str) -> tuple:
    """``generated.<key>.params.PARAMETERS``."""
    return importlib.import_module(f"generated.{key}.params").PARAMETERS


def _title_and_units(module: Any) -> tuple[str, str]:
    """The derivation's title and units sentence, from the generated module's docstring
    (``derive.codegen.python_module`` writes ``"<title>: derived quantities ..."`` and the
    units after ``"expressions. "``): the one place the runtime has them for every model."""
    doc = module.__doc__ or ""
    title, sep, _ = doc.partition(": derived quantities")
    units = doc.partition("expressions. ")[2].strip()
    spec = getattr(module, "HYBRID", None)
    if not sep and spec is not None:
        title = spec["title"]
    return title.strip(), " ".join(units.split())


def _bound(value: float) -> float | None:
    """A table bound for JSON: None where it is infinite (no bound)."""
    return float(value) if math.isfinite(value) else None


def describe(key: str) -> dict[str, Any]:
    """One model as ``vsw models --json`` lists it."""
    module = _module(key)
    title, units = _title_and_units(module)
    spec = getattr(module, "HYBRID", None)
    return {
        "name": cli_name(key),
        "title": title,
        "description": spec.get("description", title) if spec else title,
        "units": units,
        "state": list(spec["coordinates"] + spec["rates"]) if spec else None,
        "parameters": [
            {
                "name": p.name,
                "default": p.default,
                "unit": p.unit,
                "lower": _bound(p.lower),
                "upper": _bound(p.upper),
                "description": p.description,
                "reason": p.reason,
            }
            for p in parameter_table(key)
        ],
    }


def _bounds(p: Any) -> str:
    return f"({p.lower:.6g}, {p.upper:.6g})"


def _interval(p: Any) -> str:
    """The open interval of a parameter with its unit, for messages."""
    unit = f" {p.unit}" if p.unit and p.unit != "1" else ""
    return _bounds(p) + unit


def cmd_models(args: argparse.Namespace) -> int:
    """``vsw models``: every model, its units and its parameter table."""
    from vsw.cli import EXIT_OK, _dump_json, _fmt

    models = [describe(key) for key in model_keys()]
    if args.json:
        _dump_json(models, sys.stdout)
        return EXIT_OK
    out = sys.stdout
    for n, m in enumerate(models):
        if n:
            out.write("\n")
        out.write(f"{m['name']}: {m['description']}\n")
        out.write(f"  units: {m['units']}\n")
        if m["state"]:
            out.write(f"  state (--state): {', '.join(m['state'])}\n")
        if m["name"] == ILE:
            out.write("  parameters: --beta, --theta-ii, --phi0 (deg) or --param NAME=VALUE\n")
        else:
            out.write(f"  parameters: --param NAME=VALUE (--model {m['name']})\n")
        out.write(
            f"    {'name':<10} {'default':>10} {'unit':<7} {'open interval':<22} description\n"
        )
        for p in parameter_table(m["name"].replace("-", "_")):
            out.write(
                f"    {p.name:<10} {_fmt(p.default):>10} {p.unit or '-':<7} {_bounds(p):<22} "
                f"{p.description}\n"
            )
    return EXIT_OK


# --- --param, --state, --over ---------------------------------------------------------------


def _split(option: str, item: str) -> tuple[str, str]:
    name, sep, value = item.partition("=")
    if not sep or not name.strip():
        raise VswInputError(f"{option} {item!r}: expected NAME=VALUE")
    return name.strip(), value.strip()


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def _parameter_value(option: str, p: Any, text: str) -> float:
    """``text`` as a value of parameter ``p``: a number in the table's open interval."""
    value = _number(text)
    if not p.lower < value < p.upper:
        raise VswInputError(
            f"{option} {p.name}={text}: {p.name} must be a number in the open interval "
            f"{_interval(p)}: {p.reason}"
        )
    return value


def _lookup(key: str, option: str, name: str) -> Any:
    table = {p.name: p for p in parameter_table(key)}
    if name not in table:
        raise VswInputError(
            f"{option}: {name!r} is not a parameter of {cli_name(key)}: choose from "
            f"{', '.join(table)} (see 'vsw models')"
        )
    return table[name]


def parse_params(key: str, items: Sequence[str] | None) -> dict[str, float]:
    """``--param NAME=VALUE`` items as validated values (table units, angles in rad).

    Raises
    ------
    VswInputError
        One line for a malformed item, an unknown name, a name given twice, or a value
        that is not a number in the parameter's open interval (named with the interval).
    """
    out: dict[str, float] = {}
    for item in items or ():
        name, text = _split("--param", item)
        p = _lookup(key, "--param", name)
        if name in out:
            raise VswInputError(f"--param {name} given twice: give each parameter once")
        out[name] = _parameter_value("--param", p, text)
    return out


def parse_over(key: str, text: str) -> tuple[str, Any]:
    """``--over NAME=START:STOP:N``: the parameter and its N values (numpy array)."""
    import numpy as np

    name, spec = _split("--over", text)
    p = _lookup(key, "--over", name)
    parts = spec.split(":")
    if len(parts) != 3:
        raise VswInputError(f"--over {text!r}: expected NAME=START:STOP:N")
    start = _parameter_value("--over", p, parts[0].strip())
    stop = _parameter_value("--over", p, parts[1].strip())
    try:
        count = int(parts[2].strip())
    except ValueError:
        count = 0
    if not 1 <= count <= MAX_GRID:
        raise VswInputError(
            f"--over {text!r}: N = {parts[2].strip()!r} must be an integer from 1 to {MAX_GRID}"
        )
    return name, np.linspace(start, stop, count)


def _ile_flag(p: Any) -> tuple[str, str]:
    """The ILE's named option of a parameter: (dest, option), e.g. ('theta_ii', '--theta-ii')."""
    dest = p.name.lower()
    return dest, "--" + dest.replace("_", "-")


def ile_values(args: argparse.Namespace, names: Sequence[str]) -> dict[str, float]:
    """ILE parameters in radians from the named options (degrees for angles) and --param."""
    out = {}
    for p in parameter_table(ILE):
        if p.name not in names:
            continue
        dest, _ = _ile_flag(p)
        flag = getattr(args, dest, None)
        if flag is None:
            out[p.name] = args.params[p.name]
        else:
            out[p.name] = math.radians(flag) if p.cli_degrees else float(flag)
    return out


# --- options and the checks made when the arguments are parsed -----------------------------


class StoreGiven(argparse.Action):
    """``store`` that also records that the option was given (its default may be a value)."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        setattr(namespace, self.dest, values)
        namespace.given = set(getattr(namespace, "given", ())) | {self.dest}


def _given(parser: argparse.ArgumentParser, args: argparse.Namespace, dest: str) -> bool:
    """Whether the option ``dest`` was on the command line."""
    action = next(a for a in parser._actions if a.dest == dest)
    if isinstance(action, StoreGiven):
        return dest in getattr(args, "given", ())
    return getattr(args, dest) not in (None, False)  # options whose default is None/False


_ILE_ONLY = {
    "analyze": ("leg_length", "mass", "gravity", "stepper_2d"),
    "simulate": ("q0", "plot"),
    "basin": ("theta_min", "theta_max", "theta_step", "n_q", "check_edges"),
    "sweep": (),
    "animate": ("q0",),
}
_HYBRID_ONLY = {
    "analyze": (),
    "simulate": ("state",),
    "basin": ("rate_min", "rate_max", "n_rates", "max_steps", "tol", "grid", "steps", "scheduler"),
    "sweep": ("y", "keep", "transient", "brute_force", "state"),
    "animate": ("state",),
}
# The ILE's required options after the gait parameters, in the order argparse named them.
_ILE_REQUIRED = {
    "analyze": (),
    "simulate": ("--q0", "--steps"),
    "basin": (),
    "sweep": (),
    "animate": ("--q0",),
}
_ILE_GAIT = {  # the ILE parameters a command takes (basin: theta_II is its axis)
    "analyze": ("beta", "theta_II", "phi0"),
    "simulate": ("beta", "theta_II", "phi0"),
    "basin": ("beta", "phi0"),
    "sweep": ("beta", "theta_II", "phi0"),
    "animate": ("beta", "theta_II", "phi0"),
}


def add_model_options(parser: argparse.ArgumentParser, command: str) -> None:
    """``--model`` and ``--param`` of a command, and its check after parsing."""
    names = ", ".join(cli_name(k) for k in model_keys())
    parser.add_argument(
        "--model",
        type=model_type,
        default=ILE,
        metavar="NAME",
        help=f"the model: {names} (see 'vsw models')",
    )
    parser.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="a model parameter in the units of 'vsw models' (angles in rad); repeatable",
    )
    parser.after_parse = lambda p, args: after_parse(p, args, command)


def _option(parser: argparse.ArgumentParser, dest: str) -> str:
    action = next(a for a in parser._actions if a.dest == dest)
    return "/".join(action.option_strings)


def after_parse(parser: argparse.ArgumentParser, args: argparse.Namespace, command: str) -> None:
    """Checks that need the model, made right after argparse's own (same message form).

    Sets ``args.params`` (validated ``--param`` values). Raises a usage error for options
    of the other kind of model, the ILE's missing required options (the message argparse
    gave when they were required), and a parameter given both by name and by --param.
    """
    key = args.model
    args.params = parse_params(key, args.param)
    over = getattr(args, "over", None)
    over_name = over.partition("=")[0].strip() if over else None
    if over_name in args.params:
        parser.error(f"{over_name} is swept by --over: do not give it with --param")
    ile_table = parameter_table(ILE)
    if key != ILE:
        for p in ile_table:
            dest, option = _ile_flag(p)
            if getattr(args, dest, None) is not None:
                parser.error(
                    f"{option} is an option of the ile model; {cli_name(key)} takes "
                    "--param NAME=VALUE"
                )
        for dest in _ILE_ONLY[command]:
            if _given(parser, args, dest):
                parser.error(f"{_option(parser, dest)} is an option of the ile model only")
        missing = [] if command != "simulate" or args.steps is not None else ["--steps"]
    else:
        for dest in _HYBRID_ONLY[command]:
            if _given(parser, args, dest):
                parser.error(f"{_option(parser, dest)} is not an option of the ile model")
        missing = []
        for p in ile_table:
            dest, option = _ile_flag(p)
            by_name = getattr(args, dest, None) is not None
            if p.name not in _ILE_GAIT[command]:
                if p.name in args.params:
                    parser.error(
                        f"--param {p.name}: theta_II is the basin's axis: give "
                        "--theta-min/--theta-max/--theta-step (deg) instead"
                    )
                continue
            if by_name and p.name in args.params:
                parser.error(
                    f"{p.name} given twice, as {option} and as --param {p.name}: give it once"
                )
            if p.name == over_name:
                if by_name:
                    parser.error(f"{p.name} is swept by --over: drop {option}")
                continue
            if not by_name and p.name not in args.params:
                missing.append(option)
        for option in _ILE_REQUIRED[command]:
            if getattr(args, option[2:].replace("-", "_")) is None:
                missing.append(option)
    if missing:
        parser.error(f"the following arguments are required: {', '.join(missing)}")


# --- the commands on engine models ----------------------------------------------------------


def _hybrid(key: str, command: str):
    """The engine model ``key`` for ``command``, or a one-line refusal."""
    from vsw.models import load

    if not hasattr(_module(key), "HYBRID"):
        raise VswInputError(
            f"vsw {command} --model {cli_name(key)}: not available for this model yet (it has "
            "no HYBRID descriptor for the generic runtime)"
        )
    return load(key)


@contextlib.contextmanager
def _engine(model: Any) -> Iterator[None]:
    """Engine work under the CLI's contract: one line on stderr, exit 3 for a solver.

    CasADi writes its diagnostics through Python's ``sys.stderr`` and SciPy/numpy warn
    about overflow at extreme parameters; the commands report non-finite results as
    failures or missing gaits, so both are kept off stderr here. A CasADi error (a plain
    RuntimeError, e.g. CVODES failing on non-finite values) becomes a ConvergenceError
    with its last line. Progress bars made before entering keep the real stderr.
    """
    import numpy as np

    with (
        contextlib.redirect_stderr(io.StringIO()),
        warnings.catch_warnings(),
        np.errstate(all="ignore"),
    ):
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            yield
        except (ConvergenceError, InfeasibleError):
            raise
        except RuntimeError as exc:
            last = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
            raise ConvergenceError(
                f"{cli_name(model.name)}: a CasADi solver failed: {last.rsplit(': ', 1)[-1]}"
            ) from None


def _clean(value: Any) -> Any:
    """Nested dicts/lists of numbers for strict JSON (NaN and infinities become None)."""
    from vsw.models.ile.analysis import _jsonable

    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    return _jsonable(value)


def _state_dict(model, x: Sequence[float]) -> dict[str, float]:
    return dict(zip(model.coordinates + model.rates, (float(v) for v in x)))


def _units(model) -> dict[str, str]:
    time = model.units.get("time", "")
    length = model.units.get("length", "")
    return {"time": time, "length": length, "speed": f"{length}/{time}" if time else ""}


def failure_at_start(model, params: Sequence[float], state: Sequence[float]) -> str | None:
    """The failure a step starting at ``state`` is already past, if any
    (:meth:`vsw.hybrid.HybridModel.failure_at` in the phase that starts a step)."""
    return model.failure_at(model.step_event["target"], params, [float(v) for v in state])


def _pick(orbits: Sequence[Any]) -> Any | None:
    """The gait the commands follow: the first stable one, else the first."""
    stable = [o for o in orbits if o.stable]
    return (stable or list(orbits) or [None])[0]


def _write_params(out, model, params: Sequence[float]) -> None:
    units = {p.name: p.unit for p in model.parameter_table}
    text = ", ".join(f"{n} = {v:.6g} {units[n]}".rstrip() for n, v in zip(units, params))
    out.write(f"{'model':<18} {cli_name(model.name)} ({model.title})\n")
    out.write(f"{'parameters':<18} {text}\n")


def _write_orbit(out, orbit: Any, units: dict[str, str]) -> None:
    from vsw.cli import _fmt

    for name, value in orbit.state.items():
        out.write(f"  {name:<16} {_fmt(value):>14}\n")
    out.write(f"  {'period':<16} {_fmt(orbit.period):>14}  {units['time']}\n")
    out.write(f"  {'step_length':<16} {_fmt(orbit.step_length):>14}  {units['length']}\n")
    out.write(f"  {'speed':<16} {_fmt(orbit.speed):>14}  {units['speed']}\n")
    out.write(f"  {'max |eigenvalue|':<16} {_fmt(orbit.max_abs_eigenvalue):>14}\n")
    out.write(f"  {'stable':<16} {_fmt(orbit.stable):>14}\n")
    values = ", ".join(
        _fmt(e.real) if e.imag == 0 else f"{e.real:.6g}{e.imag:+.6g}j" for e in orbit.eigenvalues
    )
    out.write(f"  {'eigenvalues':<16} {values}\n")


def cmd_analyze(args: argparse.Namespace) -> int:
    """``vsw analyze --model NAME``: the period-one gaits from a scan of starts."""
    from vsw.cli import EXIT_OK, _dump_json

    model = _hybrid(args.model, "analyze")
    params = model.parameters(args.params)
    with _engine(model):
        orbits = model.fixed_points(params)
    data = {
        "model": cli_name(model.name),
        "parameters": dict(zip(model.spec["parameters"], params)),
        "units": dict(model.units),
        "fixed_points": [o.to_dict() for o in orbits],
    }
    if args.json:
        _dump_json(_clean(data), sys.stdout)
        return EXIT_OK
    out = sys.stdout
    _write_params(out, model, params)
    out.write(f"{'units':<18} {_title_and_units(model.module)[1]}\n")
    out.write(
        f"\nperiod-one gaits found from a scan of starts: {len(orbits)} (state just after "
        f"the {model.step_event['name']} that starts a step)\n"
    )
    for n, orbit in enumerate(orbits, 1):
        out.write(f"gait {n}\n")
        _write_orbit(out, orbit, _units(model))
    return EXIT_OK


def _check_cost(model, what: str, work: dict[str, float], records: int, remedy: str) -> None:
    """Refuse work beyond the limits (vsw.limits) before it starts.

    ``work`` counts units of the per-unit costs of :mod:`vsw.limits` (``"scan"``,
    ``"step"``, ``"orbit"``), measured on the rimless wheel and scaled by the model's
    phases x coordinates; ``records`` steps or points are kept for the output.
    """
    from vsw import limits

    unit = {
        "scan": limits.HYBRID_SECONDS_SCAN,
        "step": limits.HYBRID_SECONDS_PER_PHASE,
        "orbit": limits.HYBRID_SECONDS_PER_ORBIT,
    }
    size = len(model.phases) * model.n
    seconds = size * sum(unit[k] * count for k, count in work.items())
    nbytes = limits.SIMULATE_BYTES_BASE + records * limits.HYBRID_BYTES_PER_STEP
    limits.check(what, limits.Cost(seconds, nbytes), remedy)


def _parse_state(model, items: Sequence[str]) -> list[float]:
    names = model.coordinates + model.rates
    values: dict[str, float] = {}
    for item in items:
        name, text = _split("--state", item)
        if name not in names:
            raise VswInputError(
                f"--state: {name!r} is not a coordinate or rate of {cli_name(model.name)}: "
                f"choose from {', '.join(names)}"
            )
        if name in values:
            raise VswInputError(f"--state {name} given twice: give each once")
        value = _number(text)
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


def cmd_simulate(args: argparse.Namespace) -> int:
    """``vsw simulate --model NAME``: the Poincaré map iterated for ``--steps`` steps."""
    import numpy as np

    from vsw.cli import EXIT_OK, _dump_json, _fmt, _progress

    model = _hybrid(args.model, "simulate")
    params = model.parameters(args.params)
    if args.steps < 1:
        raise VswInputError(f"steps = {args.steps} must be >= 1")
    start = _parse_state(model, args.state) if args.state else None
    work = {"step": args.steps, "scan": 0 if start else 1}
    _check_cost(model, f"simulating {args.steps} steps", work, args.steps, "use fewer --steps")
    if start is None:
        with _engine(model):
            orbit = _pick(model.fixed_points(params))
        if orbit is None:
            raise ModelConditionError(
                f"{cli_name(model.name)}: no period-one gait found from a scan of starts at "
                "these parameters; give the start with --state NAME=VALUE"
            )
        start = list(orbit.state.values())
        start_from = "fixed point"
    else:
        start_from = "--state"
    x = np.array(start, dtype=float)
    section, lengths, periods = [_state_dict(model, x)], [], []
    with _progress("simulate") as bar, _engine(model):
        ended = failure_at_start(model, params, x) or "completed"
        for n in range(args.steps if ended == "completed" else 0):
            result = model.step(params, x)
            if result.ended != "completed":
                ended = result.ended
                break
            x = result.state
            section.append(_state_dict(model, x))
            lengths.append(result.step_length)
            periods.append(sum(result.durations))
            bar(n + 1, args.steps)
    data = {
        "model": cli_name(model.name),
        "parameters": dict(zip(model.spec["parameters"], params)),
        "start_from": start_from,
        "steps": args.steps,
        "section_states": section,
        "step_lengths": lengths,
        "step_periods": periods,
        "ended": ended,
        "steps_completed": len(section) - 1,
    }
    if args.json:
        _dump_json(_clean(data), sys.stdout)
        return EXIT_OK
    out = sys.stdout
    _write_params(out, model, params)
    out.write(f"ended: {ended} after {data['steps_completed']} of {args.steps} steps\n")
    names = model.coordinates + model.rates
    out.write(f"{'step':>5} " + " ".join(f"{n:>14}" for n in names) + f" {'step_length':>14}\n")
    for n, state in enumerate(section):
        length = lengths[n - 1] if n else None
        out.write(
            f"{n:>5} " + " ".join(f"{_fmt(state[k]):>14}" for k in names) + f" {_fmt(length):>14}\n"
        )
    return EXIT_OK


def _intervals(rates: Sequence[float], classes: Sequence[str]) -> list[list[float]]:
    """Runs of consecutive grid rates that converge, as [first, last] pairs."""
    runs: list[list[float]] = []
    previous = False
    for rate, kind in zip(rates, classes):
        if kind == "converges":
            if previous:
                runs[-1][1] = float(rate)
            else:
                runs.append([float(rate), float(rate)])
        previous = kind == "converges"
    return runs


def cmd_basin(args: argparse.Namespace) -> int:
    """``vsw basin --model NAME``: section rates that converge to the stable gait."""
    import numpy as np

    from vsw.cli import EXIT_OK, _dump_json, _fmt, _progress

    model = _hybrid(args.model, "basin")
    if args.grid:
        return cmd_grid_basin(args, model)
    for dest, option in (("plot", "--plot"), ("scheduler", "--scheduler"), ("steps", "--steps")):
        if getattr(args, dest) is not None and (dest != "steps" or _given_option(args, dest)):
            raise VswInputError(f"{option} belongs to the basin over a grid: give --grid twice")
    if model.n != 1:
        name = cli_name(model.name)
        x, y = model.coordinates[0], model.rates[0]
        raise VswInputError(
            f"vsw basin --model {name}: give the 2-D slice of the section with --grid twice, "
            f"e.g. --grid {x}=START:STOP:N --grid {y}=START:STOP:N"
        )
    params = model.parameters(args.params)
    low, high = model.spec["rate_range"]
    rate_min = low if args.rate_min is None else args.rate_min
    rate_max = high if args.rate_max is None else args.rate_max
    for name, value in (("--rate-min", rate_min), ("--rate-max", rate_max), ("--tol", args.tol)):
        if not math.isfinite(value):
            raise VswInputError(f"{name} = {value} must be finite")
    if not rate_min < rate_max:
        raise VswInputError(f"--rate-min = {rate_min:g} must be below --rate-max = {rate_max:g}")
    if not 2 <= args.n_rates <= MAX_GRID:
        raise VswInputError(f"--n-rates = {args.n_rates} must be from 2 to {MAX_GRID}")
    if args.max_steps < 1:
        raise VswInputError(f"--max-steps = {args.max_steps} must be >= 1")
    if not 0 < args.tol < 1:
        raise VswInputError(f"--tol = {args.tol:g} must lie in (0, 1)")
    _check_cost(
        model,
        f"a basin of {args.n_rates} rates x up to {args.max_steps} steps",
        {"scan": 1, "step": args.n_rates * args.max_steps},
        args.n_rates,
        "use a smaller --n-rates or --max-steps",
    )
    from vsw.grid_basin import stable_gait

    with _engine(model):
        gait = stable_gait(model, params)
    target = np.array(list(gait.state.values()))
    scale = max(1.0, float(np.max(np.abs(target))))
    coordinate = model.coordinates[0]
    rates = np.linspace(rate_min, rate_max, args.n_rates)
    classes, ends, steps = [], [], []
    with _progress("basin") as bar, _engine(model):
        for i, rate in enumerate(rates):
            x = np.array([gait.state[coordinate], rate])
            ended = failure_at_start(model, params, x)
            n = 0
            while ended is None and n < args.max_steps:
                result = model.step(params, x)
                n += 1
                if result.ended != "completed":
                    ended = result.ended
                    break
                x = result.state
                if np.max(np.abs(x - target)) <= args.tol * scale:
                    ended = "converged"
            ended = ended or "not converged"
            kind = {"converged": "converges", "not converged": "other", "stalled": "other"}
            classes.append(kind.get(ended, "falls"))
            ends.append(ended)
            steps.append(n)
            bar(i + 1, len(rates))
    rate_name = model.rates[0]
    data = {
        "model": cli_name(model.name),
        "parameters": dict(zip(model.spec["parameters"], params)),
        "gait": gait.to_dict(),
        "section": {coordinate: gait.state[coordinate]},
        rate_name: [float(r) for r in rates],
        "class": classes,
        "ended": ends,
        "steps": steps,
        "converging": _intervals(rates, classes),
        "tol": args.tol,
        "max_steps": args.max_steps,
        "fields": {
            rate_name: f"the grid of {rate_name} just after the step event, {coordinate} at the "
            "gait's",
            "class": "converges (reaches the gait), falls (a failure ends the walk) or other "
            "(neither within max_steps, or the integration stalled)",
            "ended": "'converged', the failure's name, 'stalled' or 'not converged'",
            "steps": "steps of the Poincare map walked",
            "converging": "runs of consecutive grid rates that converge: [first, last]",
            "tol": "converged: every state component within tol * max(1, |gait state|)",
        },
    }
    if args.json:
        _dump_json(_clean(data), sys.stdout)
        return EXIT_OK
    out = sys.stdout
    _write_params(out, model, params)
    out.write(
        f"gait: {rate_name} = {_fmt(gait.state[rate_name])} at {coordinate} = "
        f"{_fmt(gait.state[coordinate])}; converging {rate_name}: "
        + (", ".join(f"[{_fmt(a)}, {_fmt(b)}]" for a, b in data["converging"]) or "none")
        + "\n"
    )
    out.write(f"{rate_name:>14} {'class':<10} {'steps':>5}  ended\n")
    for rate, kind, n, ended in zip(rates, classes, steps, ends):
        out.write(f"{_fmt(float(rate)):>14} {kind:<10} {n:>5}  {ended}\n")
    return EXIT_OK


MAX_GRID_SIDE = 4000
"""Most values along one --grid axis."""


def _parse_grid(item: str) -> tuple[str, Any]:
    """``NAME=START:STOP:N`` -> (name, N evenly spaced values from START to STOP)."""
    import numpy as np

    name, text = _split("--grid", item)
    parts = text.split(":")
    if len(parts) != 3:
        raise VswInputError(f"--grid {item!r}: expected NAME=START:STOP:N")
    start, stop = _number(parts[0]), _number(parts[1])
    try:
        count = int(parts[2])
    except ValueError:
        raise VswInputError(f"--grid {item!r}: N = {parts[2]!r} must be an integer") from None
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise VswInputError(f"--grid {item!r}: START and STOP must be finite numbers")
    if not start < stop:
        raise VswInputError(f"--grid {item!r}: START = {start:g} must be below STOP = {stop:g}")
    if not 2 <= count <= MAX_GRID_SIDE:
        raise VswInputError(f"--grid {item!r}: N = {count} must be from 2 to {MAX_GRID_SIDE}")
    return name.strip(), np.linspace(start, stop, count)


def cmd_grid_basin(args: argparse.Namespace, model) -> int:
    """``vsw basin --model NAME --grid X=... --grid Y=...``: the basin of the stable gait
    over a 2-D slice of the section, by the batch simulator (vsw.grid_basin)."""
    import os

    from vsw import limits
    from vsw.cli import EXIT_OK, _check_plot_path, _dump_json, _fmt
    from vsw.grid_basin import basin_plot, check_grid_names, grid_basin
    from vsw.vectorize import default_threads

    for dest, option in (("rate_min", "--rate-min"), ("rate_max", "--rate-max")):
        if getattr(args, dest) is not None:
            raise VswInputError(f"{option} belongs to the basin over section rates: drop --grid")
    for dest in ("n_rates", "max_steps"):
        if _given_option(args, dest):
            option = "--" + dest.replace("_", "-")
            raise VswInputError(f"{option} belongs to the basin over section rates: drop --grid")
    if len(args.grid) != 2:
        raise VswInputError(f"--grid given {len(args.grid)} time(s): give it twice (x, then y)")
    (x_name, x), (y_name, y) = (_parse_grid(item) for item in args.grid)
    check_grid_names(model, x_name, y_name)
    if not 1 <= args.steps <= 100_000:
        raise VswInputError(f"--steps = {args.steps} must be from 1 to 100000")
    if not math.isfinite(args.tol) or not 0 < args.tol < 1:
        raise VswInputError(f"--tol = {args.tol:g} must lie in (0, 1)")
    scheduler = args.scheduler or os.environ.get("VSW_DASK_SCHEDULER", "").strip() or None
    _check_plot_path(args.plot)
    params = model.parameters(args.params)
    threads = default_threads()
    if scheduler:
        from vsw.cluster import check_scheduler

        threads = check_scheduler(scheduler)  # the cluster's worker threads
    cells = len(x) * len(y)
    # Upper bound: every cell walks every step (most fall or converge much earlier).
    seconds = (
        limits.HYBRID_SECONDS_SCAN
        + cells
        * args.steps
        * limits.BATCH_SECONDS_PER_PHASE
        * len(model.phases)
        * model.n
        / threads
    )
    nbytes = limits.SIMULATE_BYTES_BASE + cells * limits.BATCH_BYTES_PER_CELL
    limits.check(
        f"a basin of {len(x)} x {len(y)} cells x up to {args.steps} steps",
        limits.Cost(seconds, nbytes),
        "use a coarser --grid or fewer --steps",
    )
    from vsw.batch import simulator

    sim = simulator(model.name)
    with _engine(model):
        sim.library()
        result = grid_basin(model, params, x_name, x, y_name, y, args.steps, tol=args.tol,
                            scheduler=scheduler)  # fmt: skip
    data = result.to_dict()
    data["name"] = cli_name(model.name)
    data["model"] = cli_name(model.name)
    data["simulator"] = result.route
    if scheduler:
        data["scheduler"] = scheduler
    if args.plot is not None:
        from vsw.figures import save_figure

        save_figure(basin_plot(_clean(data), model.spec["coordinate_units"]), args.plot)
        data["plot"] = args.plot
    del data["name"]
    if args.json:
        _dump_json(_clean(data), sys.stdout)
        return EXIT_OK
    out = sys.stdout
    _write_params(out, model, params)
    gait = ", ".join(f"{k} = {_fmt(v)}" for k, v in result.fixed_point.items())
    out.write(f"period-one gait (max |eigenvalue| {_fmt(result.gait.max_abs_eigenvalue)}): "
              f"{gait}\n")  # fmt: skip
    out.write(
        f"grid: {x_name} {_fmt(float(x[0]))} .. {_fmt(float(x[-1]))} ({len(x)}), {y_name} "
        f"{_fmt(float(y[0]))} .. {_fmt(float(y[-1]))} ({len(y)}); up to {args.steps} steps\n"
    )
    for label, count in result.counts().items():
        out.write(f"{label:>12}: {count} cells ({100 * count / cells:.2f} %)\n")
    if result.route != "compiled":
        out.write(f"note: the walks took the {result.route} route\n")
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
    return EXIT_OK


def cmd_animate(args: argparse.Namespace) -> int:
    """``vsw animate``: the stick figure of a simulated walk as GIF, SVG or MP4."""

    from vsw.animate import animation_frames, check_output, write_animation
    from vsw.cli import EXIT_OK, _dump_json, _fmt
    from vsw.models import load

    out = check_output(args.out)
    model = load(args.model)
    if args.model == ILE:
        import generated.ile as ile_module

        values = ile_values(args, _ILE_GAIT["animate"])
        params = model.parameters(values)
        q0 = float(args.q0)
        if not (math.isfinite(q0) and q0 > 0):
            raise VswInputError(f"--q0 = {args.q0} must be a positive number (q = omega**2)")
        start = [float(ile_module.theta_I(params[0], params[2])), math.sqrt(q0)]
        start_from = "--q0"
    else:
        params = model.parameters(args.params)
        start = _parse_state(model, args.state) if args.state else None
        start_from = "--state"
        if start is None:
            with _engine(model):
                orbit = _pick(model.fixed_points(params))
            if orbit is None:
                raise ModelConditionError(
                    f"{cli_name(model.name)}: no period-one gait found from a scan of starts "
                    "at these parameters; give the start with --state NAME=VALUE"
                )
            start, start_from = list(orbit.state.values()), "fixed point"
    if args.leg_length is not None:
        leg = float(args.leg_length)
        if not (math.isfinite(leg) and leg > 0):
            raise VswInputError(f"--leg-length = {args.leg_length} must be a positive number")
        if model.units.get("time", "") == "s":
            raise VswInputError(f"{cli_name(model.name)} is in seconds already: drop "
                                "--leg-length (--speed 1 is real time)")  # fmt: skip
        speed = math.sqrt(9.81 / leg)  # model time units per second of the robot's time
    else:
        speed = float(args.speed)
    fixed = ", ".join(f"{k} = {_fmt(v)}" for k, v in zip(model.spec["parameters"], params))
    title = f"{cli_name(model.name)}: {fixed}"
    with _engine(model):
        frames = animation_frames(model, params, start, args.steps, fps=args.fps,
                                  speed=speed, title=title)  # fmt: skip
    write_animation(frames, str(out))
    events = [(float(t), e) for t, e in zip(frames.t, frames.event) if e]
    data = {
        "model": cli_name(model.name),
        "parameters": dict(zip(model.spec["parameters"], params)),
        "start": dict(zip((*model.coordinates, *model.rates), (float(v) for v in start))),
        "start_from": start_from,
        "out": str(out),
        "frames": len(frames.t),
        "fps": frames.fps,
        "model_time_per_second": speed,
        "duration": float(frames.t[-1]),
        "steps_completed": int(frames.step[-1]),
        "ended": frames.ended,
        "events": [{"t": t, "event": e} for t, e in events],
        "frame_of_events": [k for k, e in enumerate(frames.event) if e],
        "pixels": {"scale": frames.scale, "origin": list(frames.origin)},
        "fields": {
            "events": "each event's model time; the animation has a frame at each",
            "pixels": "pixel = (origin x + scale * x, origin y - scale * y) for a point (x, y) "
            "in the model's chart, the first stance foot at (0, 0)",
        },
    }
    if args.json:
        _dump_json(_clean(data), sys.stdout)
        return EXIT_OK
    sys.stdout.write(
        f"{out}: {len(frames.t)} frames at {frames.fps:g} per second, {data['duration']:.4g} "
        f"{model.units.get('time', '')} of model time, {data['steps_completed']} steps "
        f"({frames.ended})\n"
    )
    return EXIT_OK


def _given_option(args: argparse.Namespace, dest: str) -> bool:
    """Whether a StoreGiven option was on the command line."""
    return dest in getattr(args, "given", ())


def _diagram_quantity(model, y: str | None) -> str:
    """``--y``: what the bifurcation diagram shows (step length where the model has one)."""
    choices = ["step_period", *model.coordinates, *model.rates]
    if model.spec["step_length"]:
        choices.insert(0, "step_length")
    if y is None:
        return choices[0]
    if y.removeprefix("-") not in choices:
        raise VswInputError(f"--y {y!r} is not one of the {cli_name(model.name)} model's: "
                            f"{', '.join(choices)} (or minus one: --y=-NAME)")  # fmt: skip
    return y


def cmd_sweep(args: argparse.Namespace) -> int:
    """``vsw sweep``: outputs along one parameter (the ILE's closed forms, or the engine's
    gait continued from point to point, and past its loss of stability the map iterated
    for the bifurcation diagram)."""
    if args.model == ILE:
        return _sweep_ile(args)
    import numpy as np

    from vsw.cli import EXIT_OK, _check_plot_path, _fmt, _progress

    model = _hybrid(args.model, "sweep")
    name, values = parse_over(args.model, args.over)
    y = _diagram_quantity(model, args.y)
    brute = args.brute_force
    if args.state and not brute:
        raise VswInputError("--state of vsw sweep is the start of --brute-force: give both")
    default_keep = 32 if (args.plot is not None or brute) else 0
    keep = args.keep if args.keep is not None else default_keep
    if keep == 1 or keep < 0:
        raise VswInputError(f"--keep {keep}: give 0 (no iteration) or at least 2 steps to keep")
    if args.transient < 0:
        raise VswInputError(f"--transient {args.transient} must be >= 0")
    if not keep and _given_option(args, "transient"):
        raise VswInputError("--transient applies to the iterated map: give --keep N or --plot")
    if args.y is not None and args.plot is None:
        raise VswInputError("--y chooses what --plot draws: give --plot FILE")
    _check_plot_path(args.plot)
    count = len(values)
    if brute:
        if not keep:
            raise VswInputError("--brute-force iterates the map: --keep must be at least 2")
        return _sweep_brute_force(args, model, name, values, y, keep)
    _check_cost(
        model,
        f"a sweep of {count} points" + (f" iterating {args.transient + keep} steps each"
                                        if keep else ""),
        {"scan": 1, "orbit": count, "step": count * (args.transient + keep if keep else 0)},
        count * max(keep, 1),
        "use fewer points (N of --over)" + (", --keep or --transient" if keep else ""),
    )  # fmt: skip
    empty = {k: None for k in ("state", "period", "eigenvalues", "max_abs_eigenvalue")}
    empty.update(stable=None, step_length=None, speed=None)
    names = list(model.coordinates + model.rates)
    points, previous, walked_to = [], None, None
    with _progress("sweep") as bar, _engine(model):
        for i, value in enumerate(values):
            params = model.parameters({**args.params, name: float(value)})
            orbit, source = None, None
            if previous is not None:
                x0 = np.array(list(previous.state.values()))
                try:
                    orbit = model.periodic_orbit(params, x0, previous.durations)
                    source = "continuation"
                except ConvergenceError:
                    orbit = None
            if orbit is None:
                orbit, source = _pick(model.fixed_points(params)), "scan"
            point = {name: float(value), "found": orbit is not None}
            point.update({"from": source, **orbit.to_dict()} if orbit else {"from": None, **empty})
            if keep and (orbit is None or not orbit.stable):
                # The attractor followed along the sweep: from where the last iteration
                # ended, else from the previous point's gait (off this point's unstable
                # gait by the parameter step), else from this gait moved by 1e-4: a walk
                # started on an unstable gait stays there for as long as its rounding
                # takes to grow.
                if walked_to is not None:
                    start = walked_to
                elif previous is not None:
                    start = np.array(list(previous.state.values()))
                elif orbit is not None:
                    start = np.array(list(orbit.state.values())) * (1 + 1e-4)
                else:
                    start = None
                if start is None:
                    point["attractor"] = None
                else:
                    attractor = model.attractor(params, start, args.transient, keep)
                    point["attractor"] = attractor.to_dict(names)
                    walked_to = attractor.states[-1] if attractor.ended == "completed" else None
            else:
                walked_to = None
                if keep:
                    point["attractor"] = None
            points.append(point)
            previous = orbit or previous
            bar(i + 1, count)
    fixed = model.parameters(args.params)
    over_unit = next(p.unit for p in model.parameter_table if p.name == name)
    data = {
        "model": cli_name(model.name),
        "over": name,
        "over_unit": over_unit,
        "parameters": {k: v for k, v in zip(model.spec["parameters"], fixed) if k != name},
        "points": points,
    }
    if keep:
        data.update(transient=args.transient, keep=keep)
    if _diagram_out(args, model, data, y):
        return EXIT_OK
    out = sys.stdout
    state_names = model.coordinates + model.rates
    out.write(f"{'model':<12} {cli_name(model.name)} ({model.title}); over {name}\n")
    out.write(
        f"{name:>12} " + " ".join(f"{n:>12}" for n in state_names)
        + f" {'period':>12} {'max|eig|':>12} {'stable':>6}  from\n"
    )  # fmt: skip
    for p in points:
        state = p["state"] or {}
        attractor = p.get("attractor")
        note = ""
        if attractor:
            kind = (f"period-{attractor['period']}" if attractor["period"]
                    else "no repeat within --keep steps")  # fmt: skip
            note = f"; map: {attractor['ended'] if attractor['ended'] != 'completed' else kind}"
        out.write(
            f"{_fmt(p[name]):>12} " + " ".join(f"{_fmt(state.get(n)):>12}" for n in state_names)
            + f" {_fmt(p['period']):>12} {_fmt(p['max_abs_eigenvalue']):>12} "
            f"{_fmt(p['stable']):>6}  {p['from'] or 'no gait found'}{note}\n"
        )  # fmt: skip
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
    return EXIT_OK


def _diagram_out(args, model, data: dict, y: str) -> bool:
    """A sweep's figure (``--plot``) and JSON (``--json``); True when the JSON was printed."""
    from vsw.cli import _dump_json

    if args.plot is not None:
        from vsw.diagrams import bifurcation_plot
        from vsw.figures import save_figure

        save_figure(bifurcation_plot(_clean(data), y, _units(model)), args.plot)
        data["plot"] = args.plot
    if args.json:
        _dump_json(_clean(data), sys.stdout)
        return True
    return False


def _sweep_brute_force(args, model, name: str, values, y: str, keep: int) -> int:
    """``vsw sweep --brute-force``: vsw.grid_basin.brute_force_sweep, in the sweep's JSON
    and figure."""
    from vsw import limits
    from vsw.cli import EXIT_OK, _fmt
    from vsw.grid_basin import brute_force_sweep
    from vsw.vectorize import default_threads

    count = len(values)
    steps = count * (args.transient + keep)
    seconds = limits.HYBRID_SECONDS_SCAN + (
        (steps + 40 * count)
        * limits.BATCH_SECONDS_PER_PHASE
        * len(model.phases)
        * model.n
        / default_threads()
    )
    limits.check(
        f"a brute-force sweep of {count} points iterating {args.transient + keep} steps each",
        limits.Cost(seconds, limits.SIMULATE_BYTES_BASE + count * keep * 200),
        "use fewer points (N of --over), --keep or --transient",
    )
    start = _parse_state(model, args.state) if args.state else None
    with _engine(model):
        points = brute_force_sweep(model, args.params, name, values, args.transient, keep,
                                   start=start)  # fmt: skip
    fixed = model.parameters(args.params)
    data = {
        "model": cli_name(model.name),
        "over": name,
        "over_unit": next(p.unit for p in model.parameter_table if p.name == name),
        "parameters": {k: v for k, v in zip(model.spec["parameters"], fixed) if k != name},
        "method": "brute-force",
        "points": points,
        "transient": args.transient,
        "keep": keep,
    }
    if _diagram_out(args, model, data, y):
        return EXIT_OK
    out = sys.stdout
    out.write(f"{'model':<12} {cli_name(model.name)} ({model.title}); over {name}, brute "
              f"force: {args.transient} steps then {keep} kept\n")  # fmt: skip
    out.write(f"{name:>12} {'max|eig|':>12} {'stable':>6}  map\n")
    for p in points:
        attractor = p["attractor"]
        if attractor["ended"] != "completed":
            kind = attractor["ended"]
        elif attractor["period"]:
            kind = f"period-{attractor['period']}"
        else:
            kind = "no repeat within --keep steps"
        out.write(f"{_fmt(p[name]):>12} {_fmt(p['max_abs_eigenvalue']):>12} "
                  f"{_fmt(p['stable']):>6}  {kind}\n")  # fmt: skip
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
    return EXIT_OK


def _sweep_ile(args: argparse.Namespace) -> int:
    """The ILE's sweep: :func:`vsw.models.ile.sweep.sweep` over one parameter (closed forms)."""
    from vsw import limits
    from vsw.cli import EXIT_OK, _check_plot_path, _dump_json, _fmt, _progress
    from vsw.models.ile.analysis import FIELDS, _jsonable
    from vsw.models.ile.sweep import sweep

    name, values = parse_over(ILE, args.over)
    _check_plot_path(args.plot)
    names = [p.name for p in parameter_table(ILE)]
    fixed = ile_values(args, [n for n in names if n != name])
    cost = limits.Cost(
        len(values) * limits.ILE_SWEEP_SECONDS_PER_POINT,
        limits.SIMULATE_BYTES_BASE + len(values) * limits.ILE_SWEEP_BYTES_PER_POINT,
    )
    limits.check(f"a sweep of {len(values)} points", cost, "use fewer points (N of --over)")
    axes = {**fixed, name: values}
    with _progress("sweep") as bar:
        result = sweep(list(FIELDS), *(axes[n] for n in names), progress=bar)
    columns = {field: result[field].reshape(-1) for field in FIELDS}
    points = [
        {name: float(v), **{f: _jsonable(columns[f][i]) for f in FIELDS}}
        for i, v in enumerate(values)
    ]
    data = {"model": ILE, "over": name, "parameters": fixed, "points": points}
    if args.plot is not None:
        from vsw.figures import save_figure
        from vsw.models.ile.plots import ile_sweep_plot

        unit = next(p.unit for p in parameter_table(ILE) if p.name == name)
        save_figure(ile_sweep_plot(data, f"{name} [{unit}]" if unit else name), args.plot)
        data["plot"] = args.plot
    if args.json:
        _dump_json(data, sys.stdout)
        return EXIT_OK
    out = sys.stdout
    shown = ("walks", "q_fixed", "eigenvalue", "step_length", "step_period", "speed")
    text = ", ".join(f"{k} = {v:.6g}" for k, v in fixed.items())
    out.write(f"ile over {name} (rad; ILE units, see 'vsw models'); {text}\n")
    out.write(f"{name:>12} " + " ".join(f"{f:>12}" for f in shown) + "\n")
    for p in points:
        out.write(f"{_fmt(p[name]):>12} " + " ".join(f"{_fmt(p[f]):>12}" for f in shown) + "\n")
    if args.plot is not None:
        out.write(f"plot: {args.plot}\n")
    return EXIT_OK
