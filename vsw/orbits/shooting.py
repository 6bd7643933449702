"""The shooting discretisation of a hybrid periodic orbit: CasADi CVODES flows of each phase
and the multiple-shooting residual with its exact Jacobian.

A step of the model is a sequence of phases, each ended by one event
(:func:`phase_sequence`). Phase ``k`` of a period-``p`` orbit starts at ``x_k`` and lasts
``T_k``; its flow over the unit interval of ``s`` is

    x'(s) = T_k f_k(x(s), p),    x(0) = x_k,                                  (1)

so ``x(1) = phi_k(x_k, T_k)`` and ``d x(1) / d T_k = f_k(x(1))``. The residual of the orbit
in the unknowns ``u = (x_1..x_m, T_1..T_m)`` (``m`` phases over ``p`` steps) is, per phase,

    g_k(phi_k) = 0,    R_k(phi_k) - x_{k+1} = 0    (x_{m+1} = x_1),             (2)

its guard at its end and its event's reset onto the next phase's start. CVODES (Adams,
1e-13) integrates (1) with forward sensitivities, so CasADi's Jacobian of (2) is exact to
the integrator's tolerance. Shooting one phase at a time keeps each block of the Jacobian to
one phase's growth: over the four steps of the simplest walker's period-4 gait a single
shot reaches entries of 1e6 and the continuation's corrector fails (measured).

Imports: numpy, CasADi (inside functions: ``import vsw`` stays fast), ``vsw.runtime.errors``. A
model is taken by its interface (:class:`vsw.dynamics.hybrid.HybridModel`'s ``symbolic``, ``spec``,
``phases``, ``by_source``, ``step_event``, ``reset``); this module never imports
:mod:`vsw.dynamics.hybrid`, which builds on it.
"""

from __future__ import annotations

import contextlib
import functools
import io
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from vsw.runtime.errors import VswInputError

__all__ = [
    "FlowPiece",
    "flows",
    "multiple_shooting",
    "phase_blocks",
    "phase_flow",
    "phase_integrator",
    "phase_pieces",
    "phase_sequence",
    "starts_of",
]


def phase_sequence(model: Any) -> list[tuple[str, dict]]:
    """(phase, event that ends it) over one step, from the section (the phase the step
    event leads to). VswInputError where a phase has more than one event: the orbit is
    then not one sequence of phases."""
    out = []
    phase = model.step_event["target"]
    for _ in range(len(model.phases) + 1):
        events = model.by_source[phase]
        if len(events) != 1:
            raise VswInputError(
                f"{model.name}: phase {phase} has {len(events)} events; the orbit solver "
                "needs one event per phase"
            )
        out.append((phase, events[0]))
        if events[0]["ends_step"]:
            return out
        phase = events[0]["target"]
    raise VswInputError(f"{model.name}: no step event reached")


@functools.cache
def phase_integrator(model: Any, phase: str, tolerance: float, max_steps: int,
                     variational: bool = False, name: str | None = None) -> Any:  # fmt: skip
    """The flow (1) of ``phase`` as a CVODES integrator (Adams, ``tolerance`` absolute and
    relative) of ``x0`` and ``p = (params, T)`` over ``s`` in [0, 1]. With
    ``variational`` the state is ``(x, vec Phi)`` (column-major) with
    ``Phi' = T (df/dx) Phi``, so that ``Phi(1)`` from ``Phi(0) = I`` is ``d phi / d x0``
    (the variational equations beside the state: their derivatives need only first
    sensitivities)."""
    import casadi as ca

    n = 2 * model.n
    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", n)
    duration = ca.SX.sym("T")
    f = ca.vertcat(x[model.n :], model.symbolic(f"{phase}_accelerations", p, x))
    state, ode = x, duration * f
    if variational:
        phi = ca.SX.sym("phi", n, n)
        state = ca.vertcat(x, ca.vec(phi))
        ode = ca.vertcat(duration * f, ca.vec(duration * ca.mtimes(ca.jacobian(f, x), phi)))
    return ca.integrator(
        name or f"flow_{phase}", "cvodes",
        {"x": state, "p": ca.vertcat(p, duration), "ode": ode}, 0.0, 1.0,
        # Adams: the walkers are not stiff, and at these tolerances it was
        # several times faster than BDF (benchmarks case 9 times the solve).
        {"abstol": tolerance, "reltol": tolerance, "max_num_steps": max_steps,
         "linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"},
    )  # fmt: skip


@functools.cache
def flows(model: Any) -> dict[str, tuple[Any, Any, Any]]:
    """Per phase of the step: (its flow (1) as a CVODES integrator of x0 and p = (params,
    T), 1e-13 (:func:`phase_integrator`), its event's guard g(p, x), its reset R(p, x)),
    CasADi functions."""
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    out = {}
    for phase, event in phase_sequence(model):
        guard = model.symbolic(f"event_{event['name']}_guard", p, x)
        reset = model.symbolic(f"event_{event['name']}_reset", p, x)
        out[phase] = (
            phase_integrator(model, phase, 1e-13, 100000),
            ca.Function(f"guard_{phase}", [p, x], [guard]),
            ca.Function(f"reset_{phase}", [p, x], [reset]),
        )
    return out


