"""Where the NLP starts: the passive gait sampled, a kinematic guess where there is none,
one NLP's optimum moved to another (the second stage, the finer mesh), perturbed starts,
and the positive-work slacks and impulse splits filled at the least their constraints
allow."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from vsw.dynamics.hybrid import HybridModel, Orbit
from vsw.gaits.search import free_components, pick, section_states
from vsw.orbits.collocation import BERNSTEIN_OF_SAMPLES, interval_inputs, interval_states
from vsw.runtime.errors import ConvergenceError
from vsw.synthesis.powered.dynamics import flow_function, input_rate_function
from vsw.synthesis.powered.events import apply_impulses, stopping_splits
from vsw.synthesis.powered.problem import Nlp
from vsw.synthesis.powered.request import START_SPREAD, Request
from vsw.synthesis.powered.variables import block

__all__ = [
    "fill_slacks",
    "initial_guess",
    "kinematic_guess",
    "passive_start",
    "perturbed_inputs",
    "refine",
    "transfer",
]


def perturbed_inputs(model: HybridModel, params: Sequence[float], nlp: Nlp, w: np.ndarray,
                     index: int) -> np.ndarray:  # fmt: skip
    """``w`` with each phase's continuous inputs moved by up to :data:`START_SPREAD` times
    their largest magnitude over the phase (uniform, seeded by ``index``: the same starts
    on every run), kept within their bounds; the slacks filled again. An input that is
    zero throughout its phase stays zero (it has no scale of its own to move by)."""
    rng = np.random.default_rng(index)
    lbx, ubx = nlp.bounds[0], nlp.bounds[1]
    out = w.copy()
    for entry in nlp.layout:
        size = np.zeros(entry["u_knots"][2])
        for key in ("u_knots", "u_middles"):
            size = np.maximum(size, np.max(np.abs(block(w, entry[key])), axis=0, initial=0.0))
        for key in ("u_knots", "u_middles"):
            first, parts, width = entry[key]
            span = slice(first, first + parts * width)
            shift = START_SPREAD * size * rng.uniform(-1.0, 1.0, (parts, width))
            moved = block(w, entry[key]) + shift
            out[span] = np.clip(moved.reshape(-1), lbx[span], ubx[span])
    fill_slacks(model, params, nlp, out)
    nlp.start_radius(params, out)
    return out


def passive_start(model: HybridModel, params: Sequence[float]) -> Orbit | None:
    """The passive gait the commands follow (the first stable one, else the first), or
    None where there is none (a walker its inputs hold up, or parameters without one).
    A model that walks only powered has none to search for: on level ground every step
    loses energy, and the search (seconds on the compass gait's body) would end empty."""
    if model.spec.get("powered_only"):
        return None
    return pick(model.fixed_points(params))


def initial_guess(model: HybridModel, params: Sequence[float], start: Orbit, nlp: Nlp,
                  nodes: int) -> np.ndarray:  # fmt: skip
    """The passive gait's step sampled at the knots and midpoints, inputs zero."""
    state = np.array([start.state[k] for k in (*model.coordinates, *model.rates)])
    pieces, _events, ended = model.continuous_walk(params, state, 1)
    if ended != "completed" or len(pieces) != len(nlp.layout):
        raise ConvergenceError(f"{model.name}: the passive gait's step did not complete ({ended})")
    w = np.zeros(nlp.size)
    w[: len(pieces)] = [piece.end - piece.start for piece in pieces]
    for piece, entry in zip(pieces, nlp.layout):
        span = piece.end - piece.start
        knots = piece.start + span * np.arange(nodes + 1) / nodes
        middles = piece.start + span * (np.arange(nodes) + 0.5) / nodes
        for key, times in (("knots", knots), ("middles", middles)):
            first, parts, width = entry[key]
            w[first : first + parts * width] = piece.states(times).reshape(-1)
    return w


def kinematic_guess(model: HybridModel, params: Sequence[float], nlp: Nlp,
                    request: Request) -> np.ndarray:  # fmt: skip
    """A start where no passive gait is: the centre of the search box on the section (the
    state just after the step event, completed by the section), the coordinates moving at
    its constant rates until the step event's guard crosses, inputs and impulses zero; the
    rates scaled to the target period, or the target speed's duration, when there is one.
    Not a motion of the walker (it ignores gravity and the inputs): IPOPT makes it one.
    More than one phase a step: :func:`_phased_guess`."""
    sequence = model.phase_sequence()
    p = np.asarray(params, dtype=float)
    centre = np.array([[sum(model.spec["search"][k]) / 2 for k in free_components(model)]])
    x0 = section_states(model, p, centre)[0]
    if len(sequence) != 1:
        return _phased_guess(model, p, nlp, request, x0)
    ((_phase, event),) = sequence
    n = model.n
    guard = model.function(f"event_{event['name']}_guard")

    def moved(t: float) -> np.ndarray:
        return np.concatenate([x0[:n] + t * x0[n:], x0[n:]])

    # Within half a turn of the fastest coordinate: a crossing further on (a compass gait's
    # stance leg turning on past the horizontal) is no step.
    reach = np.pi / max(float(np.max(np.abs(x0[n:]))), 1e-300)
    times = np.linspace(0.0, 10.0, 2001)[1:]
    values = np.array([float(guard(*p, *moved(t))) for t in times])
    crossing = np.flatnonzero(np.sign(values[1:]) != np.sign(values[:-1]))
    crossing = crossing[times[crossing + 1] <= reach]
    if crossing.size == 0:
        return _swapped_guess(model, p, nlp, request, x0, event)
    duration = _bisected(lambda t: float(guard(*p, *moved(t))), times[crossing[0]],
                         times[crossing[0] + 1], values[crossing[0]])  # fmt: skip
    wanted = _target_duration(model, p, request, moved(duration))
    if wanted is not None:
        x0[n:] *= duration / wanted
        duration = wanted
    return _sampled_guess(nlp, request.nodes, duration, lambda f: moved(f * duration))


def _sampled_guess(nlp: Nlp, nodes: int, duration: float, state_at) -> np.ndarray:
    """One phase's unknowns from ``state_at(fraction of the phase)`` at its knots and
    midpoints, its duration, inputs and impulses zero."""
    return _sampled_phases(nlp, nodes, [duration], [state_at])


def _sampled_phases(nlp: Nlp, nodes: int, durations: Sequence[float],
                    states_at: Sequence) -> np.ndarray:  # fmt: skip
    """Each phase's unknowns from its ``state_at(fraction of the phase)`` at its knots and
    midpoints, the durations, inputs and impulses zero."""
    w = np.zeros(nlp.size)
    w[: len(durations)] = durations
    for entry, state_at in zip(nlp.layout, states_at):
        for key, fractions in (("knots", np.arange(nodes + 1) / nodes),
                               ("middles", (np.arange(nodes) + 0.5) / nodes)):  # fmt: skip
            first, parts, width = entry[key]
            sampled = np.array([state_at(f) for f in fractions])
            w[first : first + parts * width] = sampled.reshape(-1)
    return w


def _phased_guess(model: HybridModel, p: np.ndarray, nlp: Nlp, request: Request,
                  x0: np.ndarray) -> np.ndarray:  # fmt: skip
    """The kinematic start of a step of several phases: from the search box's centre
    ``x0`` the coordinates move at constant rates toward where the step event's reset
    takes them (the legs swapped), over the step's duration (as :func:`_swapped_guess`'s).
    A phase ends where its event's guard vanishes along that straight path (a push where
    the stance leg passes an angle: :func:`_guard_fraction`), else at an equal share of
    the step; where an event locks coordinates (a leg reaching its end stop) they move
    over the phase before it to where its guard vanishes (found by the secant method in
    each), and the phases after hold them there. Not a motion of the walker; IPOPT makes
    it one."""
    label = getattr(model, "cli_name", model.name)
    n = model.n
    sequence = model.phase_sequence()
    last = sequence[-1][1]
    end = model.reset(last["name"], p, x0)[:n]
    duration = _guess_duration(model, p, request, x0)
    index = {name: k for k, name in enumerate(model.coordinates)}
    start, held, reached = x0[:n].copy(), set(), 0.0
    paths, shares = [], []
    for k, (_phase, event) in enumerate(sequence):
        locked = [index[c] for c in event.get("actuated", ())] if event["reset"] == "lock" else []
        # An equal share of what is left, unless the event's guard vanishes on the way.
        fraction = reached + (1.0 - reached) / (len(sequence) - k)
        if k + 1 < len(sequence) and not locked:
            fraction = _guard_fraction(model, p, event, x0[:n], end, duration, reached) or fraction
        share = (fraction - reached) * duration
        target = x0[:n] + fraction * (end - x0[:n])
        stop = start.copy()
        free = [i for i in range(n) if i not in held]
        stop[free] = target[free]
        guard = model.function(f"event_{event['name']}_guard")
        for i in locked:

            def guard_at(v: float, i: int = i, stop: np.ndarray = stop, guard=guard) -> float:
                return float(guard(*p, *_with(stop, i, v), *np.zeros(n)))

            stop[i] = _root_in(guard_at, start[i], label, event["name"])
        rates = (stop - start) / share
        paths.append(lambda f, a=start, r=rates, t=share: np.concatenate([a + f * t * r, r]))
        shares.append(share)
        held |= set(locked)
        start, reached = stop, fraction
    return _sampled_phases(nlp, request.nodes, shares, paths)


def _guard_fraction(model: HybridModel, p: np.ndarray, event: dict, begin: np.ndarray,
                    end: np.ndarray, duration: float, after: float) -> float | None:  # fmt: skip
    """The fraction of the straight path from ``begin`` to ``end`` (coordinates, covered in
    ``duration`` at constant rates) past ``after`` where the event's guard first crosses in
    its direction, or None: sampled at 199 points, then bisected. (The event's ``when`` is
    not checked: a start, not a motion.)"""
    guard = model.function(f"event_{event['name']}_guard")
    rates = (end - begin) / duration

    def value(f: float) -> float:
        return float(guard(*p, *(begin + f * (end - begin)), *rates))

    fractions = np.linspace(after, 1.0, 201)[1:-1]
    values = np.array([value(f) for f in fractions])
    rising = values[1:] * event["direction"] > 0
    crossed = np.flatnonzero((np.sign(values[1:]) != np.sign(values[:-1])) & rising)
    if crossed.size == 0:
        return None
    return _bisected(value, fractions[crossed[0]], fractions[crossed[0] + 1], values[crossed[0]])


def _bisected(function, low: float, high: float, at_low: float) -> float:
    """Where ``function`` changes sign between ``low`` (where it is ``at_low``) and
    ``high``: 60 bisections (to the double's resolution of any bracket used here)."""
    for _ in range(60):
        middle = (low + high) / 2
        if np.sign(function(middle)) == np.sign(at_low):
            low = middle
        else:
            high = middle
    return (low + high) / 2


def _guess_duration(model: HybridModel, p: np.ndarray, request: Request,
                    x0: np.ndarray) -> float:  # fmt: skip
    """A kinematic start's step duration: the target's (:func:`_target_duration`), else
    (no target, or the centre takes no step) one time unit."""
    duration = _target_duration(model, p, request, x0)
    return duration if duration is not None and 0.0 < duration < math.inf else 1.0


def _target_duration(model: HybridModel, p: np.ndarray, request: Request,
                     end: np.ndarray) -> float | None:  # fmt: skip
    """The step's duration the targets ask for: the period, or the step length at ``end``
    over the speed; None without either."""
    if request.target_period is not None:
        return request.target_period
    if request.target_speed is None or not model.spec["step_length"]:
        return None
    return abs(float(model.step_length(p, end))) / request.target_speed


def _with(values: np.ndarray, i: int, value: float) -> np.ndarray:
    out = values.copy()
    out[i] = value
    return out


def _root_in(function, start: float, label: str, event: str) -> float:
    """A root of a scalar function by the secant method from ``start`` (and 1.01 times
    it): where a locking event's guard vanishes in the coordinate it locks."""
    a, b = start, start * 1.01 + 1e-3
    fa, fb = function(a), function(b)
    for _ in range(50):
        if fb == fa:
            break
        a, b, fa = b, b - fb * (b - a) / (fb - fa), fb
        fb = function(b)
        if abs(fb) < 1e-12:
            return b
    raise ConvergenceError(f"{label}: no start: the guard of {event} does not vanish in the "
                           "coordinate it locks near the search box's centre")  # fmt: skip


def _swapped_guess(model: HybridModel, p: np.ndarray, nlp: Nlp, request: Request,
                   x0: np.ndarray, event: dict) -> np.ndarray:  # fmt: skip
    """The start where the search box's centre at its rates meets no step event (on level
    ground the compass gait's centre moves its stance leg only, its swing foot staying up;
    mirrored rates keep its guard at zero): the coordinates move at constant
    rates from the centre to where the step event's reset takes them (the legs swapped),
    over the target's duration (step length / speed; else one time unit). Not a motion of
    the walker either; IPOPT makes it one."""
    label = getattr(model, "cli_name", model.name)
    n = model.n
    end = model.reset(event["name"], p, x0)[:n]
    if not np.all(np.isfinite(end)) or np.allclose(end, x0[:n]):
        raise ConvergenceError(f"{label}: no passive gait and no start: the search box's "
                               "centre meets no step event at its rates, and its reset does "
                               "not move it")  # fmt: skip
    duration = _guess_duration(model, p, request, x0)
    rates = (end - x0[:n]) / duration
    return _sampled_guess(
        nlp, request.nodes, duration, lambda f: np.concatenate([x0[:n] + f * (end - x0[:n]), rates])
    )


def transfer(model: HybridModel, params: Sequence[float], source: Nlp, w: np.ndarray,
             target: Nlp) -> np.ndarray:  # fmt: skip
    """``w`` of ``source`` as a start for ``target`` (same mesh): durations, states and
    inputs copied, the positive-work slacks filled (:func:`fill_slacks`)."""
    out = np.zeros(target.size)
    count = len(source.layout)
    out[:count] = w[:count]
    target.choose(source.parameters(params, w), out)
    for have, want in zip(source.layout, target.layout):
        for key in ("knots", "middles", "u_knots", "u_middles", "impulses"):
            first, parts, width = have[key]
            start = want[key][0]
            out[start : start + parts * width] = w[first : first + parts * width]
    fill_slacks(model, params, target, out)
    target.start_radius(params, out)
    return out


def refine(model: HybridModel, params: Sequence[float], coarse: Nlp, w: np.ndarray,
           fine: Nlp) -> np.ndarray:  # fmt: skip
    """``w`` on N intervals as a start on 2N: the coarse knots and midpoints are the fine
    knots, the fine midpoints halfway between them; the inputs from the coarse quadratics
    (exact at the quarter points); the slacks filled (:func:`fill_slacks`)."""
    out = np.zeros(fine.size)
    count = len(coarse.layout)
    out[:count] = w[:count]
    fine.choose(coarse.parameters(params, w), out)
    for have, want in zip(coarse.layout, fine.layout):
        first, parts, width = have["impulses"]
        out[want["impulses"][0] : want["impulses"][0] + parts * width] = w[
            first : first + parts * width
        ]
        for knots, middles in (("knots", "middles"), ("u_knots", "u_middles")):
            k, c = block(w, have[knots]), block(w, have[middles])
            if k.shape[1] == 0:
                continue
            fine_knots = np.empty((2 * len(c) + 1, k.shape[1]))
            fine_knots[0::2], fine_knots[1::2] = k, c
            if knots == "knots":
                fine_middles = (fine_knots[:-1] + fine_knots[1:]) / 2
            else:  # the quadratic through knot, midpoint, knot at s = 1/4 and 3/4
                quarter, three = interval_inputs(k[:-1], c, k[1:])[1::2]
                fine_middles = np.empty((2 * len(c), k.shape[1]))
                fine_middles[0::2], fine_middles[1::2] = quarter, three
            for key, values in ((knots, fine_knots), (middles, fine_middles)):
                first, parts, width = want[key]
                out[first : first + parts * width] = values.reshape(-1)
    fill_slacks(model, params, fine, out)
    fine.start_radius(params, out)
    return out


def fill_slacks(model: HybridModel, params: Sequence[float], nlp: Nlp, w: np.ndarray) -> None:
    """Each interval's positive-work slack of ``w`` at the least its constraints allow (its
    Bernstein coefficients at ``max(b, 0)`` of the power's); each impulse's split where it
    stops a reversing rate (:func:`stopping_splits`) and its slacks at ``max(P, 0)`` of
    its parts' power ends (in place)."""
    p = nlp.parameters(params, w)
    for k, ((phase, event), entry) in enumerate(zip(model.phase_sequence(), nlp.layout)):
        first, parts, width = entry["s_impulses"]
        if width:
            iota = block(w, entry["impulses"])[0]
            end = block(w, entry["knots"])[-1]
            splits = stopping_splits(model, event, p, end, iota)
            start = entry["splits"][0]
            w[start : start + len(splits)] = splits
            ends = apply_impulses(model, event, p, end, iota, splits)[2]
            w[first : first + width] = np.maximum(ends, 0.0)
        first, parts, width = entry["s_intervals"]
        if width:
            power = _interval_powers(model, phase, p, w[k], w, entry)
            bernstein = power @ BERNSTEIN_OF_SAMPLES.T  # (interval, input, coefficient)
            # each interval's block coefficient by coefficient, as _collocate's reshape
            slacks = np.maximum(bernstein, 0.0).transpose(0, 2, 1)
            w[first : first + parts * width] = slacks.ravel()


def _interval_powers(model: HybridModel, phase: str, p: np.ndarray, duration: float,
                     w: np.ndarray, entry: dict) -> np.ndarray:  # fmt: skip
    """Each input's power at :data:`SAMPLES` of each interval of a phase of ``w`` (as
    :func:`_collocate` has it): (interval, input, sample)."""
    flow, rates = flow_function(model, phase), input_rate_function(model, phase)
    x, xc = block(w, entry["knots"]), block(w, entry["middles"])
    u, uc = block(w, entry["u_knots"]), block(w, entry["u_middles"])
    h = duration / len(xc)
    powers = []
    for i in range(len(xc)):
        steps = (h * np.array(flow(p, x[j], u[j]), float).reshape(-1) for j in (i, i + 1))
        states = interval_states(x[i], xc[i], x[i + 1], *steps)
        inputs = interval_inputs(u[i], uc[i], u[i + 1])
        powers.append([ui * np.array(rates(p, xi), float).reshape(-1)
                       for xi, ui in zip(states, inputs)])  # fmt: skip
    return np.array(powers).transpose(0, 2, 1)
