"""The open-loop step of a powered gait: each phase integrated with the inputs as the
scheme interpolates them (SciPy DOP853, 1e-11), its event's guard and failures watched,
the events' impulses applied; the re-simulation of the collocation's phases, the work
along a motion, the powered walker's Poincare map and its eigenvalues."""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.runtime import forked
from vsw.runtime.errors import ConvergenceError
from vsw.runtime.threads import default_threads
from vsw.synthesis.powered.dynamics import flow_function, input_rate_function, margin_functions
from vsw.synthesis.powered.events import apply_impulses
from vsw.synthesis.powered.request import (
    FAILURE_MARGIN,
    RESIMULATION_TOL,
    PoweredGait,
    gait_parameters,
    input_names,
    ordered_impulses,
)

__all__ = [
    "integrate_phase",
    "motion_work",
    "open_loop_control",
    "powered_eigenvalues",
    "powered_step",
    "powered_step_jacobian",
    "resimulate",
    "watchers",
]


def resimulate(
    model: HybridModel, p: np.ndarray, durations, states, inputs, work: dict | None = None
) -> tuple[float, float, str]:
    """Each phase integrated from its first knot with the inputs the scheme implies
    (quadratic on each interval through knot, midpoint, knot), its event's guard and its
    failures watched between the knots: the largest gap to the last knot relative to
    max(1, |state|), the largest |guard| at the phases' ends, and what went wrong on the
    way ('' when nothing: an event that counts before the phase's end, or a failure).
    With ``work``, each input's positive and negative work along it
    (:func:`motion_work`) into it."""
    from scipy.integrate import solve_ivp

    worst, guard_worst = 0.0, 0.0
    for (phase, event), duration, knots, u in zip(model.phase_sequence(), durations, states,
                                                  inputs):  # fmt: skip
        control = open_loop_control(u, duration)
        watched = watchers(model, phase, event, p, control)
        solution = solve_ivp(_rhs(model, phase, p, control), (0.0, duration), knots[0],
                             method="DOP853", rtol=RESIMULATION_TOL, atol=RESIMULATION_TOL,
                             events=[fn for _, fn in watched], dense_output=True)  # fmt: skip
        if work is not None:
            nodes = (u.shape[0] - 1) // 2
            for name, (plus, minus) in zip(input_names(model)[phase],
                                           motion_work(model, phase, p, solution.sol, control,
                                                       duration, duration / nodes)):  # fmt: skip
                work[f"{phase}.{name}"] = {"positive": plus, "negative": minus}
        inside = (duration * 1e-9, duration * (1 - 1e-6))
        for (name, _), times, found in zip(watched, solution.t_events, solution.y_events):
            for t, y in zip(times, found):
                if not inside[0] < t < inside[1]:
                    continue
                if name == event["name"] and not _counts(model, event, p, y):
                    continue  # a crossing the model ignores (legs passing at mid-stance)
                return (
                    worst,
                    guard_worst,
                    f"of phase {phase} meets {name} at t = {t:.6g}, "
                    f"before its end at {duration:.6g}",
                )
        end = solution.y[:, -1]
        scale = max(1.0, float(np.max(np.abs(knots[-1]))))
        worst = max(worst, float(np.max(np.abs(end - knots[-1]))) / scale)
        guard = float(model.function(f"event_{event['name']}_guard")(*p, *end))
        guard_worst = max(guard_worst, abs(guard))
    return worst, guard_worst, ""


def motion_work(model: HybridModel, phase: str, p: np.ndarray, states, control,
                end_time: float, interval: float, points: int = 16
               ) -> list[tuple[float, float]]:  # fmt: skip
    """Each input's positive and negative work over ``[0, end_time]`` along the dense
    output ``states``: Simpson's rule on ``points`` panels in each of the mesh's
    intervals (the inputs are smooth inside them; ``max(P, 0)`` has a kink where the
    power changes sign, which the panels resolve to their width squared)."""
    names = input_names(model)[phase]
    if not names:
        return []
    rates = input_rate_function(model, phase)
    edges = np.append(np.arange(0.0, end_time, interval), end_time)
    edges = edges[np.concatenate([[True], np.diff(edges) > 1e-12 * interval])]
    plus, minus = np.zeros(len(names)), np.zeros(len(names))
    weights = np.ones(2 * points + 1)
    weights[1:-1:2], weights[2:-1:2] = 4.0, 2.0
    for a, b in zip(edges[:-1], edges[1:]):  # noqa: RUF007 (numpy arrays)
        times = np.linspace(a, b, 2 * points + 1)
        power = np.array([control(t) * np.array(rates(p, states(t)), dtype=float).reshape(-1)
                          for t in times])  # fmt: skip
        share = (b - a) / (6 * points) * weights
        plus += share @ np.maximum(power, 0.0)
        minus += share @ np.minimum(power, 0.0)
    return [(float(a), float(b)) for a, b in zip(plus, minus)]


