"""The batch simulator's model table: ``generated/<model>/c/<model>_sim.c``.

For every model with a ``HYBRID`` descriptor (the engine's), the phases' flows, the watched
guards (each phase's events, then the failures), the events' resets and ``when``
conditions and the step length become CasADi functions of ``(p, x)`` (parameter vector,
state vector) printed by CasADi's code generator, followed by a table of the model's
structure filled into ``templates/hybrid_sim.c.in``. ``vsw/dynamics/csrc/hybrid_batch.c`` (the
generic integrator, which knows no model) is compiled after it as one translation unit.
The functions are built from the generated Python module, the very source that is written,
as the model's C library is.
"""

from __future__ import annotations

import re
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


def _direct_trig(module: types.ModuleType, ca: types.ModuleType) -> types.SimpleNamespace:
    """The generated module with cosine and sine as two CasADi calls where it takes both
    from one tangent of the half angle. The tangent is numpy's choice (one SIMD ufunc for
    both, codegen._cos_sin_numpy); in C the compiler fuses cos and sin of one angle into
    one sincos call, and the tangent's division and squares are gone (the simplest
    walker's step: 7.1 against 5.7 us, one measurement). Every function of the
    module is rebound to the new backend, so that one generated function calling another
    gets it too."""
    ops = types.SimpleNamespace(**vars(module.backend_for(ca.SX.sym("x"))))
    ops.cos_sin = lambda x: (ca.cos(x), ca.sin(x))
    namespace = dict(vars(module))
    namespace["backend_for"] = lambda *args: ops
    for name, value in vars(module).items():
        if isinstance(value, types.FunctionType) and value.__module__ == module.__name__:
            namespace[name] = types.FunctionType(
                value.__code__, namespace, name, value.__defaults__, value.__closure__
            )
    return types.SimpleNamespace(**namespace)


def _hoist_parameters(p, x, outputs: list) -> tuple:
    """The table's functions of (p, x) as functions of (c, x), with c = constants(p): every
    parameter-only subexpression an x-dependent operation uses, and every parameter used
    directly, becomes one entry of c, computed once a walk instead of at every call (the
    compass gait's flow goes from 140 operations to 103, the biped's short flow from 94
    to 65). The operations and
    their order are the same, so are the results, bit for bit in CasADi's virtual machine
    (tests/test_batch.py); compiled, up to the compiler fusing sin and cos into sincos
    in one build and not the other (1 ulp at some states of the biped's long flow).

    Returns (constants(p) as an SX column, the symbols c, the outputs in c and x)."""
    import casadi as ca

    if not all(out.is_dense() for out in outputs):  # an output's nonzeros are its elements
        raise ValueError("_hoist_parameters takes dense outputs (casadi.densify)")
    table = ca.Function("table", [p, x], outputs)
    inputs = (p, x)
    value: list = [None] * table.sz_w()  # each work slot's expression now
    from_x = [False] * table.sz_w()  # whether it depends on the state
    made_by = [0] * table.sz_w()  # the instruction that computed it
    names: dict[int, ca.SX] = {}  # instruction -> its constant's symbol
    definitions: list = []
    results = [[ca.SX(0)] * out.numel() for out in outputs]

    def operand(slot: int):
        if from_x[slot] or value[slot].is_constant():
            return value[slot]
        if made_by[slot] not in names:
            names[made_by[slot]] = ca.SX.sym(f"c{len(definitions)}")
            definitions.append(value[slot])
        return names[made_by[slot]]

    for k in range(table.n_instructions()):
        op, ins, outs = (table.instruction_id(k), table.instruction_input(k),
                         table.instruction_output(k))  # fmt: skip
        if op == ca.OP_INPUT:
            value[outs[0]] = inputs[ins[0]][ins[1]]
            from_x[outs[0]] = ins[0] == 1
        elif op == ca.OP_CONST:
            value[outs[0]] = ca.SX(table.instruction_constant(k))
            from_x[outs[0]] = False
        elif op == ca.OP_OUTPUT:
            results[outs[0]][outs[1]] = operand(ins[0])
            continue
        else:
            depends = any(from_x[i] for i in ins)
            args = [operand(i) if depends else value[i] for i in ins]
            if len(args) == 1:
                value[outs[0]] = ca.SX.unary(op, args[0])
            elif len(args) == 2:
                value[outs[0]] = ca.SX.binary(op, *args)
            else:
                raise ValueError(f"CasADi operation {op} with {len(args)} operands")
            from_x[outs[0]] = depends
        made_by[outs[0]] = k
    symbols = ca.vertcat(*names.values()) if names else ca.SX(0, 1)  # as defined
    constants = ca.vertcat(*definitions) if definitions else ca.SX(0, 1)
    return constants, symbols, [ca.vertcat(*r) for r in results]


