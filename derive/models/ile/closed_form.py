"""The ILE model's closed forms: the paper's equations (1)-(23) and beyond, derived.

The model's facts are in :mod:`derive.models.ile.model`; the engine derives its equations of
motion, energies, leg force and resets (:mod:`derive.engine.hybrid`). The package's modules
chain them into the paper's closed forms: the phases and resets, eq. (1)-(6), (11)
(:mod:`~derive.models.ile.phases`); the stride map and its fixed point, eq. (7)-(10), (19)
(:mod:`~derive.models.ile.stride_map`); the energy balance (18), (20)-(23)
(:mod:`~derive.models.ile.energy`); the apex and contact bounds, eq. (14)
(:mod:`~derive.models.ile.bounds`); the step timing in Carlson form
(:mod:`~derive.models.ile.timing`); the existence conditions (12)-(17), the ones the paper
omits, and the staged forms the generated code evaluates without cancellation
(:mod:`~derive.models.ile.existence`). This module's :func:`derive` hands them to the code
generator as ``generated/ile/``. Nothing is typed in from the paper's results.
"""

from __future__ import annotations

import types

import sympy as sm

from derive.codegen import replace_unevaluated
from derive.engine import c_exports
from derive.engine.hybrid import hybrid_quantities
from derive.models.ile.bounds import apex_and_contact
from derive.models.ile.energy import energies, evaluation_forms
from derive.models.ile.existence import (
    CONDITION_PIECE_NAMES,
    condition_pieces,
    cos_ratio_margin,
    cos_ratio_threshold,
    existence_staged,
)
from derive.models.ile.model import (
    MODEL,
    PARAMETERS,
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
    r_e,
    theta,
    theta_II,
    theta_IV,
)
from derive.models.ile.phases import (
    eliminate_contact_angles,
    extension_reset,
    heelstrike,
    swing_phase_dimensionless,
)
from derive.models.ile.stride_map import check_engine_stride, stride
from derive.models.ile.timing import step_timing
from derive.quantities import CExport, Condition, Derivation, Quantity

_P = (beta, theta_II, phi0)
"""The model's parameters, the arguments of every quantity of the gait."""
_E = (*_P, q, m, g, r_e)
"""The arguments of the dimensional energies: the parameters, q and the units."""


def _paper_form(expr: sm.Expr) -> sm.Expr:
    """``expr`` with the contact angles' cosines and sines in their algebraic forms (11)."""
    return eliminate_contact_angles(expr)


def _phase_quantities(phase: dict[str, sm.Expr], hs: dict[str, sm.Expr]) -> tuple[Quantity, ...]:
    """The swing phases' acceleration (2), (4), energy and ground force, and the resets (3),
    (6)."""
    return (
        Quantity(
            name="swing_acceleration",
            args=(theta, leg_ratio),
            expr=phase["accel"],
            summary=(
                "Angular acceleration d2theta/dtau2 of a swing phase of leg length leg_ratio * r_e."
            ),
            equation="(2), (4)",
            returns="d2theta/dtau2; leg_ratio = beta gives (2), leg_ratio = 1 gives (4)",
        ),
        Quantity(
            name="phase_energy",
            args=(theta, omega, leg_ratio),
            expr=phase["energy"],
            summary="Mechanical energy of a swing phase, in units of m g r_e (its first integral).",
            returns="(kinetic + potential) / (m g r_e)",
        ),
        Quantity(
            name="normal_force",
            args=(theta, omega, leg_ratio),
            expr=phase["normal_force"],
            summary=(
                "Vertical ground force on the stance foot, in units of m g; the foot lifts off "
                "below 0"
            ),
            returns="N / (m g)",
        ),
        Quantity(
            name="extension_reset",
            args=(beta, omega_II),
            expr=extension_reset() * omega_II,
            summary="Angular velocity just after the instantaneous leg extension.",
            equation="(3)",
            returns="omega_III",
        ),
        Quantity(
            name="heelstrike_reset",
            args=(beta, phi0, omega_IV),
            expr=hs["reset_ratio"] * omega_IV,
            summary="Angular velocity of the new stance leg just after heelstrike.",
            equation="(6)",
            returns="omega_I(n+1)",
        ),
    )


