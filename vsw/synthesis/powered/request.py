"""What a powered gait is asked for and what it is: the request (cost, targets, mesh,
limits, ground), its checks before any work, the estimate of a run's time, and the result
(:class:`PoweredGait`); the names of a model's inputs and impulses."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw.dynamics.hybrid import HybridModel
from vsw.dynamics.quantities import QUANTITIES, resolve
from vsw.gaits.search import probed_step_lengths
from vsw.runtime import limits
from vsw.runtime.errors import VswInputError

__all__ = [
    "COSTS",
    "PoweredGait",
    "Request",
    "canonical_cost",
    "checked_parameters",
    "chosen_indices",
    "continuous_inputs_used",
    "estimate_seconds",
    "gait_parameters",
    "impulse_names",
    "impulses_usable",
    "input_names",
    "limited_bounds",
    "ordered_impulses",
    "parameter_interval",
    "prices_work",
]


COSTS = tuple(q.name for q in QUANTITIES.values() if "optimize" in q.commands)
"""The costs of :func:`vsw.synthesis.powered.solve.optimize`, as :mod:`vsw.dynamics.quantities`
names them (its aliases, ``cot`` and ``stability``, accepted by :class:`Request`)."""
WORK_COSTS = ("work", "cost_of_transport")
"""The costs that price the inputs' positive work (the others hold the impulses at zero:
they would be free)."""
STABILITY_MARGIN = 1e-3
"""Under ``eigenvalue`` the step map's spectral radius is an unknown at least this."""
STABILITY_ITERATIONS = 500
"""IPOPT's iterations under ``eigenvalue``."""
RESIMULATION_TOL = 1e-11
RESIMULATION_AGREES = 1e-6
"""The re-simulated phases end within this of their last knots (relative to max(1, |x|))."""
MESH_AGREES = 1e-4
"""The cost changes by at most this (relative) from N to 2N intervals a phase."""
FAILURE_MARGIN = 1e-6
"""A failure's guard counts in the re-simulation once this far past zero (in the guard's
unit): an optimum that rides a constraint (a leg at its full length) crosses it by
rounding."""
COST_ZERO = 1e-9
"""Or by at most this (absolute): a cost that is zero to IPOPT's tolerance on both meshes
(a passive gait that meets the targets needs no input)."""
CONSTRAINTS_HELD = 1e-8
"""Every constraint and bound of the NLP holds to this at IPOPT's point (absolute)."""
MAX_STARTS = 50
START_SPREAD = 1.0
"""Each start after the first moves every input at every knot and midpoint by up to this
times that input's largest magnitude over its phase at the first stage's optimum
(uniform, seeded by the start's index), within the input's bounds."""
MAX_TARGET = 1e3
"""The largest target speed, step length or period, in the model's units: no walker's step
is a kilometre or a thousand seconds long (and far beyond, the NLP's start evaluates to
NaN)."""


