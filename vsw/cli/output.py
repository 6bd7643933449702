"""What every command prints: the JSON envelope, strict JSON, and the text tables' pieces.

Every ``--json`` output of every command and model is one object that starts with the same
four keys (:func:`envelope`): ``model``, ``parameters`` (every parameter's value in the
model's units), ``units`` (the model's, and ``units.quantities``: the unit of each key of the
output that holds numbers, :func:`with_units`) and ``provenance`` (the vsw version, the git
commit where the package runs from a checkout, the command line, the tolerances used), then
the command's own keys. NaN and infinities become null (:func:`clean`); the JSON is strict.
"""

from __future__ import annotations

import functools
import json
import math
import shlex
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TextIO

import numpy as np

import vsw
from vsw.dynamics.hybrid import Orbit
from vsw.models.base import Model
from vsw.runtime.jsonable import clean
from vsw.runtime.progress import ProgressBar

__all__ = [
    "clean",
    "dump_json",
    "envelope",
    "fmt",
    "progress",
    "quantity_unit",
    "version",
    "with_units",
    "write_gait_sensitivity",
    "write_orbit",
    "write_parameters",
]

INTEGRATOR = {"integrator": "SciPy DOP853, rtol = atol = 1e-12 (events to the integrator's "
              "accuracy)"}  # fmt: skip
"""The time-domain simulation's tolerances (every command that simulates)."""

ORBIT_SOLVER = {"orbit_solver": "Newton on the orbit problem's multiple-shooting residual "
                "(exact CasADi Jacobian; CVODES Adams, 1e-13) to 1e-10 x max(1, |unknowns|), "
                "last step 1e-9; accepted when the residual is within 1e-9 x max(1, |state|) "
                "and a simulated step returns within 1e-9 x max(1, |state|) x "
                "max(1, |eigenvalue|)"}  # fmt: skip
"""The periodic-orbit solver's tolerances (:class:`vsw.orbits.OrbitProblem` and
:meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit`)."""


_CHUNK = 1 << 16


def dump_json(data: Any, out: TextIO | None = None) -> None:
    """One strict JSON object on standard output (or ``out``), written in pieces of 64 KiB:
    one write of a large string to a pipe its reader has closed ended the process with
    status 0 and no error here (CPython 3.11 on Linux), where writes of a pipe's size
    raise BrokenPipeError as the text output's do (exit 141)."""
    out = sys.stdout if out is None else out
    text = json.dumps(clean(data), allow_nan=False, indent=2) + "\n"
    for start in range(0, len(text), _CHUNK):
        out.write(text[start : start + _CHUNK])


def fmt(value: Any) -> str:
    """A number for the text tables: 6 significant digits, '-' for none."""
    if value is None:
        return "-"
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return "nan" if math.isnan(value) else f"{value:.6g}"
    return str(value)


@functools.cache
def version() -> str:
    """The package's ``__version__``, the one place the version is written (the
    distribution's metadata lags behind it in an editable install until reinstalled)."""
    return vsw.__version__


@functools.cache
def git_commit() -> str | None:
    """The commit of the checkout the package runs from, read from ``.git`` (no process
    started); None for an installed copy or anything unreadable."""
    git = Path(vsw.__file__).resolve().parent.parent / ".git"
    try:
        if git.is_file():  # a worktree: "gitdir: <path>"
            git = Path(git.read_text().split(":", 1)[1].strip())
        head = (git / "HEAD").read_text().strip()
        if not head.startswith("ref:"):
            return head or None
        ref = head.split(":", 1)[1].strip()
        common = git / "commondir"
        base = (git / common.read_text().strip()).resolve() if common.is_file() else git
        for root in (git, base):
            if (root / ref).is_file():
                return (root / ref).read_text().strip()
        packed = base / "packed-refs"
        if packed.is_file():
            for line in packed.read_text().splitlines():
                if line.endswith(" " + ref):
                    return line.split()[0]
    except (OSError, IndexError, ValueError):
        return None
    return None


