"""The ILE's energy balance: the mechanical energy at instants I-IV, the actuator's work and
the heelstrike's loss, eq. (18), (20)-(23), and their forms that evaluate without
cancellation for short steps."""

from __future__ import annotations

import functools

import sympy as sm

from derive import mechanics
from derive.models.ile.model import beta, g, m, phi0, q, q_next, r_e, theta_I, theta_II, theta_IV
from derive.models.ile.phases import heelstrike, phase_energy, same_value, square_symbol
from derive.models.ile.stride_map import fixed_point_offset, one_minus_eigenvalue, stride


@functools.cache
def energies() -> dict[str, sm.Expr]:
    """Mechanical energy (dimensional, ``m g r_e``) at instants I-IV; eq. (18), (20)-(23)."""
    st = stride()
    scale = m * g * r_e
    w2 = square_symbol("w2")
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


def _times_sin_squared(expr: sm.Expr, what: str) -> sm.Expr:
    """``expr``, which vanishes with sin phi0, as ``sin**2 phi0`` times the rest (the
    heelstrike's loss, eq. (18), (21)).

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
    """Forms of derived quantities chosen for evaluation in floating point: q^f (10) and the
    energies (18), (21), (23).

    Each is checked to equal the derived expression it replaces in the generated code
    (:func:`same_value`); the derived expressions stay the facts the audit compares with
    the paper. They avoid rounding cos phi0 to 1 where a difference with 1 is needed
    (short steps, phi0 -> 0 with beta -> 1): ``1 - lambda`` as
    :func:`one_minus_eigenvalue`, and ``1 - cos**2 phi0`` as ``sin**2 phi0``.
    """
    st, en = stride(), energies()
    q_f = same_value(fixed_point_offset() / one_minus_eigenvalue(), st["q_fixed"], "q^f")
    # E_Delta = C + q dE_Delta/dq with dE_Delta/dq = -(m g r_e beta**2 / 2)(1 - lambda).
    slope = sm.diff(en["change"], q)
    per_unit = sm.factor(slope / (1 - st["eigenvalue"]))
    if per_unit.has(phi0, q):
        raise AssertionError(f"dE_Delta/dq is not proportional to 1 - lambda: {slope}")
    constant = sm.collect(sm.expand(en["constant"]), [sm.cos(theta_I), sm.cos(theta_II)], sm.factor)
    change = same_value(
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
