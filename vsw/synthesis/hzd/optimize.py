"""Gait optimisation on the hybrid zero dynamics: the Bezier coefficients of the virtual
constraints for a target speed (and step length) that minimise the inputs' squares or
their positive work, by IPOPT through CasADi, every optimum verified on the full-order
closed loop.

The decision variables are the coefficients ``alpha_2 .. alpha_M`` of every Bezier output;
``alpha_0`` and ``alpha_1`` follow from the last two through the impact map (Westervelt,
Grizzle & Koditschek 2003, IEEE TAC 48(1), Theorem 4's construction: ``alpha_0 = a(q_+)``,
``alpha_1 = alpha_0 + (theta_- - theta_+)/M a'(q_+) q_+'/theta'(q_+)``), written as CasADi
expressions, so every optimum is impact invariant. The zero dynamics' quantities are the
constraints package's own functions (:mod:`derive.hzd` emits one source for numpy and
CasADi) evaluated symbolically at ``nodes`` Chebyshev points of the first kind in the
phase; ``V`` at the nodes and the step's integrals are Fejér sums over them (the
runtime's rule, :mod:`vsw.synthesis.hzd.zero`, as a matrix). At each node the state on the gait is
``(Phi, Phi' theta_dot)`` with ``theta_dot = sqrt(2 zeta)/I`` and ``zeta = delta^2 zeta*
- V``; there the feed-forward torques (the computed-torque law with ``y = y' = 0``) and
the stance foot's ground reaction (:func:`vsw.synthesis.powered.dynamics.reaction_function`) are
expressions in the coefficients. The NLP (:class:`HzdRequest`):

* the phase just after the impact from ``theta_-`` is ``theta_+`` (an equality), and the
  step event's guard (the swing foot's height) is zero at ``theta_-`` where the
  coefficients move it (a walker with knees);
* existence: ``delta^2 < 1``, ``V(theta_-) < 0`` and ``zeta > 0`` at every node (``zeta*
  delta^2 > max V``), with ``I`` keeping its sign (the phase is monotonic);
* the speed ``step length / period`` (and the step length when asked);
* ``|u| <= max_torque`` at the nodes; the friction cone ``normal > 0``, ``|tangential| <=
  mu normal``; the swing foot at least ``clearance sin(pi s)`` above the ground
  (``s`` the normalised phase), the model's ``swing-foot-clearance`` condition;
* the objective ``torque2`` (``integral |u|^2 dt``) or ``work`` (the inputs' positive work
  per step, by slacks ``s >= P, s >= 0``), the vocabulary of :mod:`vsw.dynamics.quantities`.

The optimum is then analysed by the runtime (:func:`vsw.synthesis.hzd.analyze` with the found
coefficients: its own quadrature on :data:`vsw.synthesis.hzd.zero.NODES` points, torques on a fine
grid, the full-order closed loop's periodic orbit and eigenvalues): it is called optimal
only when IPOPT converged, the runtime's gait meets the request and the full-order loop
returns to its start with every eigenvalue inside the unit circle.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.polynomial import chebyshev

from vsw.dynamics.hybrid import HybridModel
from vsw.runtime import blas
from vsw.runtime.errors import VswInputError
from vsw.synthesis.hzd.loop import ClosedLoop, solve
from vsw.synthesis.hzd.zero import Surface

__all__ = ["OBJECTIVES", "HzdOptimum", "HzdRequest", "optimize", "quadrature_matrix"]

OBJECTIVES = ("torque2", "work")
"""The objectives (:mod:`vsw.dynamics.quantities`' names)."""

VERIFY_TOLERANCE = 1e-6
"""Relative agreement of the runtime's speed and step length with the request, and of the
full-order loop's start and end of a step (its return)."""

BOUND_POINTS = 81
"""Phases over the step with its ends (Chebyshev points of the second kind, dense near the
ends where the torques and the reaction change fastest) where the torque bounds, the
ground's reaction and the existence of the gait are imposed (``zeta`` there from the
quadrature's interpolant)."""

CLEARANCE_POINTS = 399
"""Phases, evenly spaced inside the step, where the swing foot's clearance is imposed (it
depends on the configuration alone: cheap to impose densely)."""

MID_STANCE = 0.1
"""Half the window of the normalised phase about mid-stance (``|s - 1/2| < MID_STANCE``)
where the swing foot's clearance is not imposed: rigid legs without knees pass each other
there, and the swing foot scuffs (as in the sources) unless the legs splay."""

BETWEEN_NODES = 1e-3
"""Relative excess over a bound (torque, friction, clearance) the runtime's grid of
:data:`vsw.synthesis.hzd.SAMPLES` points may show between the NLP's nodes, where it is imposed."""


@dataclass(frozen=True)
class HzdRequest:
    """What to optimise: targets, objective and bounds (None: not imposed)."""

    speed: float
    step_length: float | None = None
    minimize: str = "torque2"
    mu: float | None = None
    max_torque: float | None = None
    clearance: float | None = 0.0
    nodes: int = 32
    zeta_margin: float = 0.01
    """``zeta`` at every node at least this fraction of ``zeta*``."""

    def check(self) -> None:
        """One line for a request that cannot be posed."""
        if not (math.isfinite(self.speed) and self.speed > 0):
            raise VswInputError(f"--speed must be a positive number (got {self.speed:g})")
        if self.step_length is not None and not (math.isfinite(self.step_length)
                                                 and self.step_length > 0):  # fmt: skip
            raise VswInputError(f"--step-length must be positive (got {self.step_length:g})")
        if self.minimize not in OBJECTIVES:
            raise VswInputError(f"--minimize {self.minimize}: vsw hzd --optimize minimises "
                                f"one of {', '.join(OBJECTIVES)}")  # fmt: skip
        if self.mu is not None and not (math.isfinite(self.mu) and self.mu > 0):
            raise VswInputError(f"--mu must be a positive number (got {self.mu:g})")
        if self.max_torque is not None and not (math.isfinite(self.max_torque)
                                                and self.max_torque > 0):  # fmt: skip
            raise VswInputError(f"--max-torque must be positive (got {self.max_torque:g})")
        if self.clearance is not None and not (math.isfinite(self.clearance)
                                               and self.clearance >= 0):  # fmt: skip
            raise VswInputError(f"--clearance must be >= 0 (got {self.clearance:g})")
        if not 8 <= self.nodes <= 200:
            raise VswInputError(f"--nodes must be from 8 to 200 (got {self.nodes})")


@dataclass
class HzdOptimum:
    """IPOPT's answer and the runtime's verification of it."""

    alphas: list[float]
    objective: float
    status: str
    converged: bool
    iterations: int
    solve_seconds: float
    build_seconds: float
    report: Any = None
    """The runtime's :class:`vsw.synthesis.hzd.HzdReport` at the optimum (None: it has no gait)."""
    verified: bool = False
    failures: list[str] = field(default_factory=list)
    """Why the optimum is not verified (empty when it is)."""
    checks: dict[str, float] = field(default_factory=dict)
    """The runtime's numbers the request is checked on."""

    @property
    def optimal(self) -> bool:
        """Converged and verified on the full-order loop."""
        return self.converged and self.verified


def quadrature_matrix(
    lo: float, hi: float, nodes: int, at: Sequence[float] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The phase's nodes (Chebyshev points of the first kind on [lo, hi]) and the matrix
    ``W`` whose row ``j`` integrates the interpolant of the nodes' values from ``lo`` to
    node ``j`` (to ``at[j]`` where ``at`` is given), its last row to ``hi``
    (Fejér's first rule, the runtime's)."""
    x = chebyshev.chebpts1(nodes)
    vander = chebyshev.chebvander(x, nodes - 1)
    integrate = chebyshev.chebint(np.eye(nodes), lbnd=-1, axis=0)
    ends = x if at is None else (2 * (np.asarray(at, float) - lo) / (hi - lo) - 1)
    rows = chebyshev.chebvander(np.append(ends, 1.0), nodes)
    matrix = rows @ integrate @ np.linalg.inv(vander) * (hi - lo) / 2
    return lo + (x + 1) * (hi - lo) / 2, matrix


class _SymbolicSurface(Surface):
    """A :class:`Surface` whose coefficients are CasADi expressions."""

    def __init__(self, package: Any, params: Sequence[float], alphas: Sequence[Any]) -> None:
        super().__init__(package, params, [0.0] * len(alphas))
        self.alphas = tuple(alphas)

    def symbolic_at(self, theta: float) -> tuple[list, list]:
        """Phi and Phi' at a numeric phase (expressions in the coefficients)."""
        out = list(self.package.surface(*self.params, *self.alphas, theta))
        return out[: self.n], out[self.n : 2 * self.n]


def _free_slots(spec: dict) -> tuple[list[int], list[tuple[int, int]]]:
    """The coefficients' indices that are decision variables, and each output's first
    slot and degree (every output must be a Bezier polynomial)."""
    free, outputs, start = [], [], 0
    for k, out in enumerate(spec["layout"]):
        if out["kind"] != "bezier":
            raise VswInputError(f"output {spec['outputs'][k]} is not a Bezier polynomial: "
                                "vsw hzd --optimize varies Bezier coefficients")  # fmt: skip
        if out["count"] < 4:
            raise VswInputError(f"output {spec['outputs'][k]} has degree {out['count'] - 1}: "
                                "the optimisation needs degree 3 or more")  # fmt: skip
        free.extend(range(start + 2, start + out["count"]))
        outputs.append((start, out["count"] - 1))
        start += out["count"]
    return free, outputs


def _with_impact(model: HybridModel, package: Any, params: Sequence[float], z: Any,
                 free: list[int], outputs: list[tuple[int, int]]) -> tuple[list, Any]:  # fmt: skip
    """Every coefficient as an expression in the free ones ``z`` (alpha_0, alpha_1 by the
    impact map) and the phase just after the impact."""
    import casadi as ca

    spec = package.HZD
    alphas: list[Any] = [ca.SX(0.0)] * len(spec["alphas"])
    for j, slot in enumerate(free):
        alphas[slot] = z[j]
    surface = _SymbolicSurface(package, params, alphas)
    q, dq = surface.symbolic_at(surface.theta_minus)
    after = model.symbolic(f"event_{model.step_event['name']}_reset", ca.DM(list(params)),
                           ca.vertcat(*q, *dq))  # fmt: skip
    q_plus, qd_plus = after[: model.n], after[model.n :]
    theta_rate = ca.dot(ca.DM(surface.phase_row), qd_plus)
    span = surface.theta_minus - surface.theta_plus
    for k, (start, degree) in enumerate(outputs):
        a0 = ca.dot(ca.DM(surface.controlled[k]), q_plus) + surface.offsets[k]
        slope = ca.dot(ca.DM(surface.controlled[k]), qd_plus) / theta_rate
        alphas[start], alphas[start + 1] = a0, a0 + span / degree * slope
    theta_after = ca.dot(ca.DM(surface.phase_row), q_plus) + surface.phase_offset
    return alphas, theta_after


@dataclass
class _Nlp:
    """The NLP's pieces: variables, constraints (with bounds), objective, start."""

    z: Any
    g: list = field(default_factory=list)
    lower: list = field(default_factory=list)
    upper: list = field(default_factory=list)
    objective: Any = 0
    start: list = field(default_factory=list)
    alphas: Any = None
    lower_z: list = field(default_factory=list)
    upper_z: list = field(default_factory=list)

    def add(self, expr: Any, low: float, high: float) -> None:
        import casadi as ca

        expr = ca.vec(ca.SX(expr)) if not isinstance(expr, ca.SX) else ca.vec(expr)
        self.g.append(expr)
        self.lower.extend([low] * expr.numel())
        self.upper.extend([high] * expr.numel())


def _node_function(model: HybridModel, surface: _SymbolicSurface, params: Sequence[float]) -> Any:
    """(alphas, theta, zeta) -> I, kappa, u, the inputs' power per unit phase rate, the
    ground's reaction (tangential, normal), the step length and theta_dot at (Phi, Phi'
    theta_dot), ``theta_dot = sqrt(2 zeta)/I``: one point of the phase."""
    import casadi as ca

    from vsw.synthesis.powered.dynamics import reaction_function

    count = len(surface.alphas)
    a = ca.SX.sym("alpha", count)
    theta = ca.SX.sym("theta")
    zeta = ca.SX.sym("zeta")
    node = _SymbolicSurface(surface.package, params, ca.vertsplit(a))
    package = surface.package
    inertia, kappa, _ = package.zero_dynamics(*params, *ca.vertsplit(a), theta)
    rate = ca.sqrt(2 * ca.fmax(zeta, 1e-12)) / inertia
    out = list(package.surface(*params, *ca.vertsplit(a), theta))
    q, dq = out[: node.n], out[node.n : 2 * node.n]
    x = [*q, *(d * rate for d in dq)]
    loop = ClosedLoop(model, node, 0.0, 0.0)
    _, b, jac, lf2 = loop.parts(list(params), x)
    decoupling = [[sum(jac[i][k] * b[k][j] for k in range(node.n)) for j in range(loop.m)]
                  for i in range(node.k)]  # fmt: skip
    u = ca.vertcat(*solve(decoupling, [-v for v in lf2]))
    p = ca.DM(list(params))
    unit = ca.vertcat(*q, *dq)
    per_rate = model.symbolic(f"{loop.phase}_input_rates", p, unit)
    reaction = reaction_function(model, loop.phase)(p, ca.vertcat(*x), u)
    length = model.symbolic("step_length_of_state", p, ca.vertcat(*x))
    return ca.Function("hzd_node", [a, theta, zeta],
                       [inertia, kappa, u, u * per_rate, reaction, length, rate])  # fmt: skip


def _clearance_function(model: HybridModel, surface: _SymbolicSurface,
                        params: Sequence[float]) -> Any:  # fmt: skip
    """(alphas, theta) -> the swing foot's clearance margin on the surface (the model's
    ``swing-foot-clearance`` condition), or None where the model declares none."""
    import casadi as ca

    phase = model.step_event["target"]
    found = [(f, d) for name, f, d in model.phases[model.phase_index[phase]].get("conditions", ())
             if name == "swing-foot-clearance"]  # fmt: skip
    if not found:
        return None
    function, direction = found[0]
    a = ca.SX.sym("alpha", len(surface.alphas))
    theta = ca.SX.sym("theta")
    out = list(surface.package.surface(*params, *ca.vertsplit(a), theta))
    x = ca.vertcat(*out[: surface.n], *([0.0] * surface.n))
    margin = -direction * model.symbolic(function, ca.DM(list(params)), x)
    return ca.Function("hzd_clearance", [a, theta], [margin])


def _build(model: HybridModel, package: Any, params: Sequence[float],
           request: HzdRequest) -> _Nlp:  # fmt: skip
    """The NLP of the module docstring."""
    import casadi as ca

    spec = package.HZD
    free, outputs = _free_slots(spec)
    z = ca.SX.sym("z", len(free))
    alphas, theta_after = _with_impact(model, package, params, z, free, outputs)
    surface = _SymbolicSurface(package, params, alphas)
    lo, hi = surface.theta_plus, surface.theta_minus
    points = lo + (1 - np.cos(np.linspace(0.0, math.pi, BOUND_POINTS))) / 2 * (hi - lo)
    nodes, weights = quadrature_matrix(lo, hi, request.nodes)
    _, at_points = quadrature_matrix(lo, hi, request.nodes, points)
    fn = _node_function(model, surface, params)
    a = ca.vertcat(*alphas)
    nlp = _Nlp(z=z, alphas=a)
    nlp.add(theta_after - lo, 0.0, 0.0)
    first = [fn(a, t, 1.0) for t in nodes]
    inertia = ca.vertcat(*(o[0] for o in first))
    kappa = ca.vertcat(*(o[1] for o in first))
    potential = -ca.mtimes(ca.DM(weights), kappa)  # V at the nodes, then at theta_minus
    delta, _ = package.impact_ratio(*params, *alphas, hi)
    d2 = delta * delta
    zeta_star = -potential[-1] / (1 - d2)
    zeta = d2 * zeta_star - potential[:-1]
    zeta_points = d2 * zeta_star + ca.mtimes(ca.DM(at_points[:-1]), kappa)
    nlp.add(1 - d2, 1e-6, math.inf)
    nlp.add(-potential[-1], 0.0, math.inf)
    nlp.add(zeta - request.zeta_margin * zeta_star, 0.0, math.inf)
    nlp.add(zeta_points - request.zeta_margin * zeta_star, 0.0, math.inf)
    nlp.add(np.sign(hi - lo) * inertia, 1e-9, math.inf)
    period = ca.dot(ca.DM(weights[-1]), inertia / ca.sqrt(2 * ca.fmax(zeta, 1e-12)))
    length = fn(a, hi, 1.0)[5]
    nlp.add(length - request.speed * period, 0.0, 0.0)
    if request.step_length is not None:
        nlp.add(length - request.step_length, 0.0, 0.0)
    _constrain_points(nlp, [fn(a, t, zeta_points[j]) for j, t in enumerate(points)], request)
    nlp.start = [0.0 if spec["defaults"][k] is None else float(spec["defaults"][k])
                 for k in free]  # fmt: skip
    _lands(nlp, model, surface, params, theta_after)
    clearance = _clearance_function(model, surface, params)
    if request.clearance is not None and clearance is not None:
        for s in _away(np.linspace(0.0, 1.0, CLEARANCE_POINTS + 2)[1:-1]):
            nlp.add(clearance(a, lo + s * (hi - lo)) - _profile(request.clearance, s),
                    0.0, math.inf)  # fmt: skip
    _objective(nlp, [fn(a, t, zeta[j]) for j, t in enumerate(nodes)], weights[-1],
               np.sign(hi - lo), request)  # fmt: skip
    return nlp


def _lands(nlp: _Nlp, model: HybridModel, surface: _SymbolicSurface,
           params: Sequence[float], theta_after: Any) -> None:  # fmt: skip
    """The step event's guard (the swing foot's height) zero at ``theta_minus`` where the
    phase's equality does not already hold it there: a walker with knees lands its swing
    foot there only if the outputs' last coefficients put it on the ground, a rigid leg
    lands it by geometry once the phase after the impact is ``theta_plus`` (the guard's
    gradient then parallel to the phase's, at the start: not imposed twice)."""
    import casadi as ca

    q, _ = surface.symbolic_at(surface.theta_minus)
    x = ca.vertcat(*q, *([0.0] * surface.n))
    guard = model.symbolic(f"event_{model.step_event['name']}_guard", ca.DM(list(params)), x)
    if not ca.depends_on(guard, nlp.z):
        return
    rows = ca.Function("rows", [nlp.z], [ca.jacobian(ca.vertcat(theta_after, guard), nlp.z)])
    if np.linalg.matrix_rank(np.array(rows(nlp.start), float), tol=1e-9) == 2:
        nlp.add(guard, 0.0, 0.0)


def _objective(nlp: _Nlp, at: list, weights: np.ndarray, sense: float,
               request: HzdRequest) -> None:  # fmt: skip
    """``integral |u|^2 dt`` or the positive work (slacks) by the quadrature's weights."""
    import casadi as ca

    if request.minimize == "torque2":
        nlp.objective = sum(weights[j] * ca.sumsqr(o[2]) / o[6] for j, o in enumerate(at))
        return
    m = at[0][2].numel()
    slack = ca.SX.sym("s", m * len(at))
    for j, o in enumerate(at):
        nlp.add(slack[j * m : (j + 1) * m] - sense * o[3], 0.0, math.inf)
    nlp.objective = sum(abs(weights[j]) * ca.sum1(slack[j * m : (j + 1) * m])
                        for j in range(len(at)))  # fmt: skip
    count = nlp.z.numel()
    nlp.z = ca.vertcat(nlp.z, slack)
    nlp.lower_z = [-math.inf] * count + [0.0] * slack.numel()
    nlp.upper_z = [math.inf] * nlp.z.numel()


def _profile(clearance: float, s: Any) -> Any:
    """The least height of the swing foot at the normalised phase ``s``."""
    return clearance * np.sin(np.pi * np.asarray(s))


def _away(s: np.ndarray) -> np.ndarray:
    """The phases of ``s`` away from mid-stance (:data:`MID_STANCE`)."""
    return s[np.abs(s - 0.5) >= MID_STANCE - 1e-9]


def _constrain_points(nlp: _Nlp, at: list, request: HzdRequest) -> None:
    """Torque bounds and the ground's reaction at the points of :data:`BOUND_POINTS`."""
    import casadi as ca

    for o in at:
        if request.max_torque is not None:
            nlp.add(o[2], -request.max_torque, request.max_torque)
        tangential, normal = ca.vertsplit(o[4])
        nlp.add(normal, 0.0, math.inf)
        if request.mu is not None:
            nlp.add(ca.vertcat(request.mu * normal - tangential,
                               request.mu * normal + tangential), 0.0, math.inf)  # fmt: skip


def _solve(nlp: _Nlp, request: HzdRequest) -> tuple[np.ndarray, float, str, bool, int]:
    """IPOPT on the NLP: the free coefficients, the objective, the status, whether it
    converged, the iterations."""
    import casadi as ca

    n = nlp.z.numel()
    start = list(nlp.start) + [0.0] * (n - len(nlp.start))
    options = {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "max_iter": 500,
               "tol": 1e-10, "constr_viol_tol": 1e-10}}  # fmt: skip
    solver = ca.nlpsol(
        "hzd_gait", "ipopt", {"x": nlp.z, "f": nlp.objective, "g": ca.vertcat(*nlp.g)}, options
    )
    blas.libraries_may_have_loaded()  # IPOPT's plugin brings CasADi's OpenBLAS
    bounds = {}
    if nlp.lower_z:
        bounds = {"lbx": nlp.lower_z, "ubx": nlp.upper_z}
    out = solver(x0=start, lbg=nlp.lower, ubg=nlp.upper, **bounds)
    stats = solver.stats()
    status = str(stats.get("return_status", "unknown"))
    converged = bool(stats.get("success", False))
    return (np.array(out["x"], float).ravel(), float(out["f"]), status, converged,
            int(stats.get("iter_count", 0)))  # fmt: skip


def optimize(model: HybridModel, model_key: str, constraints: str, values: Any,
             request: HzdRequest, gains: tuple[float, float]) -> HzdOptimum:  # fmt: skip
    """The optimum of ``request`` over the Bezier coefficients of ``constraints``, verified
    by the runtime (see the module docstring)."""
    import casadi as ca

    from vsw.synthesis.hzd import analyze
    from vsw.synthesis.hzd.package import constraints_package

    request.check()
    phase = model.step_event["target"]
    if not model.phases[model.phase_index[phase]].get("inputs"):
        raise VswInputError(f"{model.name} has no inputs: virtual constraints need actuators")
    package = constraints_package(constraints, model_key, model.module)
    if package.HZD["coordinates"] != list(model.coordinates):
        raise VswInputError(f"the constraints were derived for {package.HZD['model']}, whose "
                            f"coordinates are not {model.name}'s")  # fmt: skip
    params = model.parameters(values)
    began = time.process_time()
    nlp = _build(model, package, params, request)
    built = time.process_time()
    z, objective, status, converged, iterations = _solve(nlp, request)
    solved = time.process_time()
    alphas = [float(v) for v in
              np.array(ca.Function("a", [nlp.z], [nlp.alphas])(z), float).ravel()]  # fmt: skip
    out = HzdOptimum(alphas, objective, status, converged, iterations, solved - built,
                     built - began)  # fmt: skip
    if not converged:
        out.failures.append(f"IPOPT: {status}")
        return out
    try:
        out.report = analyze(model, model_key, constraints, values, gains, True, alphas)
    except Exception as exc:  # the runtime finds no gait there: not verified, says why
        out.failures.append(f"the runtime's analysis: {str(exc).splitlines()[0]}")
        return out
    _verify(model, params, request, out)
    return out


def _verify(model: HybridModel, params: Sequence[float], request: HzdRequest,
            out: HzdOptimum) -> None:  # fmt: skip
    """The runtime's gait against the request, and the full-order loop's return and
    eigenvalues: ``out.failures`` lists what fails, ``out.verified`` if nothing does."""
    from vsw.synthesis.powered.dynamics import reaction_function

    r = out.report
    fails = out.failures
    tol = VERIFY_TOLERANCE
    checks = {"speed": r.speed, "step_length": r.step_length,
              "mismatch": max(abs(v) for v in r.mismatch),
              "peak_torque": max(r.peak_torques.values())}  # fmt: skip
    if abs(r.speed - request.speed) > tol * request.speed:
        fails.append(f"speed {r.speed:.9g}, not {request.speed:g}")
    if request.step_length is not None and abs(r.step_length - request.step_length) > (
        tol * request.step_length
    ):
        fails.append(f"step length {r.step_length:.9g}, not {request.step_length:g}")
    if checks["mismatch"] > 1e-8:
        fails.append(f"not impact invariant (mismatch {checks['mismatch']:.3g})")
    if request.max_torque is not None and checks["peak_torque"] > request.max_torque * (
        1 + BETWEEN_NODES
    ):
        fails.append(f"peak torque {checks['peak_torque']:.6g} above {request.max_torque:g}")
    phase = model.step_event["target"]
    states, torques = r.samples["states"], r.samples["torques"]
    reaction = reaction_function(model, phase)
    forces = np.array([np.array(reaction(list(params), x, u), float).ravel()
                       for x, u in zip(states, torques)])  # fmt: skip
    checks["least_normal_force"] = float(forces[:, 1].min())
    checks["friction_ratio"] = float(np.max(np.abs(forces[:, 0]) / np.abs(forces[:, 1])))
    if checks["least_normal_force"] <= 0:
        fails.append("the stance foot's normal force is not positive over the step")
    if request.mu is not None and checks["friction_ratio"] > request.mu * (1 + BETWEEN_NODES):
        fails.append(f"|tangential|/normal reaches {checks['friction_ratio']:.6g} > mu")
    _verify_clearance(model, params, request, out, checks)
    _verify_full_order(r, checks, fails)
    out.checks = checks
    out.verified = not fails


def _verify_clearance(model: HybridModel, params: Sequence[float], request: HzdRequest,
                      out: HzdOptimum, checks: dict) -> None:  # fmt: skip
    """The swing foot's margin over ``clearance sin(pi s)`` on the runtime's grid."""
    phase = model.step_event["target"]
    conditions = model.phases[model.phase_index[phase]].get("conditions", ())
    found = [(f, d) for name, f, d in conditions if name == "swing-foot-clearance"]
    if request.clearance is None or not found:
        return
    function, direction = found[0]
    r = out.report
    grid, states = r.samples["grid"], r.samples["states"]
    s = (grid - grid[0]) / (grid[-1] - grid[0])
    margin = -direction * np.array(getattr(model.module, function)(*params, *states.T), float)
    excess = (margin - _profile(request.clearance, s))[np.abs(s - 0.5) >= MID_STANCE + 1e-9]
    checks["clearance_margin"] = float(excess.min())
    if excess.min() < -BETWEEN_NODES * max(request.clearance, 0.01 * r.step_length):
        out.failures.append(f"the swing foot is {-excess.min():.3g} below its clearance")


def _verify_full_order(r: Any, checks: dict, fails: list[str]) -> None:
    """The full-order loop returns to its start after one step, its eigenvalues inside
    the unit circle, its gait the restricted map's."""
    if r.full_order is None:
        fails.append(f"the full-order loop has no gait: {r.full_order_error}")
        return
    start = np.array(list(r.full_order.state.values()), float)
    step = r.samples["full_step"]
    back = float(np.max(np.abs(np.array(step.state, float) - start)))
    checks["full_order_return"] = back
    checks["max_abs_eigenvalue"] = r.full_order.max_abs_eigenvalue
    restricted = r.zero.theta_dot_minus
    checks["full_order_theta_dot_minus"] = r.samples["full_theta_dot_minus"]
    if step.ended != "completed" or back > VERIFY_TOLERANCE * (1 + float(np.max(np.abs(start)))):
        fails.append(f"the full-order loop does not return to its start ({step.ended}, "
                     f"{back:.3g} away)")  # fmt: skip
    if not r.full_order.max_abs_eigenvalue < 1:
        fails.append(f"the full-order gait is unstable (max |eigenvalue| "
                     f"{r.full_order.max_abs_eigenvalue:.6g})")  # fmt: skip
    if abs(checks["full_order_theta_dot_minus"] - restricted) > VERIFY_TOLERANCE * abs(restricted):
        fails.append("the full-order gait is not the restricted map's")
