"""The finite-time leg extension (TLE) model of Virtual Slope Walking.

The ILE model (``derive/models/ile.py``) with the instantaneous extension replaced by one
over a stance-angle interval: a point mass on massless telescopic legs; the stance leg is
``beta r_e`` long from heelstrike until the stance angle reaches ``theta_II``, then an
actuator drives it along a prescribed profile to ``r_e`` at ``theta_II + delta``, and it
stays ``r_e`` long until heelstrike, where the swing leg, ``beta r_e`` long at the
inter-leg angle ``phi0``, touches the ground (the ILE's heelstrike, eq. (5), (6), (11)).

The profile (a choice of this model) is the cubic smoothstep in the stance angle,

    r(theta) = beta + (1 - beta) S(s),  S(s) = 3 s**2 - 2 s**3,  s = (theta - theta_II) / delta,

which has zero slope at both ends, so the leg length and its rate are continuous: the
extension starts and ends without a jump (:class:`~derive.engine.model.Continuous`).

Conventions (the ILE's): ``theta`` is the stance-leg angle from the vertical, positive when
the hip is ahead of the stance foot; lengths in ``r_e``, time in ``sqrt(r_e / g)``, mass
``m = 1``, so energies are in ``m g r_e`` and forces in ``m g``.

What the engine derives from these facts (equations of motion, the actuator force, the
resets, the closed-form stride map) is in :func:`derive.engine.model_derivation`. This
module adds the model's own extension: the stride map in a form that evaluates without
cancellation, the leg force, the actuator work, the ground contact, the existence
conditions, and the limit ``delta -> 0`` (the ILE).

Why a second form of the stride map: the angular momentum per unit mass ``h = r**2 omega``
obeys ``d(h**2)/dtheta = 2 r**3 sin(theta)`` (checked against the engine's equations of
motion), so the extension adds ``2 J`` to ``h**2`` with ``J = int r**3 sin(theta) dtheta``
over the extension. Its closed form (sympy's, through the engine) holds powers of
``1/delta`` up to ``1/delta**9`` that cancel: at ``delta = 0.3`` it loses all digits in
double precision. Here (:mod:`derive.models.tle_moments`) ``J`` is written through the
moments ``E_m(y) = int_0^1 t**m exp(i y t) dt`` (``m = 0..9``): ``E_9`` from its power series
(alternating, truncated where the next term is below 1e-18 for ``y <= pi/2``) and the
others by the downward recurrence ``E_(m-1) = (exp(i y) - i y E_m) / m`` (integration by
parts; each step multiplies an earlier error by at most ``y/m``), so the map is accurate
to a few ulp for every ``delta`` in ``(0, pi/2)``; the derivation checks it against the
engine's closed form at 60 digits.
"""

from __future__ import annotations

import functools
import random

import sympy as sm

from derive.engine import model_derivation
from derive.engine.hybrid import (
    integrate_polynomial_trig,
    phase_dynamics,
    reset,
    stride_closed_form,
)
from derive.engine.model import (
    Continuous,
    Coordinate,
    Event,
    Impact,
    Model,
    Phase,
    PointMass,
    leg,
)
from derive.engine.numeric import evaluate
from derive.models.common import PI, closest_to_apex_cos, fell_backward, lift_off
from derive.models.families import (
    extension_angle,
    extension_interval,
    heelstrike_inter_leg_angle,
    shortening_ratio,
)
from derive.models.tle_moments import MOMENT_ORDER, moment_integral
from derive.quantities import Condition, Derivation, Quantity

PARAMETERS = (
    shortening_ratio(
        default=0.93,
        computed=(1e-12, 1.0),
        computed_reason="q^f grows as 1/beta^2 (1.1e24 at 1e-12) and overflows double "
        "precision below about 1e-154 (1e-300 failed in the generated code)",
    ),
    extension_angle(description="stance leg angle at which the extension starts", default=-0.1),
    heelstrike_inter_leg_angle(equation="ILE eq. (16)", default=0.7),
    extension_interval(
        bounds="0 < delta < theta_IV - theta_II < phi0 < pi/2 for a gait",
        default=0.4,
        computed=(1e-9, PI / 2),
        computed_reason="the leg force grows as 1/delta^2: below 1e-9 rad the extension "
        "is too stiff to integrate (at 1e-12 the search ran over 2 min); the instantaneous "
        "extension is the ile model",
    ),
)
beta, theta_II, phi0, delta = (p.symbol for p in PARAMETERS)

THETA = Coordinate(
    "theta",
    "stance leg angle",
    "rad",
    reference="the vertical",
    positive="the hip ahead of the stance foot",
)
theta, omega = THETA.q, THETA.u
r = sm.Symbol("r", positive=True)  # stance leg length in r_e: held by the leg actuator


def smoothstep(s: sm.Expr) -> sm.Expr:
    """The extension profile's shape: 0 at s = 0, 1 at s = 1, zero slope at both ends."""
    return 3 * s**2 - 2 * s**3


