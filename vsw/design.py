"""Gait design for every model: IPOPT on the periodic orbit itself.

The question of :mod:`vsw.models.ile.design` (which parameters give the gait a user wants)
for any model of the generic runtime, whose gaits have no closed form. The gait is part of
the unknowns of one nonlinear program, solved by IPOPT through CasADi:

Transcription: multiple shooting
--------------------------------
Each phase of a step is cut into :data:`SEGMENTS` segments of equal length ``T_k / S``,
``T_k`` the phase's duration (an unknown, > 0). The unknowns are the free parameters, the
state at the start of every segment and the durations. Each segment is integrated by
CVODES (the generated accelerations, tolerance :data:`INTEGRATOR_TOL`); the constraints are
the segments' continuity, each phase's event guard at its end (= 0) and the event's
``when`` (>= 0: the crossing counts), the resets between phases and periodicity (the state
after the step event equals the first node). Multiple shooting rather than collocation:
the dynamics are integrated to 1e-10 with error control, so the optimum's gait is the
runtime's gait (confirmed below by :meth:`vsw.hybrid.HybridModel.periodic_orbit` and a
simulated step) without choosing or refining a mesh, and the segments' nodes carry the
path conditions. A control input held per segment (the powered-walking issue) fits the same
transcription. Derivatives are exact (CVODES forward sensitivities); the Hessian of the
Lagrangian is IPOPT's limited-memory quasi-Newton, because exact second derivatives through
CVODES cost several times the first and IPOPT converges here in tens of iterations.

Conditions: each failure of a phase (falling back, falling forward, the stance foot lifting
off, ...) as ``-direction * guard >= margin`` at every node and at each phase's end;
between nodes the verifying simulation checks them (:func:`vsw.conditions.gait_conditions`).

Stability without a non-smooth spectral radius
----------------------------------------------
The monodromy matrix ``M`` (the Poincaré map's Jacobian) is built in the NLP from the
variational equations (integrated beside the state, so their derivatives need only first
sensitivities), each phase's saltation at its guard and the reset's Jacobian. ``max |λ|``
is not differentiable where two eigenvalues meet; instead "every eigenvalue lies in the
disc of radius ρ" is imposed as the Jury (Schur–Cohn) inequalities on the characteristic
polynomial of ``M / ρ``, polynomials in its coefficients (Newton's identities on traces of
powers of ``M``) and so smooth everywhere. ``--max-eigenvalue E`` fixes ``ρ = E``;
``--minimize eigenvalue`` makes ``ρ`` an unknown and minimises it (the epigraph form: at the
optimum the inequality of the eigenvalue(s) of largest modulus is active, whichever they
are). The polynomial keeps the model's nontrivial eigenvalues only: a reset onto a lower
dimensional set makes ``M`` singular (the simplest walker's 4x4 map has rank 2), its
structural zero eigenvalues would only scale the Jury rows badly. The count is the largest
over the starts' gaits (eigenvalues above 1e-7 of the largest).

Starts, verification and statuses
---------------------------------
The starts are the gaits the runtime's gait search finds at the parameters the request
starts from (defaults, fixes, clipped into the bounds). A solve counts only when IPOPT
reports success and the periodic-orbit solver, from IPOPT's point, confirms the gait by
simulation and every request holds on it: targets, bounds, the eigenvalue bound, every
condition's margin along the simulated step. The best verified solve wins. ``optimal``: a
verified local optimum away from every open limit. ``not-attained``: it presses against an
open limit (a parameter's open interval, kept :func:`open_distance` away, or a strict
condition margin, kept :data:`STRICT_MARGIN` above zero): the model's supremum is not a
gait. ``infeasible``: a target outside the range the same starts reach (the extreme of that
quantity designed under the other constraints), said with the extreme; ``not-converged``:
no verified design and no such proof.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsw import conditions, stop
from vsw.errors import ConvergenceError, VswInputError
from vsw.hybrid import HybridModel, Orbit
from vsw.quantities import QUANTITIES, kinetic_energy, maximised, objective_names, report
from vsw.quantities import weight as walker_weight

__all__ = [
    "DESIGN_QUANTITIES",
    "MAXIMISED",
    "MINIMISED",
    "SEGMENTS",
    "STATUSES",
    "DesignRequest",
    "GaitDesign",
    "design",
    "jury_rows",
    "open_distance",
]

SEGMENTS = 4
"""Shooting segments per phase."""

INTEGRATOR_TOL = 1e-10
"""CVODES' relative and absolute tolerance inside the NLP (the verification re-solves the
orbit at 1e-13)."""

STRICT_MARGIN = 1e-4
"""A condition that must hold strictly (a failure's margin > 0) is imposed as
``margin >= STRICT_MARGIN`` in the failure guard's unit."""

CLOSED_FAILURES = ("lift-off",)
"""Failures whose margin may reach zero: a normal force of exactly zero keeps the foot on
the ground. Imposed as ``>= CLOSED_MARGIN`` (the ILE's closed forms keep 1e-9; here the
nodes are integrated to 1e-10 and the verifying orbit is re-solved at 1e-13, so a margin
of 1e-9 can turn negative between the two)."""

CLOSED_MARGIN = 1e-7

MIN_DURATION = 1e-6
"""Lower bound of a phase duration (time units): a phase of zero length is no phase."""

MAX_ITERATIONS = 60
"""IPOPT's iterations per start: the starts that converge here take 5-55; one that runs
longer has wandered into a region of no gait, where every iteration integrates slowly."""

TARGET_TOL = 1e-6
"""Relative tolerance of a target on the verified gait."""

STATUSES = ("optimal", "not-attained", "infeasible", "not-converged")

MAXIMISED = tuple(q.name for q in QUANTITIES.values()
                  if "design" in q.commands and q.sense == "max")  # fmt: skip
MINIMISED = tuple(q.name for q in QUANTITIES.values()
                  if "design" in q.commands and q.sense == "min")  # fmt: skip
"""The objectives of a design (:mod:`vsw.quantities`), by their sense."""
DESIGN_QUANTITIES = ("speed", "step_length", "step_frequency", "period")
"""Quantities a target or a bound may name (each in the model's units)."""

_SUCCESS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def open_distance(p: Any) -> float:
    """How far the design keeps from an open limit of parameter ``p``'s interval:
    1e-3 of the interval's width or of the default's magnitude, whichever is smaller (so
    a slope of 0.009 rad keeps 9e-6 from 0, a ratio in (0, 1) 1e-3 from its ends)."""
    width = p.upper - p.lower
    size = abs(p.default) if p.default else 1.0
    return 1e-3 * min(width, size)


@dataclass(frozen=True)
class DesignRequest:
    """What a design asks for, in the model's units (angles in rad).

    ``objective``: term -> weight of the sum minimised, each term signed by its sense
    (:data:`MAXIMISED` terms enter as ``-weight * value``). ``targets``: quantity ->
    value (equalities). ``fixed``: parameter -> value. ``bounds``: parameter or quantity
    -> (lower, upper), either None. ``max_eigenvalue``: the bound on max |λ|.
    ``min_margin``: every condition's margin at least this (in its unit; >= the strict
    margin). ``starts``: how many of the gaits found at the start are tried. ``start``:
    free parameter -> the value its search for starting gaits begins at (else its default,
    or its box's middle where the default lies outside the box): a design whose targets are
    far from the defaults' gaits is started near them.
    """

    objective: Mapping[str, float] = field(default_factory=dict)
    targets: Mapping[str, float] = field(default_factory=dict)
    fixed: Mapping[str, float] = field(default_factory=dict)
    bounds: Mapping[str, tuple[float | None, float | None]] = field(default_factory=dict)
    max_eigenvalue: float | None = None
    min_margin: float = 0.0
    starts: int = 4
    start: Mapping[str, float] = field(default_factory=dict)


@dataclass
class GaitDesign:
    """The outcome of :func:`design`; ``orbit`` and ``parameters`` only for a design."""

    status: str
    message: str
    parameters: dict[str, float] | None = None
    orbit: Orbit | None = None
    quantities: dict[str, float | None] = field(default_factory=dict)
    margins: list[dict[str, Any]] = field(default_factory=list)
    objective: float | None = None
    active_constraints: tuple[str, ...] = ()
    open_limits: tuple[str, ...] = ()
    ipopt_status: str = ""
    starts: int = 0
    simulation_rel_error: float | None = None
    infeasible_reason: str | None = None

    @property
    def found(self) -> bool:
        return self.status in ("optimal", "not-attained")

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"status": self.status, "message": self.message}
        if self.found:
            out["parameters"] = dict(self.parameters or {})
            out["gait"] = self.orbit.to_dict() if self.orbit is not None else None
            out["quantities"] = dict(self.quantities)
            out["conditions"] = list(self.margins)
            out["objective"] = self.objective
            out["active_constraints"] = list(self.active_constraints)
            out["open_limits"] = list(self.open_limits)
            out["simulation_rel_error"] = self.simulation_rel_error
        if self.infeasible_reason is not None:
            out["infeasible_reason"] = self.infeasible_reason
        out["ipopt_status"] = self.ipopt_status
        out["starts"] = self.starts
        out["transcription"] = (
            f"multiple shooting, {SEGMENTS} segments per phase, CVODES {INTEGRATOR_TOL:g}; "
            "IPOPT with exact first derivatives and a limited-memory Hessian; stability by "
            "the Jury inequalities of the monodromy matrix's characteristic polynomial"
        )
        return out


