"""Powered gaits: periodic gaits with the model's inputs, optimal for a cost, by direct
collocation (IPOPT through CasADi).

A model's phases may declare continuous inputs (``Input`` in the model language: a hip
torque, a leg force), whose gains on the accelerations the derivation generates
(``<phase>_input_gains``): ``q'' = a(q, q') + B(q) u``; its events may declare impulses
(``Impulse``: a push-off), whose gains on the rates it generates too
(``event_<e>_impulse_gains_before/after``, and ``_with`` for one applied with an impact
along a held coordinate: a rigid leg's push-off). This module finds the step, with its inputs and
impulses, that meets the targets (speed, step length) at the least cost.

Transcription: Hermite–Simpson, separated form
----------------------------------------------
Each phase of a step is cut into :attr:`Request.nodes` intervals of equal length
``h = T_k / N`` (``T_k`` the phase's duration, an unknown > 0). The unknowns are the state
and the inputs at every knot and every interval's midpoint, the durations and each event's
impulses. Per interval ``[x_i, x_{i+1}]`` with midpoint ``x_c``:
``x_c = (x_i + x_{i+1}) / 2 + h / 8 (f_i - f_{i+1})`` and
``x_{i+1} = x_i + h / 6 (f_i + 4 f_c + f_{i+1})`` (Simpson's rule on a cubic state: the
scheme is fourth order); the inputs are quadratic on each interval through ``u_i``, ``u_c``,
``u_{i+1}`` (what the re-simulation interpolates; under the work costs the midpoint is tied
to its knots' mean, so the inputs are linear: see ``_collocate``). Each phase ends on its
event's guard (= 0, its ``when`` >= 0), the event's impulses before its reset, the reset
with the impulse at its impact and its impulses after map the last knot to the next
phase's first, and the step is
periodic. Every failure of a phase is a path constraint at the knots, with
the inputs' share of its guard (``<guard>_input_gains``: the ground reaction moves with
them). The model's parameters are fixed, but for those it names as the gait's own
(``chosen_parameters``: an angle at which an impulse acts), which are unknowns too.

Costs (per step): ``torque2``, the integral of the squared inputs; ``work``, the inputs'
positive work, the integral of ``max(P, 0)`` of each input's power ``P = u d(along)/dt``,
without smoothing, priced from above on each interval: where the input's rate is linear
in the state (a leg's length rate, a hip's angle rate) ``P`` there is a quartic (a linear
input times that rate of the scheme's cubic state), fixed by five samples (knots, quarter
points, midpoint: :data:`SAMPLES`), and the cost prices a quartic slack ``s >= 0, s >=
P`` by its Bernstein coefficients ``c_j >= 0, c_j >= b_j(P)`` (which make it so on the
whole interval), at their mean (its integral); where the rate is not linear (the
point-mass biped's leg in Cartesian coordinates) the bound is on the quartic through the
samples, to that interpolation's error. Samples alone (the epigraph at knots and
midpoints, used before) let the optimum hide a power that changes sign between them: a
landing absorbed by a leg force and pushed back within one interval, positive work the
mesh did not count and no refinement removed. The bound is tight where the power keeps
its sign and its Bernstein coefficients theirs; elsewhere it exceeds ``max(P, 0)``'s
integral by a small multiple of ``h max |P|`` on the interval, which vanishes as the mesh
refines (a power that wiggles about zero on a held coordinate, by O(h^3)). The ledger
(the work reported) is composite Simpson of ``max(P, 0)`` and ``min(P, 0)`` on the five
samples. ``cost_of_transport``, that work over weight times step length; impulses count by
their positive work (each applied in two parts whose split is free, each part priced by slacks
at its power's ends: exact where the split stops a reversing rate, see
:func:`_event_map`; ``c iota^2 / 2`` for one at an impact; ``torque2`` holds them at
zero: it does not price them). ``eigenvalue``: the spectral radius of the open-loop step
map (:func:`_collocated_jacobian`, :func:`_event_jacobian`, :func:`_stability_rows`;
impulses held at zero, as ``torque2`` holds them). The last three add
:attr:`Request.regularization` times the squared inputs' integral, made dimensionless.
The squared inputs' integral by Simpson's rule on the knots and midpoints. ``work``,
``cost_of_transport`` and ``eigenvalue`` start from the ``torque2`` optimum with the same
targets.

Verification: the problem is solved on N and on 2N intervals a phase (the finer from the
coarser optimum) and the cost's change between them reported; each phase is integrated
again from its first knot with the inputs as the scheme interpolates them (SciPy DOP853,
1e-11; its event's guard and its failures watched between the knots), and its end
compared with the last knot (``resimulation_error``, relative to max(1, |state|)).
``optimal`` needs all of it (:func:`optimize`). The start is the model's passive gait at
the same parameters, inputs zero; a model without one starts from its search box's centre
moving at constant rates (:func:`_kinematic_guess`). The open-loop map's eigenvalues are
reported (:func:`powered_eigenvalues`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import math
import threading
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw import limits, stop
from vsw.design import characteristic_coefficients, jury_rows
from vsw.errors import ConvergenceError, VswInputError
from vsw.gaits import free_components, pick, probed_step_lengths, section_states
from vsw.hybrid import HybridModel, Orbit
from vsw.quantities import QUANTITIES, evaluate, resolve
from vsw.quantities import weight as walker_weight

__all__ = [
    "PoweredGait",
    "Request",
    "canonical_cost",
    "optimize",
    "powered_eigenvalues",
    "powered_step",
    "walker_weight",
]

COSTS = tuple(q.name for q in QUANTITIES.values() if "optimize" in q.commands)
"""The costs of :func:`optimize`, as :mod:`vsw.quantities` names them (its aliases, ``cot``
and ``stability``, accepted by :class:`Request`)."""
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
SAMPLES = (0.0, 0.25, 0.5, 0.75, 1.0)
"""Where each interval's power is sampled (fractions of the interval): five points fix the
quartic that the power ``u P(q) q'`` of a linear input along a linear coordinate is on the
scheme's cubic state."""
SIMPSON_WEIGHTS = np.array([1.0, 4.0, 2.0, 4.0, 1.0]) / 12
"""Composite Simpson's rule on :data:`SAMPLES` (per unit of the interval): the ledger."""
BERNSTEIN_OF_SAMPLES = np.linalg.inv(
    [[math.comb(4, j) * s**j * (1 - s) ** (4 - j) for j in range(5)] for s in SAMPLES]
)
"""The quartic through five samples at :data:`SAMPLES`, as its Bernstein coefficients."""
_HERMITE = {
    s: (2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2)
    for s in (0.25, 0.75)
}
_SUCCESS = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}
MAX_STARTS = 50
START_SPREAD = 1.0
"""Each start after the first moves every input at every knot and midpoint by up to this
times that input's largest magnitude over its phase at the first stage's optimum
(uniform, seeded by the start's index), within the input's bounds."""
MAX_TARGET = 1e3
"""The largest target speed, step length or period, in the model's units: no walker's step
is a kilometre or a thousand seconds long (and far beyond, the NLP's start evaluates to
NaN)."""
_INFEASIBLE = "Infeasible_Problem_Detected"
"""IPOPT's word for a restoration phase that converged to a point of locally least
constraint violation, still violating them: reported as ``infeasible``."""


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
    the ground at each knot (``s`` the fraction of the step; :func:`_clearance`), the
    model's ``swing-foot-clearance`` condition enforced (no scuffing, no foot through the
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
    (:func:`_perturbed_inputs`), each on the coarse mesh and then the fine and judged; the
    best (:func:`best_start`: optimal first, then IPOPT's success, then cost) is the
    result (:func:`_refined_best`). Not compared: the NLPs, cached by request, do not
    depend on it."""

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
    ``<event>.new_foot``): tangential and normal (:func:`_event_map`)."""
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


def optimize(
    model: HybridModel, params: Sequence[float], request: Request, start: Orbit | None = None
) -> PoweredGait:
    """The least-cost periodic step of ``model`` at ``params`` with its inputs (see the
    module docstring), from ``start`` (default: the model's passive gait at ``params``).

    Solved on ``request.nodes`` intervals a phase and again on twice as many (each from the
    same start): the result is the finer one, with ``mesh_change`` the relative change of
    the cost between them. ``optimal`` needs IPOPT's success on both, the re-simulation
    within :data:`RESIMULATION_AGREES` and ``mesh_change`` within :data:`MESH_AGREES`;
    otherwise ``not-converged`` says which failed (:func:`_judged`). ``cost`` is the named
    cost (the positive work without the regularization the NLP adds;
    ``extra['objective']`` the NLP's). With ``request.starts`` above 1 the second stage
    starts from several points, each solved on both meshes and judged, and the best is
    the result (:func:`_refined_best`).

    Used from Python outside :func:`vsw.stop.supervised`, a Ctrl-C inside CasADi surfaces
    as a failed solve; with several starts that start is then counted as failed and the
    others go on (under ``supervised``, as the CLI runs, it stops the command)."""
    request.check()
    sequence = model._phase_sequence()
    names = input_names(model)
    label = getattr(model, "cli_name", model.name)
    if not any(names[phase] or event.get("impulses") for phase, event in sequence):
        raise VswInputError(f"{label} declares no inputs: nothing to power it with")
    if (request.target_speed or request.target_step_length) and not model.spec["step_length"]:
        raise VswInputError(f"{label} defines no step length: no speed or step target")
    _check_actuator_names(model, request)
    if not prices_work(request) and not _continuous_inputs_used(model, request):
        only = " (--use names only impulses)" if request.use else ""
        raise VswInputError(f"--minimize {request.minimize} holds every impulse at zero (it "
                            f"does not price them) and no continuous input of {label} may "
                            f"act{only}: nothing would power the step")  # fmt: skip
    _check_ground_options(model, request)
    _check_step_target(model, params, request)
    if request.starts > 1 and (request.minimize == "torque2"
                               or not _continuous_inputs_used(model, request)):  # fmt: skip
        raise VswInputError(f"--starts {request.starts}: only the second stage of work, "
                            "cost-of-transport and eigenvalue starts from several points "
                            "(the first stage's inputs perturbed); this request solves one "
                            "stage from one start")  # fmt: skip
    params = _started_within_limits(model, params, request)
    _check_cost(model, request)
    if start is None:
        start = _passive_start(model, params)  # None: the model has no passive gait
    fine = _refined_best(model, params, request, _optimize_on_mesh(model, params, request, start))
    if fine.status == "optimal" or (request.minimize == "eigenvalue"
                                    and fine.status == "not-converged"):  # fmt: skip
        try:  # under stability the independent check of the radius, converged or not
            fine.extra["eigenvalues"] = powered_eigenvalues(model, fine.parameters, fine)
        except ConvergenceError as exc:  # a perturbed step that does not end: no map
            stop.check()
            fine.extra["eigenvalues_note"] = str(exc)
    return fine


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
    declared |= {name: _parameter_interval(model, i) for name, i in chosen.items()}
    for name, _, _ in request.limits:
        low, high = _limited(declared[name], request, name)
        if low is not None and high is not None and low > high:
            raise VswInputError(f"--limit {name}: no value within both it and the bounds "
                                f"{label} declares ({_interval(declared[name])})")  # fmt: skip


def _limited(bounds: tuple, request: Request, name: str) -> tuple[float | None, float | None]:
    """An input's or impulse's declared bounds within the request's limits on it."""
    low, high = bounds
    for limit, lower, upper in request.limits:
        if limit == name:
            low = lower if low is None else low if lower is None else max(low, lower)
            high = upper if high is None else high if upper is None else min(high, upper)
    return low, high


def _parameter_interval(model: HybridModel, index: int) -> tuple[float, float]:
    row = model.parameter_table[index]
    return float(row.lower), float(row.upper)


def _started_within_limits(model: HybridModel, params: Sequence[float],
                           request: Request) -> np.ndarray:  # fmt: skip
    """``params`` with each chosen parameter taken into the request's limits on it (its
    start: the nearest value within them)."""
    p = np.array(params, dtype=float)
    for i in chosen_indices(model):
        low, high = _limited(_parameter_interval(model, i), request, model.parameter_table[i].name)
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
    per_interval = sum(4 * model.n + 2 * len(names[phase]) for phase, _ in model._phase_sequence())
    return per_interval * nodes + 4 * model.n + 2


def estimate_seconds(model: HybridModel, request: Request) -> float:
    """A conservative estimate of :func:`optimize`'s run time: each NLP built (coarse and
    fine mesh, the least squared-input stage first where there is one) and each solve at
    a full count of iterations (:data:`STABILITY_ITERATIONS` under stability,
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
    if request.minimize != "torque2" and _continuous_inputs_used(model, request):
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


def _judged(request: Request, coarse: PoweredGait, fine: PoweredGait) -> PoweredGait:
    """``fine`` (the coarse optimum solved again on twice the intervals, from itself) with
    its ``mesh_change`` and the coarse mesh's cost, and its status as the pair makes it:
    ``optimal`` only where the coarse solve succeeded too and the cost agrees between the
    meshes; an infeasible coarse mesh stays infeasible unless the fine one is optimal."""
    change = abs(fine.cost - coarse.cost) / max(abs(fine.cost), 1e-300)
    fine.extra["mesh_change"] = change
    fine.extra["coarse"] = {"nodes": request.nodes, "cost": coarse.cost,
                            "status": coarse.status}  # fmt: skip
    if "warm_start" in coarse.extra:  # the coarse mesh's first stage
        fine.extra["warm_start"] = coarse.extra["warm_start"]
    agree = change <= MESH_AGREES or abs(fine.cost - coarse.cost) <= COST_ZERO
    if coarse.status == "infeasible" and fine.status != "optimal":
        fine.status, fine.reason = coarse.status, coarse.reason + " (on the coarse mesh)"
    elif fine.status == "optimal" and coarse.ipopt_status not in _SUCCESS:
        fine.status = "not-converged"
        fine.reason = f"IPOPT {coarse.ipopt_status} on the coarse mesh"
    elif fine.status == "optimal" and not agree:
        fine.status = "not-converged"
        fine.reason = (f"the cost changes by {change:.3g} (relative) from {request.nodes} to "
                       f"{2 * request.nodes} intervals a phase: the mesh does not resolve the "
                       "optimum (try more --nodes)")  # fmt: skip
        if prices_work(request):
            fine.reason += ("; the least work may need an impulsive input, which no mesh "
                            "resolves")  # fmt: skip
    return fine


def best_start(results: Sequence[Any]) -> int:
    """The index of the best of several starts' judged results (None: that start failed):
    ``optimal`` first, then IPOPT's success, then the least cost, then the earlier start.
    A lower cost that is not ``optimal`` (a mesh that does not resolve it, a
    re-simulation that disagrees) does not beat an optimal one."""
    ranked = [(r.status != "optimal", r.ipopt_status not in _SUCCESS, r.cost, k)
              for k, r in enumerate(results) if r is not None]  # fmt: skip
    return min(ranked)[3]


def _refined_best(model: HybridModel, params: Sequence[float], request: Request,
                  solved: list[PoweredGait | str]) -> PoweredGait:  # fmt: skip
    """Each coarse optimum (one a start; a string where it failed: why) solved again on
    twice the intervals from itself, so that the change measures the mesh and not another
    local optimum, and judged (:func:`_judged`); the fine result :func:`best_start` picks. With
    several starts, each one's costs, statuses (or why it failed) in ``extra['starts']``
    of the fine result and the chosen one's index in ``best_start``."""
    finer = dataclasses.replace(request, nodes=2 * request.nodes)
    coarse_nlp, fine_nlp = _built(model, request), _built(model, finer)
    judged: list[PoweredGait | None] = []
    tried: list[dict[str, Any]] = []
    for coarse in solved:
        fine, why = None, coarse if isinstance(coarse, str) else ""
        if not isinstance(coarse, str):
            try:
                guess = _refine(model, params, coarse_nlp, coarse.extra["w"], fine_nlp)
                fine = _solve(model, params, finer, fine_nlp, guess,
                              coarse.extra["regularization_scale"])  # fmt: skip
            except ConvergenceError as exc:
                if len(solved) == 1:
                    raise
                why = f"on the fine mesh: {exc}"
        judged.append(None if fine is None else _judged(request, coarse, fine))
        if fine is None:
            tried.append({"coarse": None if isinstance(coarse, str) else coarse.cost,
                          "fine": None, "ipopt_status": None, "status": "failed",
                          "reason": why})  # fmt: skip
        else:
            tried.append({"coarse": coarse.cost, "fine": fine.cost,
                          "ipopt_status": fine.ipopt_status, "status": fine.status,
                          "reason": fine.reason or None})  # fmt: skip
    if all(fine is None for fine in judged):
        raise ConvergenceError(f"{model.name}: every one of {len(solved)} starts failed (the "
                               f"first: {tried[0]['reason']})")  # fmt: skip
    best = best_start(judged)
    fine = judged[best]
    assert fine is not None
    if len(solved) > 1:
        fine.extra["starts"] = tried
        fine.extra["best_start"] = best
    return fine


def _optimize_on_mesh(model: HybridModel, params: Sequence[float], request: Request,
                      start: Orbit | None) -> list[PoweredGait | str]:  # fmt: skip
    """The optimum on the coarse mesh from each start (for a start after the first that
    failed, why): the first stage from the passive gait or the kinematic guess, then the
    second from its optimum (:func:`_second_stage`)."""
    stage = request
    if request.minimize != "torque2" and _continuous_inputs_used(model, request):
        # Positive work is flat wherever no input does work and not smooth where one
        # starts to: from the passive gait IPOPT wanders (to steps of no duration);
        # from the least squared-input step that meets the targets it converges. (With
        # every continuous input held at zero that stage has nothing to move the walker
        # with, and more equations than unknowns: the work stage starts directly.)
        stage = dataclasses.replace(request, minimize="torque2")
    nlp = _built(model, stage)
    if start is None:
        guess = _kinematic_guess(model, params, nlp, request)
    else:
        guess = _initial_guess(model, params, start, nlp, request.nodes)
    nlp.choose(params, guess)
    nlp.start_radius(params, guess)
    if stage is request and prices_work(request):
        _fill_slacks(model, params, nlp, guess)
    result = _solve(model, params, stage, nlp, guess)
    if stage is request:
        return [result]
    staged = _built(model, request)
    scale = 1.0
    if request.minimize == "work" and result.step_length is not None:
        scale = walker_weight(model, result.parameters) * result.step_length
    if result.cost > COST_ZERO:  # the squared inputs' integral of the first stage
        # Under stability near a passive gait that integral is almost zero and the weight
        # large (4 % of the objective at the compass gait's passive speed; the share is
        # reported). A weight fixed by the walker's weight squared times the period was
        # tried: the stability test's solve then ran over 12 CPU minutes (24 s with this
        # one) and was stopped; why was not found.
        scale /= result.cost
    first = _transfer(model, params, nlp, result.extra["w"], staged)
    solved = _second_stage(model, params, request, staged, first, scale)
    for final in solved:
        if not isinstance(final, str):
            final.extra["warm_start"] = {"minimize": "torque2", "status": result.status,
                                         "cost": result.cost,
                                         "parameters": result.parameters}  # fmt: skip
    return solved


def _second_stage(model: HybridModel, params: Sequence[float], request: Request, nlp: _Nlp,
                  first: np.ndarray, scale: float) -> list[PoweredGait | str]:  # fmt: skip
    """The second stage solved from ``first`` and from ``request.starts - 1`` perturbations
    of its inputs (for one of those that failed, why). The perturbations are relative to
    ``first``'s inputs: where those are nearly zero (a passive gait meets the targets, the
    inputs only the mesh's error) every start is nearly ``first``, and the starts' equal
    costs in ``extra['starts']`` show it."""
    solved: list[PoweredGait | str] = [_solve(model, params, request, nlp, first, scale)]
    for k in range(1, request.starts):
        try:
            guess = _perturbed_inputs(model, params, nlp, first, k)
            solved.append(_solve(model, params, request, nlp, guess, scale))
        except ConvergenceError as exc:
            solved.append(str(exc))
    return solved


def _perturbed_inputs(model: HybridModel, params: Sequence[float], nlp: _Nlp, w: np.ndarray,
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
            size = np.maximum(size, np.max(np.abs(_block(w, entry[key])), axis=0, initial=0.0))
        for key in ("u_knots", "u_middles"):
            first, parts, width = entry[key]
            block = slice(first, first + parts * width)
            shift = START_SPREAD * size * rng.uniform(-1.0, 1.0, (parts, width))
            moved = _block(w, entry[key]) + shift
            out[block] = np.clip(moved.reshape(-1), lbx[block], ubx[block])
    _fill_slacks(model, params, nlp, out)
    nlp.start_radius(params, out)
    return out


def _continuous_inputs_used(model: HybridModel, request: Request) -> bool:
    """Whether any phase's continuous input may act (``use`` names it, or names none)."""
    return any(not request.use or name in request.use
               for names in input_names(model).values() for name in names)  # fmt: skip


def _passive_start(model: HybridModel, params: Sequence[float]) -> Orbit | None:
    """The passive gait the commands follow (the first stable one, else the first), or
    None where there is none (a walker its inputs hold up, or parameters without one).
    A model that walks only powered has none to search for: on level ground every step
    loses energy, and the search (seconds on the compass gait's body) would end empty."""
    if model.spec.get("powered_only"):
        return None
    return pick(model.fixed_points(params))


@dataclass(frozen=True)
class _Nlp:
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
        return _spectral_radius(self.step_jacobian(params, w))

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


@dataclass
class _Unknowns:
    """The NLP's unknowns of one phase: states and inputs at the knots and midpoints, the
    impulses of the event that ends it (in :func:`ordered_impulses`' order: before its
    reset, with its impact, after it), and
    the positive-work slacks of inputs and impulses (width 0 unless the cost is the work)."""

    knots: list
    middles: list
    u_knots: list
    u_middles: list
    s_intervals: list
    impulses: list
    splits: list
    s_impulses: list

    KEYS = (
        "knots",
        "middles",
        "u_knots",
        "u_middles",
        "s_intervals",
        "impulses",
        "splits",
        "s_impulses",
    )


@dataclass
class _Constraints:
    rows: list = field(default_factory=list)
    lower: list = field(default_factory=list)
    upper: list = field(default_factory=list)

    def add(self, expr: Any, low: float, high: float) -> None:
        self.rows.append(expr)
        self.lower.extend([low] * expr.shape[0])
        self.upper.extend([high] * expr.shape[0])


def _phase_unknowns(k: int, m: int, nu: int, nj: int, nodes: int, slack: bool) -> _Unknowns:
    import casadi as ca

    def symbols(stem: str, count: int, width: int) -> list:
        return [ca.MX.sym(f"{stem}_{k}_{i}", width) for i in range(count)]

    # The positive work's epigraph: on each interval, a quartic slack above 0 and above the
    # power, by its Bernstein coefficients (_collocate). An impulse in two parts (its
    # split), each with two slacks at its power's ends (_event_map).
    width, split_width = (nu, nj) if slack else (0, 0)
    return _Unknowns(symbols("x", nodes + 1, m), symbols("xc", nodes, m),
                     symbols("u", nodes + 1, nu), symbols("uc", nodes, nu),
                     symbols("s", nodes, len(SAMPLES) * width),
                     symbols("j", 1, nj), symbols("f", 1, split_width),
                     symbols("sj", 1, 4 * split_width))  # fmt: skip


def _collocate(model: HybridModel, phase: str, v: _Unknowns, p: Any, duration: Any,
               request: Request, g: _Constraints) -> tuple[Any, Any, dict, dict]:  # fmt: skip
    """A phase's Hermite-Simpson defects, path constraints and slacks into ``g``; its
    squared-input integral, its positive work as the cost prices it (each interval's
    Bernstein slack where the cost is the work: see the module's docstring) and each
    input's positive and negative work (composite Simpson on :data:`SAMPLES` of
    ``max(P, 0)`` and ``min(P, 0)``)."""
    import casadi as ca

    names = input_names(model)[phase]
    flow = _flow_function(model, phase)
    nodes = len(v.middles)
    h = duration / nodes
    slack = prices_work(request)
    for function, direction in _margin_functions(model, phase):
        for x, u in zip(v.knots, v.u_knots):
            g.add(-direction * function(p, x, u), 0.0, math.inf)
    if request.friction is not None:  # the stance foot's reaction within its cone
        reaction = _reaction_function(model, phase)
        for x, u in zip(v.knots, v.u_knots):
            tangential, normal = ca.vertsplit(reaction(p, x, u))
            g.add(ca.vertcat(request.friction * normal - tangential,
                             request.friction * normal + tangential), 0.0, math.inf)  # fmt: skip
    rates = _input_rate_function(model, phase) if names else None
    squares, priced = 0, 0
    positive = dict.fromkeys(names, 0)
    negative = dict.fromkeys(names, 0)
    for i in range(nodes):
        x0, x1, xc = v.knots[i], v.knots[i + 1], v.middles[i]
        u0, u1, uc = v.u_knots[i], v.u_knots[i + 1], v.u_middles[i]
        f0 = flow(p, x0, u0)
        f1 = flow(p, x1, u1)
        fc = flow(p, xc, uc)
        g.add(xc - (x0 + x1) / 2 - h / 8 * (f0 - f1), 0.0, 0.0)
        g.add(x1 - x0 - h / 6 * (f0 + 4 * fc + f1), 0.0, 0.0)
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


def interval_states(x0: Any, xc: Any, x1: Any, step0: Any, step1: Any) -> tuple:
    """The state at :data:`SAMPLES` of an interval: its knots and midpoint, and the
    scheme's cubic (Hermite, through the knots with slopes ``step = h f``) at the quarter
    points."""
    quarter, three = (a * x0 + b * step0 + c * x1 + d * step1
                      for a, b, c, d in (_HERMITE[0.25], _HERMITE[0.75]))  # fmt: skip
    return x0, quarter, xc, three, x1


def interval_inputs(u0: Any, uc: Any, u1: Any) -> tuple:
    """The inputs at :data:`SAMPLES` of an interval, on the quadratic through knot,
    midpoint and knot (the line through the knots where the midpoint is tied to them)."""
    return (u0, 0.375 * u0 + 0.75 * uc - 0.125 * u1, uc,
            -0.125 * u0 + 0.75 * uc + 0.375 * u1, u1)  # fmt: skip


def _clearance(model: HybridModel, phase: str, v: _Unknowns, p: Any, durations: Any, k: int,
               height: float, g: _Constraints) -> None:  # fmt: skip
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


def _built(model: HybridModel, request: Request) -> _Nlp:
    """:func:`_build`, where a stop reaches the caller while it runs.

    CasADi builds the NLP (its derivatives: under stability the step map's second ones)
    in C++ for up to tens of seconds without looking at signals, though it lets go of the
    GIL; under :func:`vsw.stop.supervised` in the main thread the build runs on a daemon
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


@functools.lru_cache(maxsize=8)  # a few NLPs a command; a script's loop over targets
def _build(model: HybridModel, request: Request) -> _Nlp:
    """The collocation NLP of one model and request (parameters are the NLP's ``p``)."""
    import casadi as ca

    sequence = model._phase_sequence()
    m, count, nodes = 2 * model.n, len(sequence), request.nodes
    names = input_names(model)
    slack = prices_work(request)
    given = ca.MX.sym("p", len(model.parameter_table))
    chosen = chosen_indices(model)
    # The chosen parameters are unknowns of the NLP (its last ones), the others its p.
    choice = ca.MX.sym("chosen", len(chosen))
    p = ca.vertcat(*(choice[chosen.index(i)] if i in chosen else given[i]
                     for i in range(given.shape[0])))  # fmt: skip
    scale = ca.MX.sym("regularization_scale")
    durations = ca.MX.sym("T", count)
    unknowns = [_phase_unknowns(k, m, len(names[phase]), len(event.get("impulses", ())),
                                nodes, slack)
                for k, (phase, event) in enumerate(sequence)]  # fmt: skip
    g = _Constraints()
    squares, priced, positive, negative, step_length = 0, 0, {}, {}, None
    ground: dict = {}
    stability = request.minimize == "eigenvalue"
    monodromy = ca.DM.eye(m)
    for k, (phase, event) in enumerate(sequence):
        v = unknowns[k]
        phase_squares, phase_priced, plus, minus = _collocate(model, phase, v, p, durations[k],
                                                              request, g)  # fmt: skip
        if request.clearance is not None:
            _clearance(model, phase, v, p, durations, k, request.clearance, g)
        squares = squares + phase_squares
        priced = priced + phase_priced
        positive |= {f"{phase}.{name}": value for name, value in plus.items()}
        negative |= {f"{phase}.{name}": value for name, value in minus.items()}
        end = v.knots[-1]
        g.add(model.symbolic(f"event_{event['name']}_guard", p, end), 0.0, 0.0)
        if event["when"] is not None:
            g.add(model.symbolic(event["when"], p, end), 0.0, math.inf)
        after, event_priced, plus, minus, pushes = _event_map(model, event, p, end, v, g,
                                                              request)  # fmt: skip
        ground |= pushes
        priced = priced + event_priced
        positive |= plus
        negative |= minus
        if stability:
            monodromy = ca.mtimes(ca.mtimes(
                _event_jacobian(model, phase, event, p, v, after),
                _collocated_jacobian(model, phase, v, p, durations[k])), monodromy)  # fmt: skip
        following = unknowns[(k + 1) % count].knots[0]  # the last phase: periodicity
        g.add(following - after, 0.0, 0.0)
        if event["ends_step"] and model.spec["step_length"]:
            step_length = model.symbolic("step_length_of_state", p, end)
    if request.target_step_length is not None:
        g.add(step_length - request.target_step_length, 0.0, 0.0)
    if request.target_speed is not None:
        g.add(step_length - request.target_speed * ca.sum1(durations), 0.0, 0.0)
    if request.target_period is not None:
        g.add(ca.sum1(durations) - request.target_period, 0.0, 0.0)
    work = priced
    radius = ca.MX.sym("radius", 1 if stability else 0)
    if request.minimize == "torque2":
        cost = squares
    elif stability:  # the step map's spectral radius, at least STABILITY_MARGIN
        _stability_rows(monodromy, radius, g)
        cost = radius + request.regularization * scale * squares
    elif request.minimize == "work":
        cost = work + request.regularization * scale * squares
    else:
        if step_length is None:
            raise VswInputError(f"{model.name} defines no step length: no cost of transport")
        facts = {"energy": work, "weight": walker_weight(model, p), "step_length": step_length}
        cost = (evaluate(("cost_of_transport",), facts)["cost_of_transport"]
                + request.regularization * scale * squares)  # fmt: skip
    w, layout = _vector(durations, unknowns)
    chosen_start = int(w.shape[0])
    w = ca.vertcat(w, choice, radius)
    lbx, ubx = _variable_bounds(model, sequence, layout, int(w.shape[0]), request)
    if stability:
        lbx[-1] = STABILITY_MARGIN
    for j, i in enumerate(chosen):  # within the parameter's interval and the limits on it
        name = model.parameter_table[i].name
        low, high = _limited(_parameter_interval(model, i), request, name)
        lbx[chosen_start + j], ubx[chosen_start + j] = low, high
    options = {
        "ipopt.tol": 1e-10, "ipopt.constr_viol_tol": 1e-10, "ipopt.max_iter": 3000,
        "ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes", "error_on_fail": False,
        "show_eval_warnings": False,  # a NaN at a trial point is IPOPT's to step back from
        "ipopt.mu_strategy": "adaptive", "ipopt.acceptable_tol": 1e-6,
        "ipopt.acceptable_constr_viol_tol": 1e-9, "ipopt.acceptable_iter": 5,
    }  # fmt: skip
    if stability:
        # Where the least radius is not attained (it falls toward zero, a step that forgets
        # any perturbation) IPOPT iterates on: 500 iterations bound the wait (a minute or
        # two on 20 intervals), and the result says it did not converge.
        options["ipopt.max_iter"] = STABILITY_ITERATIONS
    arguments = ca.vertcat(given, scale)  # the regularization's scale: known after stage one
    problem = {"x": w, "p": arguments, "f": cost, "g": ca.vertcat(*g.rows)}
    solver = ca.nlpsol(f"powered_{model.name}", "ipopt", problem, options)
    works = ca.Function("work", [w, arguments], [ca.vertcat(*positive.values(),
                                                            *negative.values())
                                                 if positive else ca.DM.zeros(0)])  # fmt: skip
    pushes = ca.Function("ground", [w, arguments], [ca.vertcat(*ground.values())])
    step_map = ca.Function("monodromy", [w, arguments], [monodromy]) if stability else None
    return _Nlp(solver, ca.Function("cost", [w, arguments], [cost]), layout, works,
                int(w.shape[0]), (lbx, ubx, np.array(g.lower), np.array(g.upper)), pushes,
                tuple(ground), chosen, chosen_start, int(w.shape[0]) - 1 if stability else None,
                step_map)  # fmt: skip


def _collocated_jacobian(model: HybridModel, phase: str, v: _Unknowns, p: Any,
                         duration: Any) -> Any:  # fmt: skip
    """d(last knot)/d(first knot) of a phase's Hermite-Simpson equations with the inputs
    held as functions of the time (open loop): each interval's two equations
    differentiated, the midpoint eliminated, ``L S_{i+1} = R S_i`` with
    ``L = I - h/6 A_1 - h/3 A_c + h^2/12 A_c A_1``, ``R = I + h/6 A_0 + h/3 A_c +
    h^2/12 A_c A_0`` (``A = df/dx`` at the knots and the midpoint): the exact derivative of
    the discrete step, which tends to the flow's as the mesh refines."""
    import casadi as ca

    jacobian = _flow_jacobian_function(model, phase)
    nodes = len(v.middles)
    h = duration / nodes
    eye = ca.DM.eye(2 * model.n)
    sensitivity = eye
    for i in range(nodes):
        a0 = jacobian(p, v.knots[i], v.u_knots[i])
        a1 = jacobian(p, v.knots[i + 1], v.u_knots[i + 1])
        ac = jacobian(p, v.middles[i], v.u_middles[i])
        left = eye - h / 6 * a1 - h / 3 * ac + h * h / 12 * ca.mtimes(ac, a1)
        right = eye + h / 6 * a0 + h / 3 * ac + h * h / 12 * ca.mtimes(ac, a0)
        sensitivity = ca.solve(left, ca.mtimes(right, sensitivity))
    return sensitivity


def _event_jacobian(model: HybridModel, phase: str, event: dict, p: Any, v: _Unknowns,
                    after: Any) -> Any:  # fmt: skip
    """d(state after the event)/d(state at the phase's end) along the perturbed motion: a
    perturbation ``dx`` meets the guard ``g`` ``dt = -g_x dx / (g_x f)`` later, so the
    state there moves by ``(I - f g_x / (g_x f)) dx`` (the saltation's projection; the
    inputs are functions of the phase's time, the next phase's start at the event), then
    the event's map (reset and impulses, the impulses fixed) by its Jacobian."""
    import casadi as ca

    end = v.knots[-1]
    rate = _flow_function(model, phase)(p, end, v.u_knots[-1])
    slope = ca.jacobian(model.symbolic(f"event_{event['name']}_guard", p, end), end)
    projection = ca.DM.eye(2 * model.n) - ca.mtimes(rate, slope) / ca.mtimes(slope, rate)
    return ca.mtimes(ca.jacobian(after, end), projection)


def _stability_rows(monodromy: Any, radius: Any, g: _Constraints) -> None:
    """Every eigenvalue of the step map's Jacobian within ``radius``: Jury's conditions
    (vsw.design.jury_rows) on the characteristic polynomial of ``monodromy / radius``."""
    import casadi as ca

    count = monodromy.shape[0]
    coefficients = characteristic_coefficients(monodromy, count)
    scaled = [a / radius ** (k + 1) for k, a in enumerate(coefficients)]
    g.add(ca.vertcat(*jury_rows(scaled)), 0.0, math.inf)


def _event_map(model: HybridModel, event: dict, p: Any, end: Any, v: _Unknowns,
               g: _Constraints, request: Request | None = None
               ) -> tuple[Any, Any, dict, dict, dict]:  # fmt: skip
    """The state after an event from the phase's last knot: the impulses applied before
    the reset (the rates jump by their gains), the reset with the impulse at its impact
    (the rates after gain its gains), those applied after; the impulses' positive work as
    the cost prices it and each impulse's positive and negative work.

    Impulses applied together in proportion move each one's ``along`` rate linearly
    from ``a`` to ``b``: its power goes linearly from ``iota a`` to ``iota b``, its work
    is ``iota (a + b) / 2`` (the kinetic energy's change) and its positive work
    :func:`positive_work_of_linear_power` of those ends, more than the net work where the
    rate reverses (an impulse that stops a shortening leg, then pushes it out, puts back
    as positive work what it first absorbed). Where the cost is the work each side's
    impulses are applied in two parts, first ``f iota`` (the split ``f`` in [0, 1] free
    for each impulse), then the rest, and each part's positive work is priced by two
    slacks ``s >= 0`` at its power's ends, at their mean: exact where the part's rate
    does not reverse, above it where it does, so the least priced split is the one that
    stops each reversing rate at the parts' junction, and the price is then the exact
    positive work of that schedule (the ledger's, which has the exact positive work of the
    split found, and the reported cost). The impulse applied with an impact does the work
    ``c iota^2 / 2``, never negative.

    Last, the ground's impulses on the walker over the event (its momentum's change):
    through the stance foot (the impulses before an impact's reset; a lock's impulse,
    which the foot takes too) and through the new foot (an impact, with what acts after
    it, and the stance foot's share of an impulse applied with the impact). At an impact,
    and at a change of phase where impulses act (a push at a chosen angle, through the
    stance foot), each must push (its normal part ``>= 0``: a constraint), within the
    friction cone of ``request.friction`` where it has one; a lock's is only reported
    (stopping a leg that lengthens pulls the foot: the instantaneous extension's
    idealisation, which the VSW biped shares) unless ``request.pushing_locks``."""
    import casadi as ca

    groups = impulse_names(model, event)
    n = model.n
    plus: dict = {}
    minus: dict = {}
    priced = 0
    x = end
    iota = v.impulses[0] if v.impulses else None
    splits = v.splits[0] if v.splits and v.splits[0].shape[0] else None
    offset = 0
    momentum_before = _momentum_function(model, event["source"])
    ground = {}
    for side, names in zip(("before", "with", "after"), groups):
        stem = f"event_{event['name']}_impulse"
        j = iota[offset : offset + len(names)] if names else None
        if side == "with":  # the reset, and the impulse applied with its impact
            if groups[0]:  # the impulses before, through the stance foot
                ground["stance_foot"] = momentum_before(p, x) - momentum_before(p, end)
            reset_from = x
            reset = model.symbolic(f"event_{event['name']}_reset", p, x)
            if names:
                gains = model.symbolic(f"{stem}_gains_with", p, x)
                work = model.symbolic(f"{stem}_work_with", p, x) * j * j / 2
                parts = [(work, work)]
                reset = ca.vertcat(reset[:n], reset[n:] + gains * j)
            x = reset
        elif names:
            gains = ca.reshape(model.symbolic(f"{stem}_gains_{side}", p, x), len(names), n).T
            rates = functools.partial(model.symbolic, f"{stem}_rates_{side}", p)
            first = j if splits is None else splits[offset : offset + len(names)] * j
            middle = ca.vertcat(x[:n], x[n:] + ca.mtimes(gains, first))
            jumped = ca.vertcat(x[:n], x[n:] + ca.mtimes(gains, j))
            parts = [(first * rates(x), first * rates(middle))]
            if splits is not None:
                parts.append(((j - first) * rates(middle), (j - first) * rates(jumped)))
            x = jumped
        if not names:
            continue
        work = sum((a + b) / 2 for a, b in parts)
        positive_work = sum(positive_work_of_linear_power(a, b, ca) for a, b in parts)
        if v.s_impulses and v.s_impulses[0].shape[0]:
            count = len(names)
            slacks = v.s_impulses[0][4 * offset : 4 * (offset + count)]
            ends = ca.vertcat(*(end for part in parts for end in part))
            g.add(slacks[: ends.shape[0]] - ends, 0.0, math.inf)
            priced = priced + ca.sum1(slacks[: ends.shape[0]]) / 2
        else:
            priced = priced + ca.sum1(positive_work)
        for i, name in enumerate(names):
            plus[f"{event['name']}.{name}"] = positive_work[i]
            minus[f"{event['name']}.{name}"] = work[i] - positive_work[i]
        offset += len(names)
    # The reset and what follows it: through the new foot at an impact (with the stance
    # foot's share of an impulse at the impact), through the stance foot at a lock.
    key = "new_foot" if event["reset"] == "impact" else "stance_foot"
    change = _momentum_function(model, event["target"])(p, x) - momentum_before(p, reset_from)
    ground[key] = change + ground.get(key, 0)
    # A foot is pushed, never pulled, by the ground: at an impact, at a change of phase
    # where the actuators act in an instant (a push at a chosen angle), and at a lock where
    # asked.
    acting = event["reset"] == "continuous" and _usable(request, [*groups[0], *groups[2]])
    pushing = (event["reset"] == "impact" or acting
               or (request is not None and request.pushing_locks))  # fmt: skip
    friction = None if request is None else request.friction
    if pushing:
        for foot, impulse in ground.items():
            if foot == "stance_foot" and key != foot and not _usable(request, groups[0]):
                continue  # the impulses before are held at zero: no impulse, no row
            g.add(impulse[1], 0.0, math.inf)
            if friction is not None and (event["reset"] == "impact" or acting):
                g.add(friction * impulse[1] - impulse[0], 0.0, math.inf)
                g.add(friction * impulse[1] + impulse[0], 0.0, math.inf)
    return x, priced, plus, minus, {f"{event['name']}.{k}": i for k, i in ground.items()}


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


def _usable(request: Request | None, names: Sequence[str]) -> bool:
    """Whether the optimiser may use any of these impulses (``torque2`` and ``eigenvalue``
    hold them all at zero, ``use`` those it does not name)."""
    if request is None:
        return bool(names)
    if not prices_work(request):
        return False
    return any(not request.use or name in request.use for name in names)


@functools.cache
def _momentum_function(model: HybridModel, phase: str) -> Any:
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
def _reaction_function(model: HybridModel, phase: str) -> Any:
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
    rate = ca.mtimes(ca.jacobian(momentum, x), _flow_function(model, phase)(p, x, u))
    index = model.slope_index()
    slope = 0 if index is None else p[index]
    weight = walker_weight(model, p)
    gravity = weight * ca.vertcat(ca.sin(slope), -ca.cos(slope))
    return ca.Function(f"reaction_{phase}", [p, x, u], [rate - gravity])


def positive_work_of_linear_power(before: Any, after: Any, backend: Any = np) -> Any:
    """The positive work of a power that goes linearly from ``before`` to ``after`` over a
    unit interval, ``integral of max(P, 0)``: their mean where neither is negative,
    ``hi^2 / (2 (hi - lo))`` where they differ in sign (the part past the zero crossing), 0
    where neither is positive. ``backend`` is numpy or casadi (elementwise)."""
    if backend is np:
        hi, lo = np.maximum(before, after), np.minimum(before, after)
        crossing = np.maximum(hi, 0.0) ** 2 / (2 * np.where(lo < 0, hi - lo, 1.0))
        return np.where(lo >= 0, (hi + lo) / 2, crossing)
    hi, lo = backend.fmax(before, after), backend.fmin(before, after)
    crossing = backend.fmax(hi, 0) ** 2 / (2 * backend.if_else(lo < 0, hi - lo, 1))
    return backend.if_else(lo >= 0, (hi + lo) / 2, crossing)


def _ground_impulses(nlp: _Nlp, w: np.ndarray, arguments: np.ndarray
                     ) -> dict[str, tuple[float, float]]:  # fmt: skip
    values = np.array(nlp.ground(w, arguments), dtype=float).reshape(-1, 2)
    return {key: (float(t), float(n)) for key, (t, n) in zip(nlp.ground_keys, values)}


def _vector(durations: Any, unknowns: list[_Unknowns]) -> tuple[Any, list[dict]]:
    """The unknowns as one vector (durations first, then each phase's blocks) and, per
    phase, each block's (offset, count, width)."""
    import casadi as ca

    parts, layout, offset = [durations], [], durations.shape[0]
    for v in unknowns:
        entry = {}
        for key in _Unknowns.KEYS:
            block = getattr(v, key)
            width = block[0].shape[0] if block else 0
            entry[key] = (offset, len(block), width)
            offset += len(block) * width
            parts += block
        layout.append(entry)
    return ca.vertcat(*parts), layout


def _variable_bounds(model: HybridModel, sequence: list, layout: list[dict], size: int,
                     request: Request) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Durations >= 1e-3 (a phase of no duration is no step), slacks >= 0, each input and
    impulse within its declared bounds and the request's limits, each impulse's split in
    [0, 1] (0 where it has one part); impulses zero when the cost is the squared inputs'
    integral or the stability (which do not price them: they would be free)."""
    lbx, ubx = np.full(size, -np.inf), np.full(size, np.inf)
    lbx[: len(sequence)] = 1e-3
    for (phase, event), entry in zip(sequence, layout):
        for key in ("s_intervals", "s_impulses"):
            first, parts, width = entry[key]
            lbx[first : first + parts * width] = 0.0
        first, _, width = entry["impulses"]
        split, _, split_width = entry["splits"]
        slacks = entry["s_impulses"][0]
        records = {i["name"]: i for i in event.get("impulses", ())}
        for j, name in enumerate(ordered_impulses(model, event)):
            low, high = _limited(records[name]["bounds"], request, name)
            if not prices_work(request) or (request.use and name not in request.use):
                low, high = 0.0, 0.0
            lbx[first + j] = -np.inf if low is None else low
            ubx[first + j] = np.inf if high is None else high
            if split_width:  # a split and slacks where there are two parts
                whole = records[name]["applied"] == "with" or low == high == 0.0
                lbx[split + j], ubx[split + j] = 0.0, 0.0 if whole else 1.0
                if records[name]["applied"] == "with":
                    ubx[slacks + 4 * j + 2 : slacks + 4 * j + 4] = 0.0
        bounds = [(0.0, 0.0) if request.use and i["name"] not in request.use
                  else _limited(i["bounds"], request, i["name"])
                  for i in model.phases[model.phase_index[phase]].get("inputs", ())]  # fmt: skip
        for key in ("u_knots", "u_middles"):
            first, parts, width = entry[key]
            for j, (low, high) in enumerate(bounds):
                lbx[first + j : first + parts * width : width] = -np.inf if low is None else low
                ubx[first + j : first + parts * width : width] = np.inf if high is None else high
    return lbx, ubx


def _spectral_radius(jacobian: np.ndarray) -> float:
    """The largest eigenvalue's modulus (inf where the matrix is not finite)."""
    if not np.all(np.isfinite(jacobian)):
        return math.inf
    return float(np.max(np.abs(np.linalg.eigvals(jacobian))))


@functools.cache
def _flow_jacobian_function(model: HybridModel, phase: str) -> Any:
    """(p, x, u) -> d(x')/dx with the phase's inputs held."""
    import casadi as ca

    flow = _flow_function(model, phase)
    p, x, u = (ca.SX.sym(name, *flow.size_in(i)) for i, name in enumerate("pxu"))
    return ca.Function(f"flow_jacobian_{phase}", [p, x, u], [ca.jacobian(flow(p, x, u), x)])


@functools.cache
def _flow_function(model: HybridModel, phase: str) -> Any:
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
def _input_rate_function(model: HybridModel, phase: str) -> Any:
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    return ca.Function(f"rates_{phase}", [p, x], [model.symbolic(f"{phase}_input_rates", p, x)])


@functools.cache
def _margin_functions(model: HybridModel, phase: str) -> list[tuple[Any, int]]:
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


def _initial_guess(model: HybridModel, params: Sequence[float], start: Orbit, nlp: _Nlp,
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


def _kinematic_guess(model: HybridModel, params: Sequence[float], nlp: _Nlp,
                     request: Request) -> np.ndarray:  # fmt: skip
    """A start where no passive gait is: the centre of the search box on the section (the
    state just after the step event, completed by the section), the coordinates moving at
    its constant rates until the step event's guard crosses, inputs and impulses zero; the
    rates scaled to the target period, or the target speed's duration, when there is one.
    Not a motion of the walker (it ignores gravity and the inputs): IPOPT makes it one.
    More than one phase a step: :func:`_phased_guess`."""
    sequence = model._phase_sequence()
    p = np.asarray(params, dtype=float)
    centre = np.array([[sum(model.spec["search"][k]) / 2 for k in free_components(model)]])
    x0 = section_states(model, p, centre)[0]
    if len(sequence) != 1:
        return _phased_guess(model, p, nlp, request, x0)
    ((_phase, event),) = sequence
    n = model.n
    guard = model._fn(f"event_{event['name']}_guard")

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


def _sampled_guess(nlp: _Nlp, nodes: int, duration: float, state_at) -> np.ndarray:
    """One phase's unknowns from ``state_at(fraction of the phase)`` at its knots and
    midpoints, its duration, inputs and impulses zero."""
    return _sampled_phases(nlp, nodes, [duration], [state_at])


def _sampled_phases(nlp: _Nlp, nodes: int, durations: Sequence[float],
                    states_at: Sequence) -> np.ndarray:  # fmt: skip
    """Each phase's unknowns from its ``state_at(fraction of the phase)`` at its knots and
    midpoints, the durations, inputs and impulses zero."""
    w = np.zeros(nlp.size)
    w[: len(durations)] = durations
    for entry, state_at in zip(nlp.layout, states_at):
        for key, fractions in (("knots", np.arange(nodes + 1) / nodes),
                               ("middles", (np.arange(nodes) + 0.5) / nodes)):  # fmt: skip
            first, parts, width = entry[key]
            block = np.array([state_at(f) for f in fractions])
            w[first : first + parts * width] = block.reshape(-1)
    return w


def _phased_guess(model: HybridModel, p: np.ndarray, nlp: _Nlp, request: Request,
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
    sequence = model._phase_sequence()
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
        guard = model._fn(f"event_{event['name']}_guard")
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
    guard = model._fn(f"event_{event['name']}_guard")
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


def _swapped_guess(model: HybridModel, p: np.ndarray, nlp: _Nlp, request: Request,
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


def _transfer(model: HybridModel, params: Sequence[float], source: _Nlp, w: np.ndarray,
              target: _Nlp) -> np.ndarray:  # fmt: skip
    """``w`` of ``source`` as a start for ``target`` (same mesh): durations, states and
    inputs copied, the positive-work slacks filled (:func:`_fill_slacks`)."""
    out = np.zeros(target.size)
    count = len(source.layout)
    out[:count] = w[:count]
    target.choose(source.parameters(params, w), out)
    for have, want in zip(source.layout, target.layout):
        for key in ("knots", "middles", "u_knots", "u_middles", "impulses"):
            first, parts, width = have[key]
            start = want[key][0]
            out[start : start + parts * width] = w[first : first + parts * width]
    _fill_slacks(model, params, target, out)
    target.start_radius(params, out)
    return out


def _refine(model: HybridModel, params: Sequence[float], coarse: _Nlp, w: np.ndarray,
            fine: _Nlp) -> np.ndarray:  # fmt: skip
    """``w`` on N intervals as a start on 2N: the coarse knots and midpoints are the fine
    knots, the fine midpoints halfway between them; the inputs from the coarse quadratics
    (exact at the quarter points); the slacks filled (:func:`_fill_slacks`)."""
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
            k, c = _block(w, have[knots]), _block(w, have[middles])
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
    _fill_slacks(model, params, fine, out)
    fine.start_radius(params, out)
    return out


def _fill_slacks(model: HybridModel, params: Sequence[float], nlp: _Nlp, w: np.ndarray) -> None:
    """Each interval's positive-work slack of ``w`` at the least its constraints allow (its
    Bernstein coefficients at ``max(b, 0)`` of the power's); each impulse's split where it
    stops a reversing rate (:func:`_stopping_splits`) and its slacks at ``max(P, 0)`` of
    its parts' power ends (in place)."""
    p = nlp.parameters(params, w)
    for k, ((phase, event), entry) in enumerate(zip(model._phase_sequence(), nlp.layout)):
        first, parts, width = entry["s_impulses"]
        if width:
            iota = _block(w, entry["impulses"])[0]
            end = _block(w, entry["knots"])[-1]
            splits = _stopping_splits(model, event, p, end, iota)
            start = entry["splits"][0]
            w[start : start + len(splits)] = splits
            ends = _apply_impulses(model, event, p, end, iota, splits)[2]
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
    flow, rates = _flow_function(model, phase), _input_rate_function(model, phase)
    x, xc = _block(w, entry["knots"]), _block(w, entry["middles"])
    u, uc = _block(w, entry["u_knots"]), _block(w, entry["u_middles"])
    h = duration / len(xc)
    powers = []
    for i in range(len(xc)):
        steps = (h * np.array(flow(p, x[j], u[j]), float).reshape(-1) for j in (i, i + 1))
        states = interval_states(x[i], xc[i], x[i + 1], *steps)
        inputs = interval_inputs(u[i], uc[i], u[i + 1])
        powers.append([ui * np.array(rates(p, xi), float).reshape(-1)
                       for xi, ui in zip(states, inputs)])  # fmt: skip
    return np.array(powers).transpose(0, 2, 1)


def _check_finite_start(model: HybridModel, nlp: _Nlp, guess: np.ndarray,
                        arguments: np.ndarray) -> None:  # fmt: skip
    """IPOPT is not started from a point where the NLP's cost or constraints are not
    finite: it would report a NaN at every trial point and wander to its iteration limit
    (or fail in restoration); the run ends at once with the reason."""
    with np.errstate(all="ignore"), _solver_output_dropped():
        values = nlp.solver.oracle().call({"x": guess, "p": arguments})
    for name, what in (("f", "cost"), ("g", "constraints")):
        value = np.array(values[name], dtype=float).reshape(-1)
        bad = np.flatnonzero(~np.isfinite(value))
        if len(bad):
            where = f" (row {bad[0]} of {len(value)})" if len(value) > 1 else ""
            raise ConvergenceError(f"{model.name}: the NLP's {what} are not finite at its "
                                   f"start{where}: the targets or parameters are beyond what "
                                   "this model's step can be; IPOPT was not started")  # fmt: skip


@contextlib.contextmanager
def _solver_output_dropped():
    """CasADi's and IPOPT's own messages through Python's streams (warnings of an
    evaluation, ``KeyboardInterruptException`` when a stop lands in IPOPT) go nowhere:
    what the user reads is the run's one line (the status and its reason, or the stop)."""
    sink = io.StringIO()
    with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
        yield


def _block(w: np.ndarray, entry: tuple[int, int, int]) -> np.ndarray:
    first, parts, width = entry
    return w[first : first + parts * width].reshape(parts, width)


def _solve(model: HybridModel, params: Sequence[float], request: Request, nlp: _Nlp,
           guess: np.ndarray, regularization_scale: float = 1.0) -> PoweredGait:  # fmt: skip
    lbx, ubx, lbg, ubg = nlp.bounds
    if nlp.chosen and not prices_work(request):
        # The squared inputs' integral and the stability price no impulse (they are held at
        # zero), so not where one acts either: the chosen parameters stay at their values.
        lbx, ubx = lbx.copy(), ubx.copy()
        nlp.choose(params, lbx)
        nlp.choose(params, ubx)
    arguments = np.append(np.asarray(params, dtype=float), regularization_scale)
    _check_finite_start(model, nlp, guess, arguments)
    try:
        with _solver_output_dropped():
            result = nlp.solver(x0=guess, p=arguments, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
    except RuntimeError as exc:  # a NaN in the model's functions at IPOPT's trial point
        stop.check()  # or CasADi turned Ctrl-C or the time limit into this error
        raise ConvergenceError(f"{model.name}: IPOPT failed ({' '.join(str(exc).split())[:80]})"
                               ) from None  # fmt: skip
    stop.check()  # IPOPT stopped by Ctrl-C or the time limit is no solution
    stats = nlp.solver.stats()
    status = str(stats.get("return_status", "unknown"))
    w = np.array(result["x"], dtype=float).reshape(-1)
    p = nlp.parameters(params, w)
    sequence = model._phase_sequence()
    durations = tuple(float(v) for v in w[: len(sequence)])
    times, states, inputs, input_times = [], [], [], []
    nodes = request.nodes
    for k, entry in enumerate(nlp.layout):
        t0 = sum(durations[:k])
        states.append(_block(w, entry["knots"]))
        times.append(t0 + durations[k] * np.arange(nodes + 1) / nodes)
        at_knots, at_middles = _block(w, entry["u_knots"]), _block(w, entry["u_middles"])
        merged = np.empty((2 * nodes + 1, at_knots.shape[1]))
        merged[0::2], merged[1::2] = at_knots, at_middles
        inputs.append(merged)
        input_times.append(t0 + durations[k] * np.arange(2 * nodes + 1) / (2 * nodes))
    work_values = np.array(nlp.work(w, arguments), dtype=float).reshape(-1)
    keys, impulses = [], {}
    for (phase, event), entry in zip(sequence, nlp.layout):  # the order of _build's ledger
        keys += [f"{phase}.{name}" for name in input_names(model)[phase]]
        names = [f"{event['name']}.{name}" for name in ordered_impulses(model, event)]
        keys += names
        impulses |= dict(zip(names, (float(v) for v in _block(w, entry["impulses"])[0])))
    work = {key: {"positive": float(work_values[j]), "negative": float(work_values[len(keys) + j])}
            for j, key in enumerate(keys)}  # fmt: skip
    along = {} if prices_work(request) else None
    error, guard, resimulated = _resimulate(model, p, durations, states, inputs, along)
    moved = None  # the positive work along the re-simulated motion, the impulses' as the mesh's
    if along is not None:
        moved = sum(v["positive"] for v in along.values()) + sum(
            v["positive"] for key, v in work.items() if key not in along
        )
    g = np.array(result["g"], dtype=float).reshape(-1)
    violation = float(max(np.max(lbg - g, initial=0.0), np.max(g - ubg, initial=0.0),
                          np.max(lbx - w, initial=0.0), np.max(w - ubx, initial=0.0)))  # fmt: skip
    step_length = None
    if model.spec["step_length"]:
        step_length = float(model.step_length(p, states[-1][-1]))
    period = sum(durations)
    scale = max(1.0, float(max(np.max(np.abs(s)) for s in states)))
    reason = ""
    if status == _INFEASIBLE:
        reason = (f"IPOPT found the constraints locally infeasible (violated by {violation:.3g} "
                  "where it stopped): no gait meets the targets, bounds and parameters near "
                  "this start; a local result, not a proof")  # fmt: skip
    elif status == "Invalid_Number_Detected":
        reason = ("IPOPT stopped: the NLP evaluated to NaN or inf at its iterate (the targets "
                  "or parameters beyond what this model's step can be?)")  # fmt: skip
    elif status not in _SUCCESS:
        reason = f"IPOPT {status}"
    elif not violation <= CONSTRAINTS_HELD:
        reason = f"IPOPT's point violates a constraint by {violation:.3g}"
    elif resimulated:
        reason = f"the re-simulation {resimulated}"
    elif not error <= RESIMULATION_AGREES:
        reason = f"the re-simulation ends {error:.3g} from the last knot (relative)"
    elif moved is not None and not _works_agree(
        moved,
        mesh := sum(v["positive"] for v in work.values()),
        walker_weight(model, p) * (step_length or 1.0),
    ):
        reason = (f"the positive work along the re-simulated step, {moved:.6g}, is not the "
                  f"mesh's, {mesh:.6g}: the mesh does not resolve the power")  # fmt: skip
    objective = float(nlp.cost(w, arguments))
    named, radius = objective, {}
    if nlp.radius is not None:  # the cost is the radius measured, the unknown beside it
        jacobian = nlp.step_jacobian(params, w)
        named = _spectral_radius(jacobian)
        radius = {"radius_unknown": float(w[nlp.radius]), "step_jacobian": jacobian}
        if not reason and w[nlp.radius] <= STABILITY_MARGIN * (1 + 1e-6):
            reason = (f"the radius reached its floor, {STABILITY_MARGIN:g}: the least is below "
                      "it (not attained at the floor)")  # fmt: skip
    return PoweredGait(
        status="infeasible" if status == _INFEASIBLE else "not-converged" if reason else "optimal",
        reason=reason,
        cost=_named_cost(model, p, request, work, step_length, named),
        durations=durations,
        times=times,
        states=states,
        inputs=inputs,
        input_times=input_times,
        work=work,
        step_length=step_length,
        speed=None if step_length is None else step_length / period,
        resimulation_error=error,
        guard_at_end=guard,
        ipopt_status=status,
        iterations=int(stats.get("iter_count", -1)),
        impulses=impulses,
        ground_impulses=_ground_impulses(nlp, w, arguments),
        parameters=tuple(float(v) for v in p),
        extra={
            "resimulated_work": moved,
            "state_scale": scale,
            "w": w,
            "constraint_violation": violation,
            "objective": objective,
            **radius,
            "regularization_scale": regularization_scale,
        },
    )


def _works_agree(moved: float, mesh: float, scale: float) -> bool:
    """The work along the re-simulated step and the mesh's agree within the mesh's
    tolerance (:data:`MESH_AGREES` of the larger, or 1e-9 of the weight times the step)."""
    return abs(moved - mesh) <= max(MESH_AGREES * max(abs(moved), abs(mesh)), 1e-9 * scale)


def _named_cost(model: HybridModel, p: np.ndarray, request: Request, work: dict,
                step_length: float | None, unpriced: float) -> float:  # fmt: skip
    """The cost the request names, without the regularization the NLP adds to it: for the
    costs that price no work, ``unpriced`` (the squared inputs' integral, the NLP's
    objective; the spectral radius of the collocated step map, measured); else the positive
    work, or that work per weight and step length."""
    if not prices_work(request):
        return unpriced
    positive = sum(w["positive"] for w in work.values())
    facts = {"actuator_work": positive, "energy": positive, "step_length": step_length,
             "weight": walker_weight(model, p)}  # fmt: skip
    return evaluate((request.minimize,), facts)[request.minimize]


def canonical_cost(name: str) -> str:
    """A cost's name as :mod:`vsw.quantities` spells it (``cot`` -> ``cost_of_transport``,
    ``stability`` -> ``eigenvalue``); a name no cost has is kept for :meth:`Request.check`
    to refuse."""
    try:
        return resolve(name, "optimize")[0].name
    except VswInputError:
        return name


def _resimulate(
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
    for (phase, event), duration, knots, u in zip(model._phase_sequence(), durations, states,
                                                  inputs):  # fmt: skip
        control = _control(u, duration)
        watched = _watchers(model, phase, event, p, control)
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
        guard = float(model._fn(f"event_{event['name']}_guard")(*p, *end))
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
    rates = _input_rate_function(model, phase)
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
    flow = _flow_function(model, phase)

    def rhs(t: float, x: np.ndarray) -> np.ndarray:
        return np.array(flow(p, x, control(t)), dtype=float).reshape(-1)

    return rhs


def _watchers(model: HybridModel, phase: str, event: dict, p: np.ndarray, control) -> list:
    """(name, SciPy event function) of a phase's event guard and of each failure (its guard
    with the inputs' share), non-terminal, in their directions."""
    guard_fn = model._fn(f"event_{event['name']}_guard")

    def guard(t: float, x: np.ndarray) -> float:
        return float(guard_fn(*p, *x))

    guard.direction = event["direction"]
    out = [(event["name"], guard)]
    failures = model.phases[model.phase_index[phase]]["failures"]
    for (name, _, direction), (margin, _) in zip(failures, _margin_functions(model, phase)):
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
    return event["when"] is None or float(model._fn(event["when"])(*p, *x)) > 0


def _control(inputs: np.ndarray, duration: float):
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


def _apply_impulses(model: HybridModel, event: dict, p: np.ndarray, state: np.ndarray,
                    iota: np.ndarray, splits: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """The state after an event (its impulses before the reset, the reset with the impulse
    at its impact, those after) from the state before it, each impulse's work and, with
    ``splits`` (each impulse applied in two parts, :func:`_event_map`), the ends of each
    part's power in the order of the NLP's impulse slacks (four an impulse, zero where
    unused): numpy's side of :func:`_event_map`."""
    n = model.n
    x = np.asarray(state, dtype=float)
    iota = np.asarray(iota, dtype=float)
    fractions = np.ones(len(iota)) if splits is None else np.asarray(splits, dtype=float)
    works, ends = [], []
    offset = 0
    for side, names in zip(("before", "with", "after"), impulse_names(model, event)):
        stem = f"event_{event['name']}_impulse"
        count = len(names)
        j = iota[offset : offset + count]
        if side == "with":
            reset = np.array(model._fn(f"event_{event['name']}_reset")(*p, *x), dtype=float)
            if names:
                gains = np.array(model._fn(f"{stem}_gains_with")(*p, *x), dtype=float)
                work = float(model._fn(f"{stem}_work_with")(*p, *x)) * j * j / 2
                works += list(work)
                ends += [*work, *work, *np.zeros(2 * count)]
                reset[n:] += gains.reshape(n) * j[0]
            x = reset
        elif names:
            gains = np.array(model._fn(f"{stem}_gains_{side}")(*p, *x), dtype=float)
            gains = gains.reshape(n, count)
            rates = model._fn(f"{stem}_rates_{side}")
            first = fractions[offset : offset + count] * j
            middle, jumped = x.copy(), x.copy()
            middle[n:] += gains @ first
            jumped[n:] += gains @ j
            at = [np.array(rates(*p, *y), float).reshape(-1) for y in (x, middle, jumped)]
            parts = [first * at[0], first * at[1], (j - first) * at[1], (j - first) * at[2]]
            works += list((parts[0] + parts[1] + parts[2] + parts[3]) / 2)
            ends += [value for part in parts for value in part]
            x = jumped
        offset += count
    return x, np.array(works), np.array(ends, dtype=float)


def _stopping_splits(model: HybridModel, event: dict, p: np.ndarray, state: np.ndarray,
                     iota: np.ndarray) -> np.ndarray:  # fmt: skip
    """A start for each impulse's split (:func:`_event_map`): where its rate reverses
    (applied whole, with the others in proportion), the fraction that stops it; else 1/2."""
    _x, _works, ends = _apply_impulses(model, event, p, state, iota)
    splits = np.full(len(iota), 0.5)
    offset = 0
    for side, names in zip(("before", "with", "after"), impulse_names(model, event)):
        count = len(names)
        block = ends[4 * offset : 4 * (offset + count)].reshape(4, count)
        if side != "with":
            before, after = block[0], block[1]  # the whole impulse as the first part
            reverses = before * after < 0
            fraction = np.divide(before, before - after, out=np.full(count, 0.5),
                                 where=reverses)  # fmt: skip
            splits[offset : offset + count] = np.clip(fraction, 0.0, 1.0)
        offset += count
    return splits


def powered_step(model: HybridModel, params: Sequence[float], gait: PoweredGait,
                 state: np.ndarray) -> np.ndarray:  # fmt: skip
    """One step from ``state`` with the gait's inputs as functions of the time since each
    phase began (open loop; past the planned end the last interval's quadratic continued:
    :func:`_control`), each phase
    ended by the first crossing of its event's guard that counts (its ``when``, as the
    runtime has it; SciPy DOP853, 1e-11; :func:`integrate_phase`): the powered walker's
    Poincare map. The gait's own parameters (:func:`gait_parameters`) are used."""
    p = gait_parameters(model, gait, params)
    x = np.array(state, dtype=float)
    for (phase, event), duration, u in zip(model._phase_sequence(), gait.durations, gait.inputs):
        control = _control(u, duration)
        (_, guard), *_ = _watchers(model, phase, event, p, control)
        _solution, end = integrate_phase(model, phase, event, p, control, x, duration,
                                         gait.period, [guard])  # fmt: skip
        if end is None:
            raise ConvergenceError(
                f"{model.name}: the powered step from a perturbed state meets no "
                f"{event['name']} within twice its duration and a step more"
            )
        iota = [gait.impulses[f"{event['name']}.{name}"]
                for name in ordered_impulses(model, event)]  # fmt: skip
        x = _apply_impulses(model, event, p, end[1], np.array(iota))[0]
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
                          x: np.ndarray) -> np.ndarray:  # fmt: skip
    """The Jacobian of :func:`powered_step` at ``x``: central differences, 1e-6 of
    max(1, |x_j|)."""
    jacobian = np.empty((x.size, x.size))
    for j in range(x.size):
        h = 1e-6 * max(1.0, abs(x[j]))
        up, down = x.copy(), x.copy()
        up[j] += h
        down[j] -= h
        jacobian[:, j] = (powered_step(model, params, gait, up)
                          - powered_step(model, params, gait, down)) / (2 * h)  # fmt: skip
    return jacobian


def powered_eigenvalues(model: HybridModel, params: Sequence[float],
                        gait: PoweredGait) -> list[complex]:  # fmt: skip
    """Eigenvalues of the powered step's Poincare map at the gait (central differences,
    1e-6 of max(1, |x|), of :func:`powered_step`), by modulus: the open-loop gait is stable
    when all lie inside the unit circle (a reset onto the section gives structural zeros)."""
    values = np.linalg.eigvals(powered_step_jacobian(model, params, gait, gait.states[0][0]))
    return sorted((complex(v) for v in values), key=lambda v: -abs(v))