@dataclass(frozen=True)
class Request:
    """What to optimise: the cost, the targets (None: free) and the mesh."""

    minimize: str = "torque2"
    target_speed: float | None = None
    target_step_length: float | None = None
    nodes: int = 20
    use: tuple[str, ...] = ()
    """The inputs and impulses the gait may use, by name (the others held at zero); empty:
    every one. Kuo's comparison: a push-off, or a torque on the stance leg. (``torque2`` and
    ``eigenvalue`` hold every impulse at zero whatever this says: they do not price them.)"""
    regularization: float = 1e-7
    """Weight of the squared inputs' integral added to the ``work``, ``cost_of_transport`` and
    ``eigenvalue`` costs: the positive work alone is flat along inputs that do no net work,
    where IPOPT wanders. It is made dimensionless: the integral over its value at the least
    squared-input gait with the same targets (where the work stage starts), times the
    cost's scale (weight times step length for ``work``, 1 for ``cost_of_transport``), so
    that it weighs the same on a model in scaled units and one in SI units (a 70 kg
    point-mass biped's leg force squared is 5e5 times the scaled one's); under
    ``eigenvalue`` over the squared-input integral's value at the first stage too, which
    near a passive gait is almost zero: the regularisation's share of the objective is then
    large (4 % at the compass gait's passive speed; ``extra['objective']`` against the
    radius)."""

    friction: float | None = None
    """The ground's friction coefficient: the stance foot's reaction at every knot and
    each foot's impulse at impacts within its cone, ``|tangential| <= friction * normal``
    (None: no bound; the impulses' normal part must push whatever this is, the stance
    foot's reaction as the model's lift-off failure has it). Limits: an impulse applied
    with an impact (Kuo's push-off) acts through the stance foot while the collision acts
    through the new one, and the cone holds their sum; an impulse's two parts (its split)
    are held to it together, not each."""
    pushing_locks: bool = False
    """The ground must push at locks too (a leg that slams into its end stop pulls its foot:
    with this, it reaches the stop without speed); default: reported, not constrained."""
    clearance: float | None = None
    """The swing foot's least height at mid-step: at least ``clearance sin(pi s)`` above
    the ground at each knot (``s`` the fraction of the step;
    :func:`vsw.synthesis.powered.problem._clearance`), the model's ``swing-foot-clearance``
    condition enforced (no scuffing, no foot through the
    ground before its step). None: reported, not enforced (the walkers' sources ignore
    scuffing); 0: above the ground."""
    target_period: float | None = None
    """The step's period (the sum of its phases' durations); at most two of the speed,
    the step length and the period (the third follows from them)."""
    limits: tuple[tuple[str, float | None, float | None], ...] = ()
    """Bounds of the user's on inputs, impulses and chosen parameters, by name: (name, low,
    high), None for no bound on that side; each is intersected with the bounds the model
    declares (an actuator's strength: a leg force of at most 3 m_H g; a chosen parameter's
    interval). A chosen parameter's start is taken into its limits."""
    starts: int = field(default=1, compare=False)
    """How many starts the second stage (``work``, ``cost_of_transport``, ``eigenvalue``) is
    solved from: the first stage's optimum, and after it that optimum with its inputs perturbed
    (:func:`vsw.synthesis.powered.starts.perturbed_inputs`), each on the coarse mesh and then the
    fine and judged; the best (:func:`vsw.synthesis.powered.solve.best_start`: optimal first, then
    IPOPT's success, then cost) is the result (:func:`vsw.synthesis.powered.solve._refined_best`).
    Not compared: the NLPs, cached by request, do not depend on it."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "minimize", canonical_cost(self.minimize))
        object.__setattr__(self, "use", tuple(self.use))  # hashable: the NLPs are cached
        object.__setattr__(self, "limits", tuple(tuple(limit) for limit in self.limits))

    def check(self) -> None:
        if self.minimize not in COSTS:
            raise VswInputError(f"--minimize {self.minimize}: one of {', '.join(COSTS)}")
        if not 2 <= self.nodes <= 1000:
            raise VswInputError(f"--nodes {self.nodes} must be from 2 to 1000")
        for name, value in (("target speed", self.target_speed),
                            ("target step length", self.target_step_length),
                            ("target period", self.target_period)):  # fmt: skip
            if value is not None and not (math.isfinite(value) and 0 < value <= MAX_TARGET):
                raise VswInputError(
                    f"the {name} must be a positive number at most {MAX_TARGET:g} (in the "
                    f"model's units), got {value:g}"
                )
        if None not in (self.target_speed, self.target_step_length, self.target_period):
            raise VswInputError("--target-speed, --target-step-length and --target-period: "
                                "give at most two (the step length is the speed times the "
                                "period)")  # fmt: skip
        for name, low, high in self.limits:
            for value in (low, high):
                if value is not None and not math.isfinite(value):
                    raise VswInputError(f"--limit {name}: {value} is not a finite number")
            if low is not None and high is not None and low > high:
                raise VswInputError(f"--limit {name}: its low bound {low:g} is above its high "
                                    f"bound {high:g}")  # fmt: skip
        for flag, value in (("--friction", self.friction), ("--clearance", self.clearance)):
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise VswInputError(f"{flag} {value} must be a number >= 0")
        if (not isinstance(self.starts, int) or isinstance(self.starts, bool)
                or not 1 <= self.starts <= MAX_STARTS):  # fmt: skip
            raise VswInputError(f"--starts {self.starts} must be from 1 to {MAX_STARTS}")


@dataclass
class PoweredGait:
    """An optimised step: ``status`` 'optimal' (IPOPT converged and the re-simulation
    agrees), 'infeasible' (IPOPT found the constraints locally infeasible: no gait meets
    them near where it searched, a local result and not a proof) or 'not-converged'
    (IPOPT did not converge, or the re-simulation does not agree: ``reason``), with the
    step's phases on their knots."""

    status: str
    reason: str
    cost: float
    durations: tuple[float, ...]
    times: list[np.ndarray]
    states: list[np.ndarray]  # per phase: knots x state
    inputs: list[np.ndarray]  # per phase: knots and midpoints in time order x inputs
    input_times: list[np.ndarray]
    work: dict[str, dict[str, float]]  # per input and impulse: positive, negative
    step_length: float | None
    speed: float | None
    resimulation_error: float
    guard_at_end: float
    ipopt_status: str
    iterations: int
    extra: dict[str, Any] = field(default_factory=dict)
    impulses: dict[str, float] = field(default_factory=dict)
    """Each event's impulses (``<event>.<impulse>``), in the order the step applies them."""
    ground_impulses: dict[str, tuple[float, float]] = field(default_factory=dict)
    """The ground's impulses on the walker at each event (``<event>.stance_foot``,
    ``<event>.new_foot``): tangential and normal
    (:func:`vsw.synthesis.powered.events.event_map`)."""
    parameters: tuple[float, ...] = ()
    """The parameters the step was found at, the chosen ones (:func:`chosen_indices`) at
    the optimiser's values: the ones every later use of the gait needs (its re-simulation,
    verification, eigenvalues)."""

    @property
    def period(self) -> float:
        return float(sum(self.durations))


