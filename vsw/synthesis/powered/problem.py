"""The collocation NLP of a powered step: each phase by Hermite-Simpson
(:mod:`vsw.orbits.collocation`) with its path constraints and the positive work's slacks,
its event's map, the targets, the cost, the bounds, and IPOPT through CasADi
(:class:`Nlp`, :func:`built`)."""

from __future__ import annotations

import functools
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.orbits import collocation
from vsw.orbits.collocation import (
    BERNSTEIN_OF_SAMPLES,
    SAMPLES,
    SIMPSON_WEIGHTS,
    interval_inputs,
    interval_states,
)
from vsw.runtime import blas, stop
from vsw.runtime.errors import ConvergenceError
from vsw.synthesis.powered.dynamics import (
    flow_function,
    flow_jacobian_function,
    input_rate_function,
    margin_functions,
    reaction_function,
)
from vsw.synthesis.powered.events import event_jacobian, event_map
from vsw.synthesis.powered.objectives import objective, spectral_radius
from vsw.synthesis.powered.request import (
    STABILITY_ITERATIONS,
    STABILITY_MARGIN,
    Request,
    chosen_indices,
    input_names,
    limited_bounds,
    parameter_interval,
    prices_work,
)
from vsw.synthesis.powered.variables import (
    Constraints,
    Unknowns,
    phase_unknowns,
    stacked_unknowns,
    variable_bounds,
)

__all__ = ["IPOPT_OPTIONS", "Nlp", "built"]


@dataclass(frozen=True)
class Nlp:
    """The collocation NLP of one model and request: IPOPT, the cost, work and ground
    impulses as functions of ``(w, p)``, the unknowns' layout and bounds, where the
    chosen parameters and the radius are in ``w``, and under stability the step map."""

    solver: Any
    cost: Any  # ca.Function(w, p) -> cost
    layout: list[dict[str, Any]]  # per phase: slices of w
    work: Any  # ca.Function(w, p) -> positive and negative work per input
    size: int
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # lbx, ubx, lbg, ubg
    ground: Any = None  # ca.Function(w, p) -> each event's ground impulses, stacked
    ground_keys: tuple[str, ...] = ()
    chosen: tuple[int, ...] = ()  # parameters the optimiser chooses (their table positions)
    chosen_start: int = 0  # where their values are in w (after the phases' blocks)
    radius: int | None = None  # under stability: where the spectral radius is in w (last)
    monodromy: Any = None  # under stability: ca.Function(w, p) -> the step map's Jacobian

    def start_radius(self, params: Sequence[float], w: np.ndarray) -> None:
        """Under stability, start the radius of ``w`` just outside the spectral radius of
        its collocated step map (in place), where the Jury rows hold."""
        if self.radius is None:
            return
        largest = self.spectral_radius(params, w)
        if not math.isfinite(largest):
            raise ConvergenceError("the start's step map has no finite Jacobian (an event met "
                                   "with the flow along its guard): no stability to minimise"
                                   )  # fmt: skip
        w[self.radius] = max(1.05 * largest, 2 * STABILITY_MARGIN)

    def step_jacobian(self, params: Sequence[float], w: np.ndarray) -> np.ndarray:
        """The Jacobian of ``w``'s collocated step map (the section state's)."""
        arguments = np.append(np.asarray(params, dtype=float), 1.0)
        return np.array(self.monodromy(w, arguments), dtype=float)

    def spectral_radius(self, params: Sequence[float], w: np.ndarray) -> float:
        """The spectral radius of ``w``'s collocated step map (inf where not finite)."""
        return spectral_radius(self.step_jacobian(params, w))

    def parameters(self, params: Sequence[float], w: np.ndarray) -> np.ndarray:
        """``params`` with the chosen parameters at their values in ``w``, within their
        bounds (IPOPT may end a few ulps of its tolerance past a bound it relaxed)."""
        p = np.array(params, dtype=float)
        block = slice(self.chosen_start, self.chosen_start + len(self.chosen))
        lbx, ubx = self.bounds[0][block], self.bounds[1][block]
        p[list(self.chosen)] = np.minimum(np.maximum(w[block], lbx), ubx)
        return p

    def choose(self, params: Sequence[float], w: np.ndarray) -> None:
        """Start the chosen parameters of ``w`` at their values in ``params`` (in place)."""
        values = np.asarray(params, dtype=float)[list(self.chosen)]
        w[self.chosen_start : self.chosen_start + len(self.chosen)] = values


