"""The ILE model's closed forms: the paper's equations (1)-(23) and beyond, derived.

The model's facts are in :mod:`derive.models.ile.model`; the engine derives its equations of
motion, energies, leg force and resets (:mod:`derive.engine.hybrid`). This module chains them
into the paper's closed forms (the stride map and its fixed point, eq. 7-11, 19), the
existence conditions (12)-(17) and the ones the paper omits, the energy balance (18),
(20)-(23), the apex and contact bounds, the step timing in Carlson form, and the staged
forms the generated code evaluates without cancellation; :func:`derive` hands them to the
code generator as ``generated/ile/``. Nothing is typed in from the paper's results.
"""

from __future__ import annotations

import functools

import sympy as sm

from derive import mechanics
from derive.codegen import replace_unevaluated
from derive.elliptic import pendulum_travel_time
from derive.engine import c_exports
from derive.engine.hybrid import (
    hybrid_quantities,
    impact_reset,
    jump_reset,
    phase_dynamics,
    phase_rate_map,
    stride_closed_form,
)
from derive.engine.model import Phase
from derive.models.ile.model import (
    MODEL,
    PARAMETERS,
    PHASE_I_II,
    PHASE_III_IV,
    THETA,
    beta,
    g,
    leg_ratio,
    m,
    omega,
    omega_II,
    omega_IV,
    phi0,
    q,
    q_next,
    r,
    r_e,
    stance_phase,
    theta,
    theta_I,
    theta_II,
    theta_IV,
)
from derive.quantities import CExport, Condition, Derivation, Quantity


def _square_symbol(name: str) -> sm.Symbol:
    return sm.Symbol(name, real=True)


def _same_value(form: sm.Expr, derived: sm.Expr, what: str) -> sm.Expr:
    """``form``, after checking that it equals ``derived`` (with sin**2 phi0 = 1 - cos**2 phi0).

    For groupings chosen to evaluate without cancellation: the check keeps the evaluated
    form tied to the derivation, and is much cheaper than ``simplify``.
    """
    difference = sm.expand((form - derived).subs(sm.sin(phi0) ** 2, 1 - sm.cos(phi0) ** 2))
    if difference != 0 and sm.cancel(difference) != 0:  # expand settles polynomials
        raise AssertionError(f"{what}: {form} is not {derived}")
    return form


@functools.cache
def one_minus_eigenvalue() -> sm.Expr:
    """``1 - lambda = 1 - beta**2 cos**2 phi0`` as ``(1 - beta)(1 + beta) + beta**2 sin**2 phi0``.

    For short steps (phi0 -> 0, beta -> 1) the first form rounds cos phi0 to 1 and loses
    the ``beta**2 sin**2 phi0`` part (all of it at phi0 = 1e-8); the second is a sum of two
    non-negative terms, each computed to a few ulp (1 - beta is exact for beta >= 1/2).
    """
    form = (1 - beta) * (1 + beta) + beta**2 * sm.sin(phi0) ** 2
    return _same_value(form, 1 - stride()["eigenvalue"], "1 - lambda")


@functools.cache
def swing_phase_dimensionless() -> dict[str, sm.Expr]:
    """Swing phase of leg length ``leg_ratio * r_e`` in dimensionless form, eq. (1), (2), (4).

    From the engine (:func:`derive.engine.hybrid.phase_dynamics`: Lagrange's equations of
    the stance phase in SI, the leg length held by the actuator). Returns a dict with
    ``accel_dimensional`` (eq. (1) for ``leg_ratio = beta``), ``accel``
    (``d2theta/dtau2``), ``energy`` (in units of ``m g r_e``), ``leg_force`` (the
    actuator's push along the leg, in units of ``m g``) and ``normal_force`` (vertical
    ground force on the stance foot, in units of ``m g``), in terms of ``theta``, ``omega``.
    """
    dyn = phase_dynamics(stance_phase("dimensional", leg_ratio, m, g, r_e))
    rate = THETA.u
    # tau = sqrt(g/r_e) t, so dtheta/dt = omega sqrt(g/r_e) and d2theta/dt2 = (g/r_e) d2theta/dtau2.
    to_state = {rate: omega * sm.sqrt(g / r_e)}
    accel_dimensional = dyn.accelerations[0]
    accel = sm.cancel(accel_dimensional * r_e / g)
    energy = sm.expand(dyn.energy.xreplace(to_state) / (m * g * r_e))
    leg_force = sm.expand(dyn.actuator_forces[r].xreplace(to_state) / (m * g))
    # The massless leg pushes along itself; the ground takes its vertical component.
    normal_force = sm.expand(leg_force * sm.cos(theta))
    if sm.expand(dyn.normal_force.xreplace(to_state) / (m * g) - normal_force) != 0:
        raise AssertionError("the ground reaction is not the leg force's vertical component")
    return {
        "accel_dimensional": accel_dimensional,
        "accel": accel,
        "energy": energy,
        "energy_dimensional": dyn.energy,
        "leg_force": leg_force,
        "normal_force": normal_force,
    }


def phase_energy(theta_value: sm.Expr, omega_squared: sm.Expr, ratio: sm.Expr) -> sm.Expr:
    """Energy (units ``m g r_e``) of a phase with leg ratio ``ratio`` at a state."""
    energy = swing_phase_dimensionless()["energy"]
    w2 = _square_symbol("w2")
    return energy.subs(omega**2, w2).subs({w2: omega_squared, theta: theta_value, leg_ratio: ratio})


@functools.cache
def _phase_of_ratio(ratio: sm.Expr) -> Phase:
    return {beta: PHASE_I_II, sm.Integer(1): PHASE_III_IV}.get(
        sm.sympify(ratio), None
    ) or stance_phase(f"ratio_{ratio}", ratio)


def omega_squared_along(
    ratio: sm.Expr, theta_from: sm.Expr, omega_squared_from: sm.Expr, theta_to: sm.Expr
) -> sm.Expr:
    """``omega**2`` at ``theta_to`` along a phase of leg length ``ratio``, eq. (7) steps (the
    engine's first integral of the phase, :func:`derive.engine.hybrid.phase_rate_map`)."""
    return sm.expand(
        phase_rate_map(_phase_of_ratio(ratio), theta_from, omega_squared_from, theta_to)
    )


@functools.cache
def extension_reset() -> sm.Expr:
    """``omega_III / omega_II``, eq. (3): the engine's reset of the extension (the stance
    leg's generalised momentum m r**2 omega is conserved: the actuator pushes along r)."""
    _, (omega_after,) = jump_reset(MODEL, "extension")
    return sm.cancel(omega_after / THETA.u)