def profile(angle: sm.Expr) -> sm.Expr:
    """Stance leg length (in r_e) during the extension, as a function of the stance angle."""
    return beta + (1 - beta) * smoothstep((angle - theta_II) / delta)


def _stance(name: str, length: sm.Expr, points: dict | None = None) -> Phase:
    return Phase(
        name,
        coordinates=(THETA,),
        bodies=(PointMass("hip", 1, leg(theta, r)),),
        gravity=(sm.Integer(0), sm.Integer(-1)),
        held={r: length},
        points=points or {},
    )


# The swing leg, beta r_e long at the inter-leg angle phi0 ahead of the (extended) stance leg.
SWING_FOOT = tuple(h - f for h, f in zip(leg(theta, 1), leg(theta - phi0, beta)))
SHORT = _stance("short", beta)
EXTENSION = _stance("extension", profile(theta))
LONG = _stance("long", sm.Integer(1), {"swing_foot": SWING_FOOT})
THETA_I = -sm.atan((beta - sm.cos(phi0)) / sm.sin(phi0))
"""Stance angle just after heelstrike, ILE eq. (11) (the engine checks it against the guard)."""

MODEL = Model(
    actuators={r: "leg"},
    name="tle",
    title="Finite-time leg extension model of Virtual Slope Walking",
    description="ILE walker whose stance leg extends from beta r_e to r_e along a cubic "
    "smoothstep over the stance angles [theta_II, theta_II + delta]",
    source="derive/models/tle.py",
    parameters=PARAMETERS,
    phases=(SHORT, EXTENSION, LONG),
    events=(
        Event("extension_start", "short", "extension", theta - theta_II, +1, Continuous(),
              at=theta_II),
        Event("extension_end", "extension", "long", theta - theta_II - delta, +1, Continuous(),
              at=theta_II + delta),
        Event("heelstrike", "long", "short", SWING_FOOT[1], -1,
              Impact("swing_foot", {theta: theta - phi0}), at=THETA_I + phi0, ends_step=True,
              equation="(5), (6)"),
    ),
    failures=(fell_backward(THETA, "the stance leg stops and falls back"), lift_off()),
    units={"time": "sqrt(r_e/g)", "length": "r_e", "mass": "m", "energy": "m g r_e",
           "force": "m g"},
    step_length=SWING_FOOT[0],
    section={"theta": THETA_I},  # just after heelstrike, as the ILE (eq. 11)
    search={"theta_dot": (0.0, 3.0)},
)  # fmt: skip

# --- symbols of the extension quantities ---------------------------------------------------

q = sm.Symbol("q", nonnegative=True)  # omega_I**2 just after heelstrike (the section)
fraction = sm.Symbol("fraction", real=True)  # position in the extension, s in [0, 1]
P = (beta, theta_II, phi0, delta)
cos_I, sin_I = sm.Symbol("cos_theta_I", positive=True), sm.Symbol("sin_theta_I", real=True)
cos_IV, sin_IV = sm.Symbol("cos_theta_IV", positive=True), sm.Symbol("sin_theta_IV", real=True)
theta_I_s, theta_IV_s = sm.symbols("theta_I theta_IV", real=True)  # in derived forms

LEG_FORCE_SAMPLES = 16
"""The leg force is evaluated at s = k/16, k = 0..16, of the extension (see
:func:`extension_margins`)."""


def _check_agree(a: sm.Expr, b: sm.Expr, what: str, tol: float = 1e-15, points: int = 3,
                 extra: dict | None = None, inter: tuple = ()) -> None:  # fmt: skip
    """``a`` and ``b`` agree at random gaits-like points, evaluated with 60 digits; ``a``'s
    intermediates ``inter`` (name, value) are evaluated first, in order."""
    rng = random.Random(20261212)
    for _ in range(points):
        values = {
            beta: rng.uniform(0.75, 0.98), theta_II: rng.uniform(-0.25, 0.15),
            phi0: rng.uniform(0.4, 1.0), delta: rng.uniform(0.02, 0.6),
            q: rng.uniform(0.1, 0.6), theta: rng.uniform(-0.3, 0.5),
            omega: rng.uniform(0.2, 1.0), fraction: rng.uniform(0.0, 1.0),
            theta_I_s: rng.uniform(-0.3, 0.0), theta_IV_s: rng.uniform(0.2, 0.6),
        }  # fmt: skip
        values.update(extra or {})
        va, vb = evaluate((a, b), values, 60, inter)
        if abs(va - vb) > tol * max(1, abs(vb)):
            raise AssertionError(f"{what}: {va} != {vb} at {values}")


# --- the law of the angular momentum ---------------------------------------------------------