def phase_flow(
    model: Any, phase: str, params: Sequence[float], state: np.ndarray, duration: float
) -> np.ndarray:
    """``phi_k(state, duration)`` of (1): the state after ``duration`` in ``phase``
    (RuntimeError where CVODES fails)."""
    integrator = flows(model)[phase][0]
    p = np.concatenate([np.asarray(params, float), [float(duration)]])
    with contextlib.redirect_stderr(io.StringIO()):
        return np.array(integrator(x0=np.asarray(state, float), p=p)["xf"], float).reshape(-1)


def starts_of(
    model: Any, period: int, params: Sequence[float], x0: np.ndarray, durations: Sequence[float]
) -> np.ndarray:
    """The phases' starts ``x_1..x_m`` of (2) from the section state ``x0`` and the
    durations: each by the flows and resets from the one before (RuntimeError where CVODES
    fails)."""
    starts, x = [], np.asarray(x0, dtype=float)
    for (phase, event), duration in zip(phase_sequence(model) * period, durations):
        starts.append(x)
        end = phase_flow(model, phase, params, x, duration)
        x = model.reset(event["name"], params, end)
    return np.concatenate(starts)


@dataclass(frozen=True)
class FlowPiece:
    """One phase of an orbit's step on the clock of the step: its start and end times and
    its start state, the states in between by the phase's flow (1)."""

    model: Any
    phase: str
    params: tuple[float, ...]
    start: float
    end: float
    state: np.ndarray

    def states(self, times: np.ndarray) -> np.ndarray:
        """The state at each of ``times`` (in [start, end], any order), shape (len(times),
        2n): the flow from each time to the next in increasing order (RuntimeError where
        CVODES fails)."""
        times = np.asarray(times, dtype=float)
        order = np.argsort(times, kind="stable")
        out = np.empty((len(times), len(self.state)))
        x, t = self.state, self.start
        for i in order:
            if times[i] > t:
                x = phase_flow(self.model, self.phase, self.params, x, times[i] - t)
                t = times[i]
            out[i] = x
        return out


def phase_pieces(model: Any, params: Sequence[float], x0: np.ndarray,
                 durations: Sequence[float]) -> list[FlowPiece]:  # fmt: skip
    """A step from the section state ``x0`` with the phases' ``durations`` (a periodic
    orbit's) as one :class:`FlowPiece` a phase (RuntimeError where CVODES fails)."""
    params = tuple(float(v) for v in params)
    starts = starts_of(model, 1, params, x0, durations).reshape(len(durations), -1)
    ends = np.cumsum(durations)
    return [FlowPiece(model, phase, params, float(end - duration), float(end), start)
            for (phase, _event), start, duration, end in zip(phase_sequence(model), starts,
                                                               durations, ends)]  # fmt: skip


@functools.cache
def multiple_shooting(model: Any, period: int, parameters: tuple[int, ...] = ()) -> Any:
    """The residual (2) of the period-``period`` orbit as a CasADi function of
    (u, p_0, ..., p_last) (each parameter an input of its own: CasADi differentiates in
    symbols) giving the residual, its Jacobian in ``u`` and its derivative in each
    parameter of ``parameters`` (indices). The residual's rows are, per phase, its guard
    then the ``2 n`` rows of its reset's mismatch."""
    import casadi as ca

    sequence = phase_sequence(model) * period
    phase_functions = flows(model)
    n, m = 2 * model.n, len(sequence)
    scalars = [ca.MX.sym(f"p{i}") for i in range(len(model.parameter_table))]
    p = ca.vertcat(*scalars)
    starts = ca.MX.sym("x", n * m)
    durations = ca.MX.sym("T", m)
    residuals = []
    for k, (phase, _event) in enumerate(sequence):
        integrator, guard, reset = phase_functions[phase]
        x = starts[k * n : (k + 1) * n]
        following = starts[((k + 1) % m) * n : ((k + 1) % m + 1) * n]
        end = integrator(x0=x, p=ca.vertcat(p, durations[k]))["xf"]
        residuals += [guard(p, end), reset(p, end) - following]
    u = ca.vertcat(starts, durations)
    r = ca.vertcat(*residuals)
    name = "_".join(["orbit_system", str(period), *map(str, parameters)])
    outputs = [r, ca.jacobian(r, u), *(ca.jacobian(r, scalars[i]) for i in parameters)]
    return ca.Function(name, [u, *scalars], outputs)


def phase_blocks(
    jacobian: np.ndarray, n: int, m: int
) -> Iterator[tuple[np.ndarray, float, np.ndarray, np.ndarray]]:
    """Per phase, from the Jacobian of (2) in ``u``: ``(g_x, g_T, F_x, F_T)``, the
    derivatives of its guard ``g(phi)`` and of its image ``F = R(phi)`` in its start and
    its duration. With one phase (``m = 1``) its next start is its own, so the residual's
    block holds ``F_x - I``: the identity is added back."""
    for k in range(m):
        block = jacobian[k * (n + 1) : (k + 1) * (n + 1)]
        g_x, g_t = block[0, k * n : (k + 1) * n], block[0, n * m + k]
        f_x, f_t = block[1:, k * n : (k + 1) * n], block[1:, n * m + k]
        if m == 1:
            f_x = f_x + np.eye(n)
        yield g_x, g_t, f_x, f_t