@functools.cache
def heelstrike() -> dict[str, sm.Expr]:
    """Collision geometry and reset at heelstrike, eq. (5), (6), (11).

    The stance foot is at the origin with the (extended) stance leg at ``theta_IV``;
    the swing leg, shortened to ``r_s``, is at inter-leg angle ``phi0`` ahead. Its foot
    touches level ground when its height is zero (the guard). The legs then exchange
    roles: the new stance angle is the swing leg's angle.
    """
    origin = sm.Matrix([0, 0])
    r_s = beta * r_e
    swing_angle = theta_IV - phi0
    hip = r_e * mechanics.leg_direction(theta_IV)
    swing_foot = hip - r_s * mechanics.leg_direction(swing_angle)
    guard = sm.expand(swing_foot[1] / r_e)  # swing-foot height in r_e; heelstrike when zero
    new_stance_angle = swing_angle  # hip - swing_foot = r_s * leg_direction(swing_angle)

    # Solve the guard for theta_I: write theta_IV = theta_I + phi0 and collect cos/sin theta_I.
    c, s = sm.symbols("c s", real=True)
    in_theta_I = sm.expand(sm.expand_trig(guard.subs(theta_IV, theta_I + phi0)))
    in_theta_I = in_theta_I.subs({sm.cos(theta_I): c, sm.sin(theta_I): s})
    cos_coeff, sin_coeff = in_theta_I.coeff(c), in_theta_I.coeff(s)
    tan_theta_I = -cos_coeff / sin_coeff
    theta_I_closed = sm.atan(tan_theta_I)  # |theta_I| < pi/2: the hip is above both feet
    norm_squared = mechanics.pythagorean_reduce(cos_coeff**2 + sin_coeff**2)
    # The same squared distance between the feet without the cancellation of
    # 1 + beta**2 - 2 beta cos(phi0) for short steps (phi0 -> 0, beta -> 1):
    # 1 - cos = sin**2 / (1 + cos).
    short_step_form = (1 - beta) ** 2 + 2 * beta * sm.sin(phi0) ** 2 / (1 + sm.cos(phi0))
    norm_squared = _same_value(short_step_form, norm_squared, "distance between the feet")
    # On the domain the sin coefficient is sin(phi0) > 0, and cos theta_I > 0 (hip above the
    # foot), so (cos, sin) theta_I = (sin_coeff, -cos_coeff) / norm.
    if sin_coeff == -sm.sin(phi0):
        cos_coeff, sin_coeff = -cos_coeff, -sin_coeff
    if sin_coeff != sm.sin(phi0):
        raise AssertionError(f"unexpected guard form: {in_theta_I}")
    cos_theta_I_closed = sin_coeff / sm.sqrt(norm_squared)
    sin_theta_I_closed = -cos_coeff / sm.sqrt(norm_squared)
    # theta_IV = theta_I + phi0; both closed forms share the normalisation sqrt(norm_squared).
    norm = sm.sqrt(norm_squared)
    on_theta_I = {sm.cos(theta_I): sin_coeff, sm.sin(theta_I): -cos_coeff}
    cos_theta_IV_closed = (
        mechanics.pythagorean_reduce(sm.expand_trig(sm.cos(theta_I + phi0)).subs(on_theta_I)) / norm
    )
    sin_theta_IV_closed = (
        mechanics.pythagorean_reduce(sm.expand_trig(sm.sin(theta_I + phi0)).subs(on_theta_I)) / norm
    )

    # Reset: the engine's impact map (the impulse at the new contact does no work on the
    # motion after it; for the hip mass: angular momentum about the new contact conserved).
    _, (omega_after,) = impact_reset(MODEL, "heelstrike")
    reset_ratio = sm.simplify(omega_after / THETA.u)

    step_vector = (swing_foot - origin) / r_e
    step_length_sq = sm.expand_trig(sm.expand((step_vector.T * step_vector)[0]))
    step_length_sq = mechanics.pythagorean_reduce(step_length_sq.subs(theta_IV, theta_I + phi0))

    return {
        "guard": guard,
        "new_stance_angle": new_stance_angle,
        "hip_height_condition": sm.Eq(beta * sm.cos(theta_I), sm.cos(theta_IV)),
        "tan_theta_I": tan_theta_I,
        "theta_I": theta_I_closed,
        "cos_theta_I": cos_theta_I_closed,
        "sin_theta_I": sin_theta_I_closed,
        "cos_theta_IV": cos_theta_IV_closed,
        "sin_theta_IV": sin_theta_IV_closed,
        "reset_ratio": reset_ratio,
        "step_length_squared": step_length_sq,
        "step_length_squared_short": _same_value(
            short_step_form, step_length_sq, "squared step length"
        ),
    }


def eliminate_contact_angles(expr: sm.Expr) -> sm.Expr:
    """Replace ``cos/sin theta_I`` and ``cos/sin theta_IV`` by their algebraic forms (eq. 11)."""
    hs = heelstrike()
    return expr.subs(
        {
            sm.cos(theta_I): hs["cos_theta_I"],
            sm.sin(theta_I): hs["sin_theta_I"],
            sm.cos(theta_IV): hs["cos_theta_IV"],
            sm.sin(theta_IV): hs["sin_theta_IV"],
        }
    )


@functools.cache
def stride() -> dict[str, sm.Expr]:
    """Chain the two energy integrals and the two resets into the stride map, eq. (7)-(10), (19).

    All results are in terms of ``q = omega_I**2`` (eq. 8), the parameters, and the
    symbol ``theta_I`` (eq. 11), as the paper writes them.
    """
    hs = heelstrike()
    ext = extension_reset()
    omega_II_sq = omega_squared_along(beta, theta_I, q, theta_II)
    omega_III_sq = sm.expand(ext**2 * omega_II_sq)
    omega_IV_sq = omega_squared_along(1, theta_II, omega_III_sq, theta_IV)
    # Guard: the hip height is the same on both legs, cos theta_IV = beta cos theta_I (eq. 5).
    cos_IV_from_guard = mechanics.solve_linear(hs["hip_height_condition"], sm.cos(theta_IV))
    omega_IV_sq = sm.expand(omega_IV_sq.subs(sm.cos(theta_IV), cos_IV_from_guard))
    stride_map = sm.expand(hs["reset_ratio"] ** 2 * omega_IV_sq)
    q_fixed = sm.factor(mechanics.solve_linear(sm.Eq(stride_map, q), q))
    eigenvalue = sm.factor(sm.diff(stride_map, q))
    return {
        "omega_II_squared": omega_II_sq,
        "omega_III_squared": omega_III_sq,
        "omega_IV_squared": omega_IV_sq,
        "stride_map": stride_map,
        "q_fixed": q_fixed,
        "eigenvalue": eigenvalue,
    }


