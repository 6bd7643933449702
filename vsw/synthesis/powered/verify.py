"""An optimised gait made exact: the periodic step of the walker driven by the optimum's
inputs, and its work from that motion (``vsw optimize --verify``).

The collocation's gait satisfies the walker's equations only to its mesh's accuracy (its
re-simulation ends a little away from its last knot), so its work bounds the least work
only up to that error. Here the inputs the scheme implies (quadratic on each interval,
as functions of the time since each phase began, :func:`vsw.synthesis.powered.step.powered_step`)
and the impulses are kept, and the state just after the step event is moved to the fixed
point of that open-loop step (Newton, central differences): a motion of the walker to
the integrator's tolerance (SciPy DOP853, 1e-11). Its work is integrated along it (each
input's ``max(P, 0)`` by Simpson's rule on the dense output), each impulse's exact
positive work where its split stops a reversing rate
(:func:`vsw.synthesis.powered.events.stopping_splits`); every failure, every input's bounds and
every crossing of the step event's guard that counts (its ``when``: a swing foot passing
the ground behind the stance foot is ignored, as every walker here ignores scuffing) is
watched on the way,
and the ground's impulses at each event are evaluated. Its speed and step length differ
from the targets by about the collocation's error (reported): it is a gait of the body
at those, whatever the mesh.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.runtime.errors import ConvergenceError
from vsw.synthesis.powered.dynamics import momentum_function, reaction_function
from vsw.synthesis.powered.events import apply_impulses, stopping_splits
from vsw.synthesis.powered.objectives import positive_work_of_linear_power
from vsw.synthesis.powered.request import (
    PoweredGait,
    gait_parameters,
    impulse_names,
    input_names,
    ordered_impulses,
)
from vsw.synthesis.powered.step import (
    integrate_phase,
    motion_work,
    open_loop_control,
    powered_step,
    powered_step_jacobian,
    watchers,
)

__all__ = ["PhaseRun", "VerifiedGait", "step_runs", "verify"]


WORK_PANELS = 64
"""Simpson panels in each of the mesh's intervals for the work along the motion (the
power is smooth inside them but for the kink of max(P, 0) where it changes sign)."""
FIXED_POINT_TOL = 1e-7
"""The fixed point is accepted where the step maps the state to itself within this,
relative to max(1, |state|): the open-loop step of an unstable gait (|eigenvalue| 12 at
the VSW biped's body's least-work gait) amplifies the integrator's 1e-11 to about 1e-8,
where Newton stalls (it goes on to 1e-9 for the best of its iterates)."""


@dataclass
class VerifiedGait:
    """The periodic step of the walker under the optimum's inputs: ``state`` just after
    the step event, ``residual`` its step's gap to it (relative), the step's ``period``,
    ``step_length`` and ``speed``, each input's and impulse's ``work`` (positive,
    negative) and ``positive_work`` their positive total, the ground's impulses at each
    event (tangential, normal), and ``failure``: what ended or spoiled the step ('' when
    nothing)."""

    state: np.ndarray
    residual: float
    period: float
    step_length: float | None
    speed: float | None
    work: dict[str, dict[str, float]] = field(default_factory=dict)
    ground_impulses: dict[str, tuple[float, float]] = field(default_factory=dict)
    failure: str = ""
    stance_friction: float = 0.0
    """The largest |tangential| / normal of the stance foot's reaction along the step
    (sampled at 200 instants a phase): the friction coefficient the stance needs."""
    end: np.ndarray | None = None
    """The state the step from ``state`` ends in, just after its step event."""

    @property
    def positive_work(self) -> float:
        return float(sum(w["positive"] for w in self.work.values()))

    def summary(self) -> dict[str, Any]:
        """The verification's outcome and the step's numbers, as every JSON record has them
        (``vsw optimize``'s ``verified``, a gait file's ``verification``)."""
        return {
            "status": "failed" if self.failure else "verified",
            "reason": self.failure or None,
            "residual": self.residual,
            "positive_work": self.positive_work,
            "period": self.period,
            "step_length": self.step_length,
            "speed": self.speed,
            "work": self.work,
        }


def verify(model: HybridModel, params: Sequence[float], gait: PoweredGait,
           iterations: int = 20) -> VerifiedGait:  # fmt: skip
    """The fixed point of ``gait``'s open-loop step and the step from it (module
    docstring); :class:`ConvergenceError` where Newton does not find it. The gait's own
    parameters (:func:`gait_parameters`: the chosen ones at the optimiser's values) are used."""
    p = gait_parameters(model, gait, params)
    x = np.array(gait.states[0][0], dtype=float)
    best, residual = x, np.inf
    jacobian = None
    for _ in range(iterations):
        gap = powered_step(model, p, gait, x) - x
        size = float(np.max(np.abs(gap))) / max(1.0, float(np.max(np.abs(x))))
        if size >= residual / 2 and residual <= FIXED_POINT_TOL:
            break  # at the step's noise: no better iterate will come
        if size < residual:
            best, residual = x, size
        if jacobian is None:  # the chord method: the start is near the fixed point
            jacobian = powered_step_jacobian(model, p, gait, x) - np.eye(x.size)
        x = x - np.linalg.lstsq(jacobian, gap, rcond=None)[0]
    if not residual <= FIXED_POINT_TOL:
        raise ConvergenceError(f"{model.name}: the open-loop step has no fixed point near the "
                               f"optimum (Newton's least gap {residual:.3g} in {iterations} "
                               "iterations)")  # fmt: skip
    x = best
    return _replay(model, p, gait, x, residual)


@dataclass
class PhaseRun:
    """One phase of a step driven by a gait's inputs (:func:`step_runs`): its ``control``
    (the input at the time since the phase began), SciPy's ``solution`` (dense) and
    ``watched`` guards, the time of its event ``end_time``, the state there before the
    event's impulses and reset (``before``) and after them (``after``), and the first
    failure it crosses before its end, (name, time) or None."""

    phase: str
    event: dict
    control: Any
    watched: list
    solution: Any
    end_time: float
    before: np.ndarray
    after: np.ndarray
    failure: tuple[str, float] | None


def step_runs(model: HybridModel, p: np.ndarray, gait: PoweredGait,
              x: np.ndarray) -> list[PhaseRun]:  # fmt: skip
    """One step from ``x`` with ``gait``'s inputs and impulses at the parameters ``p``,
    integrated as :func:`vsw.synthesis.powered.step.powered_step` integrates it (so that it ends
    where Newton's last step did): each phase to its event's first crossing that counts, every
    failure watched (and recorded, the phase going on to its event), each event's
    impulses applied. The one implementation of "a step with these inputs": the
    verification's (:func:`verify`) and a saved gait's replay (:mod:`vsw.studies.gait_file`).
    :class:`ConvergenceError` where a phase meets no event."""
    runs: list[PhaseRun] = []
    state = np.array(x, dtype=float)
    for (phase, event), duration, u in zip(model.phase_sequence(), gait.durations, gait.inputs):
        control = open_loop_control(u, duration)
        watched = watchers(model, phase, event, p, control)
        solution, end = integrate_phase(model, phase, event, p, control, state, duration,
                                        gait.period, [fn for _, fn in watched],
                                        dense=True)  # fmt: skip
        if end is None:
            raise ConvergenceError(
                f"{model.name}: the step with the gait's inputs meets no {event['name']} "
                "within twice its planned duration and a step more"
            )
        end_time = end[0]
        before = solution.sol(end_time)
        iota = np.array([gait.impulses[f"{event['name']}.{name}"]
                         for name in ordered_impulses(model, event)])  # fmt: skip
        after = apply_impulses(model, event, p, before, iota)[0]
        failure = _first_failure(watched, solution, end_time)
        runs.append(PhaseRun(phase, event, control, watched, solution, end_time, before,
                             after, failure))  # fmt: skip
        state = after
    return runs


def _replay(model: HybridModel, p: np.ndarray, gait: PoweredGait, x: np.ndarray,
            residual: float) -> VerifiedGait:  # fmt: skip
    """One step from ``x`` (:func:`step_runs`), every failure and the inputs' bounds
    checked; the inputs' positive and negative work along it
    (:func:`vsw.synthesis.powered.step.motion_work`), the events' impulses' and the ground's."""
    names = input_names(model)
    state, period, failure, friction = x.copy(), 0.0, "", 0.0
    work: dict[str, dict[str, float]] = {}
    ground: dict[str, tuple[float, float]] = {}
    step_length = None
    for run, duration, u in zip(step_runs(model, p, gait, x), gait.durations, gait.inputs):
        phase, event, end_time = run.phase, run.event, run.end_time
        if run.failure is not None and not failure:
            failure = f"{run.failure[0]} in phase {phase} at t = {run.failure[1]:.6g}"
        failure = failure or _outside_bounds(model, phase, run.control, end_time)
        friction = max(friction, _stance_friction(model, phase, p, run.solution, run.control,
                                                  end_time))  # fmt: skip
        nodes = (u.shape[0] - 1) // 2
        along = motion_work(model, phase, p, run.solution.sol, run.control, end_time,
                            duration / nodes, WORK_PANELS)  # fmt: skip
        for name, (plus, minus) in zip(names[phase], along):
            work[f"{phase}.{name}"] = {"positive": plus, "negative": minus}
        iota = np.array([gait.impulses[f"{event['name']}.{name}"]
                         for name in ordered_impulses(model, event)])  # fmt: skip
        state = _event(model, event, p, run.before, iota, work, ground)
        period += end_time
        if event["ends_step"] and model.spec["step_length"]:
            step_length = float(model.step_length(p, run.before))
    gap = np.max(np.abs(state - x)) / max(1.0, float(np.max(np.abs(x))))
    if not gap <= FIXED_POINT_TOL:
        failure = failure or f"the step ends {gap:.3g} from where it began (relative)"
    return VerifiedGait(x, max(residual, float(gap)), period, step_length,
                        None if step_length is None else step_length / period, work, ground,
                        failure, friction, state)  # fmt: skip


def _stance_friction(model: HybridModel, phase: str, p: np.ndarray, solution, control,
                     end_time: float) -> float:  # fmt: skip
    reaction = reaction_function(model, phase)
    worst = 0.0
    for t in np.linspace(0.0, end_time, 200):
        tangential, normal = np.array(reaction(p, solution.sol(t), control(t)),
                                      dtype=float).reshape(-1)  # fmt: skip
        worst = max(worst, abs(tangential) / normal if normal > 0 else np.inf)
    return float(worst)


def _outside_bounds(model: HybridModel, phase: str, control, end_time: float) -> str:
    """The first input outside its declared bounds between the knots (400 instants a
    phase; '' when none): the mesh holds them at its knots and midpoints only."""
    inputs = model.phases[model.phase_index[phase]].get("inputs", ())
    if not inputs:
        return ""
    times = np.linspace(0.0, end_time, 400)
    values = np.array([control(t) for t in times])
    scale = max(1.0, float(np.max(np.abs(values))))
    for k, record in enumerate(inputs):
        low, high = record["bounds"]
        for bound, side in ((low, -1.0), (high, 1.0)):
            if bound is None:
                continue
            past = side * (values[:, k] - bound) > 1e-9 * scale
            if np.any(past):
                t = times[np.argmax(past)]
                return f"{record['name']} outside its bounds in phase {phase} at t = {t:.6g}"
    return ""


def _first_failure(watched: list, solution, end_time: float) -> tuple[str, float] | None:
    """The first failure crossed before the phase's end, (name, time), or None."""
    first = None
    for (name, _), times in zip(watched[1:], solution.t_events[1:]):
        for t in times:
            if 1e-9 < t < end_time * (1 - 1e-9) and (first is None or t < first[1]):
                first = (name, float(t))
    return first


def _event(model: HybridModel, event: dict, p: np.ndarray, before: np.ndarray,
           iota: np.ndarray, work: dict, ground: dict) -> np.ndarray:  # fmt: skip
    """The state after the event; each impulse's positive work and negative work into
    ``work`` (each impulse in two parts split where its own rate stops, the group applied
    in proportion: :func:`vsw.synthesis.powered.events.stopping_splits`; exact for that schedule,
    the least positive work for an impulse alone on its side of the reset, and for a group
    possibly not the optimiser's split); the ground's impulses into
    ``ground``: through the stance foot (the impulses before an impact's reset; a lock's;
    those at a change of phase, a push at a chosen angle) and through the new foot (an
    impact and what follows it)."""
    splits = stopping_splits(model, event, p, before, iota)
    after, works, ends = apply_impulses(model, event, p, before, iota, splits)
    offset = 0
    for group in impulse_names(model, event):
        block = ends[4 * offset : 4 * (offset + len(group))].reshape(4, len(group))
        positive = (positive_work_of_linear_power(block[0], block[1])
                    + positive_work_of_linear_power(block[2], block[3]))  # fmt: skip
        for k, name in enumerate(group):
            work[f"{event['name']}.{name}"] = {
                "positive": float(positive[k]),
                "negative": float(works[offset + k] - positive[k]),
            }
        offset += len(group)
    momentum_before = momentum_function(model, event["source"])
    start = np.array(momentum_before(p, before), dtype=float).reshape(-1)
    count = len(impulse_names(model, event)[0])
    if count and event["reset"] == "impact":
        n = model.n
        gains = np.array(model.function(f"event_{event['name']}_impulse_gains_before")(*p, *before),
                         dtype=float).reshape(n, count)  # fmt: skip
        pushed = before.copy()
        pushed[n:] += gains @ iota[:count]
        middle = np.array(momentum_before(p, pushed), dtype=float).reshape(-1)
        ground[f"{event['name']}.stance_foot"] = (float(middle[0] - start[0]),
                                                  float(middle[1] - start[1]))  # fmt: skip
        start = middle
    end = np.array(momentum_function(model, event["target"])(p, after), dtype=float).reshape(-1)
    key = "new_foot" if event["reset"] == "impact" else "stance_foot"
    ground[f"{event['name']}.{key}"] = (float(end[0] - start[0]), float(end[1] - start[1]))
    return after
