"""One runtime for every hybrid walking model of the engine (``generated/<model>/``).

A generated model package carries ``HYBRID`` (its phases, events, failures, parameters,
coordinates, units) and the functions the engine derived: per phase the accelerations,
energy, ground reaction and failure guards; per event the guard, the reset and optionally
the sign that must be positive for the event to count. :class:`HybridModel` drives them:

* :meth:`HybridModel.simulate`: time-domain simulation (SciPy DOP853) whose events are the
  model's guards and resets: one implementation for every model;
* :meth:`HybridModel.step`: the Poincaré map (state just after one step event to the next);
* :meth:`HybridModel.periodic_orbit`: a period-one gait as the periodic-orbit problem of
  :mod:`vsw.orbits` (each phase's start and duration unknown; residuals: each phase's guard
  at its end and its reset onto the next phase's start), solved by its Newton on CasADi
  integrators of the generated dynamics, so it needs no event detection and gets exact
  derivatives; eigenvalues of its monodromy matrix; confirmed by one simulated step;
* :meth:`HybridModel.eigenvalues`: of the Jacobian of the Poincaré map at any section state,
  by CasADi derivatives through the integration (each phase's end time from its guard by
  the implicit function theorem): a route independent of the orbit problem's.

Imports: numpy, ``vsw.runtime.stop``, ``vsw.runtime.errors``, ``vsw.dynamics.parameters`` and
:mod:`vsw.orbits` (which takes this model by its interface and never imports this module). ``import
vsw.dynamics.hybrid`` is cheap: casadi and scipy are imported inside functions.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import io
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.parameters import check_parameter
from vsw.orbits import OrbitProblem, Solved, by_modulus, phase_sequence, shooting
from vsw.runtime import stop
from vsw.runtime.errors import ConvergenceError, VswInputError

__all__ = [
    "Attractor",
    "HybridModel",
    "Orbit",
    "PhasePiece",
    "StepResult",
    "Trajectory",
]

RTOL = 1e-12
"""Relative tolerance of every phase's integration (DOP853), the compiled simulator's too."""
ATOL = 1e-12
"""Absolute tolerance of every phase's integration."""
PHASE_TIME_LIMIT = 100.0
"""Model time after which a phase without an event has stalled (in the model's time unit)."""


@dataclass(frozen=True)
class StepResult:
    """One step of the Poincaré map: ``ended`` is 'completed' or a failure's name."""

    state: np.ndarray
    ended: str
    durations: tuple[float, ...]
    step_length: float | None = None


@dataclass(frozen=True)
class EventRecord:
    """One event of a step: the states on either side and the mechanical energy (T + V of
    the phase before, of the phase after) at each: what an actuator adds or an impact
    dissipates is ``energy_after - energy_before``."""

    name: str
    time: float
    state_before: np.ndarray
    state_after: np.ndarray
    energy_before: float
    energy_after: float

    @property
    def energy_change(self) -> float:
        return self.energy_after - self.energy_before


@dataclass(frozen=True)
class PhasePiece:
    """One phase of a walk in continuous time: its dense output over [start, end] (the
    solutions of SciPy's DOP853, several where the phase restarted past an event that did
    not count), in the step ``step`` (0 = the first)."""

    phase: str
    step: int
    start: float
    end: float
    segments: tuple  # (OdeSolution, start, end)

    def states(self, times: np.ndarray) -> np.ndarray:
        """The state at each of ``times`` (in [start, end]), shape (len(times), 2n)."""
        times = np.asarray(times, dtype=float)
        starts = np.array([s for _, s, _ in self.segments])
        which = np.clip(np.searchsorted(starts, times, side="right") - 1, 0, len(starts) - 1)
        size = np.asarray(self.segments[0][0](self.start)).size
        out = np.empty((len(times), size))
        for k, (solution, _, _) in enumerate(self.segments):
            chosen = which == k
            if np.any(chosen):
                out[chosen] = np.asarray(solution(times[chosen]), dtype=float).T
        return out