def _fixed_point_offset() -> sm.Expr:
    """``f(0)``, the stride map at ``q = 0``, grouped by ``cos theta_I`` and ``cos theta_II``."""
    offset = sm.expand(stride()["stride_map"].subs(q, 0))
    return sm.collect(offset, [sm.cos(theta_I), sm.cos(theta_II)], sm.factor)


def _times_sin_squared(expr: sm.Expr, what: str) -> sm.Expr:
    """``expr``, which vanishes with sin phi0, as ``sin**2 phi0`` times the rest.

    The expanded form is a difference of terms in ``cos**2 phi0`` that cancel for short
    steps (all of it once cos phi0 rounds to 1, below phi0 = 1.05e-8).
    """
    numerator, denominator = sm.fraction(expr)
    rest, remainder = sm.div(sm.expand(numerator), 1 - sm.cos(phi0) ** 2, sm.cos(phi0))
    if remainder != 0:  # numerator = (1 - cos**2 phi0) rest exactly: the identity check
        raise AssertionError(f"{what} does not vanish with sin phi0: {expr}")
    rest = sm.collect(sm.expand(rest), [q, q_next, sm.cos(theta_I), sm.cos(theta_II)], sm.factor)
    return sm.sin(phi0) ** 2 * rest / denominator


@functools.cache
def evaluation_forms() -> dict[str, sm.Expr]:
    """Forms of derived quantities chosen for evaluation in floating point.

    Each is checked to equal the derived expression it replaces in the generated code
    (:func:`_same_value`); the derived expressions stay the facts the audit compares with
    the paper. They avoid rounding cos phi0 to 1 where a difference with 1 is needed
    (short steps, phi0 -> 0 with beta -> 1): ``1 - lambda`` as
    :func:`one_minus_eigenvalue`, and ``1 - cos**2 phi0`` as ``sin**2 phi0``.
    """
    st, en = stride(), energies()
    q_f = _same_value(_fixed_point_offset() / one_minus_eigenvalue(), st["q_fixed"], "q^f")
    # E_Delta = C + q dE_Delta/dq with dE_Delta/dq = -(m g r_e beta**2 / 2)(1 - lambda).
    slope = sm.diff(en["change"], q)
    per_unit = sm.factor(slope / (1 - st["eigenvalue"]))
    if per_unit.has(phi0, q):
        raise AssertionError(f"dE_Delta/dq is not proportional to 1 - lambda: {slope}")
    constant = sm.collect(sm.expand(en["constant"]), [sm.cos(theta_I), sm.cos(theta_II)], sm.factor)
    change = _same_value(
        constant + per_unit * one_minus_eigenvalue() * q, en["change"], "energy change"
    )
    return {
        "q_fixed": q_f,
        "energy_dissipated": _times_sin_squared(en["dissipated"], "energy dissipated"),
        "energy_dissipated_post": _times_sin_squared(
            en["dissipated_post"], "energy dissipated (post)"
        ),
        "energy_change": change,
    }


@functools.cache
def energies() -> dict[str, sm.Expr]:
    """Mechanical energy (dimensional, ``m g r_e``) at instants I-IV; eq. (18), (20)-(23)."""
    st = stride()
    scale = m * g * r_e
    w2 = _square_symbol("w2")
    e_I = scale * phase_energy(theta_I, q, beta)
    e_II = scale * phase_energy(theta_II, st["omega_II_squared"], beta)
    e_III = scale * phase_energy(theta_II, st["omega_III_squared"], 1)
    e_IV = scale * phase_energy(theta_IV, st["omega_IV_squared"], 1)
    e_I_next = scale * phase_energy(theta_I, st["stride_map"], beta)
    guard = {sm.cos(theta_IV): beta * sm.cos(theta_I)}
    complement = sm.expand((e_III - e_II).subs(guard))
    dissipated = sm.expand((e_IV - e_I_next).subs(guard))
    # Eq. (18) writes the heelstrike loss through the state after the impact.
    dissipated_post = sm.expand(
        scale
        * (
            phase_energy(theta_IV, w2, 1)
            - phase_energy(theta_I, heelstrike()["reset_ratio"] ** 2 * w2, beta)
        ).subs(guard)
    )
    omega_IV_sq_from_next = mechanics.solve_linear(
        sm.Eq(heelstrike()["reset_ratio"] ** 2 * w2, q_next), w2
    )
    dissipated_post = sm.factor(sm.cancel(dissipated_post.subs(w2, omega_IV_sq_from_next)))
    change = sm.expand(complement - dissipated)
    constant = change.subs(q, 0)
    return {
        "E_I": e_I,
        "E_II": e_II,
        "E_III": e_III,
        "E_IV": e_IV,
        "E_I_next": e_I_next,
        "complement": complement,
        "dissipated": dissipated,
        "dissipated_post": dissipated_post,
        "change": change,
        "constant": sm.factor(constant),
    }


def _closest_to_apex_cos(theta_lo_sin, cos_lo, theta_hi_sin, cos_hi) -> sm.Expr:
    """cos of the angle in [lo, hi] closest to the apex theta = 0 (where cos is largest).

    With both ends on one side of the apex it is the larger end cosine; otherwise the
    interval contains the apex and it is 1. Written as a maximum with the indicator of
    "contains the apex" (cosines lie in (0, 1] on the domain), which evaluates without a
    select. For a reversed interval (lo > hi: the stance leg never reaches theta_II, a set
    that does not walk) the value means nothing (only its sign is used).
    """
    contains_apex = sm.Piecewise((1, theta_lo_sin * theta_hi_sin <= 0), (0, True))
    return sm.Max(cos_lo, cos_hi, contains_apex)