# --- the eigenvalue disc as smooth inequalities --------------------------------------------


def jury_rows(coefficients: Sequence[Any]) -> list[Any]:
    """Inequalities ``row >= 0`` that hold exactly when every root of the monic polynomial
    ``z^r + a_1 z^(r-1) + ... + a_r`` (``coefficients`` = a_1..a_r) lies in the closed unit
    disc: Jury's conditions with each ``|u| <= v`` written as the two rows ``v - u`` and
    ``v + u`` (smooth; degrees 1-3), the Schur–Cohn recursion for higher degrees. Works on
    floats and on CasADi expressions."""
    a = list(coefficients)
    r = len(a)
    if r == 1:
        return [1 - a[0], 1 + a[0]]
    if r == 2:
        return [1 - a[1], 1 + a[0] + a[1], 1 - a[0] + a[1]]
    if r == 3:
        inner = a[2] * a[0] - a[1]
        return [
            1 + a[0] + a[1] + a[2],
            1 - a[0] + a[1] - a[2],
            1 - a[2],
            1 + a[2],
            1 - a[2] ** 2 - inner,
            1 - a[2] ** 2 + inner,
        ]
    # Schur–Cohn: p stable iff |p_0| < |p_d| and (p_d p - p_0 p*) / z is; lowest first.
    rows = []
    poly = [1, *a][::-1]  # constant first
    while len(poly) > 1:
        lead, const = poly[-1], poly[0]
        rows.append(lead**2 - const**2)
        d = len(poly) - 1
        poly = [lead * poly[j + 1] - const * poly[d - 1 - j] for j in range(d)]
    return rows


def characteristic_coefficients(matrix: Any, count: int) -> list[Any]:
    """a_1..a_count of ``det(z I - M) = z^m + a_1 z^(m-1) + ...`` by Newton's identities
    on the traces of the powers of ``M`` (CasADi or numpy)."""
    import casadi as ca

    traces = []
    power = matrix
    for _ in range(count):
        traces.append(ca.trace(power))
        power = ca.mtimes(power, matrix)
    a: list[Any] = []
    for k in range(1, count + 1):
        total = traces[k - 1]
        for j in range(1, k):
            total = total + a[j - 1] * traces[k - j - 1]
        a.append(-total / k)
    return a


# --- the transcription --------------------------------------------------------------------


@dataclass(frozen=True)
class _Structure:
    """What the NLP's shape depends on (one solver per structure, reused across requests)."""

    free: tuple[int, ...]  # indices of the free parameters
    objective: tuple[tuple[str, float], ...]
    rows: tuple[str, ...]  # quantities constrained (targets and bounds)
    eigen: str | None  # None, 'bound' (rho given) or 'objective' (rho an unknown)
    rank: int