def _heelstrike_quantities(hs: dict[str, sm.Expr]) -> tuple[Quantity, ...]:
    """The heelstrike's guard (5) and the stance angles at the section, theta_I (11), and at
    heelstrike, theta_IV (5)."""
    return (
        Quantity(
            name="swing_foot_height",
            args=(beta, phi0, theta),
            expr=hs["guard"].subs(theta_IV, theta),
            summary=(
                "Height of the shortened swing foot, in r_e, with the extended stance leg at theta."
            ),
            equation="(5)",
            returns="heelstrike guard; zero at theta = theta_IV",
        ),
        Quantity(
            name="theta_I",
            args=(beta, phi0),
            expr=hs["theta_I"],
            summary="Stance leg angle just after heelstrike.",
            equation="(11)",
            returns="theta_I in radians",
        ),
        Quantity(
            name="theta_IV",
            args=(beta, phi0),
            expr=sm.atan2(hs["sin_theta_IV"], hs["cos_theta_IV"]),
            summary="Stance leg angle at heelstrike.",
            equation="(5)",
            returns="theta_IV = theta_I + phi0 in radians",
        ),
    )


def _stride_quantities(st: dict[str, sm.Expr], ev: dict[str, sm.Expr]) -> tuple[Quantity, ...]:
    """The stride map (7), (9), its fixed point (10), its eigenvalue (19) and the rates
    before the extension and before heelstrike (7)."""
    return (
        Quantity(
            name="stride_map",
            args=(*_P, q),
            expr=_paper_form(st["stride_map"]),
            summary=(
                "Stride map f(q): q = omega_I**2 just after one heelstrike to just after the next."
            ),
            equation="(7), (9)",
            returns="q(n+1)",
        ),
        Quantity(
            name="q_fixed",
            args=_P,
            expr=_paper_form(ev["q_fixed"]),
            summary="Fixed point q^f of the stride map.",
            equation="(10)",
            returns="q^f",
        ),
        Quantity(
            name="eigenvalue",
            args=(beta, phi0),
            expr=st["eigenvalue"],
            summary="Eigenvalue df/dq of the stride map (constant: the map is linear in q).",
            equation="(19)",
            returns="lambda",
        ),
        Quantity(
            name="omega_II_squared",
            args=(*_P, q),
            expr=_paper_form(st["omega_II_squared"]),
            summary="omega**2 just before the extension, from the energy integral of phase I-II.",
            equation="(7)",
            returns="omega_II**2",
        ),
        Quantity(
            name="omega_IV_squared",
            args=(*_P, q),
            expr=_paper_form(st["omega_IV_squared"]),
            summary="omega**2 just before heelstrike, from the energy integral of phase III-IV.",
            equation="(7)",
            returns="omega_IV**2",
        ),
    )


def _bound_quantities(ac: dict[str, sm.Expr]) -> tuple[Quantity, ...]:
    """The apex bound (14), the lift-off bound (Fig. 9's right boundary) and the least
    ground force over a step."""
    return (
        Quantity(
            name="q_apex_min",
            args=_P,
            expr=ac["q_apex_exact"],
            summary="Smallest q at instant I that carries the walker over the apex in both phases.",
            equation="(14)",
            returns="exact form of (14); holds for either sign of theta_I and theta_II",
        ),
        Quantity(
            name="q_liftoff_max",
            args=_P,
            expr=ac["q_liftoff"],
            summary=(
                "Largest q at instant I for which the stance foot stays on the ground all step."
            ),
            returns="q bound from N >= 0 (Fig. 9 right boundary)",
        ),
        Quantity(
            name="contact_margin",
            args=(*_P, q),
            expr=ac["contact_margin"],
            summary=(
                "Minimum over the step of the ground normal force on the stance foot, in units of "
                "m g."
            ),
            returns="min N / (m g) over both phases",
        ),
    )