def _without_null_checks(code: str) -> str:
    """CasADi's C with its tests for absent arguments and results removed: the table's
    callers (VSW_CALL) always pass the parameters, the state and the output. The tests
    split each function into branches, across which the compiler does not fuse cos and
    sin of one angle into one sincos call."""
    code = re.sub(r"arg\[(\d+)\]\? (arg\[\1\]\[\d+\]) : 0", r"\2", code)
    return re.sub(r"if \(res\[(\d+)\]!=0\) (res\[\1\]\[\d+\]=)", r"\2", code)


_LANE_CALLS = {"sin": "vsw_lanes_sin", "cos": "vsw_lanes_cos", "sqrt": "vsw_lanes_sqrt",
               "casadi_sq": "vsw_lanes_sq"}  # fmt: skip
"""CasADi's calls in the table's functions and their lane-wise twins (vsw/dynamics/csrc/lanes.h)."""


def _lane_trig(code: str) -> str:
    """CasADi's scalar C with its sines and cosines taken from vsw_sin and vsw_cos
    (vsw/dynamics/csrc/lanes.h), the functions the lanes take theirs from."""
    return re.sub(r"\b(sin|cos)\(", r"vsw_\1(", code)


def _casadi_bodies(code: str) -> dict[str, tuple[str, list[str]]]:
    """Each CasADi function of ``code`` by its name: its internal C name and its body's
    lines (declarations, assignments, results)."""
    found = {}
    pattern = re.compile(r"/\* (\w+):\(.*?\*/\nstatic int (casadi_f\d+)\(.*?\) \{\n(.*?)\n\}",
                         re.S)  # fmt: skip
    for name, internal, body in pattern.findall(code):
        found[name] = internal, body.splitlines()
    return found


def lane_function(name: str, lines: list[str]) -> str:
    """One of CasADi's functions of (c, x) rewritten over lanes of walks
    (vsw/dynamics/csrc/lanes.h): the same operations in the same order on each lane, so each lane's
    result is the scalar function's bit for bit (IEEE addition, multiplication, division and square
    root are exact in vector registers too, contraction is off, and sines and cosines are
    vsw/dynamics/csrc/lanes.h's, which the scalar functions call too: _lane_trig). CasADi's body
    has three kinds of line only (asserted): declarations, assignments of one operation,
    and results."""
    out = []
    for line in lines:
        line = line.strip()
        if line == "return 0;":
            continue
        if line.startswith("casadi_real "):
            out.append("    vsw_lanes " + line[len("casadi_real ") :])
            continue
        if not re.fullmatch(r"(a\d+|res\[0\]\[\d+\])=[^;]+;", line):
            raise ValueError(f"{name}: a line the lanes cannot take: {line}")
        target, value = line[:-1].split("=", 1)
        value = value.replace("arg[0][", "c[").replace("arg[1][", "x[")
        target = target.replace("res[0][", "out[")
        value = re.sub(r"\b(\w+)\(",
                       lambda m: (_LANE_CALLS[m.group(1)] if m.group(1) in _LANE_CALLS
                                  else _unknown_call(name, m.group(1))) + "(", value)  # fmt: skip
        value = re.sub(r"(vsw_lanes_(?:sin|cos)\(\w+)\)", r"\1, live)", value)
        if re.fullmatch(r"-?[0-9.]+(e[-+]?\d+)?", value):
            value = f"vsw_lanes_splat({value})"
        out.append(f"    {target}={value};")
    out = _fused_sin_cos(out)
    return (f"static inline void {name}_lanes(int live, const vsw_lanes *c, const vsw_lanes *x, "
            f"vsw_lanes *out)\n{{\n" + "\n".join(out) + "\n}")  # fmt: skip