def _rhs(model: HybridModel, phase: str, p: np.ndarray, control):
    flow = flow_function(model, phase)

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        return np.array(flow(p, x, control(t)), dtype=float).reshape(-1)

    return rhs


def watchers(model: HybridModel, phase: str, event: dict, p: np.ndarray, control) -> list:
    """(name, SciPy event function) of a phase's event guard and of each failure (its guard
    with the inputs' share), non-terminal, in their directions."""
    guard_fn = model.function(f"event_{event['name']}_guard")

    def guard(t: float, x: np.ndarray) -> float:
        return float(guard_fn(*p, *x))

    guard.direction = event["direction"]
    out = [(event["name"], guard)]
    failures = model.phases[model.phase_index[phase]]["failures"]
    for (name, _, direction), (margin, _) in zip(failures, margin_functions(model, phase)):
        # A failure's guard at zero along an arc (a leg at its full length: the optimum
        # rides the constraint) crosses it by rounding: past zero by this much it counts.
        shift = direction * FAILURE_MARGIN

        def failing(t: float, x: np.ndarray, margin=margin, shift=shift) -> float:
            return float(margin(p, x, control(t))) - shift

        failing.direction = direction
        out.append((name, failing))
    return out


def _counts(model: HybridModel, event: dict, p: np.ndarray, x: np.ndarray) -> bool:
    """Whether an event's crossing at ``x`` counts (its ``when`` positive, as the runtime
    has it)."""
    return event["when"] is None or float(model.function(event["when"])(*p, *x)) > 0


def open_loop_control(inputs: np.ndarray, duration: float):
    """The input at time ``t`` of a phase as the scheme implies it: quadratic on each
    interval through knot, midpoint and knot; past the phase's end (a perturbed step lasts
    a little longer) the last interval's quadratic continued, so that the open-loop map is
    smooth at the gait (an input held constant there would kink it where the step ends)."""
    nodes = (inputs.shape[0] - 1) // 2
    h = duration / nodes

    def control(t: float) -> np.ndarray:
        i = min(max(int(t / h), 0), nodes - 1)
        s = t / h - i
        u0, uc, u1 = inputs[2 * i], inputs[2 * i + 1], inputs[2 * i + 2]
        return u0 * (1 - s) * (1 - 2 * s) + uc * 4 * s * (1 - s) + u1 * s * (2 * s - 1)

    return control


def powered_step(model: HybridModel, params: Sequence[float], gait: PoweredGait,
                 state: np.ndarray) -> np.ndarray:  # fmt: skip
    """One step from ``state`` with the gait's inputs as functions of the time since each
    phase began (open loop; past the planned end the last interval's quadratic continued:
    :func:`open_loop_control`), each phase
    ended by the first crossing of its event's guard that counts (its ``when``, as the
    runtime has it; SciPy DOP853, 1e-11; :func:`integrate_phase`): the powered walker's
    Poincare map. The gait's own parameters (:func:`gait_parameters`) are used."""
    p = gait_parameters(model, gait, params)
    x = np.array(state, dtype=float)
    for (phase, event), duration, u in zip(model.phase_sequence(), gait.durations, gait.inputs):
        control = open_loop_control(u, duration)
        (_, guard), *_ = watchers(model, phase, event, p, control)
        _solution, end = integrate_phase(model, phase, event, p, control, x, duration,
                                         gait.period, [guard])  # fmt: skip
        if end is None:
            raise ConvergenceError(
                f"{model.name}: the powered step from a perturbed state meets no "
                f"{event['name']} within twice its duration and a step more"
            )
        iota = [gait.impulses[f"{event['name']}.{name}"]
                for name in ordered_impulses(model, event)]  # fmt: skip
        x = apply_impulses(model, event, p, end[1], np.array(iota))[0]
    return x