@functools.cache
def apex_and_contact() -> dict[str, sm.Expr]:
    """Getting over the apex, eq. (14), and keeping the stance foot on the ground.

    ``omega**2`` along a phase falls as ``cos theta`` rises, so its minimum is at the
    angle of the phase closest to the apex. The stance foot stays down while the normal
    force ``N = (3 cos theta - 2 E) cos theta`` (from the radial balance and the energy
    integral) is non-negative; ``N`` is convex in ``cos theta``.
    """
    st = stride()
    # Paper-shaped (14): the apex is crossed in phase I-II when theta_II >= 0 ...
    apex_in_first = mechanics.solve_linear(omega_squared_along(beta, theta_I, q, 0), q)
    # ... and in phase III-IV when theta_II < 0.
    omega_after_apex = omega_squared_along(1, theta_II, st["omega_III_squared"], 0)
    apex_in_second = sm.expand(mechanics.solve_linear(omega_after_apex, q))

    # Exact form, valid for either sign of theta_I and theta_II.
    hs = heelstrike()
    sin_I, cos_I = hs["sin_theta_I"], hs["cos_theta_I"]
    sin_IV, cos_IV = hs["sin_theta_IV"], hs["cos_theta_IV"]
    c_star_1 = _closest_to_apex_cos(sin_I, cos_I, sm.sin(theta_II), sm.cos(theta_II))
    c_star_2 = _closest_to_apex_cos(sm.sin(theta_II), sm.cos(theta_II), sin_IV, cos_IV)
    cstar = sm.Symbol("cstar", real=True)
    w2_first = omega_squared_along(beta, theta_I, q, theta).subs(sm.cos(theta), cstar)
    w2_second = omega_squared_along(1, theta_II, st["omega_III_squared"], theta).subs(
        sm.cos(theta), cstar
    )
    q_first = mechanics.solve_linear(w2_first, q)
    q_second = mechanics.solve_linear(w2_second, q)
    q_apex_exact = sm.Max(
        eliminate_contact_angles(q_first).subs(cstar, c_star_1),
        eliminate_contact_angles(q_second).subs(cstar, c_star_2),
    )

    # Normal force along each phase as a function of c = cos theta.
    phase = swing_phase_dimensionless()
    normal = phase["normal_force"]
    c = sm.Symbol("c", positive=True)
    e_level = sm.Symbol("E", real=True)
    # Express omega**2 through the phase's energy level E = energy / leg_ratio.
    w2 = _square_symbol("w2")
    omega_sq_of_c = mechanics.solve_linear(
        phase["energy"].subs(omega**2, w2).subs(sm.cos(theta), c) - e_level * leg_ratio, w2
    )
    normal_of_c = sm.expand(
        normal.subs(omega**2, w2).subs(w2, omega_sq_of_c).subs(sm.cos(theta), c)
    )
    vertex = mechanics.solve_linear(sm.diff(normal_of_c, c), c)

    def level(ratio, theta_at, omega_sq_at):
        return sm.expand(phase_energy(theta_at, omega_sq_at, ratio) / ratio)

    level_1 = level(beta, theta_I, q)
    level_2 = level(1, theta_II, st["omega_III_squared"])
    phases = (
        (level_1, sm.Min(cos_I, sm.cos(theta_II)), c_star_1),
        (level_2, sm.Min(sm.cos(theta_II), cos_IV), c_star_2),
    )
    margins, q_limits = [], []
    for lvl, c_min, c_max in phases:
        lvl = eliminate_contact_angles(lvl)
        at_vertex = sm.Min(sm.Max(vertex.subs(e_level, lvl), c_min), c_max)
        margins.append(normal_of_c.subs(e_level, lvl).subs(c, at_vertex))
        # With c > 0, N >= 0 over [c_min, c_max] exactly when N(c_min) >= 0.
        boundary = sm.expand(normal_of_c.subs(c, c_min) / c_min).subs(e_level, lvl)
        q_limits.append(mechanics.solve_linear(boundary, q))
    return {
        "apex_in_first_phase": apex_in_first,
        "apex_in_second_phase": apex_in_second,
        "q_apex_exact": q_apex_exact,
        "normal_force_of_cos": normal_of_c,
        "contact_margin": sm.Min(*margins),
        "q_liftoff": sm.Min(*q_limits),
    }


CONTACT_ANGLE_NAMES = {
    sm.cos(theta_I): sm.Symbol("cos_theta_I", positive=True),
    sm.sin(theta_I): sm.Symbol("sin_theta_I", real=True),
    sm.cos(theta_IV): sm.Symbol("cos_theta_IV", positive=True),
    sm.sin(theta_IV): sm.Symbol("sin_theta_IV", real=True),
}
"""Names of the heelstrike angles' cosines and sines in staged (intermediate) forms."""