@dataclass
class _Nlp:
    solver: Any
    quantities: Any  # ca.Function(w, P) -> the design quantities
    row_names: list[str]
    row_kinds: list[str]  # 'equality', 'margin', 'when', 'quantity', 'jury'
    layout: dict[str, slice]
    size: int


def _vector_field(model: HybridModel, phase: str, p: Any, x: Any) -> Any:
    import casadi as ca

    return ca.vertcat(x[model.n :], model.symbolic(f"{phase}_accelerations", p, x))


@functools.cache
def _segment_flows(model: HybridModel, variational: bool) -> dict[str, Any]:
    """Per phase: CVODES over a segment of length h, state x (with the variational
    matrix Phi, column-major, when ``variational``), parameters (p, h)."""
    import casadi as ca

    m = 2 * model.n
    p = ca.SX.sym("p", len(model.parameter_table))
    h = ca.SX.sym("h")
    x = ca.SX.sym("x", m)
    flows = {}
    for phase, _event in model._phase_sequence():
        f = _vector_field(model, phase, p, x)
        state, rhs = x, h * f
        if variational:
            phi = ca.SX.sym("phi", m, m)
            state = ca.vertcat(x, ca.vec(phi))
            rhs = ca.vertcat(h * f, ca.vec(h * ca.mtimes(ca.jacobian(f, x), phi)))
        flows[phase] = ca.integrator(
            f"segment_{phase}", "cvodes", {"x": state, "p": ca.vertcat(p, h), "ode": rhs},
            0.0, 1.0,
            {"abstol": INTEGRATOR_TOL, "reltol": INTEGRATOR_TOL, "max_num_steps": 20000,
             "linear_multistep_method": "adams", "nonlinear_solver_iteration": "functional"},
        )  # fmt: skip
    return flows


@functools.cache
def _event_jacobians(model: HybridModel, phase: str, event: str) -> Any:
    """(p, x) -> the phase's vector field, the event guard's gradient and the reset's
    Jacobian at x: the pieces of the saltation at the phase's end."""
    import casadi as ca

    p = ca.SX.sym("p", len(model.parameter_table))
    x = ca.SX.sym("x", 2 * model.n)
    guard = model.symbolic(f"event_{event}_guard", p, x)
    reset = model.symbolic(f"event_{event}_reset", p, x)
    return ca.Function(f"saltation_{phase}", [p, x], [
        _vector_field(model, phase, p, x), ca.jacobian(guard, x), ca.jacobian(reset, x),
    ])  # fmt: skip


def _kinetic_loss(model: HybridModel, before: str, after: str, p: Any, x_before: Any,
                  x_after: Any) -> Any:  # fmt: skip
    """Kinetic energy an impact dissipates: ``T = E(q, rates) - E(q, 0)`` on either side.
    Not the change of ``E``: a walker's potential is measured from its stance foot, which
    an impact moves (down the slope's step), while the bodies do not move in the impact.
    On a periodic gait it is the energy a step must get back (gravity's work down a slope,
    an actuator's on level ground). numpy or CasADi."""
    params = _split(p)
    return (kinetic_energy(model, before, params, x_before)
            - kinetic_energy(model, after, params, x_after))  # fmt: skip


def _split(p: Any) -> list[Any]:
    if isinstance(p, np.ndarray):
        return [float(v) for v in p]
    import casadi as ca

    return ca.vertsplit(p)


def _impact_events(model: HybridModel) -> set[str]:
    return {e["name"] for e in model.events if e["reset"] == "impact"}


