"""A model's functions the collocation and the re-simulation evaluate, as CasADi
functions of ``(p, x[, u])`` cached per model and phase: the flow with the inputs
(``q'' = a(q, q') + B(q) u``), its Jacobian, the inputs' rates, the failures' guards with
the inputs' share, and the walker's momentum and the ground's reaction on the stance
foot."""

from __future__ import annotations

import functools
from typing import Any

from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.quantities import weight as walker_weight
from vsw.synthesis.powered.request import input_names

__all__ = [
    "flow_function",
    "flow_jacobian_function",
    "input_rate_function",
    "margin_functions",
    "momentum_function",
    "reaction_function",
]


@functools.cache
def momentum_function(model: HybridModel, phase: str) -> Any:
    """(p, x) -> the walker's linear momentum in the phase's chart (tangential along the
    ground, normal to it): each body's mass times its position's rate."""
    import casadi as ca

    n = model.n
    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * n)
    return ca.Function(f"momentum_{phase}", [p, x], [_momentum(model, phase, p, x)])


def _momentum(model: HybridModel, phase: str, p: Any, x: Any) -> Any:
    import casadi as ca

    n = model.n
    positions = model.symbolic(f"{phase}_positions", p, x)
    inertias = model.symbolic(f"{phase}_inertias", p, x)
    momentum = ca.SX.zeros(2)
    for body in range(positions.shape[0] // 3):
        where = positions[3 * body : 3 * body + 2]
        momentum += inertias[2 * body] * ca.mtimes(ca.jacobian(where, x[:n]), x[n:])
    return momentum


@functools.cache
def reaction_function(model: HybridModel, phase: str) -> Any:
    """(p, x, u) -> the ground's reaction on the stance foot in the phase's chart
    (tangential, normal): the walker's rate of momentum less its weight, which acts along
    the chart's ``(sin gamma, -cos gamma)`` on a slope ``gamma`` (:meth:`HybridModel.slope`;
    0 on level ground)."""
    import casadi as ca

    n = model.n
    names = input_names(model)[phase]
    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * n)
    u = ca.SX.sym("u", len(names))
    momentum = _momentum(model, phase, p, x)
    rate = ca.mtimes(ca.jacobian(momentum, x), flow_function(model, phase)(p, x, u))
    index = model.slope_index()
    slope = 0 if index is None else p[index]
    weight = walker_weight(model, p)
    gravity = weight * ca.vertcat(ca.sin(slope), -ca.cos(slope))
    return ca.Function(f"reaction_{phase}", [p, x, u], [rate - gravity])


@functools.cache
def flow_jacobian_function(model: HybridModel, phase: str) -> Any:
    """(p, x, u) -> d(x')/dx with the phase's inputs held."""
    import casadi as ca

    flow = flow_function(model, phase)
    p, x, u = (ca.SX.sym(name, *flow.size_in(i)) for i, name in enumerate("pxu"))
    return ca.Function(f"flow_jacobian_{phase}", [p, x, u], [ca.jacobian(flow(p, x, u), x)])


@functools.cache
def flow_function(model: HybridModel, phase: str) -> Any:
    """(p, x, u) -> x' with the phase's inputs (none: the passive flow)."""
    import casadi as ca

    n = model.n
    names = input_names(model)[phase]
    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * n)
    u = ca.SX.sym("u", len(names))
    acc = model.symbolic(f"{phase}_accelerations", p, x)
    if names:
        gains = ca.reshape(model.symbolic(f"{phase}_input_gains", p, x), len(names), n).T
        acc = acc + ca.mtimes(gains, u)
    return ca.Function(f"flow_{phase}", [p, x, u], [ca.vertcat(x[n:], acc)])


@functools.cache
def input_rate_function(model: HybridModel, phase: str) -> Any:
    """(p, x) -> the rate of each input's ``along`` coordinate (its power is the input
    times it)."""
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    return ca.Function(f"rates_{phase}", [p, x], [model.symbolic(f"{phase}_input_rates", p, x)])


@functools.cache
def margin_functions(model: HybridModel, phase: str) -> list[tuple[Any, int]]:
    """(p, x, u) -> each failure's guard with the inputs' share, and its direction."""
    import casadi as ca

    names = input_names(model)[phase]
    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    u = ca.SX.sym("u", len(names))
    out = []
    for _failure, function, direction in model.phases[model.phase_index[phase]]["failures"]:
        guard = model.symbolic(function, p, x)
        if names:
            guard = guard + ca.dot(model.symbolic(f"{function}_input_gains", p, x), u)
        out.append((ca.Function(f"margin_{function}", [p, x, u], [guard]), direction))
    return out