class _Held:
    """A phase's dense output that is one state at every time (a phase not integrated)."""

    def __init__(self, state: np.ndarray) -> None:
        self.state = np.array(state, dtype=float)

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        if t.ndim == 0:
            return self.state.copy()
        return np.repeat(self.state[:, None], t.size, axis=1)


@dataclass(frozen=True)
class Trajectory:
    """A simulated walk: samples, the phase of each, and the section states."""

    t: np.ndarray
    states: np.ndarray  # (n_samples, 2 n)
    phase: np.ndarray  # phase index of each sample
    section: np.ndarray  # states just after each step event (the first is the start)
    ended: str
    steps_completed: int


@dataclass(frozen=True)
class Orbit:
    """A period-one gait."""

    state: dict[str, float]  # coordinates and rates just after the step event
    durations: tuple[float, ...]
    period: float
    eigenvalues: tuple[complex, ...]
    step_length: float | None
    residual: float
    phase_states: tuple[np.ndarray, ...] = field(repr=False, default=())

    @property
    def max_abs_eigenvalue(self) -> float:
        return max(abs(e) for e in self.eigenvalues)

    @property
    def stable(self) -> bool:
        return self.max_abs_eigenvalue < 1.0

    @property
    def speed(self) -> float | None:
        return None if self.step_length is None else self.step_length / self.period

    def to_dict(self) -> dict[str, Any]:
        return {
            "state": dict(self.state),
            "period": self.period,
            "phase_durations": list(self.durations),
            "eigenvalues": [[float(e.real), float(e.imag)] for e in self.eigenvalues],
            "max_abs_eigenvalue": self.max_abs_eigenvalue,
            "stable": self.stable,
            "step_length": self.step_length,
            "speed": self.speed,
            "residual": self.residual,
        }


@dataclass(frozen=True)
class Attractor:
    """Where the Poincaré map goes from a start: the section states of the last ``keep``
    steps after a transient, and the smallest period ``k`` with which they repeat.

    ``ended`` is 'completed' or the failure that ended the walk (then ``states`` holds
    the steps walked before it, at most ``keep``); ``period`` is None when the kept steps
    do not repeat within the tolerance (an orbit of longer period, chaos, or a transient
    that is not over) or the walk failed.
    """

    states: np.ndarray  # (kept steps, 2 n): states just after each step event
    step_lengths: tuple[float | None, ...]
    step_periods: tuple[float, ...]
    ended: str
    steps_walked: int
    period: int | None

    def to_dict(self, names: Sequence[str]) -> dict[str, Any]:
        return {
            "ended": self.ended,
            "steps_walked": self.steps_walked,
            "period": self.period,
            "states": [dict(zip(names, (float(v) for v in row))) for row in self.states],
            "step_lengths": list(self.step_lengths),
            "step_periods": list(self.step_periods),
        }


