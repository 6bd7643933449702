"""Hybrid zero dynamics (HZD) of a model with one degree of underactuation: virtual
constraints declared in a constraints file, their surface and zero dynamics derived.

A constraints file is plain Python, like a model file: it builds ``CONSTRAINTS =
Constraints(phase=..., theta_plus=..., theta_minus=..., outputs={...})`` from the model's
coordinates (:func:`coordinates`) and the phase symbols :data:`THETA` (the phase variable's
value) and :data:`S` (the normalised phase ``s = (theta - theta_plus)/(theta_minus -
theta_plus)``). Each output is ``y_i = a_i(q) - h_i(theta)``: ``a_i`` an affine function of
the coordinates (what the actuators control), ``h_i`` an expression in ``THETA`` or ``S``,
or a :class:`Bezier` polynomial in ``s`` (Westervelt, Grizzle & Koditschek 2003, IEEE TAC
48(1):42-56, Section V), or an :class:`InvariantBezier` whose first two coefficients the
impact map sets at run time (ibid., Theorem 4's construction: the outputs vanish with their
rates just after every impact that starts on the surface).

The derivation (Westervelt et al. 2003, Section IV; Grizzle, Abba & Plestan 2001):

* the surface ``q = Phi(theta)``: ``[a(q); theta(q)] = [h(theta); theta]`` solved for ``q``
  (the phase and the controlled functions are affine in ``q`` and independent: exactly one
  degree of freedom is left);
* ``sigma``, the angular momentum about the stance foot (clockwise positive: the sense in
  which a walker that walks forward turns), linear in the rates; on the surface ``sigma =
  I(theta) theta_dot`` with ``I(theta) = sigma(Phi, Phi')``;
* the actuators exert no torque about the stance foot (checked: their generalised forces
  do no work on a rigid rotation about it), so ``d sigma/dt`` is gravity's moment,
  ``sum m_i (y_i g_x - x_i g_y)`` (``m g x_cm`` on level ground);
* with ``zeta = sigma^2 / 2``: ``d zeta/d theta = sigma (d sigma/dt)/theta_dot = kappa(theta)
  = I(theta) * moment(theta)`` (Westervelt et al. 2003, eq. (53) with their ``kappa_1
  kappa_2``), integrated at run time;
* through the impact the angular momentum about the new stance foot is conserved, so
  ``delta = sigma_+/sigma_-`` is the angular momentum about the swing foot over that about
  the stance foot, both at ``Phi(theta_minus)``, ``Phi'(theta_minus)`` (ibid., eq. (57)).

``python -m derive.hzd --model KEY --constraints FILE --out DIR`` writes the generated
package (numpy and CasADi, :mod:`derive.codegen`) into ``DIR/hzd_constraints/``;
``vsw.synthesis.hzd`` runs it in a subprocess and caches the result, as for a model file.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import math
import os
import shutil
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import sympy as sm

from derive.quantities import Derivation, Parameter, Quantity

__all__ = [
    "THETA",
    "Bezier",
    "Constraints",
    "ConstraintsError",
    "InvariantBezier",
    "Reduced",
    "S",
    "Step",
    "bezier_of",
    "coordinates",
    "derivation",
    "reduce",
    "restricted_map",
    "value",
]

THETA = sm.Symbol("hzd_theta", real=True)
"""The phase variable's value in an output's desired expression."""
S = sm.Symbol("hzd_s", real=True)
"""The normalised phase, 0 just after an impact and 1 just before the next."""


class ConstraintsError(ValueError):
    """Constraints that cannot be derived (reported in one line)."""


def coordinates(*names: str) -> tuple[sm.Symbol, ...]:
    """The model's coordinates by name, as the engine's chart has them."""
    return tuple(sm.Symbol(n, real=True) for n in names)


@dataclass(frozen=True)
class Bezier:
    """``h(s) = sum_k alpha_k C(M, k) s^k (1 - s)^(M - k)``, ``M = len(alpha) - 1``."""

    alpha: tuple

    def __post_init__(self) -> None:
        if len(self.alpha) < 2:
            raise ConstraintsError("a Bezier polynomial needs at least two coefficients")


@dataclass(frozen=True)
class InvariantBezier:
    """A Bezier polynomial of degree ``len(later) + 1`` whose coefficients ``alpha_2 ..
    alpha_M`` are ``later``; ``alpha_0`` and ``alpha_1`` follow from the impact map at run
    time (Westervelt et al. 2003: ``alpha_0`` the controlled coordinates just after the
    impact, ``alpha_1 = alpha_0 + (theta_minus - theta_plus)/M`` times their rate per unit
    rate of the phase there)."""

    later: tuple

    def __post_init__(self) -> None:
        if len(self.later) < 2:
            raise ConstraintsError("an impact-invariant Bezier polynomial needs alpha_2 .. "
                                   "alpha_M, M >= 3: at least two coefficients")  # fmt: skip


@dataclass(frozen=True)
class Step:
    """A desired value that steps at the phase value ``at``: ``before`` from ``theta_plus``
    to ``at``, ``after`` from there to ``theta_minus`` (each an expression in :data:`THETA`
    or :data:`S`, the model's parameters or the constraints' own). The configuration jumps
    there at once, moved by an impulse of the inputs: :func:`reduce` checks that the inputs
    can make the jump and that their impulse has no moment about the stance foot, so that
    ``sigma`` is carried across while ``I(theta)`` jumps."""

    at: Any
    before: Any
    after: Any


def value(k: int) -> sm.Symbol:
    """Output ``k``'s desired value in :attr:`Constraints.inverse`."""
    return sm.Symbol(f"hzd_value_{k}", real=True)


