"""What a family of models shares: the parameter rows of one body that several models walk
(the compass gait's, the three-link biped's, the point-mass walker's), the rows of the VSW
leg extension (the ILE's, the TLE's and the VSW bipeds'), and the compass gait's hip torque.

Each row is written once, so that two models of one body cannot drift apart; where a model
words a row otherwise or gives it another default, that is an argument here.
"""

from __future__ import annotations

import sympy as sm

from derive.engine.model import Input, Parameter, ParameterCondition
from derive.models.common import PI, gravity_parameter, scale_parameter


def compass_gait_rows() -> tuple[Parameter, ...]:
    """The compass gait's body (Goswami et al. 1996), Drake's ``CompassGaitParams`` as
    defaults (mass_hip 10 kg, mass_leg 5 kg, length_leg 1 m, center_of_mass_leg 0.5 m from
    the hip): the hip mass ``m_h``, each leg's mass ``m``, and the distances ``a`` from a
    foot and ``b`` from the hip to a leg's mass."""
    return (
        scale_parameter(
            name="m_h",
            latex="m_H",
            reason="hip mass m_h > 0",
            description="hip mass",
            default=10.0,
            unit="kg",
        ),
        scale_parameter(
            name="m",
            latex="m",
            reason="leg mass m > 0",
            description="mass of each leg",
            default=5.0,
            unit="kg",
        ),
        scale_parameter(
            name="a",
            latex="a",
            reason="a > 0",
            description="distance from a foot to its leg's mass",
            default=0.5,
            unit="m",
        ),
        scale_parameter(
            name="b",
            latex="b",
            reason="b > 0",
            description="distance from the hip to a leg's mass",
            default=0.5,
            unit="m",
        ),
    )


def compass_gait_hip_torque(theta: sm.Expr, psi: sm.Expr) -> Input:
    """The compass gait's hip torque between the stance leg ``theta`` and the swing leg
    ``psi`` (Drake's ``CompassGait`` input, its "control" port), in N m."""
    return Input(
        "hip_torque",
        theta - psi,
        "hip",
        unit="N m",
        description="torque between the legs at the hip, positive spreading them (the "
        "swing leg forward); its reaction acts on the stance leg",
    )


def three_link_rows() -> tuple[Parameter, ...]:
    """The three-link biped's legs and masses (Grizzle et al. 2001, Table I; Westervelt et
    al. 2007's model_params_three_link.m): the hip mass ``m_h``, each leg's mass ``m`` at
    its middle, the torso's mass ``m_t`` and the leg length ``r``. The torso's length is
    the model's own row (its name differs between the models)."""
    return (
        scale_parameter(
            name="m_h",
            latex="M_H",
            reason="hip mass m_h > 0",
            description="hip mass",
            default=15.0,
            unit="kg",
        ),
        scale_parameter(
            name="m",
            latex="m",
            reason="leg mass m > 0",
            description="mass of each leg (at its middle)",
            default=5.0,
            unit="kg",
        ),
        scale_parameter(
            name="m_t",
            latex="M_T",
            reason="torso mass m_t > 0",
            description="torso mass",
            default=10.0,
            unit="kg",
        ),
        scale_parameter(
            name="r",
            latex="r",
            reason="leg length r > 0",
            description="leg length",
            default=1.0,
            unit="m",
        ),
    )


POINT_MASS_UNITS_TEXT = "Lengths in m, time in s, energies in J (scaled: m = g = l = 1 by default)."
"""The generated docstrings' sentence on the point-mass walkers' units."""


def point_mass_walker_rows(leg_description: str) -> tuple[Parameter, ...]:
    """A point mass on two massless legs walking steps of a given length (Kuo 2002;
    Srinivasan & Ruina 2006), scaled by default (``m = g = l = 1``): the mass ``m`` at the
    hip, gravity ``g``, the leg length ``l`` (``leg_description``: rigid or at most that
    long) and the step length ``d``."""
    return (
        scale_parameter(
            name="m",
            latex="m",
            reason="mass m > 0",
            description="mass at the hip",
            default=1.0,
            unit="kg",
        ),
        gravity_parameter(1.0),
        scale_parameter(
            name="l",
            latex="l",
            reason="leg length l > 0",
            description=leg_description,
            default=1.0,
            unit="m",
        ),
        scale_parameter(
            name="d",
            latex="d",
            reason="step length d > 0",
            description="step length: from the stance foot to the next",
            default=0.6,
            unit="m",
        ),
    )


def legs_reach_the_step(l: sm.Expr, d: sm.Expr) -> ParameterCondition:
    """Legs ``l`` long reach a step ``d`` long: ``d < 2 l``."""
    return ParameterCondition(2 * l - d, "the step d must be shorter than 2 l: the legs must reach")


def shortening_ratio(*, default: float, **fields) -> Parameter:
    """The VSW leg's shortening ratio ``0 < beta = r_s / r_e < 1`` (``fields``: the other
    fields of :class:`~derive.quantities.Parameter`, such as ``computed``)."""
    return Parameter(
        name="beta",
        latex=r"\beta",
        lower=0.0,
        upper=1.0,
        reason="beta = r_s / r_e is a length-shortening ratio: 0 < beta < 1",
        description="length shorten ratio r_s / r_e",
        assumptions={"positive": True},
        default=default,
        unit="1",
        **fields,
    )


def extension_angle(*, description: str, default: float, **fields) -> Parameter:
    """The stance angle ``|theta_II| < pi/2`` at which the VSW leg extends
    (``description``: where in the extension it stands)."""
    return Parameter(
        name="theta_II",
        latex=r"\theta_{II}",
        lower=-PI / 2,
        upper=PI / 2,
        reason="the stance leg must point below the horizontal: |theta_II| < pi/2",
        description=description,
        default=default,
        unit="rad",
        **fields,
    )


def heelstrike_inter_leg_angle(*, equation: str, default: float, **fields) -> Parameter:
    """The inter-leg angle ``0 < phi0 < pi/2`` at heelstrike (``equation``: the ILE's
    condition (16), as the model cites it)."""
    return Parameter(
        name="phi0",
        latex=r"\varphi_0",
        lower=0.0,
        upper=PI / 2,
        reason=f"inter-leg angle at heelstrike: 0 < phi0 < pi/2, {equation}",
        description="inter-leg angle at heelstrike",
        assumptions={"positive": True},
        default=default,
        unit="rad",
        **fields,
    )


def extension_interval(*, bounds: str, default: float, **fields) -> Parameter:
    """The stance-angle interval ``0 < delta < pi/2`` of a finite-time leg extension
    (``bounds``: the model's statement of them)."""
    return Parameter(
        name="delta",
        latex=r"\Delta",
        lower=0.0,
        upper=PI / 2,
        reason=f"stance-angle interval of the extension: {bounds}",
        description="stance-angle interval of the leg extension",
        assumptions={"positive": True},
        default=default,
        unit="rad",
        **fields,
    )
