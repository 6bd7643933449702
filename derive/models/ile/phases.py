"""The ILE's phases and resets in the paper's units: the swing phases, eq. (1), (2), (4),
their first integral (the steps of eq. 7), the extension's reset (3), the heelstrike's
geometry and reset, eq. (5), (6), (11).

Each comes from the engine (:mod:`derive.engine.hybrid`) applied to the model's facts
(:mod:`derive.models.ile.model`); the other modules of the package chain them.
"""

from __future__ import annotations

import functools

import sympy as sm

from derive import mechanics
from derive.engine.hybrid import impact_reset, jump_reset, phase_dynamics, phase_rate_map
from derive.engine.model import Phase
from derive.models.ile.model import (
    MODEL,
    PHASE_I_II,
    PHASE_III_IV,
    THETA,
    beta,
    g,
    leg_ratio,
    m,
    omega,
    phi0,
    r,
    r_e,
    stance_phase,
    theta,
    theta_I,
    theta_IV,
)


def square_symbol(name: str) -> sm.Symbol:
    """A real symbol standing for a squared rate such as ``omega**2`` (eq. 7, 8), so that
    ``omega**2`` can be replaced as a whole."""
    return sm.Symbol(name, real=True)


def same_value(form: sm.Expr, derived: sm.Expr, what: str) -> sm.Expr:
    """``form``, after checking that it equals ``derived`` (with sin**2 phi0 = 1 - cos**2 phi0).

    For groupings chosen to evaluate without cancellation (of eq. (10), (11), (19), (23)):
    the check keeps the evaluated form tied to the derivation, and is much cheaper than
    ``simplify``.
    """
    difference = sm.expand((form - derived).subs(sm.sin(phi0) ** 2, 1 - sm.cos(phi0) ** 2))
    if difference != 0 and sm.cancel(difference) != 0:  # expand settles polynomials
        raise AssertionError(f"{what}: {form} is not {derived}")
    return form


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
    """Energy (units ``m g r_e``) of a phase with leg ratio ``ratio`` at a state: the first
    integral of eq. (2) (``ratio = beta``) or (4) (``ratio = 1``)."""
    energy = swing_phase_dimensionless()["energy"]
    w2 = square_symbol("w2")
    return energy.subs(omega**2, w2).subs({w2: omega_squared, theta: theta_value, leg_ratio: ratio})


@functools.cache
def _phase_of_ratio(ratio: sm.Expr) -> Phase:
    """The stance phase of leg length ``ratio``: the model's own for eq. (2) and (4)."""
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
    norm_squared = same_value(short_step_form, norm_squared, "distance between the feet")
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
        "step_length_squared_short": same_value(
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