@dataclass(frozen=True)
class Constraints:
    """Virtual constraints: ``phase`` (affine in the coordinates) runs from ``theta_plus``
    just after an impact to ``theta_minus`` at the next; ``outputs`` maps each controlled
    function of the coordinates to its desired value (an expression in :data:`THETA` or
    :data:`S`, a :class:`Bezier` or an :class:`InvariantBezier`)."""

    phase: sm.Expr
    theta_plus: Any
    theta_minus: Any
    outputs: dict
    title: str = ""
    names: tuple[str, ...] = field(default=())
    inputs: tuple[str, ...] = field(default=())
    """The inputs that enforce the outputs (the others idle at zero); empty: all of them."""
    inverse: dict | None = None
    """The surface when the phase or a controlled function is not affine in the
    coordinates: each coordinate in :data:`THETA` and the outputs' values :func:`value`
    (checked: the phase and the controlled functions of it give back ``THETA`` and the
    values)."""
    parameters: dict = field(default_factory=dict)
    """The constraints' own symbols by name (beside the model's parameters), with values."""


def bezier_of(polynomial: sm.Expr, degree: int) -> tuple[sm.Expr, ...]:
    """The Bezier coefficients of degree ``degree`` of a polynomial in :data:`S` (exact,
    by degree elevation: ``alpha_k = sum_j c_j C(k, j)/C(M, j)``)."""
    poly = sm.Poly(sm.expand(polynomial), S)
    if poly.degree() > degree:
        raise ConstraintsError(f"a polynomial of degree {poly.degree()} has no Bezier form "
                               f"of degree {degree}")  # fmt: skip
    coeff = [poly.coeff_monomial(S**j) for j in range(degree + 1)]
    return tuple(
        sm.nsimplify(sum(coeff[j] * sm.binomial(k, j) / sm.binomial(degree, j)
                         for j in range(k + 1)))
        for k in range(degree + 1)
    )  # fmt: skip


def _bernstein(alpha: list, s: sm.Expr) -> sm.Expr:
    degree = len(alpha) - 1
    return sum(a * sm.binomial(degree, k) * s**k * (1 - s) ** (degree - k)
               for k, a in enumerate(alpha))  # fmt: skip


def _number(value: Any, what: str) -> float:
    try:
        out = float(sm.sympify(value))
    except (TypeError, ValueError, sm.SympifyError):
        raise ConstraintsError(f"{what} must be a number (got {value!r})") from None
    if not math.isfinite(out):
        raise ConstraintsError(f"{what} must be finite (got {value!r})")
    return out


def _by_name(expr: Any, symbols: dict[str, sm.Symbol]) -> sm.Expr:
    """``expr`` with each free symbol replaced by the model's of the same name (a file may
    make its symbols with other assumptions)."""
    expr = sm.sympify(expr)
    return expr.xreplace({s: symbols[s.name] for s in expr.free_symbols if s.name in symbols})