def chosen_indices(model: HybridModel) -> tuple[int, ...]:
    """The positions in the parameter table of the parameters the optimiser chooses with
    the gait (``Model.chosen_parameters``: an angle at which an impulse acts)."""
    names = [q.name for q in model.parameter_table]
    return tuple(names.index(name) for name in model.spec.get("chosen_parameters", ()))


def gait_parameters(model: HybridModel, gait: PoweredGait, params: Sequence[float]) -> np.ndarray:
    """The parameters a gait's step is taken at: ``params`` with the chosen ones
    (:func:`chosen_indices`) at the gait's values where it records them."""
    p = np.array(params, dtype=float)
    if gait.parameters:
        chosen = list(chosen_indices(model))
        p[chosen] = np.asarray(gait.parameters, dtype=float)[chosen]
    return p


def prices_work(request: Request) -> bool:
    """Whether the request's cost prices the positive work (and so its impulses)."""
    return request.minimize in WORK_COSTS


def input_names(model: HybridModel) -> dict[str, list[str]]:
    """Each phase's inputs by name (empty lists for phases without)."""
    return {p["name"]: [i["name"] for i in p.get("inputs", ())] for p in model.phases}


def impulse_names(model: HybridModel, event: dict) -> tuple[list[str], list[str], list[str]]:
    """An event's impulses by name, in the order the step applies them (the NLP's too):
    those before its reset, the one with its impact (along a held coordinate), those after."""
    impulses = event.get("impulses", ())
    return tuple([i["name"] for i in impulses if i["applied"] == side]
                 for side in ("before", "with", "after"))  # fmt: skip


def ordered_impulses(model: HybridModel, event: dict) -> list[str]:
    """An event's impulses in the order the step applies them (:func:`impulse_names`)."""
    return [name for group in impulse_names(model, event) for name in group]


def _check_actuator_names(model: HybridModel, request: Request) -> None:
    """``use`` names inputs or impulses of the model, ``limits`` those or its chosen
    parameters, and each limit leaves a value within the bounds the model declares
    (one-line refusals)."""
    label = getattr(model, "cli_name", model.name)
    known = [name for names in input_names(model).values() for name in names]
    for event in model.events:
        known += [i["name"] for i in event.get("impulses", ())]
    chosen = {model.parameter_table[i].name: i for i in chosen_indices(model)}
    for flag, name in (*(("--use", n) for n in request.use),
                       *(("--limit", n) for n, _, _ in request.limits)):  # fmt: skip
        if name not in known and not (flag == "--limit" and name in chosen):
            what = "input or impulse" + (" or chosen parameter" if flag == "--limit" else "")
            names = [*known, *chosen] if flag == "--limit" else known
            raise VswInputError(f"{flag} {name}: {label} has no {what} {name} (its: "
                                f"{', '.join(dict.fromkeys(names))})")  # fmt: skip
    declared = {i["name"]: i["bounds"] for phase in model.phases for i in phase.get("inputs", ())}
    for event in model.events:
        declared |= {i["name"]: i["bounds"] for i in event.get("impulses", ())}
    declared |= {name: parameter_interval(model, i) for name, i in chosen.items()}
    for name, _, _ in request.limits:
        low, high = limited_bounds(declared[name], request, name)
        if low is not None and high is not None and low > high:
            raise VswInputError(f"--limit {name}: no value within both it and the bounds "
                                f"{label} declares ({_interval(declared[name])})")  # fmt: skip


def limited_bounds(bounds: tuple, request: Request, name: str) -> tuple[float | None, float | None]:
    """An input's or impulse's declared bounds within the request's limits on it."""
    low, high = bounds
    for limit, lower, upper in request.limits:
        if limit == name:
            low = lower if low is None else low if lower is None else max(low, lower)
            high = upper if high is None else high if upper is None else min(high, upper)
    return low, high