@functools.cache
def _build(model: HybridModel, structure: _Structure) -> _Nlp:
    """The NLP of one structure; numbers that vary between requests (fixed values, the
    eigenvalue bound) are its parameters, bounds are the solver call's."""
    import casadi as ca

    sequence = model._phase_sequence()
    n_par, m, count = len(model.parameter_table), 2 * model.n, len(sequence)
    eigen = structure.eigen is not None
    flows = _segment_flows(model, eigen)
    fixed_values = ca.MX.sym("P", n_par + 1)  # parameter values, then the eigenvalue bound
    free = ca.MX.sym("free", len(structure.free))
    nodes = [[ca.MX.sym(f"x_{k}_{s}", m) for s in range(SEGMENTS)] for k in range(count)]
    durations = ca.MX.sym("T", count)
    rho = ca.MX.sym("rho", 1 if structure.eigen == "objective" else 0)
    position = {j: i for i, j in enumerate(structure.free)}
    p = ca.vertcat(*(free[position[j]] if j in position else fixed_values[j]
                     for j in range(n_par)))  # fmt: skip

    rows: list[Any] = []
    names: list[str] = []
    kinds: list[str] = []

    def add(expr: Any, name: str, kind: str) -> None:
        rows.append(expr)
        names.extend([name] * expr.shape[0])
        kinds.extend([kind] * expr.shape[0])

    monodromy = ca.MX.eye(m)
    energy_lost = 0
    step_length = None
    failures = {ph["name"]: ph["failures"] for ph in model.phases}
    start_failures = {ph["name"]: ph.get("start_failures", ()) for ph in model.phases}
    for k, (phase, event) in enumerate(sequence):
        h = durations[k] / SEGMENTS
        phi_phase = ca.MX.eye(m)
        for failure, function, direction in start_failures[phase]:
            add(-direction * model.symbolic(function, p, nodes[k][0]), failure, "margin")
        for s in range(SEGMENTS):
            x_s = nodes[k][s]
            for failure, function, direction in failures[phase]:
                add(-direction * model.symbolic(function, p, x_s), failure, "margin")
            start = ca.vertcat(x_s, ca.vec(ca.MX.eye(m))) if eigen else x_s
            out = flows[phase](x0=start, p=ca.vertcat(p, h))["xf"]
            end = out[:m]
            if eigen:
                phi_phase = ca.mtimes(ca.reshape(out[m:], m, m), phi_phase)
            if s + 1 < SEGMENTS:
                add(nodes[k][s + 1] - end, "continuity", "equality")
        for failure, function, direction in failures[phase]:
            add(-direction * model.symbolic(function, p, end), failure, "margin")
        guard = model.symbolic(f"event_{event['name']}_guard", p, end)
        add(guard, f"{event['name']} guard", "equality")
        if event["when"] is not None:
            add(model.symbolic(event["when"], p, end), f"{event['name']} when", "when")
        after = model.symbolic(f"event_{event['name']}_reset", p, end)
        nxt = nodes[k + 1][0] if k + 1 < count else nodes[0][0]
        add(nxt - after, "periodicity" if k + 1 == count else "reset", "equality")
        if event["name"] in _impact_events(model):
            energy_lost = energy_lost + _kinetic_loss(model, phase, event["target"], p, end,
                                                      after)  # fmt: skip
        if event["ends_step"] and model.spec["step_length"]:
            step_length = model.symbolic("step_length_of_state", p, end)
        if eigen:
            f_end, grad, jac_reset = _event_jacobians(model, phase, event["name"])(p, end)
            saltation = ca.MX.eye(m) - ca.mtimes(f_end, grad) / ca.mtimes(grad, f_end)
            monodromy = ca.mtimes(ca.mtimes(jac_reset, ca.mtimes(saltation, phi_phase)),
                                  monodromy)  # fmt: skip
    radius = rho if structure.eigen == "objective" else fixed_values[n_par]
    facts = {
        "period": ca.sum1(durations),
        "energy_per_step": energy_lost,
        "energy": energy_lost,
        "eigenvalue": radius,
        "weight": walker_weight(model, p),
    }
    if step_length is not None:  # else no quantity of the step's length
        facts["step_length"] = step_length
    quantities = report(facts)
    if eigen:
        coefficients = characteristic_coefficients(monodromy, structure.rank)
        scaled = [c / radius ** (k + 1) for k, c in enumerate(coefficients)]
        for row in jury_rows(scaled):
            add(row, "eigenvalue", "jury")
        quantities["eigenvalue_radius"] = radius
    for name in structure.rows:
        add(quantities[name], name, "quantity")

    objective = 0
    for term, weight in structure.objective:
        value = radius if term == "eigenvalue" else quantities[term]
        objective = objective + (-weight if maximised(term) else weight) * value
    w = ca.vertcat(free, *[x for phase_nodes in nodes for x in phase_nodes], durations, rho)
    layout = {
        "free": slice(0, len(structure.free)),
        "nodes": slice(len(structure.free), len(structure.free) + count * SEGMENTS * m),
    }
    layout["durations"] = slice(layout["nodes"].stop, layout["nodes"].stop + count)
    layout["rho"] = slice(layout["durations"].stop, layout["durations"].stop + rho.shape[0])
    nlp = {"x": w, "p": fixed_values, "f": objective, "g": ca.vertcat(*rows)}
    options = {
        "ipopt.tol": 1e-8, "ipopt.constr_viol_tol": 1e-9, "ipopt.max_iter": MAX_ITERATIONS,
        "ipopt.acceptable_tol": 1e-6,
        "ipopt.acceptable_constr_viol_tol": 1e-9, "ipopt.acceptable_iter": 5,
        "ipopt.mu_strategy": "adaptive",
        "ipopt.hessian_approximation": "limited-memory", "ipopt.print_level": 0,
        "print_time": False, "ipopt.sb": "yes", "error_on_fail": False,
    }  # fmt: skip
    solver = ca.nlpsol(f"design_{model.name}", "ipopt", nlp, options)
    table = ca.vertcat(*quantities.values())
    quantity_function = ca.Function("quantities", [w, fixed_values], [table])
    quantity_function.names = list(quantities)  # type: ignore[attr-defined]
    return _Nlp(solver, quantity_function, names, kinds, layout, int(w.shape[0]))


# --- one request ----------------------------------------------------------------------------


@dataclass
class _Solve:
    start: int
    ipopt_status: str
    w: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    parameters: tuple[float, ...] = ()
    orbit: Orbit | None = None
    quantities: dict[str, float | None] = field(default_factory=dict)
    margins: list[dict[str, Any]] = field(default_factory=list)
    objective: float = math.inf
    failure: str = ""  # why it is not a verified design

    @property
    def verified(self) -> bool:
        return self.orbit is not None and not self.failure