def _collocate(model: HybridModel, phase: str, v: Unknowns, p: Any, duration: Any,
               request: Request, g: Constraints) -> tuple[Any, Any, dict, dict]:  # fmt: skip
    """A phase's Hermite-Simpson defects, path constraints and slacks into ``g``; its
    squared-input integral, its positive work as the cost prices it (each interval's
    Bernstein slack where the cost is the work: see the module's docstring) and each
    input's positive and negative work (composite Simpson on :data:`SAMPLES` of
    ``max(P, 0)`` and ``min(P, 0)``)."""
    import casadi as ca

    names = input_names(model)[phase]
    flow = flow_function(model, phase)
    nodes = len(v.middles)
    h = duration / nodes
    slack = prices_work(request)
    for function, direction in margin_functions(model, phase):
        for x, u in zip(v.knots, v.u_knots):
            g.add(-direction * function(p, x, u), 0.0, math.inf)
    if request.friction is not None:  # the stance foot's reaction within its cone
        reaction = reaction_function(model, phase)
        for x, u in zip(v.knots, v.u_knots):
            tangential, normal = ca.vertsplit(reaction(p, x, u))
            g.add(ca.vertcat(request.friction * normal - tangential,
                             request.friction * normal + tangential), 0.0, math.inf)  # fmt: skip
    rates = input_rate_function(model, phase) if names else None
    squares, priced = 0, 0
    positive = dict.fromkeys(names, 0)
    negative = dict.fromkeys(names, 0)
    for i in range(nodes):
        x0, x1, xc = v.knots[i], v.knots[i + 1], v.middles[i]
        u0, u1, uc = v.u_knots[i], v.u_knots[i + 1], v.u_middles[i]
        f0 = flow(p, x0, u0)
        f1 = flow(p, x1, u1)
        fc = flow(p, xc, uc)
        for defect in collocation.defects(x0, xc, x1, f0, fc, f1, h):
            g.add(defect, 0.0, 0.0)
        if not names:
            continue
        squares = squares + h / 6 * (ca.sumsqr(u0) + 4 * ca.sumsqr(uc) + ca.sumsqr(u1))
        if slack:
            # Where the cost is the work, the inputs are linear on each interval: a free
            # midpoint input can peak where its power's samples vanish (a leg force at a
            # midpoint where the leg's rate changes sign) and add energy the quadrature
            # does not count; tied to its knots it cannot act unseen.
            g.add(uc - (u0 + u1) / 2, 0.0, 0.0)
        power = ca.horzcat(*(u * rates(p, x) for x, u in
                             zip(interval_states(x0, xc, x1, h * f0, h * f1),
                                 interval_inputs(u0, uc, u1))))  # fmt: skip
        if slack:
            bernstein = ca.mtimes(power, ca.DM(BERNSTEIN_OF_SAMPLES.T))
            s = ca.reshape(v.s_intervals[i], len(names), len(SAMPLES))
            g.add(ca.vec(s - bernstein), 0.0, math.inf)
            priced = priced + h * ca.sum1(ca.sum2(s)) / len(SAMPLES)
        positive_power = ca.fmax(power, 0)  # the ledger: composite Simpson on the samples
        plus = h * ca.mtimes(positive_power, ca.DM(SIMPSON_WEIGHTS))
        minus = h * ca.mtimes(power - positive_power, ca.DM(SIMPSON_WEIGHTS))
        for j, name in enumerate(names):
            positive[name] = positive[name] + plus[j]
            negative[name] = negative[name] + minus[j]
        if not slack:
            priced = priced + ca.sum1(plus)
    return squares, priced, positive, negative


def _clearance(model: HybridModel, phase: str, v: Unknowns, p: Any, durations: Any, k: int,
               height: float, g: Constraints) -> None:  # fmt: skip
    """The swing foot at least ``height sin(pi s)`` above the ground at each knot inside
    phase ``k`` (``s`` the fraction of the step gone: it lifts at 0 and lands at 1), where
    the model declares its clearance (the ``swing-foot-clearance`` condition)."""
    import casadi as ca

    period = ca.sum1(durations)
    start = ca.sum1(durations[:k]) if k else 0
    nodes = len(v.middles)
    for name, function, direction in model.phases[model.phase_index[phase]].get("conditions", ()):
        if name != "swing-foot-clearance":
            continue
        for i in range(1, nodes):
            fraction = (start + durations[k] * i / nodes) / period
            margin = -direction * model.symbolic(function, p, v.knots[i])
            g.add(margin - height * ca.sin(math.pi * fraction), 0.0, math.inf)