def _energy_quantities(en: dict[str, sm.Expr], ev: dict[str, sm.Expr]) -> tuple[Quantity, ...]:
    """The energy added (20), lost (18), (21), its change (22), (23) and the constant C
    of (23)."""
    return (
        Quantity(
            name="energy_complement",
            args=_E,
            expr=_paper_form(en["complement"]),
            summary="Energy added by the leg extension (the actuator's work per step), E_c.",
            equation="(20)",
            returns="E_c",
        ),
        Quantity(
            name="energy_dissipated",
            args=_E,
            expr=_paper_form(ev["energy_dissipated"]),
            summary="Energy lost at heelstrike, E_r, in terms of q of the same step.",
            equation="(21)",
            returns="E_r",
        ),
        Quantity(
            name="energy_dissipated_post",
            args=(beta, phi0, q_next, m, g, r_e),
            expr=ev["energy_dissipated_post"],
            summary="Energy lost at heelstrike in terms of q just after the impact.",
            equation="(18)",
            returns="E_r",
        ),
        Quantity(
            name="energy_change",
            args=_E,
            expr=_paper_form(ev["energy_change"]),
            summary="Net change of mechanical energy over one step, E_c - E_r.",
            equation="(22), (23)",
            returns="E_Delta",
        ),
        Quantity(
            name="energy_constant",
            args=(*_P, m, g, r_e),
            expr=_paper_form(en["constant"]),
            summary="The constant C of eq. (23): E_Delta at q = 0.",
            equation="(23)",
            returns="C",
        ),
    )


def _timing_quantities(tm: dict[str, sm.Expr]) -> tuple[Quantity, ...]:
    """The step length (the distance between the feet at heelstrike, eq. (5)) and the
    phases' durations (beyond the paper)."""
    return (
        Quantity(
            name="step_length",
            args=(beta, phi0),
            expr=tm["step_length"],
            summary="Distance between successive footholds (and hip travel per step), in r_e.",
            returns="step length / r_e",
        ),
        Quantity(
            name="phase_durations",
            args=(*_P, q),
            expr=(tm["duration_I_II"], tm["duration_III_IV"]),
            summary="Durations of the swing phases I-II and III-IV in dimensionless time tau.",
            returns="(tau_I_II, tau_III_IV)",
        ),
    )


def _paper_conditions(qf: sm.Expr, ac: dict[str, sm.Expr]) -> tuple[Condition, ...]:
    """The paper's existence conditions (12)-(16) at the fixed point ``qf``."""
    return (
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
    )