@functools.cache
def momentum_law() -> dict[str, sm.Expr]:
    """``h = r**2 omega`` from the engine's momenta and ``d(h**2)/dtheta = 2 r**3 sin theta``
    in every phase, checked against the engine's equations of motion.

    Along a phase ``d(h**2)/dtheta = 2 h (dh/dt) / omega`` with ``dh/dt`` from the chain rule
    and the engine's acceleration.
    """
    out = {}
    for phase in (SHORT, EXTENSION, LONG):
        dyn = phase_dynamics(phase)
        length = sm.sympify(phase.held[r])
        h = dyn.momenta[theta].xreplace({r: length})
        rate = h.diff(theta) * omega + h.diff(omega) * dyn.accelerations[0]
        law = 2 * h * rate / omega
        _check_agree(law, 2 * length**3 * sm.sin(theta), f"d(h**2)/dtheta in {phase.name}")
        out[phase.name] = h
    return out


def _h2_change(length: sm.Expr, start: sm.Expr, end: sm.Expr) -> sm.Expr:
    """Change of ``h**2`` over a phase of constant length: the integral of the law."""
    s = sm.Dummy("s", real=True)
    return sm.integrate(2 * length**3 * sm.sin(s), (s, start, end))


# --- the stable extension integral -----------------------------------------------------------


@functools.cache
def cubed_profile_terms() -> tuple[tuple[sm.Expr, tuple[sm.Rational, ...]], ...]:
    """``r(s)**3 = sum_j w_j(beta) S(s)**j`` with ``w_j >= 0``: each ``(w_j, coefficients
    of S**j in s**0..s**9)``; the grouping keeps ``beta`` and ``1 - beta`` apart."""
    s = sm.Symbol("s", real=True)
    terms = []
    for j in range(4):
        weight = sm.binomial(3, j) * beta ** (3 - j) * (1 - beta) ** j
        poly = sm.Poly(smoothstep(s) ** j, s)
        coeffs = tuple(poly.coeff_monomial(s**n) for n in range(MOMENT_ORDER + 1))
        terms.append((weight, coeffs))
    check = sum((w * sum(c * s**n for n, c in enumerate(cs)) for w, cs in terms), sm.Integer(0))
    if sm.expand(check - profile(theta_II + delta * s) ** 3) != 0:
        raise AssertionError("r**3 is not the sum of its smoothstep terms")
    return tuple(terms)


def extension_integral(x: sm.Expr, tag: str) -> tuple[list[tuple[sm.Symbol, sm.Expr]], sm.Expr]:
    """``J(x) = int_{theta_II}^{theta_II + delta x} r**3 sin(theta) dtheta`` as named
    intermediates (their names end in ``tag``) and an expression over them, in moment form
    (:func:`derive.models.tle_moments.moment_integral`)."""
    return moment_integral(x, tag, cubed_profile_terms(), theta_II, delta)


# --- the heelstrike geometry -----------------------------------------------------------------


@functools.cache
def geometry() -> list[tuple[sm.Symbol, sm.Expr]]:
    """``cos/sin theta_I`` and ``cos/sin theta_IV`` as intermediates, in forms without
    cancellation for short steps (the ILE's), checked against the engine's section angle
    and the heelstrike guard."""
    section = stride_closed_form(MODEL).section_angle
    rho = sm.Symbol("rho", positive=True)
    foot_gap = (1 - beta) ** 2 + 2 * beta * sm.sin(phi0) ** 2 / (1 + sm.cos(phi0))
    inter = [
        (rho, sm.sqrt(foot_gap)),
        (cos_I, sm.sin(phi0) / rho),
        (sin_I, (sm.cos(phi0) - beta) / rho),
        (cos_IV, beta * cos_I),  # equal hip heights on both legs, eq. (5)
        (sin_IV, sin_I * sm.cos(phi0) + cos_I * sm.sin(phi0)),
    ]
    for name, value, reference in (
        ("cos theta_I", cos_I, sm.cos(section)),
        ("sin theta_I", sin_I, sm.sin(section)),
        ("cos theta_IV", cos_IV, sm.cos(section + phi0)),
        ("sin theta_IV", sin_IV, sm.sin(section + phi0)),
    ):
        _check_agree(value, reference, name, inter=tuple(inter))
    return inter


ANGLES = {sm.cos(theta_I_s): cos_I, sm.sin(theta_I_s): sin_I,
          sm.cos(theta_IV_s): cos_IV, sm.sin(theta_IV_s): sin_IV}  # fmt: skip


def one_minus_eigenvalue() -> sm.Expr:
    """``1 - lambda`` as ``(1 - beta)(1 + beta) + beta**2 sin**2 phi0`` (no cancellation)."""
    form = (1 - beta) * (1 + beta) + beta**2 * sm.sin(phi0) ** 2
    _check_agree(form, 1 - stride_closed_form(MODEL).slope, "1 - lambda")
    return form


# --- the stride map with the extension integral as a symbol ----------------------------------

J = sm.Symbol("J", real=True)  # the extension integral over the whole extension


