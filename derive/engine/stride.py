"""The stride map in closed form, for one free coordinate and events at fixed angles.

Along a phase ``theta'' = A + B theta'**2``, so ``u = rate**2`` obeys the linear equation
``du/dtheta = 2 A + 2 B u``, solved with its integrating factor
(:func:`phase_rate_map`); the resets scale ``u`` by a constant
(:func:`stride_closed_form`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import sympy as sm

from derive.engine.algebra import expand, tidy, within_ops
from derive.engine.dynamics import phase_dynamics
from derive.engine.model import Model, Phase
from derive.engine.resets import check_event_angle, reset

__all__ = ["StrideForm", "integrate_polynomial_trig", "phase_rate_map", "stride_closed_form"]


@dataclass(frozen=True)
class StrideForm:
    """The closed-form stride map ``q' = slope q + offset`` in ``q = rate**2``."""

    slope: sm.Expr
    offset: sm.Expr
    section_angle: sm.Expr  # the coordinate just after the step event

    @property
    def fixed_point(self) -> sm.Expr:
        return self.offset / (1 - self.slope)


def integrate_polynomial_trig(expr: sm.Expr, s: sm.Symbol, low: sm.Expr, high: sm.Expr):
    """``int_low^high expr ds`` for ``expr = sum_k p_k(s) f_k(a_k s + b_k)`` with polynomials
    ``p_k``, ``f_k`` in {sin, cos, 1} and ``a_k`` free of ``s``, by repeated integration by
    parts (``int p sin u = -cos u sum_j (-1)**j p^(2j) / a**(2j+1) + sin u sum_j (-1)**j
    p^(2j+1) / a**(2j+2)``); None for any other integrand. Seconds faster than
    :func:`sympy.integrate` on a degree-9 polynomial with symbolic coefficients.
    """
    groups = _polynomial_trig_groups(expr, s)
    if groups is None:
        return None
    for key in groups:
        slope = key.args[0].diff(s) if key != 1 else None
        if slope is not None and (slope.has(s) or slope == 0):
            return None
    ordered = sorted(groups.items(), key=lambda kv: sm.default_sort_key(kv[0]))
    # The antiderivative is built at each end (not built in s and then substituted: the
    # coefficients recur in every derivative, and a substitution walks each occurrence).
    return _antiderivative(ordered, s, high) - _antiderivative(ordered, s, low)