class _Problem:
    """A request checked against a model: free parameters, their boxes, the structure."""

    def __init__(self, model: HybridModel, request: DesignRequest) -> None:
        self.model = model
        self.request = request
        self.table = list(model.parameter_table)
        names = [p.name for p in self.table]
        self.available = set(DESIGN_QUANTITIES) - (
            set() if model.spec["step_length"] else {"speed", "step_length"}
        )
        self._check_names(names)
        self.free = tuple(j for j, p in enumerate(self.table) if self._is_free(p))
        self.box = {j: self._box(self.table[j]) for j in self.free}
        self.start = self._start_parameters()
        self.objective = self._objective()
        self.rows = tuple(sorted(set(request.targets) | (set(request.bounds) & self.available)))
        self.eigen = ("objective" if "eigenvalue" in self.objective
                      else "bound" if request.max_eigenvalue is not None else None)  # fmt: skip
        if len(request.targets) > len(self.free):
            raise VswInputError(
                f"{len(request.targets)} target(s) ({', '.join(request.targets)}) for "
                f"{len(self.free)} free parameter(s) ({self.free_names() or 'none'}): each "
                "target needs a parameter to meet it; free one (drop a --fix, or --bound a "
                "scale)"
            )

    def free_names(self) -> str:
        return ", ".join(self.table[j].name for j in self.free)

    def _check_names(self, names: list[str]) -> None:
        request = self.request
        for name in request.fixed:
            if name not in names:
                raise VswInputError(f"--fix {name}: not a parameter of {self.model.name} "
                                    f"(its parameters: {', '.join(names)})")  # fmt: skip
        for name in request.bounds:
            if name not in names and name not in self.available:
                raise VswInputError(
                    f"--bound {name}: neither a parameter of {self.model.name} "
                    f"({', '.join(names)}) nor a quantity ({', '.join(sorted(self.available))})"
                )
        for name in request.targets:
            if name not in self.available:
                raise VswInputError(f"target {name}: {self.model.name} has no such quantity "
                                    f"(it has {', '.join(sorted(self.available))})")  # fmt: skip
        for name, value in request.targets.items():
            low, high = request.bounds.get(name, (None, None))
            if (low is not None and value < low) or (high is not None and value > high):
                raise VswInputError(f"target {name} = {value:g} contradicts --bound "
                                    f"{name}={_range_text(low, high)}")  # fmt: skip
        objectives = [n.replace("-", "_") for n in objective_names("design")]
        for term in request.objective:
            if term not in objectives:
                raise VswInputError(f"objective {term!r}: choose from "
                                    f"{', '.join(objectives)}")  # fmt: skip
            if (
                term in ("speed", "step_length", "cost_of_transport")
                and "speed" not in self.available
            ):
                raise VswInputError(f"objective {term}: {self.model.name} defines no step length")
        for name in request.start:
            if name not in names:
                raise VswInputError(f"--start {name}: not a parameter of {self.model.name} "
                                    f"(its parameters: {', '.join(names)})")  # fmt: skip
            if name in request.fixed:
                raise VswInputError(f"--start {name} and --fix {name}: a fixed parameter has "
                                    "no start; give one")  # fmt: skip
        e = request.max_eigenvalue
        if e is not None and not (math.isfinite(e) and e > 0):
            raise VswInputError(f"--max-eigenvalue {e}: must be a positive number")

    def _is_free(self, p: Any) -> bool:
        if p.name in self.request.fixed:
            value = self.request.fixed[p.name]
            if p.name in self.request.bounds:
                low, high = self.request.bounds[p.name]
                if (low is not None and value < low) or (high is not None and value > high):
                    raise VswInputError(f"--fix {p.name}={value:g} contradicts --bound "
                                        f"{p.name}={_range_text(low, high)}")  # fmt: skip
            _inside_table(p, value, f"--fix {p.name}={value:g}")
            return False
        # A parameter on (0, inf) is held unless bounded: the tables do not say which are
        # pure scales (g, an overall mass or length: the gait's units only) and which
        # ratios (a leg's mass against the hip's), and with no finite interval there is no
        # box to design in. The user's --bound makes it a design variable.
        scale = p.lower == 0 and math.isinf(p.upper)
        return not scale or p.name in self.request.bounds

    def _box(self, p: Any) -> tuple[float, float]:
        distance = open_distance(p)
        low, high = p.lower + distance, p.upper - distance
        if p.computed is not None:
            low, high = max(low, p.computed[0]), min(high, p.computed[1])
        user_low, user_high = self.request.bounds.get(p.name, (None, None))
        for value in (user_low, user_high):
            if value is not None:
                _inside_table(p, value, f"--bound {p.name}={_range_text(user_low, user_high)}")
        if user_low is not None:
            low = max(low, user_low)
        if user_high is not None:
            high = min(high, user_high)
        if not low <= high:
            raise VswInputError(f"--bound {p.name}={_range_text(user_low, user_high)}: empty")
        if math.isinf(low) or math.isinf(high):
            raise VswInputError(f"--bound {p.name}: give a finite interval (A:B)")
        return low, high

    def _start_parameters(self) -> tuple[float, ...]:
        free_names = {self.table[j].name for j in self.free}
        for name in self.request.start:
            if name not in free_names:
                raise VswInputError(f"--start {name}: not designed (a scale on (0, inf) is "
                                    "held unless --bound gives it an interval)")  # fmt: skip
        out = []
        for j, p in enumerate(self.table):
            value = self.request.fixed.get(p.name, p.default)
            if j in self.box:
                low, high = self.box[j]
                if p.name in self.request.start:
                    value = self.request.start[p.name]
                    if not low <= value <= high:
                        raise VswInputError(f"--start {p.name}={value:g}: outside its design "
                                            f"interval [{low:g}, {high:g}]")  # fmt: skip
                elif not low <= value <= high:
                    value = 0.5 * (low + high)
            out.append(float(value))
        return tuple(out)

    def _objective(self) -> dict[str, float]:
        objective = dict(self.request.objective)
        if not objective:
            if not self.request.targets and self.request.max_eigenvalue is None:
                raise VswInputError("give an objective (--maximize/--minimize) or a target")
            objective = {"eigenvalue": 1.0}
        return objective

    def structure(
        self,
        rank: int,
        objective: Mapping[str, float] | None = None,
        rows: tuple[str, ...] | None = None,
        eigen: str | None = "same",
    ) -> _Structure:
        objective = self.objective if objective is None else objective
        eigen = self.eigen if eigen == "same" else eigen
        return _Structure(
            self.free,
            tuple(sorted(objective.items())),
            self.rows if rows is None else rows,
            eigen,
            rank if eigen else 0,
        )


def _inside_table(p: Any, value: float, given: str) -> None:
    if not (math.isfinite(value) and p.lower < value < p.upper):
        raise VswInputError(f"{given}: {p.name} must lie in the open interval "
                            f"({p.lower:.6g}, {p.upper:.6g}): {p.reason}")  # fmt: skip
    if p.computed is not None and not p.computed[0] <= value <= p.computed[1]:
        raise VswInputError(
            f"{given}: {p.name} outside the computed range "
            f"[{p.computed[0]:.6g}, {p.computed[1]:.6g}]: {p.computed_reason}"
        )


def _range_text(low: float | None, high: float | None) -> str:
    return f"{'' if low is None else f'{low:g}'}:{'' if high is None else f'{high:g}'}"


def _nontrivial_rank(orbits: Sequence[Orbit]) -> int:
    """How many eigenvalues of the step map are not structural zeros."""
    rank = 1
    for orbit in orbits:
        largest = max(1.0, orbit.max_abs_eigenvalue)
        rank = max(rank, sum(abs(e) > 1e-7 * largest for e in orbit.eigenvalues))
    return rank