def _fused_sin_cos(lines: list[str]) -> list[str]:
    """The lane-wise lines with each sine and cosine of one unchanged operand taken from one
    ``vsw_lanes_sincos``: lane by lane (without libmvec) GCC fuses the two calls into
    glibc's sincos, which costs about 1.6 of one call and returns sin's and cos's values,
    bit for bit."""
    call = re.compile(r"    (\w+)=vsw_lanes_(sin|cos)\((a\d+), live\);")
    lines = list(lines)
    declared = []
    for i, line in enumerate(lines):
        first = call.fullmatch(line)
        if not first:
            continue
        target, kind, operand = first.groups()
        if target == operand:  # the call overwrites its operand: a later call takes another
            continue
        other = "cos" if kind == "sin" else "sin"
        for j in range(i + 1, len(lines)):
            second = call.fullmatch(lines[j])
            if second and second.group(2) == other and second.group(3) == operand:
                pair = f"vsw_sc{len(declared)}"
                declared.append(pair)
                lines[i] = (f"    vsw_lanes_sincos({operand}, live, &{pair}_sin, &{pair}_cos);\n"
                            f"    {target}={pair}_{kind};")  # fmt: skip
                lines[j] = f"    {second.group(1)}={pair}_{other};"
                break
            if lines[j].startswith(f"    {operand}="):  # the operand changes: no pair
                break
    if declared:
        names = ", ".join(f"{d}_sin, {d}_cos" for d in declared)
        lines.insert(0, f"    vsw_lanes {names};")
    return lines


def _unknown_call(name: str, call: str) -> str:
    raise ValueError(f"{name}: CasADi's {call}() has no lane-wise twin (derive/sim_codegen.py)")


def _c_list(values) -> str:
    return ", ".join(str(v) for v in values)


def table(descriptor: dict, module: types.ModuleType, prefix: str) -> types.SimpleNamespace:
    """The table's functions before the hoisting, as (name, dense SX of (p, x)) in
    ``pending``, with the table's structure (the C names of each dispatcher's functions,
    watch directions and meanings, event targets): what :func:`simulator_c_source` prints
    and tests/test_batch.py checks."""
    import casadi as ca

    module = _direct_trig(module, ca)
    params = descriptor["parameters"]
    state = (*descriptor["coordinates"], *descriptor["rates"])
    n = len(descriptor["coordinates"])
    p = ca.SX.sym("p", len(params))
    x = ca.SX.sym("x", len(state))
    args = [*ca.vertsplit(p), *ca.vertsplit(x)]
    pending: list[tuple[str, ca.SX]] = []

    def function(name: str, out) -> str:
        out = ca.vertcat(*out) if isinstance(out, (tuple, list)) else ca.SX(out)
        # Dense: the C reads every element, and _hoist_parameters indexes elements.
        pending.append((name, ca.densify(out)))
        return prefix + name

    phase_index = {ph["name"]: k for k, ph in enumerate(descriptor["phases"])}
    event_index = {ev["name"]: k for k, ev in enumerate(descriptor["events"])}
    failures = failure_names(descriptor)
    flows, watches, n_watch, directions, whats = [], [], [], [], []
    guard_functions: list[list[str]] = []
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
        # Each guard alone too: event location needs one guard at each iterate, and a
        # phase's whole set costs several times one (the compass gait's four guards 92 ns).
        guard_functions.append([function(f"{phase['name']}_guard_{k}", g)
                                for k, g in enumerate(guards)])  # fmt: skip
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
    return types.SimpleNamespace(
        p=p, x=x, pending=pending, params=params, state=state, failures=failures,
        flows=flows, watches=watches, guard_functions=guard_functions, n_watch=n_watch,
        directions=directions, whats=whats, max_watch=max_watch, resets=resets, whens=whens,
        targets=targets, ends_step=ends_step, step_length=step_length, step_event=step_event,
        start_phase=phase_index[step_event["target"]],
    )  # fmt: skip


def _cases(names: list[str], returns: str = "") -> str:
    """A dispatcher's ``switch`` cases: the k-th calls the k-th function (``"0"``: none)."""
    return "\n".join(
        f"    case {k}:\n        VSW_CALL({name}, c, x, out);\n        return{returns};"
        for k, name in enumerate(names)
        if name != "0"
    )


def _lane_cases(names: list[str]) -> str:
    """A lane-wise dispatcher's ``switch`` cases: the k-th calls the k-th lane function."""
    return "\n".join(f"    case {k}:\n        {name}_lanes(live, c, x, out);\n        return;"
                     for k, name in enumerate(names))  # fmt: skip