def _affine_row(expr: sm.Expr, q: list[sm.Symbol], what: str) -> tuple[list[float], float]:
    """The coefficients and constant of an affine function of the coordinates."""
    extra = expr.free_symbols - set(q)
    if extra:
        names = ", ".join(sorted(s.name for s in extra))
        raise ConstraintsError(f"{what} may use only the model's coordinates ({names} is not one)")
    row = [sm.diff(expr, v) for v in q]
    if any(r.free_symbols for r in row):
        raise ConstraintsError(f"{what} must be affine in the coordinates (got {expr})")
    constant = expr.xreplace(dict.fromkeys(q, 0))
    return [_number(r, what) for r in row], _number(constant, what)


@dataclass
class _Outputs:
    """The desired expressions in the phase, the coefficients as symbols."""

    desired: list[sm.Expr]
    alphas: list[sm.Symbol]
    defaults: list[float | None]
    layout: list[dict]


def _desired(constraints: Constraints, theta_plus: float, theta_minus: float) -> _Outputs:
    s_of_theta = (THETA - theta_plus) / (theta_minus - theta_plus)
    out = _Outputs([], [], [], [])
    for k, (controlled, value) in enumerate(constraints.outputs.items()):
        if isinstance(value, Bezier | InvariantBezier):
            given = (
                (None, None, *value.later) if isinstance(value, InvariantBezier) else value.alpha
            )
            symbols = [sm.Symbol(f"alpha_{k}_{j}", real=True) for j in range(len(given))]
            defaults = [None if a is None else _number(a, f"output {controlled}'s alpha_{j}")
                        for j, a in enumerate(given)]  # fmt: skip
            out.desired.append(_bernstein(symbols, s_of_theta))
            out.alphas.extend(symbols)
            out.defaults.extend(defaults)
            out.layout.append({"kind": "bezier", "count": len(symbols),
                               "invariant": isinstance(value, InvariantBezier)})  # fmt: skip
            continue
        expr = sm.sympify(value)
        extra = expr.free_symbols - {THETA, S}
        if extra:
            names = ", ".join(sorted(s.name for s in extra))
            raise ConstraintsError(f"output {controlled}'s desired value may use only THETA "
                                   f"and S, not {names}")  # fmt: skip
        out.desired.append(expr.xreplace({S: s_of_theta}))
        out.layout.append({"kind": "expression", "count": 0, "invariant": False})
    return out


def _model(model_key: str) -> Any:
    """The engine model: a built-in's module by its registry name, or a model file."""
    from derive.registry import MODEL_MODULES

    if model_key in MODEL_MODULES:
        return importlib.import_module(MODEL_MODULES[model_key]).MODEL
    return _load_file(Path(model_key), "derive_hzd_model").MODEL