@functools.cache
def stride() -> dict[str, sm.Expr]:
    """``h**2`` at the phase ends and the stride map, in terms of ``q``, ``J`` and the
    heelstrike angles (symbols ``theta_I``, ``theta_IV``): the law of :func:`momentum_law`
    integrated phase by phase, the heelstrike reset from the engine.
    """
    h = momentum_law()
    theta_III = theta_II + delta
    h2_I = h["short"].xreplace({omega: sm.sqrt(q)}) ** 2
    h2_II = h2_I + _h2_change(beta, theta_I_s, theta_II)
    h2_III = h2_II + 2 * J
    h2_IV = h2_III + _h2_change(sm.Integer(1), theta_III, theta_IV_s)
    omega_IV_sq = h2_IV  # r = 1
    factor = reset(MODEL, "heelstrike")[1][0].xreplace({omega: 1})
    stride_map = sm.expand(factor**2 * omega_IV_sq)
    return {
        "h2_I": h2_I,
        "h2_II": sm.expand(h2_II),
        "h2_III": sm.expand(h2_III),
        "omega_IV_squared": sm.expand(omega_IV_sq),
        "stride_map": stride_map,
        "reset_factor": factor,
    }


@functools.cache
def full_integral() -> tuple[list[tuple[sm.Symbol, sm.Expr]], sm.Expr]:
    """``J`` over the whole extension (``x = 1``) as intermediates; checked against the
    closed form sympy integrates."""
    inter, value = extension_integral(sm.Integer(1), "full")
    s = sm.Dummy("s", real=True)
    closed = integrate_polynomial_trig(
        delta * profile(theta_II + delta * s) ** 3 * sm.sin(theta_II + delta * s), s, 0, 1
    )
    _check_agree(value, closed, "J (series form)", tol=1e-17, inter=tuple(inter))
    return inter, value


def _on_geometry(expr: sm.Expr) -> sm.Expr:
    """Heelstrike angles' cos/sin replaced by the names :func:`geometry` defines."""
    return sm.expand(expr).xreplace(ANGLES)


@functools.cache
def stride_forms() -> dict[str, object]:
    """The stride map, its fixed point and the energies in evaluation form, each checked
    against the engine's closed form (60 digits at random points)."""
    st = stride()
    geo = geometry()
    j_inter, j_value = full_integral()
    inter = [*geo, *j_inter, (J, j_value)]
    stride_map = _on_geometry(st["stride_map"])
    slope = stride_map.diff(q)
    offset = sm.collect(stride_map.xreplace({q: 0}), [J], sm.factor)
    engine = stride_closed_form(MODEL)
    if sm.simplify(slope - engine.slope) != 0:
        raise AssertionError(f"the eigenvalue is not the engine's: {slope}")
    check = {}
    for k in range(3):  # the engine's closed form cancels badly: many digits
        check = {delta: sm.Float([0.05, 0.3, 0.9][k], 80)}
        _check_agree(offset, engine.offset, "stride map offset", tol=1e-15, points=1,
                     extra=check, inter=tuple(inter))  # fmt: skip
    q_fixed = offset / one_minus_eigenvalue()
    return {"intermediates": inter, "stride_map": slope * q + offset, "offset": offset,
            "slope": slope, "q_fixed": q_fixed}  # fmt: skip


@functools.cache
def energies() -> dict[str, sm.Expr]:
    """Energy added by the actuator (the extension), lost at heelstrike, in ``m g r_e``,
    as functions of ``q`` of the same step (symbols ``J``, heelstrike angles).

    The point mass gains energy only from the leg actuator (gravity is conservative), so
    the actuator's work over the extension is ``E(III) - E(II)``, each from the engine's
    phase energy at the ends of the extension (where the leg's rate is zero).
    """
    st = stride()
    theta_III = theta_II + delta
    e_short = phase_dynamics(SHORT).energy
    e_ext = phase_dynamics(EXTENSION).energy
    e_long = phase_dynamics(LONG).energy

    def at(energy, angle, h2, length):
        return energy.xreplace({theta: angle, omega: sm.sqrt(h2) / length**2})

    e_II = at(e_ext, theta_II, st["h2_II"], beta)
    e_III = at(e_ext, theta_III, st["h2_III"], 1)
    # The engine's energies of the neighbouring phases agree at the ends (continuity).
    some_j = {J: sm.Rational(1, 10)}
    e_short_II = at(e_short, theta_II, st["h2_II"], beta)
    _check_agree(e_II.xreplace(some_j), e_short_II.xreplace(some_j), "energy at II")
    e_long_III = at(e_long, theta_III, st["h2_III"], 1)
    _check_agree(e_III.xreplace(some_j), e_long_III.xreplace(some_j), "energy at III")
    q_next = st["stride_map"]
    e_IV = at(e_long, theta_IV_s, st["omega_IV_squared"], 1)
    e_I_next = at(e_short, theta_I_s, beta**4 * q_next, beta)
    added = sm.expand(e_III - e_II)
    lost = sm.expand((e_IV - e_I_next).xreplace({sm.cos(theta_IV_s): beta * sm.cos(theta_I_s)}))
    return {"added": added, "dissipated": lost}


# --- the limit delta -> 0 --------------------------------------------------------------------


