"""The ILE's existence conditions: (12) q^f > 0 and its rewriting (13), the apex (14) and the
stance contact at the fixed point, over named intermediate values that the generated code
computes once (:func:`existence_staged`), and their smooth pieces for a gradient-based
optimiser (:func:`condition_pieces`)."""

from __future__ import annotations

import functools

import sympy as sm

from derive import mechanics
from derive.models.common import closest_to_apex_cos
from derive.models.ile.bounds import apex_and_contact
from derive.models.ile.model import (
    beta,
    leg_ratio,
    omega,
    phi0,
    q,
    theta,
    theta_I,
    theta_II,
    theta_IV,
)
from derive.models.ile.phases import (
    extension_reset,
    heelstrike,
    omega_squared_along,
    phase_energy,
    square_symbol,
    swing_phase_dimensionless,
)
from derive.models.ile.stride_map import fixed_point_offset, one_minus_eigenvalue, stride

Staged = tuple[tuple[sm.Symbol, sm.Expr], ...]
"""Named intermediate values, in the order the generated code computes them."""


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


CONTACT_ANGLE_NAMES = {
    sm.cos(theta_I): sm.Symbol("cos_theta_I", positive=True),
    sm.sin(theta_I): sm.Symbol("sin_theta_I", real=True),
    sm.cos(theta_IV): sm.Symbol("cos_theta_IV", positive=True),
    sm.sin(theta_IV): sm.Symbol("sin_theta_IV", real=True),
}
"""Names of the heelstrike angles' cosines and sines in staged (intermediate) forms."""


def _fixed_point_stages() -> Staged:
    """The named values every margin starts from: ``cos/sin theta_I`` and ``cos/sin theta_IV``
    (eq. 11), the eigenvalue (19), ``q_f`` (10), and ``omega_II**2`` (7) and ``omega_III**2``
    (3) at the fixed point.

    The stride map is affine, f(q) = lambda q + f(0), so q^f = f(0) / (1 - lambda), with
    1 - lambda in a form without cancellation for short steps.
    """
    hs, st = heelstrike(), stride()
    names = CONTACT_ANGLE_NAMES
    q_f = sm.Symbol("q_f", real=True)
    omega_II_sq = sm.Symbol("omega_II_sq", real=True)
    omega_III_sq = sm.Symbol("omega_III_sq", real=True)
    eigenvalue = sm.Symbol("eigenvalue", real=True)
    stride_map = st["stride_map"].xreplace(names)
    if sm.expand(stride_map - (st["eigenvalue"] * q + stride_map.subs(q, 0))) != 0:
        raise AssertionError("the stride map is not affine in q")
    offset = fixed_point_offset().xreplace(names)
    return (
        (names[sm.cos(theta_I)], hs["cos_theta_I"]),
        (names[sm.sin(theta_I)], hs["sin_theta_I"]),
        (names[sm.cos(theta_IV)], hs["cos_theta_IV"]),
        (names[sm.sin(theta_IV)], hs["sin_theta_IV"]),
        (eigenvalue, st["eigenvalue"]),
        (q_f, offset / one_minus_eigenvalue()),
        # omega_III**2 = (extension ratio)**2 omega_II**2 as a product, not expanded: for
        # short stance legs (beta -> 0) the expanded terms cancel.
        (omega_II_sq, st["omega_II_squared"].xreplace(names).subs(q, q_f)),
        (omega_III_sq, extension_reset() ** 2 * omega_II_sq),
    )