def _guard_cases(guard_functions: list[list[str]], max_watch: int) -> str:
    """The one-guard dispatcher's cases, numbered ``phase * max_watch + k``."""
    return "\n".join(
        f"    case {phase * max_watch + k}:\n        VSW_CALL({name}, c, x, out);\n"
        "        return out[0];"
        for phase, names in enumerate(guard_functions)
        for k, name in enumerate(names)
    )


def _padded(rows: list[list[int]], max_watch: int) -> str:
    """Rows of a ``[phases][max_watch]`` C array, each padded with zeros."""
    return ", ".join("{" + _c_list(r + [0] * (max_watch - len(r))) + "}" for r in rows)


def _compiled(model: str, prefix: str, t: types.SimpleNamespace) -> tuple[list, str, int]:
    """The table's functions of (c, x) after the hoisting, CasADi's C code of them (without
    its null checks) and the number of constants."""
    import casadi as ca

    constants, c, hoisted = _hoist_parameters(t.p, t.x, [out for _, out in t.pending])
    # A subexpression a function computes twice (the simplest walker's guards take cos theta
    # twice, the VSW biped's four cosines more) is computed once: the same operations on the
    # same operands, so the same results, bit for bit.
    hoisted = [ca.cse(out) for out in hoisted]
    functions = [ca.Function(prefix + "constants", [t.p], [constants], ["p"], ["c"])]
    functions += [
        ca.Function(prefix + name, [c, t.x], [out], ["c", "x"], [name])
        for (name, _), out in zip(t.pending, hoisted)
    ]
    casadi_code, _ = casadi_c(f"{model}_sim", functions, prefix, with_header=False)
    return functions, _without_null_checks(casadi_code), constants.numel()


def _describe(descriptor: dict, t: types.SimpleNamespace) -> dict[str, str]:
    """The template's comment lines: the model's parameters, state, phases, events and
    failures."""
    return {
        "parameters": ", ".join(t.params),
        "state": ", ".join(t.state),
        "phases": ", ".join(ph["name"] for ph in descriptor["phases"]),
        "events": ", ".join(
            f"{ev['name']} ({ev['source']} -> {ev['target']}"
            + (", ends the step" if ev["ends_step"] else "")
            + ")"
            for ev in descriptor["events"]
        ),
        "failures": ", ".join(t.failures) or "none",
    }


def simulator_c_source(model: str, source: str, descriptor: dict, module: types.ModuleType) -> str:
    """The model table of the batch simulator (see the module docstring)."""
    import casadi as ca

    prefix = f"vsw_{model}_sim_"
    t = table(descriptor, module, prefix)
    functions, casadi_code, n_constants = _compiled(model, prefix, t)
    bodies = _casadi_bodies(casadi_code)
    lane_functions = "\n\n".join(
        lane_function(name, bodies[name][1]) for name in (*t.flows, *t.watches)
    )
    template = string.Template(TEMPLATE.read_text())
    return template.substitute(
        header=header(source, " *"),
        casadi_version=ca.__version__,
        **_describe(descriptor, t),
        casadi_code=_lane_trig(casadi_code).rstrip("\n"),
        n_params=len(t.params),
        n_constants=n_constants,
        constants=prefix + "constants",
        n_state=len(t.state),
        n_phases=len(descriptor["phases"]),
        n_events=len(descriptor["events"]),
        n_failures=len(t.failures),
        max_watch=t.max_watch,
        start_phase=t.start_phase,
        sz_arg=max(f.sz_arg() for f in functions),
        sz_res=max(f.sz_res() for f in functions),
        sz_iw=max(f.sz_iw() for f in functions),
        sz_w=max(f.sz_w() for f in functions),
        flow_cases=_cases(t.flows),
        lane_functions=lane_functions,
        lane_flow_cases=_lane_cases(t.flows),
        lane_watch_cases=_lane_cases(t.watches),
        watch_cases=_cases(t.watches),
        guard_cases=_guard_cases(t.guard_functions, t.max_watch),
        n_watch=_c_list(t.n_watch),
        directions=_padded(t.directions, t.max_watch),
        whats=_padded(t.whats, t.max_watch),
        reset_cases=_cases(t.resets),
        when_cases=_cases(t.whens, " 1"),
        targets=_c_list(t.targets),
        ends_step=_c_list(t.ends_step),
        step_length_body=(
            f"    VSW_CALL({t.step_length}, c, x, out);\n    return 1;"
            if t.step_length != "0"
            else "    (void)c;\n    (void)x;\n    (void)out;\n    return 0;"
        ),
    )