def envelope(
    model: Model,
    params: Sequence[float] | None,
    argv: Sequence[str],
    tolerances: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The four keys every JSON output starts with."""
    parameters = None if params is None else dict(zip(model.spec["parameters"], params))
    return {
        "model": model.cli_name,
        "parameters": parameters,
        "units": {
            **dict(model.units),
            "angle": "rad",
            "parameters": {p.name: p.unit for p in model.parameter_table},
        },
        "provenance": {
            "vsw": version(),
            "commit": git_commit(),
            "command": shlex.join(["vsw", *argv]),
            "tolerances": dict(tolerances or {}),
        },
    }


QUANTITIES = {
    "period": "time",
    "step_period": "time",
    "step_length": "length",
    "speed": "speed",
    "step_frequency": "frequency",
    "period_steps": "steps",
    "energy_per_step": "energy",
    "work": "energy",
    "positive_work": "energy",
    "impulses": "impulse",
    "ground_impulses": "impulse",
    "eigenvalue": "1",
    "max_abs_eigenvalue": "1",
    "eigenvalues": "1",
    "cost_of_transport": "1",
    "residual": "1",
    "resimulation_error": "1",
    "phase_durations": "time",
    "durations": "time",
    "time": "time",
    "contact_margin": "force",
    "energy_added": "energy",
    "energy_lost": "energy",
    "q_fixed": "q",
    "q_apex_min": "q",
    "q_liftoff_max": "q",
    "omega_I": "omega",
    "theta_I": "rad",
    "theta_IV": "rad",
    "energy_ledger": "energy",
    "ground_impulse": "impulse",
    "duration": "time",
    "balance_relative": "1",
    "cells": "1",
    "candidates": "1",
    "newton_converged": "1",
    "unconfirmed": "1",
    "standing": "1",
    "scan_outcomes": "1",
    "step_lengths": "length",
    "step_periods": "time",
    "period_time": "time",
    "steps": "steps",
    "steps_completed": "steps",
    "n_steps": "steps",
    "q": "q",
    "q0": "q",
    "q_fixed_closed_form": "q",
    "q_min": "q",
    "q_max": "q",
    "omega_min": "omega",
    "omega_max": "omega",
    "theta_II_deg": "deg",
    "attractor.period": "steps",
    "trajectory.rows": "1",
    "trajectory.rate": "frequency",
    "steps_walked": "steps",
    "keep": "steps",
    "transient": "steps",
    "max_steps": "steps",
    "counts": "1",
    "tol": "1",
}
"""What an output's quantities are, by key: a dimension of the model's units
(:func:`dimension_unit`), or '1' for a dimensionless number."""


SI_SUFFIXES = (("_m_s", "m/s"), ("_leg_s", "leg/s"), ("_J_per_kg", "J/kg"), ("_hz", "Hz"),
               ("_m", "m"), ("_s", "s"), ("_J", "J"))  # fmt: skip
"""Keys of results converted to SI (the ILE's with a robot scale), by their unit's suffix."""


def dimension_unit(model: Model, dimension: str) -> str:
    """A dimension in the model's units: its time, length, energy, force or mass unit, or
    speed (length/time), frequency (Hz where time is in s, else 1/time), impulse (force
    time), q (a squared rate: g/r_e where the time unit is sqrt(r_e/g)), omega (a rate:
    sqrt(g/r_e) there); '1' and 'rad' stay."""
    units = dict(model.units)
    time, length = units.get("time", ""), units.get("length", "")
    if dimension == "speed":
        return f"{length}/{time}"
    if dimension == "frequency":
        return "Hz" if time == "s" else f"1/{time}"
    if dimension in ("q", "omega"):
        scaled = time.startswith("sqrt(") and time.endswith(")") and "/" in time
        if scaled:  # sqrt(a/b) -> b/a
            a, b = time[5:-1].split("/", 1)
            return f"{b}/{a}" if dimension == "q" else f"sqrt({b}/{a})"
        return f"1/{time}^2" if dimension == "q" else f"rad/{time}"
    if dimension == "impulse":
        return f"{units.get('force', '')} {time}"
    return units.get(dimension, dimension)


def quantity_unit(model: Model, name: str) -> str:
    """The unit of the output quantity ``name`` (:data:`QUANTITIES`) in the model's units;
    '' for a name it does not know."""
    dimension = QUANTITIES.get(name)
    return "" if dimension is None else dimension_unit(model, dimension)


def _holds_numbers(value: Any) -> bool:
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return False
    if isinstance(value, (int, float, np.integer, np.floating)):
        return True
    if isinstance(value, Mapping):
        return any(_holds_numbers(v) for v in value.values())
    if isinstance(value, (list, tuple)):
        return any(_holds_numbers(v) for v in value)
    return False


def _key_unit(model: Model, parent: str, key: str, extra: Mapping[str, str]) -> str | None:
    for name in (f"{parent}.{key}", key):
        if name in extra:
            return extra[name]
    if f"{parent}.{key}" in QUANTITIES:
        return quantity_unit(model, f"{parent}.{key}")
    state = {s["name"]: s["unit"] for s in model.spec["state"]}
    if key in state:
        return state[key]
    if key in QUANTITIES:
        return quantity_unit(model, key)
    table = {p.name: p.unit for p in model.parameter_table}
    if key in table:
        return table[key]
    for suffix, unit in SI_SUFFIXES:
        if key.endswith(suffix):
            return unit
    return None


def with_units(model: Model, data: dict[str, Any], extra: Mapping[str, str] | None = None
               ) -> dict[str, Any]:  # fmt: skip
    """``data`` (an :func:`envelope` and a command's keys) with ``units.quantities``: the
    unit of every key that holds numbers, '1' for a dimensionless one or a count.

    The convention every ``--json`` output follows: a number's unit is the ``unit`` of the
    object it is in, where that object has one (a condition's margin; '' there is
    dimensionless), else that of the
    innermost key on its path that ``units.quantities`` names, as ``PARENT.KEY`` (a key of
    an object under the key PARENT: ``attractor.period``, a number of steps) or as ``KEY``
    (``period``; ``work``: each of its numbers; a state component's name), and under
    ``parameters`` the parameter's (``units.parameters``). ``extra``: a command's own keys
    (an impulse by name)."""
    extra = dict(extra or {})
    quantities: dict[str, str] = {}

    def visit(value: Any, parent: str) -> None:
        if isinstance(value, Mapping):
            if isinstance(value.get("unit"), str):
                return  # its numbers are in its own unit
            for key, item in value.items():
                if not _holds_numbers(item):
                    continue
                unit = _key_unit(model, parent, str(key), extra)
                if unit is not None:
                    qualified = f"{parent}.{key}"
                    named = qualified if qualified in extra or qualified in QUANTITIES else key
                    quantities[str(named)] = unit or "1"
                visit(item, str(key))
        elif isinstance(value, (list, tuple)):
            for item in value:
                visit(item, parent)

    visit({k: v for k, v in data.items() if k not in ("units", "parameters", "provenance")}, "")
    data["units"] = {**data.get("units", {}), "quantities": {
        **data.get("units", {}).get("quantities", {}), **quantities}}  # fmt: skip
    return data


def unit_text(unit: str | None) -> str:
    """A unit after a number: nothing for dimensionless ('1' or '')."""
    return "" if unit in (None, "", "1") else f" {unit}"


def write_gait_sensitivity(out: Any, model: Any, gsn: dict, width: int, indent: str = "") -> None:
    """One line: the gait sensitivity norm and each indicator's share, with units."""
    units = dict(model.units)
    parts = ", ".join(f"{k.replace('_', ' ')} {fmt(v)} {units[k.split('_')[1]]}/rad"
                      for k, v in gsn["gsn_by_indicator"].items())  # fmt: skip
    label = f"{indent}{'gait sensitivity':<{width}}"
    out.write(f"{label} {fmt(gsn['gsn'])} ({parts}; the H2 norm of the indicators' response "
              "to one step's slope)\n")  # fmt: skip


def write_parameters(out: TextIO, model: Model, params: Sequence[float]) -> None:
    """The text header of a command: the model and its parameter values with units."""
    units = {p.name: p.unit for p in model.parameter_table}
    text = ", ".join(f"{n} = {v:.6g}{unit_text(units[n])}" for n, v in zip(units, params))
    out.write(f"{'model':<18} {model.cli_name} ({model.title})\n")
    out.write(f"{'parameters':<18} {text}\n")


def write_orbit(out: TextIO, model: Model, orbit: Orbit) -> None:
    """A gait's lines in a text table: state, period, step, eigenvalues."""
    units = dict(model.units)
    state_units = {s["name"]: s["unit"] for s in model.spec["state"]}
    for name, value in orbit.state.items():
        out.write(f"  {name:<16} {fmt(value):>14}  {state_units.get(name, '')}\n")
    out.write(f"  {'period':<16} {fmt(orbit.period):>14}  {units.get('time', '')}\n")
    out.write(f"  {'step_length':<16} {fmt(orbit.step_length):>14}  {units.get('length', '')}\n")
    speed_unit = f"{units.get('length', '')}/{units.get('time', '')}"
    out.write(f"  {'speed':<16} {fmt(orbit.speed):>14}  {speed_unit}\n")
    out.write(f"  {'max |eigenvalue|':<16} {fmt(orbit.max_abs_eigenvalue):>14}\n")
    out.write(f"  {'stable':<16} {fmt(orbit.stable):>14}\n")
    values = ", ".join(
        fmt(e.real) if e.imag == 0 else f"{e.real:.6g}{e.imag:+.6g}j" for e in orbit.eigenvalues
    )
    out.write(f"  {'eigenvalues':<16} {values}\n")


def progress(label: str) -> ProgressBar:
    """A progress bar on stderr (drawn only on a terminal): the command's passes of
    blockwise work numbered on one line."""
    return ProgressBar(label, passes=True)