@functools.cache
def existence_staged() -> tuple[
    tuple[tuple[sm.Symbol, sm.Expr], ...], tuple[sm.Expr, ...], tuple[str, ...]
]:
    """q^f, eigenvalue and every condition margin over named intermediate values.

    The same quantities as :func:`derive`'s ``q_fixed``, ``eigenvalue`` and condition
    margins, built from the same phase integrals, but kept in terms of ``cos/sin theta_I``,
    ``cos/sin theta_IV`` (eq. 11), ``q_f`` and ``omega_III**2`` so the generated code
    computes each once. The apex margin uses that ``omega**2`` along a phase is linear in
    ``q`` with a positive slope ``k``: ``q_f - q_root = omega**2(q_f) / k``, so
    ``q_f - max(q_roots) = min(omega**2_min / k)`` without solving for the roots.
    tests/test_generated_backends.py checks the result against the explicit forms.

    Returns
    -------
    intermediates : tuple of (sympy.Symbol, sympy.Expr)
    outputs : tuple of sympy.Expr
        ``(q_f, eigenvalue, *margins)``.
    margin_names : tuple of str
        Condition names of the margins, in order.
    """
    hs, st = heelstrike(), stride()
    names = CONTACT_ANGLE_NAMES
    cos_I, sin_I = names[sm.cos(theta_I)], names[sm.sin(theta_I)]
    cos_IV, sin_IV = names[sm.cos(theta_IV)], names[sm.sin(theta_IV)]
    q_f = sm.Symbol("q_f", real=True)
    omega_II_sq = sm.Symbol("omega_II_sq", real=True)
    omega_III_sq = sm.Symbol("omega_III_sq", real=True)
    eigenvalue = sm.Symbol("eigenvalue", real=True)
    # The stride map is affine, f(q) = lambda q + f(0), so q^f = f(0) / (1 - lambda), with
    # 1 - lambda in a form without cancellation for short steps.
    stride_map = st["stride_map"].xreplace(names)
    if sm.expand(stride_map - (st["eigenvalue"] * q + stride_map.subs(q, 0))) != 0:
        raise AssertionError("the stride map is not affine in q")
    offset = _fixed_point_offset().xreplace(names)
    intermediates = (
        (cos_I, hs["cos_theta_I"]),
        (sin_I, hs["sin_theta_I"]),
        (cos_IV, hs["cos_theta_IV"]),
        (sin_IV, hs["sin_theta_IV"]),
        (eigenvalue, st["eigenvalue"]),
        (q_f, offset / one_minus_eigenvalue()),
        # omega_III**2 = (extension ratio)**2 omega_II**2 as a product, not expanded: for
        # short stance legs (beta -> 0) the expanded terms cancel.
        (omega_II_sq, st["omega_II_squared"].xreplace(names).subs(q, q_f)),
        (omega_III_sq, extension_reset() ** 2 * omega_II_sq),
    )
    # Phase I-II starts at theta_I with q; phase III-IV starts at theta_II with omega_III**2.
    c_star = (
        _closest_to_apex_cos(sin_I, cos_I, sm.sin(theta_II), sm.cos(theta_II)),
        _closest_to_apex_cos(sm.sin(theta_II), sm.cos(theta_II), sin_IV, cos_IV),
    )
    c_lowest = (sm.Min(cos_I, sm.cos(theta_II)), sm.Min(sm.cos(theta_II), cos_IV))
    slopes = (sm.Integer(1), sm.diff(st["omega_III_squared"], q))
    starts = ((beta, theta_I, q_f), (sm.Integer(1), theta_II, omega_III_sq))
    staged = list(intermediates)
    apex_margins, contact_margins = [], []
    normal = sm.factor(apex_and_contact()["normal_force_of_cos"])
    c, e_level = sm.Symbol("c", positive=True), sm.Symbol("E", real=True)
    vertex = mechanics.solve_linear(sm.diff(normal, c), c)
    for k, ((ratio, theta_from, w2_from), c_top, c_bottom, slope) in enumerate(
        zip(starts, c_star, c_lowest, slopes), start=1
    ):
        if not slope.is_positive:
            raise AssertionError(f"omega**2 must rise with q along every phase: {slope}")
        # The rise of cos theta from the phase's start to its point nearest the apex, named
        # so that omega**2 there is w2_from - (2 / ratio) rise with no cancellation of the
        # large terms 2 cos / ratio (short stance legs, beta -> 0).
        top, rise = sm.Symbol(f"cos_apex_{k}", positive=True), sm.Symbol(f"rise_{k}", real=True)
        cos_from = sm.cos(theta_from).xreplace(names)
        staged += [(top, c_top), (rise, top - cos_from)]
        w2_at = omega_squared_along(ratio, theta_from, w2_from, theta).xreplace(names)
        w2_min = sm.expand(w2_at.subs(sm.cos(theta), cos_from + rise))
        if w2_min.has(cos_from):
            raise AssertionError(f"the rise did not cancel the start cosine: {w2_min}")
        apex_margins.append(w2_min / slope)
        level = sm.expand(phase_energy(theta_from, w2_from, ratio) / ratio).xreplace(names)
        at_vertex = sm.Min(sm.Max(vertex.subs(e_level, level), c_bottom), top)
        contact_margins.append(normal.subs(e_level, level).subs(c, at_vertex))
    intermediates = tuple(staged)
    margins = {
        "q_positive": q_f,
        "cos_ratio": cos_ratio_margin().xreplace(names),
        "apex": sm.Min(*apex_margins),
        "theta_I_negative": beta - sm.cos(phi0),
        "phi0_below_right_angle": sm.pi / 2 - phi0,
        "extension_before_symmetric_contact": phi0 / 2 - theta_II,
        "extension_before_heelstrike": sm.atan2(sin_IV, cos_IV) - theta_II,
        "extension_reached": theta_II - hs["theta_I"],
        "stance_contact": sm.Min(*contact_margins),
    }
    return intermediates, (q_f, eigenvalue, *margins.values()), tuple(margins)


CONDITION_PIECE_NAMES = (
    "apex_phase_I_II",
    "apex_phase_III_IV",
    "normal_force_I",
    "normal_force_II",
    "normal_force_IV",
)
"""Outputs of :func:`condition_pieces`, in order."""


@functools.cache
def condition_pieces() -> tuple[
    tuple[tuple[sm.Symbol, sm.Expr], ...], tuple[sm.Expr, ...], tuple[str, ...]
]:
    """Smooth pieces of the apex condition (14) and of the stance contact, at the fixed point.

    The exact margins (:func:`existence_staged`) are minima over the phases with the
    phase's point nearest the apex chosen by the signs of theta_I and theta_II, so they
    have kinks; a gradient-based optimiser needs the pieces one by one:

    * ``apex_phase_I_II``: ``omega**2`` at theta = 0 along phase I-II (slope 1 in q), the
      apex margin when theta_I <= 0 <= theta_II (phase III-IV then starts at theta_II >= 0,
      where omega**2 / beta**4 = omega_II**2 is larger);
    * ``apex_phase_III_IV``: ``omega**2`` at theta = 0 along phase III-IV divided by its
      slope in q, the apex margin when theta_II <= 0;
    * ``normal_force_I``, ``normal_force_II``, ``normal_force_IV``: N / (m g) at instant I,
      just before the extension (II) and at instant IV. N = (3 c - 2 E) c is convex in
      c = cos theta with its vertex at E / 3, and N(c) >= 0 needs c >= 2 E / 3, so when
      these are >= 0 N rises from each phase's lowest cosine to its apex and the minimum
      over the step is the smallest of them (N just after the extension is larger than
      just before: the extension scales omega**2 by beta**4 < beta).

    Returns
    -------
    intermediates, outputs, names
        As :func:`existence_staged`, the outputs named by ``CONDITION_PIECE_NAMES``.
    """
    staged, _, _ = existence_staged()
    names = CONTACT_ANGLE_NAMES
    by_name = {symbol.name: symbol for symbol, _ in staged}
    q_f, w2_II, w2_III = by_name["q_f"], by_name["omega_II_sq"], by_name["omega_III_sq"]
    theta_I_at = {sm.cos(theta_I): names[sm.cos(theta_I)]}
    apex_1 = omega_squared_along(beta, theta_I, q_f, 0).xreplace(theta_I_at)
    # omega**2 along phase III-IV rises with q at the slope of omega_III**2.
    slope = sm.diff(stride()["omega_III_squared"], q)
    apex_2 = omega_squared_along(1, theta_II, w2_III, 0) / slope
    w2_IV = omega_squared_along(1, theta_II, w2_III, theta_IV).xreplace(names)
    w2 = _square_symbol("w2")
    normal = swing_phase_dimensionless()["normal_force"].subs(omega**2, w2)

    def normal_at(angle: sm.Expr, omega_squared: sm.Expr, ratio: sm.Expr) -> sm.Expr:
        at = normal.subs({w2: omega_squared, theta: angle, leg_ratio: ratio})
        return at.xreplace(names)

    outputs = (
        apex_1,
        apex_2,
        normal_at(theta_I, q_f, beta),
        normal_at(theta_II, w2_II, beta),
        normal_at(theta_IV, w2_IV, 1),
    )
    # Keep only the intermediates the pieces use (the generator emits every one).
    used: set[sm.Symbol] = set().union(*(sm.sympify(e).free_symbols for e in outputs))
    for symbol, expr in reversed(staged):
        if symbol in used:
            used |= expr.free_symbols
    intermediates = tuple((s, v) for s, v in staged if s in used)
    return intermediates, outputs, CONDITION_PIECE_NAMES