def parameter_interval(model: HybridModel, index: int) -> tuple[float, float]:
    """The interval the parameter table gives the parameter at ``index``."""
    row = model.parameter_table[index]
    return float(row.lower), float(row.upper)


def started_within_limits(model: HybridModel, params: Sequence[float],
                          request: Request) -> np.ndarray:  # fmt: skip
    """``params`` with each chosen parameter taken into the request's limits on it (its
    start: the nearest value within them)."""
    p = np.array(params, dtype=float)
    for i in chosen_indices(model):
        name = model.parameter_table[i].name
        low, high = limited_bounds(parameter_interval(model, i), request, name)
        p[i] = min(max(p[i], low), high)
    return p


def _interval(bounds: tuple) -> str:
    low, high = bounds
    return f"{'-inf' if low is None else f'{low:g}'} to {'inf' if high is None else f'{high:g}'}"


# The estimate of a run (:func:`estimate_seconds`), measured by hand on the reference machine
# (2 cores shared with other work) on the compass gait (torque2 and work, N = 20 and 40:
# 206-606 unknowns) and free-vsw-biped-stop (stability, N = 4, 8 and 16: 141-501 unknowns),
# with time.perf_counter around CasADi's nlpsol and each solve; rounded up:
#: IPOPT's iterations of a solve under torque2, work and cot (measured 5-73; its limit is
#: 3000, reached by no measured run)
OPTIMIZE_ITERATIONS = 100
#: one IPOPT iteration per unknown, torque2, work and cot: 0.05-0.08 ms
OPTIMIZE_SECONDS_PER_ITERATION_UNKNOWN = 1e-4
#: one IPOPT iteration per unknown, stability (the step map's second derivatives):
#: 0.44-0.51 ms (0.76 under a load of 4)
STABILITY_SECONDS_PER_ITERATION_UNKNOWN = 6e-4
#: building the NLP (CasADi's derivatives), per unknown, torque2, work and cot: 0.4-0.7 ms
OPTIMIZE_BUILD_SECONDS_PER_UNKNOWN = 1e-3
#: building the NLP, per unknown squared, stability: 1.9 s at 141 unknowns, 3.8-6.8 s at
#: 261, 29 s at 501 (9.6e-5 to 1.16e-4)
STABILITY_BUILD_SECONDS_PER_UNKNOWN2 = 1.2e-4


def _unknowns(model: HybridModel, nodes: int) -> int:
    """About how many unknowns the NLP on ``nodes`` intervals a phase has: the state (at
    knots and midpoints) and the inputs of every interval (measured within a few per cent
    on the compass gait and free-vsw-biped-stop)."""
    names = input_names(model)
    per_interval = sum(4 * model.n + 2 * len(names[phase]) for phase, _ in model.phase_sequence())
    return per_interval * nodes + 4 * model.n + 2


def estimate_seconds(model: HybridModel, request: Request) -> float:
    """A conservative estimate of :func:`vsw.synthesis.powered.solve.optimize`'s run time: each NLP
    built (coarse and fine mesh, the least squared-input stage first where there is one)
    and each solve at a full count of iterations (:data:`STABILITY_ITERATIONS` under stability,
    :data:`OPTIMIZE_ITERATIONS` otherwise), from the per-unknown costs above."""

    def build(unknowns: int, minimize: str) -> float:
        if minimize == "eigenvalue":
            return STABILITY_BUILD_SECONDS_PER_UNKNOWN2 * unknowns**2
        return OPTIMIZE_BUILD_SECONDS_PER_UNKNOWN * unknowns

    def solve(unknowns: int, minimize: str) -> float:
        if minimize == "eigenvalue":
            return STABILITY_ITERATIONS * STABILITY_SECONDS_PER_ITERATION_UNKNOWN * unknowns
        return OPTIMIZE_ITERATIONS * OPTIMIZE_SECONDS_PER_ITERATION_UNKNOWN * unknowns

    coarse, fine = _unknowns(model, request.nodes), _unknowns(model, 2 * request.nodes)
    seconds = 0.0
    if request.minimize != "torque2" and continuous_inputs_used(model, request):
        seconds += build(coarse, "torque2") + solve(coarse, "torque2")
    for unknowns in (coarse, fine):
        seconds += build(unknowns, request.minimize)
        seconds += request.starts * solve(unknowns, request.minimize)
    return seconds