def integrate_phase(model: HybridModel, phase: str, event: dict, p: np.ndarray, control,
                    x: np.ndarray, duration: float, period: float, events: list,
                    dense: bool = False) -> tuple[Any, tuple | None]:  # fmt: skip
    """A phase of the open-loop step from ``x`` (SciPy DOP853, 1e-11; ``events[0]`` its
    event's guard) and the first crossing of that guard that counts, (t, state), or None:
    over twice the planned duration, and where none comes there (a phase of almost no
    duration, perturbed: a leg that reaches its stop just before heelstrike) over a step
    more."""
    from scipy.integrate import solve_ivp

    for window in (2 * duration, 2 * duration + period):
        solution = solve_ivp(_rhs(model, phase, p, control), (0.0, window), x, method="DOP853",
                             rtol=RESIMULATION_TOL, atol=RESIMULATION_TOL, events=events,
                             dense_output=dense)  # fmt: skip
        for t, y in zip(solution.t_events[0], solution.y_events[0]):
            if t > 1e-9 * duration and _counts(model, event, p, y):
                return solution, (float(t), y)
    return solution, None


def powered_step_jacobian(model: HybridModel, params: Sequence[float], gait: PoweredGait,
                          x: np.ndarray, step: float = 1e-6) -> np.ndarray:  # fmt: skip
    """The Jacobian of :func:`powered_step` at ``x``: central differences, ``step`` of
    max(1, |x_j|)."""
    return _differences(model, params, gait, x, (step,))[0]


def _differences(model: HybridModel, params: Sequence[float], gait: PoweredGait,
                 x: np.ndarray, steps: Sequence[float]) -> list[np.ndarray]:  # fmt: skip
    """:func:`powered_step_jacobian` at each of ``steps``, the perturbed steps shared among
    the cores (:func:`vsw.runtime.forked.split_map`: each is a SciPy integration, which
    holds Python's lock)."""
    widths = [[step * max(1.0, abs(v)) for v in x] for step in steps]
    starts = []
    for row in widths:
        for j, h in enumerate(row):
            for sign in (1.0, -1.0):
                start = x.copy()
                start[j] += sign * h
                starts.append(start)
    ends = iter(forked.split_map(functools.partial(powered_step, model, params, gait), starts,
                                 default_threads()))  # fmt: skip
    out = []
    for row in widths:
        jacobian = np.empty((x.size, x.size))
        for j, h in enumerate(row):
            jacobian[:, j] = (next(ends) - next(ends)) / (2 * h)
        out.append(jacobian)
    return out


EIGENVALUE_STEP = 5e-4
"""The step of :func:`powered_eigenvalues`' differences, of max(1, |x_j|)."""

SMOOTH_MAP = 1e-2
"""The largest difference between the radii of :func:`powered_eigenvalues`' coarser
differences and its extrapolation, of max(1, radius), of a map smooth at that scale."""


def powered_eigenvalues(model: HybridModel, params: Sequence[float],
                        gait: PoweredGait) -> list[complex]:  # fmt: skip
    """Eigenvalues of the powered step's Poincare map at the gait, by modulus: the open-loop
    gait is stable when all lie inside the unit circle (a reset onto the section gives
    structural zeros). Its Jacobian by central differences at ``h`` and ``2 h``
    (:data:`EIGENVALUE_STEP`) combined by Richardson's extrapolation, ``(4 J(h) - J(2 h)) /
    3``, exact to O(h^4). A smaller step buys nothing: the simulated step's own error
    divided by the step is what limits it. (Measured once, the compass
    gait's least-torque gait at 0.8 m/s: 1.341484 here, 1.34148 to 1.34149 by every
    extrapolated step from 2.5e-4 to 1e-3, and 1.344 by plain differences at 1e-6.)
    ConvergenceError where the coarser differences' radius and the extrapolation's differ
    by more than :data:`SMOOTH_MAP`."""
    x = gait.states[0][0]
    fine, coarse = _differences(model, params, gait, x, (EIGENVALUE_STEP, 2 * EIGENVALUE_STEP))
    values = np.linalg.eigvals((4 * fine - coarse) / 3)
    # A perturbation that changes the step's events (another crossing counts, a short
    # phase skipped) makes the map rough at this scale: the differences then disagree by
    # far more than their O(h^2) (at most 4e-4 of the radius on the three gaits measured).
    radius = float(np.max(np.abs(values)))
    coarse_radius = float(np.max(np.abs(np.linalg.eigvals(coarse))))
    if not abs(coarse_radius - radius) <= SMOOTH_MAP * max(1.0, radius):
        raise ConvergenceError(
            f"{model.name}: the open-loop map is not smooth at the gait (max |eigenvalue| "
            f"{coarse_radius:.4g} by differences at {2 * EIGENVALUE_STEP:g}, {radius:.4g} "
            "extrapolated): no eigenvalues"
        )
    return sorted((complex(v) for v in values), key=lambda v: -abs(v))