def _antiderivative(groups: list, s: sm.Symbol, at: sm.Expr) -> sm.Expr:
    """The antiderivative of ``sum_f f sum_n c_n s**n`` (``groups``: ``(f, {n: c_n})``, ``f``
    a sine or cosine of ``s`` or 1) at ``s = at``."""
    out = sm.Integer(0)
    for key, coeffs in groups:
        if key == 1:
            out += sm.Add(*(c * at ** (n + 1) / (n + 1) for n, c in coeffs.items()))
            continue
        argument = key.args[0]
        slope = argument.diff(s)
        # The k-th derivative of sum_n c_n s**n, over slope**(k + 1), signed by k // 2.
        parts = ([], [])
        for k in range(max(coeffs) + 1):
            derivative = sm.Add(*(c * sm.ff(n, k) * at ** (n - k)
                                  for n, c in coeffs.items() if n >= k))  # fmt: skip
            parts[k % 2].append(sm.Integer(-1) ** (k // 2) * derivative / slope ** (k + 1))
        even, odd = sm.Add(*parts[0]), sm.Add(*parts[1])
        argument = argument.xreplace({s: at})
        if isinstance(key, sm.sin):
            out += -sm.cos(argument) * even + sm.sin(argument) * odd
        else:
            out += sm.sin(argument) * even + sm.cos(argument) * odd
    return out


def _polynomial_trig_groups(expr: sm.Expr, s: sm.Symbol) -> dict | None:
    """The expanded ``expr`` as ``{f: {n: c_n}}`` for ``sum_f f sum_n c_n s**n`` with ``f``
    a sine or cosine of ``s`` or 1 and ``c_n`` free of ``s`` (collected term by term: a
    polynomial over the coefficients' field takes most of a second to build); None when it
    has no such form."""
    groups: dict[sm.Expr, dict[int, list[sm.Expr]]] = {}
    for term in sm.Add.make_args(expand(expr)):
        key, power, rest = sm.Integer(1), 0, []
        for factor in sm.Mul.make_args(term):
            base, exponent = factor.as_base_exp()
            if not factor.has(s):
                rest.append(factor)
            elif isinstance(factor, (sm.sin, sm.cos)) and key == 1:
                key = factor
            elif base == s and exponent.is_Integer and exponent > 0:
                power += int(exponent)
            else:
                return None
        groups.setdefault(key, {}).setdefault(power, []).append(sm.Mul(*rest))
    return {
        key: {n: sm.Add(*terms) for n, terms in sorted(powers.items())}
        for key, powers in groups.items()
    }


def phase_rate_map(
    phase: Phase, angle_from: sm.Expr, rate_squared_from: sm.Expr, angle_to: sm.Expr
) -> sm.Expr | None:
    """``rate**2`` at ``angle_to`` along a one-coordinate phase started at ``angle_from``.

    With ``theta'' = A(theta) + B(theta) theta'**2`` (Lagrange's equations are quadratic in
    the rates), ``u = theta'**2`` obeys ``du/dtheta = 2 A + 2 B u``; with the integrating
    factor ``mu = exp(-int 2 B)``: ``u(to) = (mu(from) u(from) + int 2 A mu) / mu(to)``.
    None when the phase has more coordinates or the integrals are not elementary.
    """
    if len(phase.coordinates) != 1:
        return None
    theta, omega = phase.coordinates[0].q, phase.coordinates[0].u
    w = sm.Symbol("w", positive=True)
    acc = phase_dynamics(phase).accelerations[0].xreplace({omega: sm.sqrt(w)})
    small = within_ops(acc)
    raw_b = acc.diff(w)
    slope_b = expand(raw_b) if small else raw_b
    if slope_b.has(w) or slope_b.has(omega):
        return None
    a_part = expand(acc - slope_b * w) if small else acc.xreplace({w: 0})
    s = sm.Dummy("s", real=True)
    if slope_b == 0:  # a leg of constant length: the energy integral
        integral = sm.integrate((2 * a_part).xreplace({theta: s}), (s, angle_from, angle_to))
        return expand(rate_squared_from + integral)
    # A logarithmic derivative c D'/D (a held profile D) integrates to c log D; sympy's
    # integrate finds it too, in seconds rather than milliseconds. (cancel's canonical
    # form is the same from the expanded B, which holds the profile's expanded powers of
    # 1/delta in every term's denominator: it takes four times as long from that.)
    numerator, denominator = sm.fraction(sm.cancel(2 * raw_b))
    ratio = sm.cancel(numerator / denominator.diff(theta))
    if ratio.has(theta):
        antiderivative = sm.integrate(2 * slope_b, theta)
    else:
        antiderivative = ratio * sm.log(denominator)
    if antiderivative.has(sm.Integral):
        return None
    # exp(k log P) evaluates to P**k: mu is a power of the profile.
    start = antiderivative.xreplace({theta: angle_from})
    mu = sm.factor(sm.exp(-antiderivative) * sm.exp(start))
    integrand = sm.factor(2 * acc.xreplace({w: 0}) * mu).xreplace({theta: s})
    integral = integrate_polynomial_trig(integrand, s, angle_from, angle_to)
    if integral is None:
        integral = sm.integrate(integrand, (s, angle_from, angle_to))
    if integral.has(sm.Integral):
        return None
    return tidy((rate_squared_from + integral) / sm.factor(mu.xreplace({theta: angle_to})))


@functools.cache
def stride_closed_form(model: Model) -> StrideForm | None:
    """The stride map in closed form, when the model has one free coordinate, every event
    sits at a fixed angle (``Event.at``) and every reset scales the rate by a factor.

    Along a phase ``theta'' = A + B theta'**2``, so ``w = theta'**2`` obeys
    ``dw/dtheta = 2 A + 2 B w``: with the integrating factor ``mu = exp(-int 2 B)``,
    ``w mu`` changes by ``int 2 A mu`` from the phase's first angle to its last. Where the
    phase holds a coordinate on a profile (``B != 0``) the antiderivative of ``2 B`` is a
    logarithm, so ``mu`` is a power of the profile; the integrand is factored first so the
    profile cancels before sympy integrates it.
    """
    if len(model.coordinates) != 1 or any(e.at is None for e in model.events):
        return None
    theta, omega = model.coordinates[0].q, model.coordinates[0].u
    by_source = {e.source: e for e in model.events}
    step_event = next(e for e in model.events if e.ends_step)
    for event in model.events:
        check_event_angle(model, event.name)
    q = sm.Symbol("q", nonnegative=True)
    angle = reset(model, step_event.name)[0][0].xreplace({theta: step_event.at})
    u = q
    phase = model.phase(step_event.target)
    for _ in range(len(model.phases) + 1):
        event = by_source[phase.name]
        end = sm.sympify(event.at)
        u = phase_rate_map(phase, angle, u, end)
        if u is None:
            return None
        # The reset scales the rate: u -> factor**2 u.
        coords_after, rates_after = reset(model, event.name)
        factor = sm.cancel(rates_after[0].xreplace({theta: end}) / omega)
        if factor.has(omega):
            return None
        u = expand(factor**2 * u) if within_ops(u) else factor**2 * u
        angle = coords_after[0].xreplace({theta: end})
        if event.ends_step:
            break
        phase = model.phase(event.target)
    if within_ops(u):
        u = expand(u)
        if u.diff(q, 2) != 0:
            return None
        return StrideForm(sm.factor(u.diff(q)), u.xreplace({q: 0}), angle)
    slope = u.diff(q)
    if slope.has(q):  # each phase and reset maps u affinely: only the slope can fail
        return None
    return StrideForm(tidy(slope), tidy(u.xreplace({q: 0})), angle)