@functools.cache
def step_timing() -> dict[str, sm.Expr]:
    """Step length, phase durations and period (item 7 of the derivation; beyond the paper).

    The period is the time integral of ``dtheta / omega`` over both phases, with
    ``omega`` from each phase's energy integral, in Carlson form (:mod:`derive.elliptic`).
    """
    hs = heelstrike()
    st = stride()
    # The foot distance without the cancellation of 1 + beta**2 - 2 beta cos phi0.
    step_length = sm.sqrt(hs["step_length_squared_short"])

    def level(ratio, theta_at, omega_sq_at):
        return eliminate_contact_angles(
            sm.expand(phase_energy(theta_at, omega_sq_at, ratio) / ratio)
        )

    end_I = (hs["sin_theta_I"], hs["cos_theta_I"])
    end_II = (sm.sin(theta_II), sm.cos(theta_II))
    end_IV = (hs["sin_theta_IV"], hs["cos_theta_IV"])
    duration_1 = pendulum_travel_time(end_I, end_II, level(beta, theta_I, q), beta)
    duration_2 = pendulum_travel_time(
        end_II, end_IV, level(1, theta_II, st["omega_III_squared"]), sm.Integer(1)
    )
    return {
        "step_length": step_length,
        "duration_I_II": duration_1,
        "duration_III_IV": duration_2,
    }


def _paper_form(expr: sm.Expr) -> sm.Expr:
    return eliminate_contact_angles(expr)