@functools.cache
def ile_limit() -> dict[str, sm.Expr]:
    """Taylor coefficients at ``delta = 0`` of the fixed point and of the energy input.

    ``J`` is ``delta int_0^1 r(s)**3 sin(theta_II + delta s) ds``; its Taylor series in
    ``delta`` (of the sine, term by term: the integrand is entire) has polynomial
    coefficients. With them the fixed point is ``q0 + q1 delta + q2 delta**2 + O(delta**3)``
    and the actuator work at the fixed point ``E0 + E1 delta + E2 delta**2 + O(delta**3)``;
    ``q0``, ``E0`` are the ILE's (10), (20) (tests compare), the eigenvalue is
    ``beta**2 cos**2 phi0`` for every ``delta`` (19).

    Returns the coefficients, and ``D(delta) = J + cos(theta_II + delta) - cos theta_II``,
    the integral of ``(r**3 - 1) sin(theta)`` over the extension, by which the TLE's
    stride-map offset exceeds the ILE's (times ``2 cos**2 phi0 / beta**2``) and its energy
    input at equal ``q`` exceeds (20).
    """
    s = sm.Symbol("s", real=True)
    order = 3

    def taylor(f: sm.Expr, terms: int) -> sm.Expr:  # sympy's series without its machinery
        return sum((f.diff(delta, n).xreplace({delta: 0}) * delta**n / sm.factorial(n)
                    for n in range(terms)), sm.Integer(0))  # fmt: skip

    sine = taylor(sm.sin(theta_II + delta * s), order)
    # A polynomial in s (the profile is one in (theta - theta_II) / delta): integrated term
    # by term, a second of sympy's integrate.
    integrand = sm.expand(profile(theta_II + delta * s) ** 3 * sine)
    integral = integrate_polynomial_trig(integrand, s, 0, 1)
    if integral is None:
        raise AssertionError("J's Taylor integrand is no polynomial in s")
    j_series = sm.expand(delta * integral)
    j_series = sum((j_series.coeff(delta, n) * delta**n for n in range(order + 1)), sm.Integer(0))
    forms = stride_forms()
    qf = forms["offset"] / (1 - forms["slope"])
    cos_III = taylor(sm.cos(theta_II + delta), order + 1)
    qf_series = sm.expand(qf.xreplace({J: j_series}).xreplace({sm.cos(theta_II + delta): cos_III}))
    added = _on_geometry(energies()["added"])
    e_fixed = added.xreplace({q: qf}).xreplace({J: j_series})
    e_series = sm.expand(e_fixed.xreplace({sm.cos(theta_II + delta): cos_III}))
    out = {}
    for n in range(order):
        out[f"q{n}"] = sm.factor(qf_series.coeff(delta, n))
        out[f"E{n}"] = sm.factor(e_series.coeff(delta, n))
    d_series = sm.expand(j_series + cos_III - sm.cos(theta_II))
    out["D1"] = sm.factor(d_series.coeff(delta, 1))
    out["D2"] = sm.factor(d_series.coeff(delta, 2))
    if d_series.coeff(delta, 0) != 0:
        raise AssertionError("D(0) is not 0")
    return out


# --- the extension's leg force, ground contact and the conditions ----------------------------


def _normal_force_of_cos(phase: Phase) -> tuple[sm.Expr, sm.Symbol, sm.Symbol]:
    """The ground's normal force in a phase of constant leg length as a function of
    ``c = cos(theta)`` and the phase's energy ``E`` (both symbols), from the engine's."""
    dyn = phase_dynamics(phase)
    c, level, w = sm.symbols("c E w", real=True)
    energy = dyn.energy.xreplace({omega: sm.sqrt(w)})
    w_of_level = _linear_root(energy - level, w)
    normal = dyn.normal_force.xreplace({omega: sm.sqrt(w)}).xreplace({w: w_of_level})
    normal = sm.expand(normal).subs(sm.sin(theta) ** 2, 1 - sm.cos(theta) ** 2)
    normal = sm.expand(normal.xreplace({sm.cos(theta): c}))
    if normal.has(theta) or sm.degree(normal, c) != 2 or normal.coeff(c, 2) <= 0:
        raise AssertionError(f"{phase.name}: N is not a convex quadratic in cos theta: {normal}")
    return normal, c, level


def _linear_root(expr: sm.Expr, x: sm.Symbol) -> sm.Expr:
    """The root of ``expr``, linear in ``x`` (as sympy's solve has it, without the solver's
    first call: a tenth of a second)."""
    slope = expr.diff(x)
    if slope == 0 or slope.has(x):
        raise AssertionError(f"{expr} is not linear in {x}")
    return -expr.xreplace({x: 0}) / slope


def _min(*args: sm.Expr) -> sm.Expr:
    """Min without sympy comparing the arguments (seconds on large ones)."""
    return sm.Min(*args, evaluate=False)


def _max(*args: sm.Expr) -> sm.Expr:
    return sm.Max(*args, evaluate=False)