def _initial_point(problem: _Problem, nlp: _Nlp, orbit: Orbit, rho: float) -> np.ndarray:
    """IPOPT's start from a gait: its parameters, its state at every node, its durations."""
    model = problem.model
    state = np.array(list(orbit.state.values()))
    pieces, _events, ended = model.continuous_walk(problem.start, state, 1)
    if ended != "completed" or len(pieces) != len(orbit.durations):
        raise ConvergenceError(f"{model.name}: the start gait does not walk a step")
    w = np.zeros(nlp.size)
    w[nlp.layout["free"]] = [problem.start[j] for j in problem.free]
    nodes = []
    for piece in pieces:
        times = piece.start + (piece.end - piece.start) * np.arange(SEGMENTS) / SEGMENTS
        nodes.append(piece.states(times).reshape(-1))
    w[nlp.layout["nodes"]] = np.concatenate(nodes)
    w[nlp.layout["durations"]] = [piece.end - piece.start for piece in pieces]
    w[nlp.layout["rho"]] = rho
    return w


def _bounds(
    problem: _Problem, nlp: _Nlp, targets: Mapping[str, float]
) -> dict[str, np.ndarray]:  # fmt: skip
    request = problem.request
    lbx = np.full(nlp.size, -np.inf)
    ubx = np.full(nlp.size, np.inf)
    lbx[nlp.layout["free"]] = [problem.box[j][0] for j in problem.free]
    ubx[nlp.layout["free"]] = [problem.box[j][1] for j in problem.free]
    lbx[nlp.layout["durations"]] = MIN_DURATION
    lbx[nlp.layout["rho"]] = 1e-4
    if request.max_eigenvalue is not None:
        ubx[nlp.layout["rho"]] = request.max_eigenvalue
    lbg = np.zeros(len(nlp.row_kinds))
    ubg = np.zeros(len(nlp.row_kinds))
    for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
        if kind == "margin":
            lbg[i], ubg[i] = _margin_floor(name, request), np.inf
        elif kind in ("when", "jury"):
            lbg[i], ubg[i] = 0.0, np.inf
        elif kind == "quantity":
            if name in targets:
                lbg[i] = ubg[i] = targets[name]
            else:
                low, high = request.bounds.get(name, (None, None))
                lbg[i] = -np.inf if low is None else low
                ubg[i] = np.inf if high is None else high
    p = np.array([*problem.start, request.max_eigenvalue or 1.0])
    return {"lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg, "p": p}


def _solve(problem: _Problem, nlp: _Nlp, bounds: Mapping[str, np.ndarray], w0: np.ndarray,
           start: int) -> _Solve:  # fmt: skip
    # CasADi reports integrator trouble on stderr; the status and the verification say
    # what matters.
    with contextlib.redirect_stderr(io.StringIO()), contextlib.redirect_stdout(io.StringIO()):
        try:
            out = nlp.solver(x0=w0, **bounds)
            status = str(nlp.solver.stats().get("return_status", "unknown"))
        except RuntimeError as exc:
            stop.check()
            return _Solve(start, "error: " + " ".join(str(exc).split())[:60], w0,
                          np.zeros_like(w0), np.zeros(len(nlp.row_kinds)))  # fmt: skip
    stop.check()  # IPOPT ends an interrupted solve with a status, not an exception
    return _Solve(
        start,
        status,
        np.array(out["x"]).reshape(-1),
        np.array(out["lam_x"]).reshape(-1),
        np.array(out["lam_g"]).reshape(-1),
    )


def _margin_floor(failure: str, request: DesignRequest) -> float:
    """The least margin the NLP imposes on a failure's guard."""
    floor = CLOSED_MARGIN if failure in CLOSED_FAILURES else STRICT_MARGIN
    return max(floor, request.min_margin)


def _parameters_of(problem: _Problem, nlp: _Nlp, w: np.ndarray) -> tuple[float, ...]:
    values = list(problem.start)
    for i, j in enumerate(problem.free):
        values[j] = float(w[nlp.layout["free"]][i])
    return tuple(values)


def _verify(problem: _Problem, nlp: _Nlp, solve: _Solve, targets: Mapping[str, float],
            objective: Mapping[str, float]) -> _Solve:  # fmt: skip
    """Whether IPOPT's point is a gait that meets the request, by the runtime's own
    periodic-orbit solver (1e-13) and simulation."""
    model = problem.model
    if solve.ipopt_status not in _SUCCESS:
        solve.failure = f"IPOPT {solve.ipopt_status}"
        return solve
    params = _parameters_of(problem, nlp, solve.w)
    m = 2 * model.n
    state = solve.w[nlp.layout["nodes"]][:m]
    try:
        orbit = model.periodic_orbit(params, state, solve.w[nlp.layout["durations"]])
    except ConvergenceError as exc:
        solve.failure = f"not confirmed: {exc}"
        return solve
    x_star = np.array(list(orbit.state.values()))
    if not np.max(np.abs(x_star - state)) <= 1e-6 * max(1.0, float(np.max(np.abs(x_star)))):
        solve.failure = "the confirmed orbit is another gait"
        return solve
    quantities = _orbit_quantities(model, params, orbit)
    margins = conditions.gait_conditions(model, params, orbit)
    problems = _violations(problem, quantities, margins, targets)
    if problems:
        solve.failure = "; ".join(problems)
        return solve
    solve.parameters, solve.orbit = params, orbit
    solve.quantities, solve.margins = quantities, margins
    solve.objective = _objective_value(objective, quantities)
    return solve


def _orbit_quantities(model: HybridModel, params: Sequence[float], orbit: Orbit) -> dict:
    state = np.array(list(orbit.state.values()))
    lost = 0.0
    phase = model.step_event["target"]
    for record in model.step_events(params, state):
        event = next(e for e in model.by_source[phase] if e["name"] == record.name)
        if record.name in _impact_events(model):
            lost += float(_kinetic_loss(model, phase, event["target"], np.asarray(params),
                                        record.state_before, record.state_after))  # fmt: skip
        phase = event["target"]
    facts = {
        "period": orbit.period,
        "eigenvalue": orbit.max_abs_eigenvalue,
        "energy_per_step": float(lost),
        "energy": float(lost),
        "step_length": orbit.step_length,
        "weight": walker_weight(model, params),
    }
    return report(facts)


def _violations(problem: _Problem, quantities: Mapping[str, Any], margins: list[dict],
                targets: Mapping[str, float]) -> list[str]:  # fmt: skip
    request = problem.request
    out = []
    for name, value in targets.items():
        got = quantities[name]
        if got is None or not abs(got - value) <= TARGET_TOL * max(1.0, abs(value)):
            out.append(f"target {name} {value:g} missed ({got})")
    for name, (low, high) in request.bounds.items():
        if name in quantities:
            got = quantities[name]
            slack = TARGET_TOL * max(1.0, abs(got))
            if (low is not None and got < low - slack) or (high is not None and got > high + slack):
                out.append(f"{name} {got:.6g} outside {_range_text(low, high)}")
    e = request.max_eigenvalue
    if e is not None and not quantities["eigenvalue"] <= e * (1 + TARGET_TOL):
        out.append(f"max |eigenvalue| {quantities['eigenvalue']:.6g} above {e:g}")
    for margin in margins:
        if not margin.get("ends_walk", True):
            continue  # a condition the model reports, not one its walks must meet
        closed = margin["name"] in CLOSED_FAILURES
        if margin["margin"] is not None and not (
            margin["margin"] >= 0 if closed else margin["margin"] > 0
        ):
            out.append(f"condition {margin['name']} fails (margin {margin['margin']:.3g})")
        elif margin["margin"] is not None and margin["margin"] < request.min_margin * (1 - 1e-6):
            out.append(f"condition {margin['name']} margin {margin['margin']:.3g} below "
                       f"{request.min_margin:g}")  # fmt: skip
    return out


def _objective_value(objective: Mapping[str, float], quantities: Mapping[str, Any]) -> float:
    total = 0.0
    for term, weight in objective.items():
        value = quantities[term]
        total += (-weight if maximised(term) else weight) * float(value)
    return total


def _multistart(
    problem: _Problem,
    seeds: Sequence[Orbit],
    rank: int,
    objective: Mapping[str, float] | None = None,
    targets: Mapping[str, float] | None = None,
    eigen: str | None = "same",
) -> tuple[_Solve | None, list[_Solve], _Nlp]:
    objective = problem.objective if objective is None else objective
    targets = problem.request.targets if targets is None else targets
    rows = tuple(sorted(set(targets) | (set(problem.request.bounds) & problem.available)))
    structure = problem.structure(rank, objective, rows, eigen)
    nlp = _build(problem.model, structure)
    bounds = _bounds(problem, nlp, targets)
    solves, best = [], None
    for k, orbit in enumerate(seeds):
        rho = 1.05 * max(orbit.max_abs_eigenvalue, 1e-3)
        try:
            w0 = _initial_point(problem, nlp, orbit, rho)
        except ConvergenceError:
            continue
        solve = _verify(problem, nlp, _solve(problem, nlp, bounds, w0, k), targets, objective)
        solves.append(solve)
        if solve.verified and (best is None or solve.objective < best.objective - 1e-12):
            best = solve
    return best, solves, nlp


def _open_limits(problem: _Problem, nlp: _Nlp, solve: _Solve) -> tuple[str, ...]:
    """The open limits the optimum presses against (its multiplier pulls it there)."""
    out = []
    free_w = solve.w[nlp.layout["free"]]
    free_lam = solve.lam_x[nlp.layout["free"]]
    for i, j in enumerate(problem.free):
        p = problem.table[j]
        low, high = problem.box[j]
        tol = 1e-7 * max(1.0, abs(high - low))
        pulled = abs(free_lam[i]) > 1e-8
        # Open only where the box's edge is the table's open limit kept at its distance
        # (not a closed bound of the user's, not the computed range's end).
        distance = open_distance(p)
        if pulled and abs(free_w[i] - low) <= tol and low == p.lower + distance:
            out.append(f"{p.name} -> {p.lower:.6g}")
        if pulled and abs(free_w[i] - high) <= tol and high == p.upper - distance:
            out.append(f"{p.name} -> {p.upper:.6g}")
    if problem.request.min_margin <= STRICT_MARGIN:
        g = None
        for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
            if name in CLOSED_FAILURES:
                continue
            margin = _margin_floor(name, problem.request)
            if kind == "margin" and abs(solve.lam_g[i]) > 1e-8:
                g = g if g is not None else _constraint_values(nlp, solve.w, problem)
                if abs(g[i] - margin) <= 1e-7:
                    text = f"margin of {name} -> 0"
                    if text not in out:
                        out.append(text)
    return tuple(out)


def _constraint_values(nlp: _Nlp, w: np.ndarray, problem: _Problem) -> np.ndarray:
    p = np.array([*problem.start, problem.request.max_eigenvalue or 1.0])
    with contextlib.redirect_stderr(io.StringIO()):
        return np.array(nlp.solver.get_function("nlp_g")(w, p)).reshape(-1)


def _active(problem: _Problem, nlp: _Nlp, solve: _Solve) -> tuple[str, ...]:
    out = []
    for i, (name, kind) in enumerate(zip(nlp.row_names, nlp.row_kinds)):
        if kind in ("margin", "quantity", "jury") and abs(solve.lam_g[i]) > 1e-8:
            label = "max |eigenvalue|" if kind == "jury" else name
            if name in problem.request.targets:
                continue
            if label not in out:
                out.append(label)
    for i, j in enumerate(problem.free):
        if abs(solve.lam_x[nlp.layout["free"]][i]) > 1e-8:
            out.append(f"{problem.table[j].name} bound")
    return tuple(out)


def design(model: HybridModel, request: DesignRequest) -> GaitDesign:
    """Design the model's free parameters and its gait for ``request`` (module docstring).

    Raises VswInputError for a malformed request (unknown names, bounds outside the
    parameter table, contradictory fixes, bounds and targets, more targets than free
    parameters); every other outcome is a status of the result.
    """
    if not (isinstance(request.starts, int) and 1 <= request.starts <= 50):
        raise VswInputError(f"starts = {request.starts!r} must be an integer from 1 to 50")
    problem = _Problem(model, request)
    if not problem.free:
        raise VswInputError(f"every parameter of {model.name} is fixed: nothing to design "
                            "(drop a --fix, or --bound a scale)")  # fmt: skip
    seeds, tried, why_none = _seeds(problem)
    if not seeds:
        return GaitDesign("not-converged", f"not converged: no gait to start from at "
                          f"{tried} parameter set(s) of the box ({why_none})")  # fmt: skip
    rank = _nontrivial_rank(seeds)
    best, solves, nlp = _multistart(problem, seeds, rank)
    statuses = ", ".join(sorted({s.ipopt_status for s in solves})) or "no start"
    if best is None:
        reason = _infeasibility(problem, seeds, rank)
        if reason is not None:
            return GaitDesign("infeasible", f"infeasible: {reason}", ipopt_status=statuses,
                              starts=len(solves), infeasible_reason=reason)  # fmt: skip
        why = "; ".join(sorted({s.failure for s in solves}))[:300]
        return GaitDesign("not-converged", f"not converged: no verified design from "
                          f"{len(solves)} start(s) ({why})", ipopt_status=statuses,
                          starts=len(solves))  # fmt: skip
    limits = _open_limits(problem, nlp, best)
    status = "not-attained" if limits else "optimal"
    if limits:
        message = (f"not attained: the optimum lies on the open limit(s) {', '.join(limits)}; "
                   f"the design keeps its distance (parameters: 1e-3 of the interval or the "
                   f"default, margins {STRICT_MARGIN:g})")  # fmt: skip
    else:
        message = (f"optimal (local, the best verified of {len(solves)} IPOPT solve(s) from "
                   f"the gaits at the start; IPOPT {best.ipopt_status})")  # fmt: skip
    state = np.array(list(best.orbit.state.values()))
    step = model.step(best.parameters, state)
    scale = max(1.0, float(np.max(np.abs(state))))
    sim_error = float(np.max(np.abs(step.state - state))) / scale
    names = [p.name for p in problem.table]
    return GaitDesign(
        status,
        message,
        dict(zip(names, best.parameters)),
        best.orbit,
        best.quantities,
        best.margins,
        best.objective,
        _active(problem, nlp, best),
        limits,
        best.ipopt_status,
        len(solves),
        sim_error,
    )


START_SETS = 6
"""Parameter sets searched for gaits to start from, at most: the request's start (its
``start`` values, else defaults and fixes; a default outside the box replaced by the box's
middle), then the box's centre and Halton points of the box,
until one has gaits (a rimless wheel with wide spokes on a gentle slope has none)."""


def _seeds(problem: _Problem) -> tuple[list[Orbit], int, str]:
    """The gaits IPOPT starts from (at most ``starts``), the parameter sets searched and,
    when none has a gait, the last search's reason."""
    free = problem.free
    points = [problem.start]
    centre = list(problem.start)
    for j in free:
        centre[j] = 0.5 * sum(problem.box[j])
    points.append(tuple(centre))
    for k in range(1, START_SETS):
        point = list(problem.start)
        for d, j in enumerate(free):
            low, high = problem.box[j]
            point[j] = low + _halton(k, _PRIMES[d % len(_PRIMES)]) * (high - low)
        points.append(tuple(point))
    why = ""
    for tried, params in enumerate(points[:START_SETS], start=1):
        search = problem.model.search_gaits(params)
        if search.gaits:
            problem.start = tuple(params)
            return list(search.gaits)[: problem.request.starts], tried, ""
        why = search.why_none()
    return [], min(len(points), START_SETS), why


_PRIMES = (2, 3, 5, 7, 11, 13)


def _halton(index: int, base: int) -> float:
    value, fraction = 0.0, 1.0
    while index:
        fraction /= base
        value += fraction * (index % base)
        index //= base
    return value


def _infeasibility(problem: _Problem, seeds: Sequence[Orbit], rank: int) -> str | None:
    """Why no design exists, when the extremes the same starts reach prove it: a target
    beyond the largest or smallest value of its quantity under the other constraints, an
    eigenvalue bound below the least max |eigenvalue|."""
    request = problem.request
    for name, value in request.targets.items():
        others = {k: v for k, v in request.targets.items() if k != name}
        for sense in (+1, -1):
            extreme = _extreme(problem, seeds, rank, name, sense, others)
            if extreme is None:
                continue
            slack = TARGET_TOL * max(1.0, abs(extreme))
            beyond = value > extreme + slack if sense > 0 else value < extreme - slack
            if beyond:
                word = "largest" if sense > 0 else "smallest"
                return (f"the target {name} {value:g} lies beyond the {word} {name} of the "
                        f"gaits the design reaches from the same starts under the other "
                        f"constraints, {extreme:.6g} (a local extreme)")  # fmt: skip
    if request.max_eigenvalue is not None:
        least = _extreme(problem, seeds, rank, "eigenvalue", -1, request.targets, eigen=None)
        if least is not None and least > request.max_eigenvalue:
            return (
                f"--max-eigenvalue {request.max_eigenvalue:g} lies below the least max "
                f"|eigenvalue| the design reaches from the same starts, {least:.6g}"
            )
    return None


def _extreme(problem: _Problem, seeds: Sequence[Orbit], rank: int, name: str, sense: int,
             targets: Mapping[str, float], eigen: str | None = "same") -> float | None:  # fmt: skip
    """The largest (sense +1) or smallest (-1) verified value of a quantity."""
    if name == "eigenvalue":
        objective = {"eigenvalue": 1.0}
        eigen = "objective"
        saved = problem.request
        problem.request = dataclasses.replace(saved, max_eigenvalue=None)
        try:
            best, _, _ = _multistart(problem, seeds, rank, objective, targets, eigen)
        finally:
            problem.request = saved
        return None if best is None else float(best.quantities["eigenvalue"])
    # The term enters as -w * value when maximised, +w * value otherwise.
    objective = {name: float(sense if maximised(name) else -sense)}
    eigen_mode = "bound" if problem.request.max_eigenvalue is not None else None
    best, _, _ = _multistart(problem, seeds, rank, objective, targets, eigen_mode)
    return None if best is None else float(best.quantities[name])
