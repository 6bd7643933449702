"""The batch simulator's model table: ``generated/<model>/c/<model>_sim.c``.

For every model with a ``HYBRID`` descriptor (the engine's), the phases' flows, the watched
guards (each phase's events, then the failures), the events' resets and ``when``
conditions and the step length become CasADi functions of ``(p, x)`` (parameter vector,
state vector) printed by CasADi's code generator, followed by a table of the model's
structure filled into ``templates/hybrid_sim.c.in``. ``vsw/csrc/hybrid_batch.c`` (the
generic integrator, which knows no model) is compiled after it as one translation unit.
The functions are built from the generated Python module, the very source that is written,
as the model's C library is.
"""

from __future__ import annotations

import string
import types
from pathlib import Path

from derive.codegen import casadi_c, header

TEMPLATE = Path(__file__).resolve().parent / "templates" / "hybrid_sim.c.in"


def failure_names(descriptor: dict) -> tuple[str, ...]:
    """Every failure of the model, in the order of first appearance (their C indices)."""
    names: list[str] = []
    for phase in descriptor["phases"]:
        for name, _function, _direction in (*phase["failures"], *phase.get("start_failures", ())):
            if name not in names:
                names.append(name)
    return tuple(names)


def _c_list(values) -> str:
    return ", ".join(str(v) for v in values)


def simulator_c_source(model: str, source: str, descriptor: dict, module: types.ModuleType) -> str:
    """The model table of the batch simulator (see the module docstring)."""
    import casadi as ca

    params = descriptor["parameters"]
    state = (*descriptor["coordinates"], *descriptor["rates"])
    n = len(descriptor["coordinates"])
    p = ca.SX.sym("p", len(params))
    x = ca.SX.sym("x", len(state))
    args = [*ca.vertsplit(p), *ca.vertsplit(x)]
    prefix = f"vsw_{model}_sim_"
    functions: list = []

    def function(name: str, out) -> str:
        out = ca.vertcat(*out) if isinstance(out, (tuple, list)) else out
        functions.append(ca.Function(prefix + name, [p, x], [out], ["p", "x"], [name]))
        return prefix + name

    phase_index = {ph["name"]: k for k, ph in enumerate(descriptor["phases"])}
    event_index = {ev["name"]: k for k, ev in enumerate(descriptor["events"])}
    failures = failure_names(descriptor)
    flows, watches, n_watch, directions, whats = [], [], [], [], []
    for phase in descriptor["phases"]:
        accelerations = getattr(module, f"{phase['name']}_accelerations")(*args)
        flows.append(function(f"{phase['name']}_flow", [*args[len(params) + n :], *accelerations]))
        guards, direction, what = [], [], []
        for event in descriptor["events"]:
            if event["source"] == phase["name"]:
                guards.append(getattr(module, f"event_{event['name']}_guard")(*args))
                direction.append(event["direction"])
                what.append(event_index[event["name"]])
        for name, fn, sign in phase["failures"]:
            guards.append(getattr(module, fn)(*args))
            direction.append(sign)
            what.append(-1 - failures.index(name))
        for name, fn, sign in phase.get("start_failures", ()):
            guards.append(getattr(module, fn)(*args))
            direction.append(2 * sign)  # checked at the phase's start only (hybrid_batch.c)
            what.append(-1 - failures.index(name))
        watches.append(function(f"{phase['name']}_watch", guards))
        n_watch.append(len(guards))
        directions.append(direction)
        whats.append(what)
    max_watch = max(n_watch)
    resets, whens, targets, ends_step = [], [], [], []
    for event in descriptor["events"]:
        resets.append(
            function(
                f"{event['name']}_reset", getattr(module, f"event_{event['name']}_reset")(*args)
            )
        )
        when = event["when"]
        whens.append(
            function(f"{event['name']}_when", getattr(module, when)(*args)) if when else "0"
        )
        targets.append(phase_index[event["target"]])
        ends_step.append(int(event["ends_step"]))
    step_length = "0"
    if descriptor["step_length"]:
        step_length = function("step_length", module.step_length_of_state(*args))
    step_event = next(e for e in descriptor["events"] if e["ends_step"])

    casadi_code, _ = casadi_c(f"{model}_sim", functions, prefix, with_header=False)

    def padded(rows: list[list[int]]) -> str:
        return ", ".join("{" + _c_list(r + [0] * (max_watch - len(r))) + "}" for r in rows)

    template = string.Template(TEMPLATE.read_text())
    return template.substitute(
        header=header(source, " *"),
        casadi_version=ca.__version__,
        parameters=", ".join(params),
        state=", ".join(state),
        phases=", ".join(ph["name"] for ph in descriptor["phases"]),
        events=", ".join(
            f"{ev['name']} ({ev['source']} -> {ev['target']}"
            + (", ends the step" if ev["ends_step"] else "")
            + ")"
            for ev in descriptor["events"]
        ),
        failures=", ".join(failures) or "none",
        casadi_code=casadi_code.rstrip("\n"),
        n_params=len(params),
        n_state=len(state),
        n_phases=len(descriptor["phases"]),
        n_events=len(descriptor["events"]),
        n_failures=len(failures),
        max_watch=max_watch,
        start_phase=phase_index[step_event["target"]],
        sz_arg=max(f.sz_arg() for f in functions),
        sz_res=max(f.sz_res() for f in functions),
        sz_iw=max(f.sz_iw() for f in functions),
        sz_w=max(f.sz_w() for f in functions),
        flows=_c_list(flows),
        watches=_c_list(watches),
        n_watch=_c_list(n_watch),
        directions=padded(directions),
        whats=padded(whats),
        resets=_c_list(resets),
        whens=_c_list(whens),
        targets=_c_list(targets),
        ends_step=_c_list(ends_step),
        step_length=step_length,
    )