def _load_file(path: Path, name: str) -> Any:
    sys.path.insert(0, str(path.parent))
    spec = importlib.util.spec_from_file_location(f"{name}_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise ConstraintsError(f"{path} is not a Python file")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _step_phase(model: Any) -> tuple[Any, Any]:
    """The phase a step starts in and the event that ends the step (a single-phase step:
    the HZD of one continuous phase and one impact)."""
    event = next(e for e in model.events if e.ends_step)
    phase = next(p for p in model.phases if p.name == event.target)
    if event.source != phase.name:
        raise ConstraintsError(f"{model.name}: the step has more than one phase; the zero "
                               "dynamics here take one phase and its impact")  # fmt: skip
    if not phase.inputs:
        raise ConstraintsError(f"{model.name} has no inputs to enforce constraints with")
    return phase, event


def _momentum(bodies: list, about: tuple, q: list, qd: list) -> sm.Expr:
    """Angular momentum of the bodies about ``about`` (clockwise positive)."""
    total = sm.Integer(0)
    for body in bodies:
        x, y = (body.position[0] - about[0], body.position[1] - about[1])
        vx, vy = (sum(sm.diff(c, v) * w for v, w in zip(q, qd)) for c in body.position)
        total += body.mass * (y * vx - x * vy)
        if hasattr(body, "inertia"):
            total -= body.inertia * sum(sm.diff(body.angle, v) * w for v, w in zip(q, qd))
    return total


def _check_no_moment(phase: Any, q: list, params: tuple[Parameter, ...],
                     inputs: tuple | None = None) -> None:  # fmt: skip
    """The inputs' generalised forces do no work on a rigid rotation about the stance foot
    (else ``d sigma/dt`` would hold the torques): checked at three random points, the
    rotation's direction in the coordinates solved by least squares. The phase's held
    coordinates (a leg's length held by its actuator) are put in first."""
    import numpy as np

    rng = np.random.default_rng(2003)
    held = dict(phase.held)
    positions = [sm.Matrix(_held(b, held).position) for b in phase.bodies]
    jac = sm.Matrix.vstack(*[p.jacobian(q) for p in positions])
    turn = sm.Matrix([c for p in positions for c in (p[1], -p[0])])
    inputs = phase.inputs if inputs is None else inputs
    forces = sm.Matrix([[sm.diff(sm.sympify(i.along).xreplace(held), v) for v in q]
                        for i in inputs])  # fmt: skip
    symbols = [p.symbol for p in params] + q
    f = sm.lambdify(symbols, (jac, turn, forces), "numpy")
    for _ in range(3):
        values = [(p.default if p.default else 1.0) for p in params]
        values += list(rng.uniform(-0.4, 0.4, len(q)))
        j, t, b = (np.array(a, float) for a in f(*values))
        w, *_ = np.linalg.lstsq(j, t.ravel(), rcond=None)
        if np.max(np.abs(j @ w - t.ravel())) > 1e-9:
            return  # the chart has no rigid rotation (a coordinate fixed to the ground)
        if np.max(np.abs(b @ w)) > 1e-9 * max(1.0, float(np.max(np.abs(b)))):
            raise ConstraintsError(
                "the inputs exert a torque about the stance foot: the zero dynamics here "
                "need one degree of underactuation there"
            )


def _surface(constraints: Constraints, q: list, desired: list) -> tuple[sm.Matrix, list]:
    """``Phi(theta)``: the affine rows of the controlled functions and the phase, solved."""
    rows, constants = [], []
    for k, controlled in enumerate(constraints.outputs):
        row, constant = _affine_row(controlled, q, f"controlled function {k} ({controlled})")
        rows.append(row)
        constants.append(constant)
    row, constant = _affine_row(constraints.phase, q, f"the phase variable ({constraints.phase})")
    rows.append(row)
    constants.append(constant)
    matrix = sm.Matrix(rows).applyfunc(sm.nsimplify)
    if matrix.rank() < len(q):
        raise ConstraintsError(
            f"the constraints leave {len(q) - matrix.rank()} degrees of freedom besides the "
            "phase, not none: the controlled functions and the phase are dependent"
        )
    target = sm.Matrix([*desired, THETA]) - sm.Matrix(constants).applyfunc(sm.nsimplify)
    return matrix.inv() * target, [*rows[-1], constants[-1]]


def derivation(model: Any, constraints: Constraints, name: str) -> Derivation:
    """The constraints' generated quantities (see the module docstring)."""
    if _needs_reduce(constraints):
        raise ConstraintsError(
            "vsw hzd's runtime takes a phase and outputs affine in the coordinates, every "
            "input and no Step; derive.hzd.restricted_map derives the map of these"
        )
    phase, event = _step_phase(model)
    q = [c.q for c in phase.coordinates]
    qd = [c.u for c in phase.coordinates]
    if len(constraints.outputs) != len(phase.inputs) or len(q) != len(phase.inputs) + 1:
        raise ConstraintsError(
            f"{model.name} has {len(q)} coordinates and {len(phase.inputs)} inputs: the "
            f"constraints give {len(constraints.outputs)} outputs; the zero dynamics here "
            "need one output per input and one coordinate more than inputs"
        )
    names = {s.name: s for s in q}
    constraints = Constraints(
        phase=_by_name(constraints.phase, names),
        theta_plus=constraints.theta_plus,
        theta_minus=constraints.theta_minus,
        outputs={_by_name(k, names): v for k, v in constraints.outputs.items()},
        title=constraints.title,
    )
    theta_plus = _number(constraints.theta_plus, "theta_plus")
    theta_minus = _number(constraints.theta_minus, "theta_minus")
    if theta_plus == theta_minus:
        raise ConstraintsError("theta_plus and theta_minus must differ")
    _check_no_moment(phase, q, model.parameters)
    outs = _desired(constraints, theta_plus, theta_minus)
    phi, phase_row = _surface(constraints, q, outs.desired)
    dphi = phi.diff(THETA)
    on = _on_surface(phase, event, q, qd, phi)
    inertia, moment = on.inertia, on.moment
    swing = on.swing.xreplace({THETA: theta_minus})
    stance = inertia.xreplace({THETA: theta_minus})
    params = tuple(p.symbol for p in model.parameters)
    args = (*params, *outs.alphas, THETA)
    out = Derivation(
        model=name,
        title=f"Virtual constraints {name} of {model.name}",
        source="derive/hzd.py",
        parameters=model.parameters,
        units="Angles in radians; the model's units otherwise.",
    )
    d_desired = [sm.diff(h, THETA) for h in outs.desired]
    out.add(Quantity("desired", args, (*outs.desired, *d_desired,
                     *(sm.diff(h, THETA) for h in d_desired)),
                     "the outputs' desired values, their first and second derivatives in the "
                     "phase",
                     returns="h, dh/dtheta, d2h/dtheta2, each one per output"))  # fmt: skip
    out.add(Quantity("surface", args, (*phi, *dphi, *dphi.diff(THETA)),
                     "the constraint surface q = Phi(theta), Phi' and Phi''",
                     returns="q, dq/dtheta, d2q/dtheta2, each one per coordinate"))  # fmt: skip
    out.add(Quantity("zero_dynamics", args, (inertia, inertia * moment, moment),
                     "I(theta) (sigma = I theta_dot), kappa = d zeta/d theta = I times "
                     "gravity's moment about the stance foot, and that moment",
                     equation="Westervelt et al. 2003, (53)",
                     returns="I, kappa, moment"))  # fmt: skip
    out.add(
        Quantity(
            "impact_ratio",
            args,
            (swing / stance, stance),
            "delta = sigma_+/sigma_- through the impact from Phi(theta_minus) (the "
            "angular momentum about the new stance foot is conserved), and I there",
            equation="Westervelt et al. 2003, (57)",
            returns="delta, I(theta_minus)",
        )
    )
    out.add(Quantity("angular_momentum", (*params, *q, *qd), on.sigma,
                     "sigma, the angular momentum about the stance foot (clockwise positive)",
                     returns="sigma"))  # fmt: skip
    out.constants["HZD"] = (
        _spec(model, constraints, q, phase_row, outs),
        "What the constraints declare, for the runtime (vsw.synthesis.hzd).",
    )
    return out


def _spec(model: Any, constraints: Constraints, q: list, phase_row: list,
          outs: _Outputs) -> dict[str, Any]:  # fmt: skip
    """What the runtime reads of the constraints (the generated package's ``HZD``)."""
    return {
        "model": model.name,
        "phase": str(constraints.phase),
        "phase_row": phase_row,
        "theta_plus": _number(constraints.theta_plus, "theta_plus"),
        "theta_minus": _number(constraints.theta_minus, "theta_minus"),
        "outputs": [str(k) for k in constraints.outputs],
        "controlled": [list(_affine_row(k, q, "")) for k in constraints.outputs],
        "alphas": [a.name for a in outs.alphas],
        "defaults": outs.defaults,
        "layout": outs.layout,
        "title": constraints.title,
        "coordinates": [s.name for s in q],
    }


# ------------------------------------------------------------------ the symbolic reduction


def _needs_reduce(constraints: Constraints) -> bool:
    """Whether the constraints use what only :func:`reduce` takes (a :class:`Step`, a
    declared inverse, a subset of the inputs or symbols of their own)."""
    steps = any(isinstance(v, Step) for v in constraints.outputs.values())
    return (
        steps
        or constraints.inverse is not None
        or bool(constraints.inputs)
        or bool(constraints.parameters)
    )


@dataclass
class Reduced:
    """The zero dynamics on a surface made of pieces: piece ``j`` runs from ``breaks[j]``
    to ``breaks[j + 1]`` (``theta_plus``, the steps' phases, ``theta_minus``), on it ``q =
    surfaces[j](theta)``, ``sigma = inertia[j] theta_dot`` and ``d sigma/dt = moment[j]``;
    ``sigma`` is continuous at the steps; ``delta = sigma_+/sigma_-`` through the impact."""

    breaks: list
    surfaces: list
    inertia: list
    moment: list
    delta: sm.Expr
    symbols: dict

    @property
    def kappa(self) -> list:
        """``d zeta/d theta = I(theta) * moment(theta)`` on each piece (Westervelt et al.
        2003, (53))."""
        return [i * m for i, m in zip(self.inertia, self.moment)]


def _used_inputs(phase: Any, names: tuple[str, ...]) -> tuple:
    if not names:
        return tuple(phase.inputs)
    known = {i.name: i for i in phase.inputs}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ConstraintsError(f"the model has no input {unknown[0]!r} (it has "
                               f"{', '.join(known)})")  # fmt: skip
    return tuple(known[n] for n in names)


def _symbolic(expr: Any, symbols: dict, what: str) -> sm.Expr:
    """``expr`` in the model's and the constraints' symbols, :data:`THETA` and :data:`S`."""
    expr = _by_name(expr, symbols)
    extra = expr.free_symbols - set(symbols.values()) - {THETA, S}
    if extra:
        names = ", ".join(sorted(str(e) for e in extra))
        raise ConstraintsError(f"{what} may use THETA, S and the model's and the "
                               f"constraints' parameters, not {names}")  # fmt: skip
    return expr


def _pieces(constraints: Constraints, symbols: dict, s_of_theta: sm.Expr) -> tuple[list, list]:
    """The steps' phases in order and each piece's desired values (one per output)."""
    first, later = [], []
    for k, (controlled, v) in enumerate(constraints.outputs.items()):
        if isinstance(v, Bezier | InvariantBezier):
            raise ConstraintsError(
                f"output {controlled}: the symbolic reduction takes expressions and Steps; "
                "Bezier outputs go to vsw hzd"
            )
        if isinstance(v, Step):
            at = _symbolic(v.at, symbols, f"output {controlled}'s step")
            later.append((at, k, _symbolic(v.after, symbols, f"output {controlled}")))
            v = v.before
        first.append(_symbolic(v, symbols, f"output {controlled}").xreplace({S: s_of_theta}))
    breaks: list = []
    for at, _, _ in later:
        if at not in breaks:
            breaks.append(at)
    if len(breaks) > 1:
        try:
            breaks.sort(key=lambda b: float(b))
        except TypeError:
            raise ConstraintsError("steps at more than one symbolic phase: their order is "
                                   "not known") from None  # fmt: skip
    pieces = [first]
    for at in breaks:
        piece = list(pieces[-1])
        for where, k, after in later:
            if where == at:
                piece[k] = after.xreplace({S: s_of_theta})
        pieces.append(piece)
    return breaks, pieces


def _sample(exprs: list, rng: Any, fixed: dict) -> list[float]:
    """``exprs`` at random values in [0.5, 1.5] of every free symbol not in ``fixed``."""
    free = set().union(*(sm.sympify(e).free_symbols for e in exprs)) - set(fixed)
    values = {**fixed, **{f: rng.uniform(0.5, 1.5) for f in sorted(free, key=str)}}
    return [complex(sm.sympify(e).xreplace(values).evalf()) for e in exprs]


def _inverse_surface(constraints: Constraints, q: list, symbols: dict) -> sm.Matrix:
    """The declared inverse, checked at five random points: the phase of it is THETA and
    the controlled functions of it are the values."""
    import numpy as np

    inverse = {_by_name(k, symbols): _by_name(v, symbols) for k, v in constraints.inverse.items()}
    if set(inverse) != set(q):
        raise ConstraintsError("the inverse must give every coordinate of the model")
    phi = sm.Matrix([inverse[v] for v in q])
    on = dict(zip(q, phi))
    values = [value(k) for k in range(len(constraints.outputs))]
    checks = [constraints.phase.xreplace(on) - THETA]
    checks += [c.xreplace(on) - h for c, h in zip(constraints.outputs, values)]
    rng = np.random.default_rng(2003)
    for _ in range(5):
        fixed = {THETA: rng.uniform(-1.0, 1.0)}
        worst = max(abs(v) for v in _sample(checks, rng, fixed))
        if not worst < 1e-9:
            raise ConstraintsError(
                "the inverse does not invert the phase and the controlled functions (off by "
                f"{worst:.3g} at a random point)"
            )
    return phi


def _mass_matrix(bodies: list, q: list) -> sm.Matrix:
    """``M(q)`` of the bodies (``T = q_dot' M q_dot / 2``)."""
    out = sm.zeros(len(q), len(q))
    for body in bodies:
        jac = sm.Matrix(body.position).jacobian(q)
        out += body.mass * jac.T * jac
        if hasattr(body, "inertia"):
            turn = sm.Matrix([body.angle]).jacobian(q)
            out += body.inertia * turn.T * turn
    return out


def _check_jump(before: sm.Matrix, after: sm.Matrix, at: sm.Expr, inputs: tuple,
                bodies: list, q: list) -> None:  # fmt: skip
    """The jump ``Phi_after(at) - Phi_before(at)`` is a displacement the inputs' impulse
    makes: in the span of ``M^-1 B`` (checked at three random points, numerically)."""
    import numpy as np

    on = dict(zip(q, before.xreplace({THETA: at})))
    jump = (after - before).xreplace({THETA: at})
    forces = sm.Matrix([[sm.diff(i.along, v) for v in q] for i in inputs]).T.xreplace(on)
    moves = _mass_matrix(bodies, q).xreplace(on).LUsolve(forces)
    rng = np.random.default_rng(2003)
    for _ in range(3):
        entries = _sample([*moves, *jump], rng, {})
        a = np.array(entries[: len(moves)]).reshape(moves.shape)
        b = np.array(entries[len(moves) :])
        w, *_ = np.linalg.lstsq(a, b, rcond=None)
        if np.max(np.abs(a @ w - b)) > 1e-9 * max(1.0, float(np.max(np.abs(b)))):
            raise ConstraintsError(f"the step at theta = {at} moves the configuration where "
                                   "the inputs' impulse cannot")  # fmt: skip


def reduce(model: Any, constraints: Constraints) -> Reduced:
    """The zero dynamics of ``constraints`` on ``model`` in closed form, the constraints'
    values symbolic if they are (their own :attr:`Constraints.parameters` as symbols)."""
    phase, event = _step_phase(model)
    inputs = _used_inputs(phase, tuple(constraints.inputs))
    q = [c.q for c in phase.coordinates]
    qd = [c.u for c in phase.coordinates]
    if len(constraints.outputs) != len(inputs) or len(q) != len(inputs) + 1:
        raise ConstraintsError(f"{len(q)} coordinates, {len(inputs)} inputs and "
                               f"{len(constraints.outputs)} outputs: the zero dynamics need "
                               "one output per input and one coordinate more")  # fmt: skip
    symbols = {p.symbol.name: p.symbol for p in model.parameters}
    symbols.update({n: sm.Symbol(n, real=True) for n in constraints.parameters})
    names = {**symbols, **{v.name: v for v in q}}
    plus = _symbolic(constraints.theta_plus, symbols, "theta_plus")
    minus = _symbolic(constraints.theta_minus, symbols, "theta_minus")
    constraints = Constraints(
        phase=_by_name(constraints.phase, names),
        theta_plus=plus,
        theta_minus=minus,
        outputs={_by_name(k, names): v for k, v in constraints.outputs.items()},
        inverse=constraints.inverse,
    )
    _check_no_moment(phase, q, model.parameters, inputs)
    breaks, pieces = _pieces(constraints, symbols, (THETA - plus) / (minus - plus))
    if constraints.inverse is not None:
        chart = _inverse_surface(constraints, q, names)
        surfaces = [chart.xreplace({value(k): h for k, h in enumerate(p)}) for p in pieces]
    else:
        surfaces = [_surface(constraints, q, p)[0] for p in pieces]
    bodies = [_held(b, dict(phase.held)) for b in phase.bodies]
    for at, before, after in zip(breaks, surfaces, surfaces[1:]):
        _check_jump(before, after, at, inputs, bodies, q)
    pieces_on = [_on_surface(phase, event, q, qd, phi) for phi in surfaces]
    inertia = [sm.simplify(on.inertia) for on in pieces_on]
    moments = [sm.simplify(on.moment) for on in pieces_on]
    delta = pieces_on[-1].swing.xreplace({THETA: minus}) / inertia[-1].xreplace({THETA: minus})
    return Reduced([plus, *breaks, minus], surfaces, inertia, moments, delta, symbols)


def restricted_map(reduced: Reduced) -> tuple[sm.Expr, sm.Expr | None]:
    """``delta^2`` and ``V(theta_minus)`` of the restricted map ``zeta_{k+1} = delta^2
    zeta_k - V(theta_minus)`` on ``zeta = sigma^2/2`` just before the impact (Westervelt
    et al. 2003, (58)-(60)): ``V = -integral kappa`` over the pieces, ``zeta`` carried
    across the steps; ``None`` when sympy finds no closed form (the runtime's quadrature
    then)."""
    total = sm.Integer(0)
    for lo, hi, kappa in zip(reduced.breaks, reduced.breaks[1:], reduced.kappa):
        part = sm.integrate(kappa, (THETA, lo, hi))
        if part.has(sm.Integral):
            return reduced.delta**2, None
        total += part
    return reduced.delta**2, -total


@dataclass(frozen=True)
class _OnSurface:
    """The step phase's momenta and gravity's moment on a surface ``q = Phi(theta)``."""

    sigma: sm.Expr
    """The angular momentum about the stance foot, in the coordinates and their rates."""
    inertia: sm.Expr
    """``I(theta)``: ``sigma`` on the surface per unit ``theta_dot``."""
    moment: sm.Expr
    """Gravity's moment about the stance foot on the surface."""
    swing: sm.Expr
    """The angular momentum about the new contact on the surface per unit ``theta_dot``
    (the impact conserves it: ``delta`` is it over ``I`` at ``theta_minus``)."""


def _on_surface(phase: Any, event: Any, q: list, qd: list, phi: sm.Matrix) -> _OnSurface:
    """:class:`_OnSurface` of the phase's bodies (held coordinates put in) on ``phi``."""
    bodies = [_held(b, dict(phase.held)) for b in phase.bodies]
    rates, on = dict(zip(qd, phi.diff(THETA))), dict(zip(q, phi))
    sigma = _momentum(bodies, (0, 0), q, qd)
    gx, gy = phase.gravity
    moment = sum(b.mass * (b.position[1] * gx - b.position[0] * gy) for b in bodies)
    contact = _held_point(phase, event.reset.new_contact)
    swing = _momentum(bodies, contact, q, qd)
    return _OnSurface(sigma, sigma.xreplace(rates).xreplace(on), moment.xreplace(on),
                      swing.xreplace(rates).xreplace(on))  # fmt: skip


def _held_point(phase: Any, name: str) -> tuple[sm.Expr, ...]:
    """The phase's named point (the new contact) with its held coordinates put in."""
    held = dict(phase.held)
    return tuple(sm.sympify(c).xreplace(held) for c in phase.points[name])


def _held(body: Any, held: dict) -> Any:
    """A body with the phase's held coordinates put in."""
    if not held:
        return body
    changes = {"position": tuple(sm.sympify(c).xreplace(held) for c in body.position)}
    if hasattr(body, "angle"):
        changes["angle"] = sm.sympify(body.angle).xreplace(held)
    return type(body)(**{**body.__dict__, **changes})


def render(model_key: str, constraints_path: Path) -> dict[str, str]:
    """The generated package's files for a constraints file and a model."""
    from derive import codegen

    module = _load_file(constraints_path, "derive_hzd_constraints")
    constraints = getattr(module, "CONSTRAINTS", None)
    if not isinstance(constraints, Constraints):
        raise ConstraintsError(f"{constraints_path} defines no CONSTRAINTS = Constraints(...)")
    model = _model(model_key)
    return {"__init__.py": codegen.python_module(derivation(model, constraints, "hzd"))}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m derive.hzd")
    parser.add_argument("--model", required=True)
    parser.add_argument("--constraints", required=True, type=Path)
    parser.add_argument("--out", required=True, type=Path)
    args = parser.parse_args(argv)
    try:
        files = render(args.model, args.constraints.resolve())
    except ConstraintsError as exc:
        print(f"python -m derive.hzd: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # a file that does not run: its error in one line
        where = f"{type(exc).__name__}: {exc}".splitlines()[0]
        print(f"python -m derive.hzd: {args.constraints}: {where}", file=sys.stderr)
        return 2
    staging = args.out.with_name(f".{args.out.name}.{os.getpid()}")
    shutil.rmtree(staging, ignore_errors=True)
    (staging / "hzd_constraints").mkdir(parents=True)
    for rel, text in files.items():
        (staging / "hzd_constraints" / rel).write_text(text)
    shutil.rmtree(args.out, ignore_errors=True)
    os.replace(staging, args.out)
    return 0


if __name__ == "__main__":
    # Run as derive.hzd, the module the constraints file imports (not as __main__, whose
    # classes would be other classes).
    from derive.hzd import main as _main_of_module

    raise SystemExit(_main_of_module())