def _check_cost(model: HybridModel, request: Request) -> None:
    """Refuse, before any work, a run the estimate puts beyond ``VSW_MAX_SECONDS``."""
    starts = f" from {request.starts} starts" if request.starts > 1 else ""
    limits.check(
        f"optimizing {request.minimize} on {request.nodes} and {2 * request.nodes} intervals "
        f"a phase{starts}",
        limits.Cost(estimate_seconds(model, request), 0.0),
        "use fewer --nodes" + (" or --starts" if request.starts > 1 else ""),
    )


def _check_step_target(model: HybridModel, params: Sequence[float], request: Request) -> None:
    """A step length fixed by the parameters (the point-mass biped's ``d``) and a target
    that differs from it contradict each other: a one-line refusal, not an infeasible NLP."""
    target = request.target_step_length
    if target is None and None not in (request.target_speed, request.target_period):
        target = request.target_speed * request.target_period  # what the two imply
    if target is None:
        return
    lengths = probed_step_lengths(model, params)
    if len(lengths) == 1:
        (length,) = lengths
        if not math.isclose(length, target, rel_tol=1e-12):
            label = getattr(model, "cli_name", model.name)
            given = (f"--target-step-length {target:g}" if request.target_step_length is not None
                     else f"--target-speed times --target-period, {target:g},")  # fmt: skip
            raise VswInputError(f"{label}'s step length is set by its parameters ({length:g}): "
                                f"{given} contradicts it (set the parameter instead)")  # fmt: skip


def continuous_inputs_used(model: HybridModel, request: Request) -> bool:
    """Whether any phase's continuous input may act (``use`` names it, or names none)."""
    return any(not request.use or name in request.use
               for names in input_names(model).values() for name in names)  # fmt: skip


def _check_ground_options(model: HybridModel, request: Request) -> None:
    """``--clearance`` needs a swing foot's clearance and ``--pushing-locks`` a lock among
    the model's declarations (one-line refusals, not options silently ignored)."""
    label = getattr(model, "cli_name", model.name)
    if request.clearance is not None and not any(
        name == "swing-foot-clearance"
        for phase in model.phases for name, _, _ in phase.get("conditions", ())
    ):  # fmt: skip
        raise VswInputError(f"--clearance: {label} declares no swing foot's clearance")
    if request.pushing_locks and not any(e["reset"] == "lock" for e in model.events):
        raise VswInputError(f"--pushing-locks: {label} has no lock")


def impulses_usable(request: Request | None, names: Sequence[str]) -> bool:
    """Whether the optimiser may use any of these impulses (``torque2`` and ``eigenvalue``
    hold them all at zero, ``use`` those it does not name)."""
    if request is None:
        return bool(names)
    if not prices_work(request):
        return False
    return any(not request.use or name in request.use for name in names)


def canonical_cost(name: str) -> str:
    """A cost's name as :mod:`vsw.dynamics.quantities` spells it (``cot`` -> ``cost_of_transport``,
    ``stability`` -> ``eigenvalue``); a name no cost has is kept for :meth:`Request.check`
    to refuse."""
    try:
        return resolve(name, "optimize")[0].name
    except VswInputError:
        return name


def checked_parameters(model: HybridModel, params: Sequence[float],
                       request: Request) -> np.ndarray:  # fmt: skip
    """The request checked against the model before any work (one-line refusals: inputs,
    names, targets, ground options, starts, the run's estimated time) and ``params`` with
    each chosen parameter taken into its limits (:func:`started_within_limits`)."""
    request.check()
    sequence = model.phase_sequence()
    names = input_names(model)
    label = getattr(model, "cli_name", model.name)
    if not any(names[phase] or event.get("impulses") for phase, event in sequence):
        raise VswInputError(f"{label} declares no inputs: nothing to power it with")
    if (request.target_speed or request.target_step_length) and not model.spec["step_length"]:
        raise VswInputError(f"{label} defines no step length: no speed or step target")
    _check_actuator_names(model, request)
    if not prices_work(request) and not continuous_inputs_used(model, request):
        only = " (--use names only impulses)" if request.use else ""
        raise VswInputError(f"--minimize {request.minimize} holds every impulse at zero (it "
                            f"does not price them) and no continuous input of {label} may "
                            f"act{only}: nothing would power the step")  # fmt: skip
    _check_ground_options(model, request)
    _check_step_target(model, params, request)
    if request.starts > 1 and (request.minimize == "torque2"
                               or not continuous_inputs_used(model, request)):  # fmt: skip
        raise VswInputError(f"--starts {request.starts}: only the second stage of work, "
                            "cost-of-transport and eigenvalue starts from several points "
                            "(the first stage's inputs perturbed); this request solves one "
                            "stage from one start")  # fmt: skip
    params = started_within_limits(model, params, request)
    _check_cost(model, request)
    return params