def _phase_margins(
    q_f: sm.Symbol, omega_III_sq: sm.Symbol
) -> tuple[list[tuple[sm.Symbol, sm.Expr]], list[sm.Expr], list[sm.Expr]]:
    """Each phase's apex margin (14) and least normal force at the fixed point, with the
    named values they need beyond :func:`_fixed_point_stages`.

    ``omega**2`` along a phase is linear in ``q`` with a positive slope ``k``, so
    ``q_f - q_root = omega**2(q_f) / k``: the apex margin is ``omega**2`` at the phase's
    point nearest the apex over ``k``, without solving for the root.
    """
    st = stride()
    names = CONTACT_ANGLE_NAMES
    cos_I, sin_I = names[sm.cos(theta_I)], names[sm.sin(theta_I)]
    cos_IV, sin_IV = names[sm.cos(theta_IV)], names[sm.sin(theta_IV)]
    # Phase I-II starts at theta_I with q; phase III-IV starts at theta_II with omega_III**2.
    c_star = (
        closest_to_apex_cos(sin_I, cos_I, sm.sin(theta_II), sm.cos(theta_II)),
        closest_to_apex_cos(sm.sin(theta_II), sm.cos(theta_II), sin_IV, cos_IV),
    )
    c_lowest = (sm.Min(cos_I, sm.cos(theta_II)), sm.Min(sm.cos(theta_II), cos_IV))
    slopes = (sm.Integer(1), sm.diff(st["omega_III_squared"], q))
    starts = ((beta, theta_I, q_f), (sm.Integer(1), theta_II, omega_III_sq))
    staged: list[tuple[sm.Symbol, sm.Expr]] = []
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
    return staged, apex_margins, contact_margins


@functools.cache
def existence_staged() -> tuple[Staged, tuple[sm.Expr, ...], tuple[str, ...]]:
    """q^f (10), eigenvalue (19) and every condition margin, (12)-(17) and the ones the paper
    omits, over named intermediate values.

    The same quantities as :func:`~derive.models.ile.closed_form.derive`'s ``q_fixed``,
    ``eigenvalue`` and condition margins, built from the same phase integrals, but kept in
    terms of ``cos/sin theta_I``, ``cos/sin theta_IV`` (eq. 11), ``q_f`` and
    ``omega_III**2`` so the generated code computes each once. The apex margin uses that
    ``omega**2`` along a phase is linear in ``q`` with a positive slope ``k``:
    ``q_f - q_root = omega**2(q_f) / k``, so ``q_f - max(q_roots) = min(omega**2_min / k)``
    without solving for the roots. tests/test_generated_backends.py checks the result
    against the explicit forms.

    Returns
    -------
    intermediates : tuple of (sympy.Symbol, sympy.Expr)
    outputs : tuple of sympy.Expr
        ``(q_f, eigenvalue, *margins)``.
    margin_names : tuple of str
        Condition names of the margins, in order.
    """
    hs = heelstrike()
    fixed = _fixed_point_stages()
    by_name = {symbol.name: symbol for symbol, _ in fixed}
    q_f, eigenvalue = by_name["q_f"], by_name["eigenvalue"]
    sin_IV, cos_IV = by_name["sin_theta_IV"], by_name["cos_theta_IV"]
    staged, apex_margins, contact_margins = _phase_margins(q_f, by_name["omega_III_sq"])
    margins = {
        "q_positive": q_f,
        "cos_ratio": cos_ratio_margin().xreplace(CONTACT_ANGLE_NAMES),
        "apex": sm.Min(*apex_margins),
        "theta_I_negative": beta - sm.cos(phi0),
        "phi0_below_right_angle": sm.pi / 2 - phi0,
        "extension_before_symmetric_contact": phi0 / 2 - theta_II,
        "extension_before_heelstrike": sm.atan2(sin_IV, cos_IV) - theta_II,
        "extension_reached": theta_II - hs["theta_I"],
        "stance_contact": sm.Min(*contact_margins),
    }
    return (*fixed, *staged), (q_f, eigenvalue, *margins.values()), tuple(margins)


CONDITION_PIECE_NAMES = (
    "apex_phase_I_II",
    "apex_phase_III_IV",
    "normal_force_I",
    "normal_force_II",
    "normal_force_IV",
)
"""Outputs of :func:`condition_pieces`, in order."""


@functools.cache
def condition_pieces() -> tuple[Staged, tuple[sm.Expr, ...], tuple[str, ...]]:
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
    w2 = square_symbol("w2")
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