def built(model: HybridModel, request: Request) -> Nlp:
    """:func:`_build`, where a stop reaches the caller while it runs.

    CasADi builds the NLP (its derivatives: under stability the step map's second ones)
    in C++ for up to tens of seconds without looking at signals, though it lets go of the
    GIL; under :func:`vsw.runtime.stop.supervised` in the main thread the build runs on a daemon
    thread and the main thread waits where the signals of Ctrl-C and the run-time limit
    reach it. A stopped run leaves the build to finish unwatched (in the ``vsw`` program
    the process ends with the command)."""
    if not (stop.supervising() and threading.current_thread() is threading.main_thread()):
        return _build(model, request)
    outcome: dict[str, Any] = {}

    def build() -> None:
        try:
            outcome["nlp"] = _build(model, request)
        except BaseException as exc:  # raised again in the caller's thread
            outcome["error"] = exc

    worker = threading.Thread(target=build, name="vsw-nlp-build", daemon=True)
    worker.start()
    while worker.is_alive():
        worker.join(0.05)
        stop.check()
    if "error" in outcome:
        raise outcome["error"]
    return outcome["nlp"]


@dataclass
class _Transcribed:
    """What the phases of a step add up to beyond their constraints: the squared inputs'
    integral, the positive work as the cost prices it, each input's and impulse's
    positive and negative work, the ground's impulses at the events, the step map's
    Jacobian (under stability) and the step's length."""

    squares: Any = 0
    priced: Any = 0
    positive: dict = field(default_factory=dict)
    negative: dict = field(default_factory=dict)
    ground: dict = field(default_factory=dict)
    monodromy: Any = None
    step_length: Any = None


def _transcribe(model: HybridModel, request: Request, p: Any, durations: Any,
                unknowns: list[Unknowns], g: Constraints) -> _Transcribed:  # fmt: skip
    """Each phase collocated (:func:`_collocate`), ended on its event's guard (its ``when``
    >= 0) and mapped by the event (:func:`vsw.synthesis.powered.events.event_map`) onto the next
    phase's first knot, the last onto the first (periodicity); the constraints into
    ``g``."""
    import casadi as ca

    sequence = model.phase_sequence()
    count = len(sequence)
    stability = request.minimize == "eigenvalue"
    out = _Transcribed(monodromy=ca.DM.eye(2 * model.n))
    for k, (phase, event) in enumerate(sequence):
        v = unknowns[k]
        phase_squares, phase_priced, plus, minus = _collocate(model, phase, v, p, durations[k],
                                                              request, g)  # fmt: skip
        if request.clearance is not None:
            _clearance(model, phase, v, p, durations, k, request.clearance, g)
        out.squares = out.squares + phase_squares
        out.priced = out.priced + phase_priced
        out.positive |= {f"{phase}.{name}": value for name, value in plus.items()}
        out.negative |= {f"{phase}.{name}": value for name, value in minus.items()}
        end = v.knots[-1]
        g.add(model.symbolic(f"event_{event['name']}_guard", p, end), 0.0, 0.0)
        if event["when"] is not None:
            g.add(model.symbolic(event["when"], p, end), 0.0, math.inf)
        after, event_priced, plus, minus, pushes = event_map(model, event, p, end, v, g,
                                                             request)  # fmt: skip
        out.ground |= pushes
        out.priced = out.priced + event_priced
        out.positive |= plus
        out.negative |= minus
        if stability:
            out.monodromy = ca.mtimes(ca.mtimes(
                event_jacobian(model, phase, event, p, v, after),
                _collocated_jacobian(model, phase, v, p, durations[k])), out.monodromy)  # fmt: skip
        following = unknowns[(k + 1) % count].knots[0]  # the last phase: periodicity
        g.add(following - after, 0.0, 0.0)
        if event["ends_step"] and model.spec["step_length"]:
            out.step_length = model.symbolic("step_length_of_state", p, end)
    return out


def _targets(request: Request, step_length: Any, durations: Any, g: Constraints) -> None:
    """The request's step length, speed and period as equality constraints into ``g``."""
    import casadi as ca

    if request.target_step_length is not None:
        g.add(step_length - request.target_step_length, 0.0, 0.0)
    if request.target_speed is not None:
        g.add(step_length - request.target_speed * ca.sum1(durations), 0.0, 0.0)
    if request.target_period is not None:
        g.add(ca.sum1(durations) - request.target_period, 0.0, 0.0)


IPOPT_OPTIONS = {
    "ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 3000,
    "ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "error_on_fail": False,
    "show_eval_warnings": False,  # a NaN at a trial point is IPOPT's to step back from
    "ipopt.mu_strategy": "adaptive", "ipopt.acceptable_tol": 1e-6,
    "ipopt.acceptable_constr_viol_tol": 1e-9, "ipopt.acceptable_iter": 5,
}  # fmt: skip
"""IPOPT's options for every powered NLP (under stability its iterations are
:data:`vsw.synthesis.powered.request.STABILITY_ITERATIONS`)."""