def _phase_contact_min(phase: Phase, level: sm.Expr, c_low: sm.Expr, c_high: sm.Expr,
                       tag: str) -> tuple[list[tuple[sm.Symbol, sm.Expr]], sm.Symbol]:  # fmt: skip
    """Least normal force over a phase of constant length at energy ``level`` whose
    cos(theta) ranges over ``[c_low, c_high]``: the convex quadratic in ``cos theta`` at
    its vertex clipped to the range. Returns intermediates and the name of the result."""
    normal, c, e = _normal_force_of_cos(phase)
    vertex = _linear_root(normal.diff(c), c)
    e_s, at_s, n_s = (sm.Symbol(f"{name}_{tag}", real=True) for name in ("E", "c_min_N", "N_min"))
    inter = [
        (e_s, level),
        (at_s, _min(_max(vertex.xreplace({e: e_s}), c_low), c_high)),
        (n_s, normal.xreplace({e: e_s, c: at_s})),
    ]
    return inter, n_s


@functools.cache
def leg_force_of_state() -> sm.Expr:
    """The leg actuator's force in the extension (in m g; > 0 pushes: compressive) from the
    engine, in terms of ``theta`` and ``w = omega**2``; checked: N = F cos theta."""
    dyn = phase_dynamics(EXTENSION)
    force = dyn.actuator_forces[r]
    w = sm.Symbol("w", nonnegative=True)
    in_w = force.xreplace({omega: sm.sqrt(w)})
    if in_w.has(sm.sqrt(w)):
        raise AssertionError("the leg force is not a function of omega**2")
    # The massless leg carries the whole ground reaction along itself.
    _check_agree(dyn.normal_force, force * sm.cos(theta), "N = F cos theta in the extension")
    return in_w


def _leg_force_at(x: sm.Expr, h2: sm.Expr) -> sm.Expr:
    """The leg force at position ``x`` of the extension with ``h**2 = h2`` there."""
    w = sm.Symbol("w", nonnegative=True)
    angle = theta_II + delta * x
    length = profile(angle)
    return leg_force_of_state().xreplace({theta: angle}).xreplace({w: h2 / length**4})


@functools.cache
def extension_margins() -> dict[str, object]:
    """Intermediates and margins (functions of ``q``) of the step's conditions.

    * ``apex``: the least ``h**2`` over the step. ``d(h**2)/dtheta = 2 r**3 sin theta``, so
      ``h**2`` falls before the apex and rises after it: its least value over each phase is
      at the phase's angle closest to ``theta = 0`` (exact).
    * ``stance_contact``: the least normal force over the short and long phases (exact:
      a convex quadratic in ``cos theta`` at constant energy, as in the ILE).
    * ``leg_compressive``: the least leg force over the extension, sampled at
      ``s = k / 16``, ``k = 0..16`` (both ends included). The ground reaction there is the
      leg force along the leg, so this is the extension's ground contact too. Between the
      samples the force can dip lower; tests/test_tle.py bounds that against 2001 points.
    """
    st = stride()
    forms = stride_forms()
    inter = list(forms["intermediates"])
    h2_II = _on_geometry(st["h2_II"])
    h2_III = _on_geometry(st["h2_III"])
    h2_II_s, h2_III_s = sm.symbols("h2_II h2_III", real=True)
    inter += [(h2_II_s, h2_II), (h2_III_s, h2_III)]
    theta_III = theta_II + delta
    # Apex: h**2 at the closest-to-apex angle of each phase.
    c_short, c_long = sm.symbols("c_max_short c_max_long", positive=True)
    inter += [
        (c_short, closest_to_apex_cos(sin_I, cos_I, sm.sin(theta_II), sm.cos(theta_II), False)),
        (c_long, closest_to_apex_cos(sm.sin(theta_III), sm.cos(theta_III), sin_IV, cos_IV, False)),
    ]
    h2_short, h2_ext, h2_long = sm.symbols("h2_min_short h2_min_extension h2_min_long", real=True)
    # h**2 at the angle where cos theta = c_short (c_long): the law integrated there.
    inter.append((h2_short, h2_II_s + _h2_change(beta, theta_II, theta_I_s).xreplace(
        {sm.cos(theta_I_s): c_short})))  # fmt: skip
    inter.append((h2_long, h2_III_s + _h2_change(sm.Integer(1), theta_III, theta_IV_s).xreplace(
        {sm.cos(theta_IV_s): c_long})))  # fmt: skip
    # The apex's place in the extension (clipped to it); an expression of the arguments,
    # since the trig functions of the moments take it.
    x_apex = _min(_max(-theta_II / delta, 0), 1)
    j_inter, j_apex = extension_integral(x_apex, "apex")
    inter += j_inter
    inter.append((h2_ext, h2_II_s + 2 * j_apex))
    apex = _min(h2_short, h2_ext, h2_long)
    # Leg force at the samples; the last sample is the end of the extension (J).
    forces, normals = [], []
    for k in range(LEG_FORCE_SAMPLES + 1):
        x = sm.Rational(k, LEG_FORCE_SAMPLES)
        if k == 0:
            h2 = h2_II_s
        elif k == LEG_FORCE_SAMPLES:
            h2 = h2_III_s
        else:
            k_inter, j_k = extension_integral(x, f"k{k}")
            inter += k_inter
            h2 = h2_II_s + 2 * j_k
        force = sm.Symbol(f"F_k{k}", real=True)
        inter.append((force, _leg_force_at(x, h2)))
        forces.append(force)
        normals.append(force * sm.cos(theta_II + delta * x))
    # Ground contact in the phases of constant length.
    short_level = phase_dynamics(SHORT).energy.xreplace({theta: theta_I_s, omega: sm.sqrt(q)})
    long_level = phase_dynamics(LONG).energy.xreplace({theta: theta_III,
                                                       omega: sm.sqrt(h2_III_s)})  # fmt: skip
    short_inter, n_short = _phase_contact_min(
        SHORT, short_level.xreplace(ANGLES), _min(cos_I, sm.cos(theta_II)), c_short, "short"
    )
    long_inter, n_long = _phase_contact_min(
        LONG, long_level, _min(sm.cos(theta_III), cos_IV), c_long, "long"
    )
    inter += short_inter + long_inter
    return {
        "intermediates": inter,
        "apex": apex,
        "leg_compressive": _min(*forces),
        "stance_contact": _min(n_short, n_long),
        "contact_margin": _min(n_short, n_long, *normals),
        "theta_I": sm.atan2(sin_I, cos_I),
        "theta_IV": sm.atan2(sin_IV, cos_IV),
    }