def _extension_conditions(
    qf: sm.Expr, ac: dict[str, sm.Expr], hs: dict[str, sm.Expr]
) -> tuple[Condition, ...]:
    """The extension before heelstrike, (17) and its exact form, and the conditions the
    paper omits: the extension reached and the stance foot kept on the ground."""
    return (
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
            margin=sm.atan2(hs["sin_theta_IV"], hs["cos_theta_IV"]) - theta_II,
            strict=True,
            status="exact",
            physical=True,
            meaning="theta_II < theta_IV: the leg extends before heelstrike",
            unit="rad",
        ),
        Condition(
            name="extension_reached",
            equation=None,
            margin=theta_II - hs["theta_I"],
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


def _condition_quantities(conditions: tuple[Condition, ...]) -> tuple[Quantity, ...]:
    """The conditions' margins (12)-(17), alone and staged with q^f (10) and lambda (19),
    and the smooth pieces of the apex (14) and contact margins."""
    staged_intermediates, staged_outputs, staged_names = existence_staged()
    if staged_names != tuple(c.name for c in conditions):
        raise AssertionError("existence_staged() and the condition list disagree")
    piece_intermediates, piece_outputs, _ = condition_pieces()
    return (
        Quantity(
            name="condition_margins",
            args=_P,
            expr=tuple(c.margin for c in conditions),
            summary=(
                "Margins of the existence conditions at the fixed point, in the order of "
                "CONDITIONS."
            ),
            equation="(12)-(17)",
            returns=(
                "tuple of margins; each condition holds when its margin is > 0 (>= 0 if not strict)"
            ),
        ),
        Quantity(
            name="fixed_point_conditions",
            args=_P,
            expr=staged_outputs,
            summary=(
                "q^f, eigenvalue and existence-condition margins in one pass (shared terms once)."
            ),
            equation="(10), (19), (12)-(17)",
            returns="(q^f, lambda, *margins in the order of CONDITIONS)",
            intermediates=staged_intermediates,
        ),
        Quantity(
            name="condition_pieces",
            args=_P,
            expr=piece_outputs,
            summary="Smooth pieces of the apex (14) and stance-contact margins at the fixed point.",
            equation="(14)",
            returns="("
            + ", ".join(CONDITION_PIECE_NAMES)
            + "); see derive.models.ile.condition_pieces",
            intermediates=piece_intermediates,
            output_names=CONDITION_PIECE_NAMES,
        ),
    )


def _add_engine_exports(d: Derivation) -> None:
    """The engine's functions and descriptor for the generic runtime, its stride map checked
    against the paper-shaped one (9), and what the C library, the batch evaluator and the
    explorer page export."""
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
    check_engine_stride()
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


def _add_facts(
    d: Derivation,
    phase: dict[str, sm.Expr],
    hs: dict[str, sm.Expr],
    st: dict[str, sm.Expr],
    en: dict[str, sm.Expr],
    ac: dict[str, sm.Expr],
) -> None:
    """The derived facts the audit compares with the paper's equations (1)-(23)."""
    d.facts.update({f"phase.{k}": v for k, v in phase.items()})
    d.facts.update({f"heelstrike.{k}": v for k, v in hs.items() if isinstance(v, sm.Basic)})
    d.facts.update({f"stride.{k}": v for k, v in st.items()})
    d.facts.update({f"energy.{k}": v for k, v in en.items()})
    d.facts.update({f"apex.{k}": v for k, v in ac.items()})
    d.facts["extension.ratio"] = extension_reset()
    d.facts["cos_ratio.margin"] = cos_ratio_margin()
    d.facts["cos_ratio.threshold"] = cos_ratio_threshold()


def derive() -> Derivation:
    """Derive every quantity of the ILE model, eq. (1)-(23) and beyond; the single entry point
    for code generation."""
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
    for qty in (
        *_phase_quantities(phase, hs),
        *_heelstrike_quantities(hs),
        *_stride_quantities(st, ev),
        *_bound_quantities(ac),
        *_energy_quantities(en, ev),
        *_timing_quantities(tm),
    ):
        d.add(qty)
    qf = d.quantities["q_fixed"].expr
    conditions = (*_paper_conditions(qf, ac), *_extension_conditions(qf, ac, hs))
    d.conditions = conditions
    for qty in _condition_quantities(conditions):
        d.add(qty)
    _add_engine_exports(d)
    _add_facts(d, phase, hs, st, en, ac)
    return d


def _step_metrics(
    module: types.ModuleType, beta: float, theta_II: float, phi0: float
) -> list[float]:
    """The C export ``step_metrics``: step length, period, speed and contact margin at q^f (10),
    composed from the generated functions."""
    q_f = module.q_fixed(beta, theta_II, phi0)
    length = module.step_length(beta, phi0)
    tau_I_II, tau_III_IV = module.phase_durations(beta, theta_II, phi0, q_f)
    period = tau_I_II + tau_III_IV
    return [length, period, length / period, module.contact_margin(beta, theta_II, phi0, q_f)]