def _bounds(model: HybridModel, request: Request, layout: list[dict], size: int,
            chosen_start: int) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The unknowns' bounds (:func:`vsw.synthesis.powered.variables.variable_bounds`), the radius's
    floor under stability, and each chosen parameter within its interval and the limits
    on it."""
    lbx, ubx = variable_bounds(model, model.phase_sequence(), layout, size, request)
    if request.minimize == "eigenvalue":
        lbx[-1] = STABILITY_MARGIN
    for j, i in enumerate(chosen_indices(model)):
        name = model.parameter_table[i].name
        low, high = limited_bounds(parameter_interval(model, i), request, name)
        lbx[chosen_start + j], ubx[chosen_start + j] = low, high
    return lbx, ubx


@functools.lru_cache(maxsize=8)  # a few NLPs a command; a script's loop over targets
def _build(model: HybridModel, request: Request) -> Nlp:
    """The collocation NLP of one model and request (parameters are the NLP's ``p``)."""
    import casadi as ca

    sequence = model.phase_sequence()
    names = input_names(model)
    given = ca.MX.sym("p", len(model.parameter_table))
    chosen = chosen_indices(model)
    # The chosen parameters are unknowns of the NLP (its last ones), the others its p.
    choice = ca.MX.sym("chosen", len(chosen))
    p = ca.vertcat(*(choice[chosen.index(i)] if i in chosen else given[i]
                     for i in range(given.shape[0])))  # fmt: skip
    scale = ca.MX.sym("regularization_scale")
    durations = ca.MX.sym("T", len(sequence))
    unknowns = [phase_unknowns(k, 2 * model.n, len(names[phase]),
                               len(event.get("impulses", ())), request.nodes,
                               prices_work(request))
                for k, (phase, event) in enumerate(sequence)]  # fmt: skip
    g = Constraints()
    step = _transcribe(model, request, p, durations, unknowns, g)
    _targets(request, step.step_length, durations, g)
    stability = request.minimize == "eigenvalue"
    radius = ca.MX.sym("radius", 1 if stability else 0)
    cost = objective(model, request, p, step.squares, step.priced, step.step_length,
                     step.monodromy, radius, scale, g)  # fmt: skip
    w, layout = stacked_unknowns(durations, unknowns)
    chosen_start = int(w.shape[0])
    w = ca.vertcat(w, choice, radius)
    lbx, ubx = _bounds(model, request, layout, int(w.shape[0]), chosen_start)
    options = dict(IPOPT_OPTIONS)
    if stability:
        # Where the least radius is not attained (it falls toward zero, a step that forgets
        # any perturbation) IPOPT iterates on: 500 iterations bound the wait (a minute or
        # two on 20 intervals), and the result says it did not converge.
        options["ipopt.max_iter"] = STABILITY_ITERATIONS
    arguments = ca.vertcat(given, scale)  # the regularization's scale: known after stage one
    problem = {"x": w, "p": arguments, "f": cost, "g": ca.vertcat(*g.rows)}
    solver = ca.nlpsol(f"powered_{model.name}", "ipopt", problem, options)
    blas.libraries_may_have_loaded()  # IPOPT's plugin brings CasADi's OpenBLAS
    works = ca.Function("work", [w, arguments], [ca.vertcat(*step.positive.values(),
                                                            *step.negative.values())
                                                 if step.positive else ca.DM.zeros(0)])  # fmt: skip
    pushes = ca.Function("ground", [w, arguments], [ca.vertcat(*step.ground.values())])
    step_map = (ca.Function("monodromy", [w, arguments], [step.monodromy]) if stability
                else None)  # fmt: skip
    return Nlp(solver, ca.Function("cost", [w, arguments], [cost]), layout, works,
               int(w.shape[0]), (lbx, ubx, np.array(g.lower), np.array(g.upper)), pushes,
               tuple(step.ground), chosen, chosen_start,
               int(w.shape[0]) - 1 if stability else None, step_map)  # fmt: skip


def _collocated_jacobian(model: HybridModel, phase: str, v: Unknowns, p: Any,
                         duration: Any) -> Any:  # fmt: skip
    """d(last knot)/d(first knot) of a phase's Hermite-Simpson equations with the inputs
    held as functions of the time (open loop): :func:`vsw.orbits.collocation.sensitivity`,
    the exact derivative of the discrete step."""
    jacobian = flow_jacobian_function(model, phase)
    return collocation.sensitivity(lambda x, u: jacobian(p, x, u), v.knots, v.middles,
                                   v.u_knots, v.u_middles, duration, 2 * model.n)  # fmt: skip