def derive() -> Derivation:
    """Derive every quantity of the ILE model; the single entry point for code generation."""
    phase = swing_phase_dimensionless()
    hs = heelstrike()
    st = stride()
    en = energies()
    ac = apex_and_contact()
    tm = step_timing()
    ev = evaluation_forms()
    d = Derivation(
        model="ile",
        title="Instantaneous leg extension model of Virtual Slope Walking",
        source="derive/models/ile/closed_form.py",
        parameters=PARAMETERS,
        units="Angles in radians, time in units of sqrt(r_e / g), lengths in r_e.",
        paper=True,
    )
    P = (beta, theta_II, phi0)
    d.add(
        Quantity(
            name="swing_acceleration",
            args=(theta, leg_ratio),
            expr=phase["accel"],
            summary=(
                "Angular acceleration d2theta/dtau2 of a swing phase of leg length leg_ratio * r_e."
            ),
            equation="(2), (4)",
            returns="d2theta/dtau2; leg_ratio = beta gives (2), leg_ratio = 1 gives (4)",
        )
    )
    d.add(
        Quantity(
            name="phase_energy",
            args=(theta, omega, leg_ratio),
            expr=phase["energy"],
            summary="Mechanical energy of a swing phase, in units of m g r_e (its first integral).",
            returns="(kinetic + potential) / (m g r_e)",
        )
    )
    d.add(
        Quantity(
            name="normal_force",
            args=(theta, omega, leg_ratio),
            expr=phase["normal_force"],
            summary=(
                "Vertical ground force on the stance foot, in units of m g; the foot lifts off "
                "below 0"
            ),
            returns="N / (m g)",
        )
    )
    d.add(
        Quantity(
            name="extension_reset",
            args=(beta, omega_II),
            expr=extension_reset() * omega_II,
            summary="Angular velocity just after the instantaneous leg extension.",
            equation="(3)",
            returns="omega_III",
        )
    )
    d.add(
        Quantity(
            name="heelstrike_reset",
            args=(beta, phi0, omega_IV),
            expr=hs["reset_ratio"] * omega_IV,
            summary="Angular velocity of the new stance leg just after heelstrike.",
            equation="(6)",
            returns="omega_I(n+1)",
        )
    )
    d.add(
        Quantity(
            name="swing_foot_height",
            args=(beta, phi0, theta),
            expr=hs["guard"].subs(theta_IV, theta),
            summary=(
                "Height of the shortened swing foot, in r_e, with the extended stance leg at theta."
            ),
            equation="(5)",
            returns="heelstrike guard; zero at theta = theta_IV",
        )
    )
    d.add(
        Quantity(
            name="theta_I",
            args=(beta, phi0),
            expr=hs["theta_I"],
            summary="Stance leg angle just after heelstrike.",
            equation="(11)",
            returns="theta_I in radians",
        )
    )
    d.add(
        Quantity(
            name="theta_IV",
            args=(beta, phi0),
            expr=sm.atan2(hs["sin_theta_IV"], hs["cos_theta_IV"]),
            summary="Stance leg angle at heelstrike.",
            equation="(5)",
            returns="theta_IV = theta_I + phi0 in radians",
        )
    )
    d.add(
        Quantity(
            name="stride_map",
            args=(*P, q),
            expr=_paper_form(st["stride_map"]),
            summary=(
                "Stride map f(q): q = omega_I**2 just after one heelstrike to just after the next."
            ),
            equation="(7), (9)",
            returns="q(n+1)",
        )
    )
    d.add(
        Quantity(
            name="q_fixed",
            args=P,
            expr=_paper_form(ev["q_fixed"]),
            summary="Fixed point q^f of the stride map.",
            equation="(10)",
            returns="q^f",
        )
    )
    d.add(
        Quantity(
            name="eigenvalue",
            args=(beta, phi0),
            expr=st["eigenvalue"],
            summary="Eigenvalue df/dq of the stride map (constant: the map is linear in q).",
            equation="(19)",
            returns="lambda",
        )
    )
    d.add(
        Quantity(
            name="omega_II_squared",
            args=(*P, q),
            expr=_paper_form(st["omega_II_squared"]),
            summary="omega**2 just before the extension, from the energy integral of phase I-II.",
            equation="(7)",
            returns="omega_II**2",
        )
    )
    d.add(
        Quantity(
            name="omega_IV_squared",
            args=(*P, q),
            expr=_paper_form(st["omega_IV_squared"]),
            summary="omega**2 just before heelstrike, from the energy integral of phase III-IV.",
            equation="(7)",
            returns="omega_IV**2",
        )
    )
    d.add(
        Quantity(
            name="q_apex_min",
            args=P,
            expr=ac["q_apex_exact"],
            summary="Smallest q at instant I that carries the walker over the apex in both phases.",
            equation="(14)",
            returns="exact form of (14); holds for either sign of theta_I and theta_II",
        )
    )
    d.add(
        Quantity(
            name="q_liftoff_max",
            args=P,
            expr=ac["q_liftoff"],
            summary=(
                "Largest q at instant I for which the stance foot stays on the ground all step."
            ),
            returns="q bound from N >= 0 (Fig. 9 right boundary)",
        )
    )
    d.add(
        Quantity(
            name="contact_margin",
            args=(*P, q),
            expr=ac["contact_margin"],
            summary=(
                "Minimum over the step of the ground normal force on the stance foot, in units of "
                "m g."
            ),
            returns="min N / (m g) over both phases",
        )
    )
    E = (*P, q, m, g, r_e)
    d.add(
        Quantity(
            name="energy_complement",
            args=E,
            expr=_paper_form(en["complement"]),
            summary="Energy added by the leg extension (the actuator's work per step), E_c.",
            equation="(20)",
            returns="E_c",
        )
    )
    d.add(
        Quantity(
            name="energy_dissipated",
            args=E,
            expr=_paper_form(ev["energy_dissipated"]),
            summary="Energy lost at heelstrike, E_r, in terms of q of the same step.",
            equation="(21)",
            returns="E_r",
        )
    )
    d.add(
        Quantity(
            name="energy_dissipated_post",
            args=(beta, phi0, q_next, m, g, r_e),
            expr=ev["energy_dissipated_post"],
            summary="Energy lost at heelstrike in terms of q just after the impact.",
            equation="(18)",
            returns="E_r",
        )
    )
    d.add(
        Quantity(
            name="energy_change",
            args=E,
            expr=_paper_form(ev["energy_change"]),
            summary="Net change of mechanical energy over one step, E_c - E_r.",
            equation="(22), (23)",
            returns="E_Delta",
        )
    )
    d.add(
        Quantity(
            name="energy_constant",
            args=(*P, m, g, r_e),
            expr=_paper_form(en["constant"]),
            summary="The constant C of eq. (23): E_Delta at q = 0.",
            equation="(23)",
            returns="C",
        )
    )
    d.add(
        Quantity(
            name="step_length",
            args=(beta, phi0),
            expr=tm["step_length"],
            summary="Distance between successive footholds (and hip travel per step), in r_e.",
            returns="step length / r_e",
        )
    )
    d.add(
        Quantity(
            name="phase_durations",
            args=(*P, q),
            expr=(tm["duration_I_II"], tm["duration_III_IV"]),
            summary="Durations of the swing phases I-II and III-IV in dimensionless time tau.",
            returns="(tau_I_II, tau_III_IV)",
        )
    )

    qf = d.quantities["q_fixed"].expr
    hsI = hs
    conditions = (
        Condition(
            name="q_positive",
            equation="(12)",
            margin=qf,
            strict=True,
            status="implied",
            physical=True,
            meaning="q = omega_I**2 must be positive at the fixed point",
            unit="g/r_e",
        ),
        Condition(
            name="cos_ratio",
            equation="(13)",
            margin=_paper_form(cos_ratio_margin()),
            strict=True,
            status="exact",
            physical=False,
            meaning="(12) rewritten with (10): the same condition",
            unit="",
        ),
        Condition(
            name="apex",
            equation="(14)",
            margin=qf - ac["q_apex_exact"],
            strict=True,
            status="exact",
            physical=True,
            meaning="omega stays positive over the apex in both phases (no fall backward)",
            unit="g/r_e",
        ),
        Condition(
            name="theta_I_negative",
            equation="(15)",
            margin=beta - sm.cos(phi0),
            strict=True,
            status="framing",
            physical=False,
            meaning="theta_I < 0: the new stance foot lands ahead of the hip",
            unit="",
        ),
        Condition(
            name="phi0_below_right_angle",
            equation="(16)",
            margin=sm.pi / 2 - phi0,
            strict=True,
            status="exact",
            physical=True,
            meaning="cos phi0 > 0, so omega_I > 0 after heelstrike",
            unit="rad",
        ),
        Condition(
            name="extension_before_symmetric_contact",
            equation="(17)",
            margin=phi0 / 2 - theta_II,
            strict=True,
            status="conservative",
            physical=False,
            meaning="theta_II < phi0/2, where equal legs would touch down",
            unit="rad",
        ),
        Condition(
            name="extension_before_heelstrike",
            equation="(17) exact",
            margin=sm.atan2(hsI["sin_theta_IV"], hsI["cos_theta_IV"]) - theta_II,
            strict=True,
            status="exact",
            physical=True,
            meaning="theta_II < theta_IV: the leg extends before heelstrike",
            unit="rad",
        ),
        Condition(
            name="extension_reached",
            equation=None,
            margin=theta_II - hsI["theta_I"],
            strict=True,
            status="missing",
            physical=True,
            meaning="theta_II > theta_I: the stance leg reaches the extension angle",
            unit="rad",
        ),
        Condition(
            name="stance_contact",
            equation=None,
            # Unevaluated Min and Max: evaluation compares the phases' margins pairwise
            # (half a second of the model's derivation) and orders none of them.
            margin=replace_unevaluated(ac["contact_margin"], {q: qf}),
            strict=False,
            status="missing",
            physical=True,
            meaning="the ground normal force stays non-negative over the whole step",
            unit="m g",
        ),
    )
    d.conditions = conditions
    d.add(
        Quantity(
            name="condition_margins",
            args=P,
            expr=tuple(c.margin for c in conditions),
            summary=(
                "Margins of the existence conditions at the fixed point, in the order of "
                "CONDITIONS."
            ),
            equation="(12)-(17)",
            returns=(
                "tuple of margins; each condition holds when its margin is > 0 (>= 0 if not strict)"
            ),
        )
    )
    staged_intermediates, staged_outputs, staged_names = existence_staged()
    if staged_names != tuple(c.name for c in conditions):
        raise AssertionError("existence_staged() and the condition list disagree")
    d.add(
        Quantity(
            name="fixed_point_conditions",
            args=P,
            expr=staged_outputs,
            summary=(
                "q^f, eigenvalue and existence-condition margins in one pass (shared terms once)."
            ),
            equation="(10), (19), (12)-(17)",
            returns="(q^f, lambda, *margins in the order of CONDITIONS)",
            intermediates=staged_intermediates,
        )
    )
    piece_intermediates, piece_outputs, _ = condition_pieces()
    d.add(
        Quantity(
            name="condition_pieces",
            args=P,
            expr=piece_outputs,
            summary="Smooth pieces of the apex (14) and stance-contact margins at the fixed point.",
            equation="(14)",
            returns="("
            + ", ".join(CONDITION_PIECE_NAMES)
            + "); see derive.models.ile.condition_pieces",
            intermediates=piece_intermediates,
            output_names=CONDITION_PIECE_NAMES,
        )
    )
    # The engine's functions for the generic runtime (vsw.dynamics.hybrid), and its stride map in
    # closed form, which must be the one chained above from the same phases and resets.
    engine_quantities, descriptor = hybrid_quantities(MODEL)
    for qty in engine_quantities:
        d.add(qty)
    d.constants["HYBRID"] = (
        dict(descriptor, closed_form=True),
        "The model for the generic runtime (vsw.dynamics.hybrid): parameters, coordinates, phases "
        "with their failure guards, events with their guards and resets, units.",
    )
    _check_engine_stride()
    d.c_exports = (
        CExport("stride_map", ("beta", "theta_II", "phi0", "q"), "q(n+1) from q(n), eq. (9)"),
        CExport("q_fixed", ("beta", "theta_II", "phi0"), "fixed point q^f, eq. (10)"),
        CExport("eigenvalue", ("beta", "phi0"), "eigenvalue of the stride map, eq. (19)"),
        CExport(
            "step_metrics",
            ("beta", "theta_II", "phi0"),
            "[step_length, step_period, speed, contact_margin] at the fixed point",
            build=_step_metrics,
        ),
        CExport("condition_margins", ("beta", "theta_II", "phi0"), "existence condition margins"),
    )
    # And what a controller or another simulator needs to step the model: the engine's
    # phase accelerations and resets.
    d.c_exports += c_exports(MODEL, engine_quantities)
    d.batch = ("fixed_point_conditions",)
    # What the explorer page (vsw explore) computes in the browser.
    d.js_exports = (
        "fixed_point_conditions",
        "q_fixed",
        "eigenvalue",
        "stride_map",
        "theta_I",
        "theta_IV",
        "step_length",
        "phase_durations",
        "q_apex_min",
        "q_liftoff_max",
        "condition_margins",
        "swing_acceleration",
        "extension_reset",
        "heelstrike_reset",
    )
    d.facts.update({f"phase.{k}": v for k, v in phase.items()})
    d.facts.update({f"heelstrike.{k}": v for k, v in hs.items() if isinstance(v, sm.Basic)})
    d.facts.update({f"stride.{k}": v for k, v in st.items()})
    d.facts.update({f"energy.{k}": v for k, v in en.items()})
    d.facts.update({f"apex.{k}": v for k, v in ac.items()})
    d.facts["extension.ratio"] = extension_reset()
    d.facts["cos_ratio.margin"] = cos_ratio_margin()
    d.facts["cos_ratio.threshold"] = cos_ratio_threshold()
    return d