def _condition_list(margins: dict[str, object], q_f: sm.Expr) -> tuple[Condition, ...]:
    """The existence conditions of a TLE gait (margins at ``q = q_f``)."""
    at_fixed = {q: q_f}
    return (
        Condition("q_positive", None, q_f, True, "exact", True,
                  "q = omega_I**2 > 0 at the fixed point", "g/r_e"),
        Condition("apex", None, margins["apex"].xreplace(at_fixed), True, "exact", True,
                  "h**2 = (r**2 omega)**2 > 0 over the whole step: the walker passes the apex "
                  "(no fall backward)", "g r_e^3"),
        Condition("extension_reached", None, theta_II - margins["theta_I"], True, "exact", True,
                  "theta_II > theta_I: the stance leg reaches the start of the extension",
                  "rad"),
        Condition("extension_completed", None, margins["theta_IV"] - theta_II - delta, True,
                  "exact", True, "theta_II + delta < theta_IV: the extension ends before "
                  "heelstrike", "rad"),
        Condition("leg_compressive", None, margins["leg_compressive"].xreplace(at_fixed), False,
                  "sampled", True, "the leg pushes (force >= 0) over the extension, so the "
                  "foot stays on the ground there; least of 17 samples s = k/16", "m g"),
        Condition("stance_contact", None, margins["stance_contact"].xreplace(at_fixed), False,
                  "exact", True, "the ground normal force stays >= 0 over the short and the "
                  "long phase (the leg pushes there too)", "m g"),
    )  # fmt: skip


# --- the derivation --------------------------------------------------------------------------


def _stride_quantities(d: Derivation, forms: dict[str, object]) -> None:
    """The stride map and its fixed point in place of the engine's closed form, which
    cancels badly (ILE eq. (9), (10) at delta = 0)."""
    inter = tuple(forms["intermediates"])
    d.quantities["stride_map"] = Quantity(
        "stride_map", (*P, q), forms["stride_map"],
        "Stride map in q = omega_I**2 (just after heelstrike), evaluated through the moment "
        "series of the extension integral.", None, "q of the next step", intermediates=inter,
    )  # fmt: skip
    d.quantities["q_fixed"] = Quantity(
        "q_fixed", P, forms["q_fixed"], "Fixed point q^f of the stride map (period-one gait).",
        None, "q^f", intermediates=inter,
    )  # fmt: skip


def _extension_quantities(d: Derivation) -> None:
    """The extension profile and the leg actuator's force in every phase."""
    d.add(Quantity(
        "extension_profile", (beta, theta_II, delta, theta),
        (profile(theta), profile(theta).diff(theta), profile(theta).diff(theta, 2)),
        "Stance leg length on the extension profile and its first two theta-derivatives.",
        None, "(r, dr/dtheta, d2r/dtheta2) in r_e per rad**k",
        output_names=("r", "dr_dtheta", "d2r_dtheta2"),
    ))  # fmt: skip
    for phase in (SHORT, EXTENSION, LONG):
        d.add(Quantity(
            f"{phase.name}_leg_force", (*P, theta, omega),
            phase_dynamics(phase).actuator_forces[r],
            f"Force of the stance leg's actuator in phase {phase.name} (the held length's "
            "generalised force), in m g.", None, "leg force; > 0 pushes (compressive)",
        ))  # fmt: skip