def repeat_period(states: np.ndarray, tol: float) -> int | None:
    """Smallest ``k <= len(states) / 2`` with every state within ``tol * max(1, |state|)``
    of the state ``k`` steps later, or None."""
    count = len(states)
    for k in range(1, count // 2 + 1):
        gap = np.abs(states[k:] - states[:-k])
        if np.all(gap <= tol * np.maximum(1.0, np.abs(states[:-k]))):
            return k
    return None


class HybridModel:
    """A generated model package through one interface."""

    def __init__(self, module: Any) -> None:
        self.module = module
        spec = module.HYBRID
        self.spec = spec
        self.name: str = spec["name"]
        self.title: str = spec["title"]
        params = importlib.import_module(f"{module.__name__}.params")
        self.parameter_table = params.PARAMETERS
        self.coordinates: tuple[str, ...] = spec["coordinates"]
        self.rates: tuple[str, ...] = spec["rates"]
        self.n = len(self.coordinates)
        self.phases = spec["phases"]
        self.events = spec["events"]
        self.phase_index = {p["name"]: k for k, p in enumerate(self.phases)}
        self.by_source = {}
        for event in self.events:
            self.by_source.setdefault(event["source"], []).append(event)
        self.step_event = next(e for e in self.events if e["ends_step"])
        self.units = spec["units"]

    # --- parameters -------------------------------------------------------------------

    def parameters(self, values: Mapping[str, float] | None = None) -> tuple[float, ...]:
        """The parameter vector: defaults, overridden by ``values`` (validated)."""
        values = dict(values or {})
        names = [p.name for p in self.parameter_table]
        for name in values:
            if name not in names:
                raise VswInputError(
                    f"parameter {name!r} is not one of the {self.name} model's: {', '.join(names)}"
                )
        out = []
        for p in self.parameter_table:
            value = values.get(p.name, p.default)
            if value is None:
                raise VswInputError(f"parameter {p.name} of {self.name} has no default: give it")
            out.append(float(check_parameter(p.name, value, self.parameter_table)))
        self._check_parameter_conditions(out)
        return tuple(out)

    def _check_parameter_conditions(self, params: Sequence[float]) -> None:
        """The model's conditions between parameters (``parameter_conditions``): a set that
        breaks one is refused in one line with its reason and the values it involves."""
        names = [p.name for p in self.parameter_table]
        zeros = [0.0] * (2 * self.n)  # the generated functions take a state; unused here
        for condition in self.spec.get("parameter_conditions", ()):
            value = float(self.function(condition["function"])(*params, *zeros))
            if value > 0 or (value == 0 and not condition["strict"]):
                continue
            values = ", ".join(f"{k} = {params[names.index(k)]:g}" for k in condition["parameters"])
            raise VswInputError(f"{self.name}: {condition['reason']} (got {values})")

    # --- generated functions -----------------------------------------------------------

    def function(self, name: str) -> Any:
        """The generated numpy function ``name`` of the model's package (``{phase}_energy``,
        ``event_{name}_reset``, ...), called with the parameters and the state."""
        return getattr(self.module, name)

    def symbolic(self, name: str, p: Any, x: Any) -> Any:
        """A generated function of the parameters and the state on CasADi vectors ``p``
        and ``x`` (the NLPs' form: ``vsw.synthesis.design``, ``vsw.synthesis.powered``), its outputs
        stacked."""
        import casadi as ca

        out = self.function(name)(*ca.vertsplit(p), *ca.vertsplit(x))
        return ca.vertcat(*out) if isinstance(out, tuple) else out

    def symbolic_weight(self, p: Any) -> Any:
        """The walker's weight in the model's force unit on CasADi parameters ``p`` (the
        cost of transport's scale): the generated ``weight`` where the derivation gives
        one, else 1 (a model whose units are already scaled by its weight)."""
        import casadi as ca

        if hasattr(self.module, "weight"):
            return self.module.weight(*ca.vertsplit(p), *([0.0] * (2 * self.n)))
        return 1.0

    def accelerations(self, phase: str, params: Sequence[float], state: np.ndarray) -> np.ndarray:
        return np.array(self.function(f"{phase}_accelerations")(*params, *state), dtype=float)

    def energy(self, phase: str, params: Sequence[float], state: np.ndarray) -> float:
        return float(self.function(f"{phase}_energy")(*params, *state))

    def normal_force(self, phase: str, params: Sequence[float], state: np.ndarray) -> float:
        return float(self.function(f"{phase}_normal_force")(*params, *state))

    def guard(self, event: str, params: Sequence[float], state: np.ndarray) -> float:
        """The event's guard at a state: zero where the event happens."""
        return float(self.function(f"event_{event}_guard")(*params, *state))

    def reset(self, event: str, params: Sequence[float], state: np.ndarray) -> np.ndarray:
        return np.array(self.function(f"event_{event}_reset")(*params, *state), dtype=float)

    def slope(self, params: Sequence[float]) -> float:
        """The slope the walker walks down, rad (its chart lies along it): the parameter
        ``gamma`` of a model whose table calls it a slope angle; 0 on level ground."""
        index = self.slope_index()
        return 0.0 if index is None else float(params[index])

    def slope_index(self) -> int | None:
        """The index of the slope's parameter in the table (:meth:`slope`), or None."""
        for k, p in enumerate(self.parameter_table):
            if p.name == "gamma" and "slope" in p.description:
                return k
        return None

    def step_length(self, params: Sequence[float], state: np.ndarray) -> float | None:
        if not self.spec["step_length"]:
            return None
        return float(self.function("step_length_of_state")(*params, *state))

    # --- simulation --------------------------------------------------------------------

    def failure_at(self, phase: str, params: Sequence[float], state: np.ndarray) -> str | None:
        """The failure a phase starting at ``state`` is already past, if any (a failure
        with direction -1 (+1) has happened where its guard is negative (positive)): a
        guard that starts beyond zero never crosses it), including those the phase checks
        only there (``start_failures``: the VSW biped's extension-missed)."""
        record = self.phases[self.phase_index[phase]]
        for name, function, direction in (*record["failures"], *record.get("start_failures", ())):
            if float(self.function(function)(*params, *np.asarray(state, float))) * direction > 0:
                return name
        return None

    def _phase_run(
        self, phase: str, params, state: np.ndarray, t0: float, dense: bool,
        max_step: float = np.inf, segments: list | None = None,
    ):  # fmt: skip
        """Integrate one phase to its first event or failure. ``segments``: a list to
        which each integration's continuous solution is appended as (solution, start, end)
        (SciPy's dense output: DOP853's own 7th-order interpolant)."""
        from scipy.integrate import solve_ivp

        failed = self.failure_at(phase, params, state)
        if failed is not None:
            x = np.array(state, dtype=float)
            return "failure", failed, t0, x, [t0], [x.copy()]
        n = self.n
        accelerations = _on_floats(self.function(f"{phase}_accelerations"), params)

        def rhs(_t, x):
            out = np.empty(2 * n)
            out[:n] = x[n:]
            out[n:] = accelerations(x)
            return out

        watchers = []  # (kind, name, function)
        for event in self.by_source.get(phase, []):
            guard = self.function(f"event_{event['name']}_guard")
            watchers.append(("event", event, guard, event["direction"]))
        for failure, fname, direction in self.phases[self.phase_index[phase]]["failures"]:
            watchers.append(("failure", failure, self.function(fname), direction))
        functions = []
        for _, _, fn, direction in watchers:
            f = functools.partial(lambda _t, x, fn: float(fn(x)), fn=_on_floats(fn, params))
            f.terminal = True
            f.direction = direction
            functions.append(f)
        t_start, x = t0, np.array(state, dtype=float)
        samples_t, samples_x = [t0], [x.copy()]
        for _ in range(20):  # restarts past events that do not count ('when' <= 0)
            sol = solve_ivp(
                rhs, (t_start, t0 + PHASE_TIME_LIMIT), x, method="DOP853",
                rtol=RTOL, atol=ATOL, events=functions, max_step=max_step,
                dense_output=segments is not None,
            )  # fmt: skip
            k = next((i for i, te in enumerate(sol.t_events) if len(te)), None)
            if segments is not None and sol.sol is not None:
                end = float(sol.t_events[k][0]) if sol.status == 1 else float(sol.t[-1])
                segments.append((sol.sol, float(t_start), end))
            if dense:
                samples_t.extend(sol.t[1:])
                samples_x.extend(sol.y.T[1:])
            if sol.status != 1 or k is None:
                return "stalled", None, t_start, x, samples_t, samples_x
            kind, what, _, _ = watchers[k]
            t_hit, x_hit = float(sol.t_events[k][0]), np.array(sol.y_events[k][0])
            samples_t.append(t_hit)
            samples_x.append(x_hit.copy())
            if kind == "event" and what["when"] is not None:
                if float(self.function(what["when"])(*params, *x_hit)) <= 0:
                    # Not this one (a scuff the model ignores): continue just past it.
                    t_start, x = t_hit, x_hit
                    t_start += 1e-9
                    x = x_hit + 1e-9 * rhs(t_hit, x_hit)
                    continue
            return kind, what, t_hit, x_hit, samples_t, samples_x
        return "stalled", None, t_start, x, samples_t, samples_x

    def step(self, params: Sequence[float], state: np.ndarray) -> StepResult:
        """One step from a state just after the step event (the Poincaré section)."""
        phase = self.step_event["target"]
        t = 0.0
        x = np.array(state, dtype=float)
        durations = []
        for _ in range(len(self.phases) + 1):
            kind, what, t_end, x_end, *_ = self._phase_run(phase, params, x, t, dense=False)
            durations.append(t_end - t)
            if kind == "failure":
                return StepResult(x_end, what, tuple(durations))
            if kind == "stalled":
                return StepResult(x_end, "stalled", tuple(durations))
            length = self.step_length(params, x_end) if what["ends_step"] else None
            x = self.reset(what["name"], params, x_end)
            t = t_end
            if what["ends_step"]:
                return StepResult(x, "completed", tuple(durations), length)
            phase = what["target"]
        raise ConvergenceError(f"{self.name}: a step visited more phases than the model has")

    def step_events(self, params: Sequence[float], state: np.ndarray) -> list[EventRecord]:
        """The events of one step from a section state, with the energy on either side
        (empty events past a failure: the list ends where the walk does)."""
        phase = self.step_event["target"]
        t = 0.0
        x = np.array(state, dtype=float)
        records = []
        for _ in range(len(self.phases) + 1):
            kind, what, t_end, x_end, *_ = self._phase_run(phase, params, x, t, dense=False)
            if kind != "event":
                break
            x = self.reset(what["name"], params, x_end)
            records.append(self.event_record(params, what, t_end, x_end, x.copy()))
            t = t_end
            if what["ends_step"]:
                break
            phase = what["target"]
        return records

    def event_record(self, params: Sequence[float], event: dict, time: float,
                     before: np.ndarray, after: np.ndarray) -> EventRecord:  # fmt: skip
        """``event`` (one of :attr:`events`) at ``time``, from ``before`` to ``after`` its
        reset, with the energy of its source phase before and of its target phase after."""
        return EventRecord(
            event["name"], float(time), before, after,
            float(self.function(f"{event['source']}_energy")(*params, *before)),
            float(self.function(f"{event['target']}_energy")(*params, *after)),
        )  # fmt: skip

    def continuous_walk(
        self, params: Sequence[float], state: np.ndarray, steps: int
    ) -> tuple[list[PhasePiece], list[tuple[int, EventRecord]], str]:
        """``steps`` steps from a section state as continuous solutions: each phase's
        pieces of SciPy's dense output, each event (with the step it ends or falls in) and
        how the walk ended ('completed', a failure's name or 'stalled')."""
        phase = self.step_event["target"]
        t, x, done = 0.0, np.array(state, dtype=float), 0
        pieces: list[PhasePiece] = []
        events: list[tuple[int, EventRecord]] = []
        while done < steps:
            segments: list = []
            kind, what, t_end, x_end, *_ = self._phase_run(
                phase, params, x, t, dense=False, segments=segments
            )
            # A phase already past a failure at its start was not integrated: its piece is
            # the start state held for no time, so a walk that ends at once still samples.
            held = ((_Held(x_end), t, t_end),)
            pieces.append(PhasePiece(phase, done, t, t_end, tuple(segments) or held))
            if kind != "event":
                return pieces, events, what if kind == "failure" else "stalled"
            after = self.reset(what["name"], params, x_end)
            events.append((done, self.event_record(params, what, t_end, x_end, after.copy())))
            x, t, phase = after, t_end, what["target"]
            done += bool(what["ends_step"])
        return pieces, events, "completed"

    def attractor(
        self,
        params: Sequence[float],
        state: np.ndarray,
        transient: int,
        keep: int,
        tol: float = 1e-7,
    ) -> Attractor:
        """Iterate the Poincaré map ``transient + keep`` steps from the section state
        ``state`` and keep the last ``keep``: the brute-force way to the period-k orbits
        and chaos that follow a period-one gait past its loss of stability (a bifurcation
        diagram). ``tol`` is relative, as in :func:`repeat_period`."""
        x = np.array(state, dtype=float)
        kept: list[np.ndarray] = []
        lengths: list[float | None] = []
        periods: list[float] = []
        ended, walked = "completed", 0
        for walked in range(1, transient + keep + 1):
            result = self.step(params, x)
            if result.ended != "completed":
                ended, walked = result.ended, walked - 1
                break
            x = result.state
            if walked > transient:
                kept.append(x)
                lengths.append(result.step_length)
                periods.append(float(sum(result.durations)))
        states = np.array(kept, dtype=float).reshape(-1, 2 * self.n)
        period = repeat_period(states, tol) if ended == "completed" and len(states) > 1 else None
        return Attractor(states, tuple(lengths), tuple(periods), ended, walked, period)

    def simulate(
        self,
        params: Sequence[float],
        state: np.ndarray,
        steps: int,
        phase: str | None = None,
        max_step: float = np.inf,
    ) -> Trajectory:
        """Simulate ``steps`` steps from ``state`` at the start of ``phase`` (default: the
        phase after the step event). ``max_step`` bounds the integrator's step, for denser
        samples (plots, animations); the default lets it choose."""
        phase = phase or self.step_event["target"]
        t = 0.0
        x = np.array(state, dtype=float)
        ts, xs, ps, section = [], [], [], [x.copy()]
        done = 0
        ended = "completed"
        while done < steps:
            kind, what, t_end, x_end, st, sx = self._phase_run(
                phase, params, x, t, dense=True, max_step=max_step
            )
            ts.extend(st)
            xs.extend(sx)
            ps.extend([self.phase_index[phase]] * len(st))
            if kind != "event":
                ended = what if kind == "failure" else "stalled"
                break
            x = self.reset(what["name"], params, x_end)
            t = t_end
            if what["ends_step"]:
                done += 1
                section.append(x.copy())
            phase = what["target"]
        return Trajectory(np.array(ts), np.array(xs), np.array(ps), np.array(section), ended,
                          done)  # fmt: skip

    # --- periodic orbits (CasADi) ------------------------------------------------------

    def phase_sequence(self) -> list[tuple[str, dict]]:
        """(phase, event that ends it) over one step (:func:`vsw.orbits.phase_sequence`)."""
        return phase_sequence(self)

    def periodic_orbit(
        self,
        params: Sequence[float],
        state: np.ndarray,
        durations: Sequence[float],
        step: Callable[[Sequence[float], np.ndarray], StepResult] | None = None,
    ) -> Orbit:
        """Solve the period-one orbit from a guess (state on the section, phase durations):
        :meth:`vsw.orbits.OrbitProblem.solve` (Newton on the multiple-shooting residual),
        the residual within 1e-9 of max(1, |state|) and every duration positive; the
        eigenvalues of its monodromy matrix (:mod:`vsw.orbits.monodromy`).

        The orbit is confirmed by the time-domain simulation: one simulated step from it
        (events located on DOP853's dense output) must pass every phase and return to it
        within 1e-9 (relative to max(1, |state|), times the largest |eigenvalue| on an
        unstable gait); otherwise the rootfinder's solution is no gait (a guard crossed
        earlier, a failure on the way) and :class:`ConvergenceError` says so. ``step``: the
        simulation that confirms, as :meth:`step` (the default, SciPy's DOP853) returns it;
        the commands pass the compiled batch simulator's
        (:meth:`vsw.dynamics.batch.BatchSimulator.step_phases`, the same method and tolerance, and
        no SciPy to import). Either is independent of the solver's CVODES integration.
        """
        problem = OrbitProblem(self)
        p = np.asarray(params, float)
        state, durations = np.asarray(state, float), np.asarray(durations, float)
        if not (np.all(np.isfinite(state)) and np.all(np.isfinite(durations))):
            raise ConvergenceError(f"{self.name}: the periodic-orbit guess is not finite")
        try:
            guess = problem.unknowns(p, state, durations)
        except RuntimeError as exc:  # CVODES gave up (a guess far from any orbit)
            stop.check()  # or CasADi turned Ctrl-C or the time limit into this error
            raise _solver_failed(self.name, str(exc)) from None
        return self.confirmed_orbit(params, problem, problem.solve(p, guess), step)

    def confirmed_orbit(
        self,
        params: Sequence[float],
        problem: OrbitProblem,
        solved: Solved,
        step: Callable[[Sequence[float], np.ndarray], StepResult] | None = None,
    ) -> Orbit:
        """The orbit a solve of the period-one ``problem`` at ``params`` found, with the
        checks of :meth:`periodic_orbit`: converged, every duration positive, its
        eigenvalues defined, and the simulated step from it back on it
        (:class:`ConvergenceError` otherwise). For a caller whose own Newton already solved
        the orbit at these parameters (the design's pin): no second solve. ``solved`` must
        be ``problem.solve(params, ...)``, which nothing here can check; ``problem`` must be
        this model's, of period one (ValueError otherwise)."""
        if problem.model is not self or problem.period != 1:
            raise ValueError(f"{self.name}: confirmed_orbit takes a period-one orbit problem "
                             "of this model")  # fmt: skip
        n = 2 * self.n
        if solved.error is not None and not solved.converged:
            raise _solver_failed(self.name, solved.error)
        size, solution = solved.residual, solved.u
        scale = max(1.0, float(np.max(np.abs(solution[:n]))))
        if not (solved.converged and size <= 1e-9 * scale):
            raise ConvergenceError(
                f"{self.name}: the periodic-orbit solver did not converge (residual {size:.3g})"
            )
        t_star = problem.durations(solution)
        if np.any(t_star <= 0):
            raise ConvergenceError(
                f"{self.name}: the periodic-orbit solver converged to no gait: a phase "
                f"duration is not positive ({', '.join(f'{v:.3g}' for v in t_star)})"
            )
        x_star = problem.section_state(solution)
        eigenvalues = problem.eigenvalues(solved.jacobian)
        if not eigenvalues:  # a guard grazing at its phase's end, or NaN
            raise ConvergenceError(
                f"{self.name}: the orbit's eigenvalues are undefined (a guard that does not "
                "cross at its phase's end)"
            )
        simulated = (step or self.step)(params, x_star)
        if simulated.ended != "completed" or len(simulated.durations) != len(t_star):
            raise ConvergenceError(
                f"{self.name}: the rootfinder's orbit is no gait: the simulated step from it "
                + ("skips a phase" if simulated.ended == "completed" else simulated.ended)
            )
        gap = float(np.max(np.abs(simulated.state - x_star)))
        # The step's own integration error, amplified up to |lambda| on an unstable gait.
        if not gap <= 1e-9 * scale * max(1.0, abs(eigenvalues[0])):
            raise ConvergenceError(
                f"{self.name}: the rootfinder's orbit is no gait: the simulated step from it "
                f"ends {gap:.3g} away"
            )
        return Orbit(
            state=dict(zip(self.coordinates + self.rates, (float(v) for v in x_star))),
            durations=tuple(float(v) for v in t_star),
            period=float(np.sum(t_star)),
            eigenvalues=tuple(eigenvalues),
            # The confirming step's own: integrating the orbit once more would repeat it.
            step_length=simulated.step_length,
            residual=size,
        )

    @functools.cache  # noqa: B019
    def _poincare_function(self):
        """The Poincaré map as a CasADi function of the section state (each phase's end
        time from its guard by a rootfinder: derivatives by the implicit function theorem)."""
        import casadi as ca

        flows = shooting.flows(self)
        n = 2 * self.n
        p = ca.MX.sym("p", len(self.parameter_table))
        x0 = ca.MX.sym("x0", n)
        guesses = ca.MX.sym("T0", len(self.phase_sequence()))
        x = x0
        for k, (phase, _event) in enumerate(self.phase_sequence()):
            integrator, guard, reset = flows[phase]
            tau = ca.MX.sym("tau")
            xs = ca.MX.sym("xs", n)
            pp = ca.MX.sym("pp", p.shape[0])
            g_of_tau = guard(pp, integrator(x0=xs, p=ca.vertcat(pp, tau))["xf"])
            options = {"abstol": 1e-12, "max_iter": 50, "error_on_fail": False}
            root = ca.rootfinder(f"end_{phase}", "newton",
                                 ca.Function(f"g_{phase}", [tau, ca.vertcat(xs, pp)], [g_of_tau]),
                                 options)  # fmt: skip
            t_end = root(guesses[k], ca.vertcat(x, p))
            x = reset(p, integrator(x0=x, p=ca.vertcat(p, t_end))["xf"])
        return ca.Function("poincare", [x0, p, guesses], [x, ca.jacobian(x, x0)])

    def eigenvalues(self, params: Sequence[float], state: np.ndarray) -> list[complex]:
        """Eigenvalues of the Poincaré map's Jacobian at a section state."""
        result = self.step(params, state)
        durations = result.durations
        if len(durations) != len(self.phase_sequence()):
            raise ConvergenceError(f"{self.name}: the step from this state skips a phase")
        try:
            with contextlib.redirect_stderr(io.StringIO()):
                x_end, jac = self._poincare_function()(
                    np.asarray(state, float), np.asarray(params, float),
                    np.asarray(durations, float),
                )  # fmt: skip
        except RuntimeError as exc:  # an end time's rootfinder failed
            stop.check()  # or CasADi turned Ctrl-C or the time limit into this error
            raise ConvergenceError(
                f"{self.name}: the Poincaré map's derivative failed "
                f"({' '.join(str(exc).split())[-60:]})"
            ) from None
        # The guards' rootfinders stop at 1e-12 (CVODES' own error is near that) without
        # failing: whether they found the step is checked here, on the simulated one.
        x_end = np.array(x_end, dtype=float).reshape(-1)
        gap = (
            float(np.max(np.abs(x_end - result.state))) if np.all(np.isfinite(x_end)) else math.inf
        )
        if not gap <= 1e-8 * max(1.0, float(np.max(np.abs(result.state)))):
            raise ConvergenceError(
                f"{self.name}: the Poincaré map's derivative did not find the simulated step "
                f"(gap {gap:.3g})"
            )
        return by_modulus(np.linalg.eigvals(np.array(jac, dtype=float)))


def _solver_failed(name: str, error: str) -> ConvergenceError:
    """The periodic-orbit solver's failure where CVODES gave up, in one line."""
    return ConvergenceError(
        f"{name}: the periodic-orbit solver failed ({' '.join(error.split())[:80]})"
    )


def _on_floats(function: Any, params: Sequence[float]) -> Any:
    """``function(*params, *x)`` of a state array ``x``, called on Python floats: the same
    IEEE arithmetic as on numpy's scalars (+, -, *, / and pow correctly rounded or libm's
    in both; the functions are numpy's either way), and cheaper: the integrator makes the
    call at every stage. Where Python raises instead of returning inf or
    NaN (a division by zero, an overflowing power), the call is made again on numpy's
    scalars, as it always was."""
    fixed = [float(v) for v in params]

    def call(x: np.ndarray) -> Any:
        try:
            return function(*fixed, *x.tolist())
        except (ZeroDivisionError, OverflowError):
            return function(*params, *x)

    return call