def _check_engine_stride() -> None:
    """The engine's stride map (:func:`derive.engine.hybrid.stride_closed_form`) equals the
    paper-shaped one of :func:`stride` (numerically, at random walking parameter sets)."""
    engine = stride_closed_form(MODEL)
    if engine is None:
        raise AssertionError("the engine finds no closed-form stride map for the ILE")
    st = stride()
    ours = eliminate_contact_angles(st["stride_map"]).subs(theta_I, heelstrike()["theta_I"])
    rng = __import__("random").Random(7)
    for _ in range(6):
        point = {
            beta: sm.Float(rng.uniform(0.55, 0.95), 30),
            phi0: sm.Float(rng.uniform(0.5, 1.0), 30),
            theta_II: sm.Float(rng.uniform(-0.05, 0.2), 30),
            q: sm.Float(rng.uniform(0.2, 1.0), 30),
        }
        mine = (engine.slope * q + engine.offset).xreplace(point).evalf(30)
        paper = ours.xreplace(point).evalf(30)
        if abs(mine - paper) > 1e-20:
            raise AssertionError(f"engine stride map {mine} != paper-shaped {paper} at {point}")


def _step_metrics(module, beta, theta_II, phi0):
    """The C export ``step_metrics``: step length, period, speed and contact margin at q^f,
    composed from the generated functions."""
    q_f = module.q_fixed(beta, theta_II, phi0)
    length = module.step_length(beta, phi0)
    tau_I_II, tau_III_IV = module.phase_durations(beta, theta_II, phi0, q_f)
    period = tau_I_II + tau_III_IV
    return [length, period, length / period, module.contact_margin(beta, theta_II, phi0, q_f)]


def cos_ratio_threshold() -> sm.Expr:
    """Right-hand side of (13): q^f > 0 solved for ``cos theta_II / cos theta_I``."""
    numerator, _ = sm.fraction(sm.together(stride()["q_fixed"]))
    ratio = sm.Symbol("ratio", positive=True)
    # The denominator is positive on the domain (beta cos phi0 < 1), so the sign of q^f is
    # the sign of its numerator, linear in cos theta_II = ratio * cos theta_I.
    in_ratio = sm.expand(numerator.subs(sm.cos(theta_II), ratio * sm.cos(theta_I)))
    return sm.factor(mechanics.solve_linear(in_ratio, ratio))


def cos_ratio_margin() -> sm.Expr:
    """Margin of (13): ``cos theta_II / cos theta_I - threshold``."""
    return sm.cos(theta_II) / sm.cos(theta_I) - cos_ratio_threshold()