def _state_quantities(d: Derivation, margins: dict[str, object]) -> None:
    """The stance angles at heelstrike (ILE eq. (5), (11)) and the state along the
    extension: ``h**2`` and the leg force at a fraction of it."""
    geo_inter = list(geometry())
    d.add(Quantity("theta_I", (beta, phi0), margins["theta_I"],
                   "Stance angle just after heelstrike (ILE eq. (11)).", None, "theta_I",
                   intermediates=tuple(geo_inter)))  # fmt: skip
    d.add(Quantity("theta_IV", (beta, phi0), margins["theta_IV"],
                   "Stance angle at heelstrike.", None, "theta_IV = theta_I + phi0",
                   intermediates=tuple(geo_inter)))  # fmt: skip
    x_inter, j_x = extension_integral(fraction, "x")
    h2_x = _on_geometry(stride()["h2_II"]) + 2 * j_x
    d.add(Quantity(
        "extension_h_squared", (*P, q, fraction), h2_x,
        "(r**2 omega)**2 at position s = fraction in [0, 1] of the extension, from q.",
        None, "h**2 in g r_e**3", intermediates=(*geo_inter, *x_inter),
    ))  # fmt: skip
    h2_sym = sm.Symbol("h2_x", real=True)
    d.add(Quantity(
        "extension_leg_force_at", (*P, q, fraction), _leg_force_at(fraction, h2_sym),
        "Leg force at position s = fraction in [0, 1] of the extension, from q.", None,
        "leg force in m g; > 0 pushes", intermediates=(*geo_inter, *x_inter, (h2_sym, h2_x)),
    ))  # fmt: skip


def _energy_quantities(d: Derivation, inter: tuple) -> None:
    """The actuator's work per step and the heelstrike's loss (ILE eq. (20), (21))."""
    en = energies()
    d.add(Quantity(
        "energy_input", (*P, q), _on_geometry(en["added"]),
        "Work of the leg actuator per step: the energy added over the extension "
        "(E_III - E_II), from q of the same step.", None, "E_c in m g r_e", intermediates=inter,
    ))  # fmt: skip
    d.add(Quantity(
        "energy_dissipated", (*P, q), _on_geometry(en["dissipated"]),
        "Energy lost at heelstrike, from q of the same step.", None, "E_r in m g r_e",
        intermediates=inter,
    ))  # fmt: skip


def _condition_quantities(d: Derivation, forms: dict[str, object], margins: dict) -> None:
    """The least ground force over a step, the existence conditions, and q^f, lambda (ILE
    eq. (10), (19)) and the margins in one pass."""
    q_f = sm.Symbol("q_f", real=True)
    m_inter = margins["intermediates"]
    d.add(Quantity(
        "contact_margin", (*P, q), margins["contact_margin"],
        "Least ground normal force over the step from q (short and long phases exact, "
        "the extension at s = k/16).", None, "min N in m g", intermediates=tuple(m_inter),
    ))  # fmt: skip
    d.conditions = conditions = _condition_list(margins, q_f)
    fixed_inter = (*((k, v.xreplace({q: q_f})) for k, v in m_inter), (q_f, forms["q_fixed"]))
    d.add(Quantity(
        "fixed_point_conditions", P,
        (q_f, forms["slope"], *(c.margin for c in conditions)),
        "q^f, eigenvalue and the condition margins in one pass.", None,
        "(q^f, lambda, *margins in the order of CONDITIONS)", intermediates=fixed_inter,
        output_names=("q_fixed", "eigenvalue", *(c.name for c in conditions)),
    ))  # fmt: skip


def _limit_quantity(lim: dict[str, sm.Expr]) -> Quantity:
    """The Taylor coefficients at delta = 0, whose constant terms are the ILE's (10), (20)."""
    names = ("q0", "q1", "q2", "E0", "E1", "E2")
    return Quantity(
        "ile_limit", (beta, theta_II, phi0), tuple(lim[n].xreplace(ANGLES) for n in names),
        "Taylor coefficients at delta = 0 of q^f and of the actuator work at q^f: "
        "q^f = q0 + q1 delta + q2 delta**2 + O(delta**3), likewise E.", None,
        "(q0, q1, q2, E0, E1, E2); q0, E0 are the ILE's (10), (20)",
        intermediates=tuple(geometry()), output_names=names,
    )  # fmt: skip


def derive() -> Derivation:
    """The engine's package of the TLE model and its extension quantities."""
    d = model_derivation(
        MODEL,
        "Angles in radians, lengths in r_e, time in sqrt(r_e / g), forces in m g, energies "
        "in m g r_e (m = 1).",
    )
    forms = stride_forms()
    _stride_quantities(d, forms)
    _extension_quantities(d)
    margins = extension_margins()
    _state_quantities(d, margins)
    _energy_quantities(d, tuple(forms["intermediates"]))
    _condition_quantities(d, forms, margins)
    lim = ile_limit()
    d.add(_limit_quantity(lim))
    d.facts.update({f"stride.{k}": v for k, v in stride().items()})
    d.facts.update({f"energy.{k}": v for k, v in energies().items()})
    d.facts.update({f"limit.{k}": v for k, v in lim.items()})
    d.facts["profile"] = profile(theta)
    d.facts["leg_force"] = leg_force_of_state()
    return d
