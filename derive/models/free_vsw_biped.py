"""The VSW biped's body with free actuation: the gait of least work that body can walk
(VSW's price on its own biped).

The body of the VSW biped (vsw_biped.py): a point mass ``m_H`` at the hip and two legs
whose mass ``m = mu m_H`` sits ``b`` below the hip on the upper, rigid segment; the lower
segment telescopes and is massless, so a leg's length changes no inertia about the hip.
Level ground; scaled units as the VSW biped's (lengths in ``l``, time in ``sqrt(l/g)``,
masses in ``m_H``, energies in ``m_H g l``).

The VSW biped holds its stance leg at ``beta l``, then ``l``, extending it in an instant at
``theta_II`` (the held-hip rule holding the swing leg). Here the stance leg's length ``r``
is a coordinate of its own, moved by the leg's force ``F >= 0`` between ``l_min`` and
``l`` (both ends failures: the path stays within them), and a hip torque acts between the
legs: the VSW biped's actuators, free in time. Heelstrike is the VSW biped's: the swing
foot, the swing leg ``beta l`` long, reaches the ground; the impact sticks the new foot
and the legs swap, so the new stance leg starts ``beta l`` long. Its lower segment slides
freely as it lands (the impact does no work along it: no collision along the new leg),
unless the leg's actuator takes an impulse along it just after (``heel_strike``, a
collision where it stops the leg: with it the landing is the VSW biped's rigid one); the
trailing leg may push off along itself just before (``push_off``); the hip torque may act
in an instant just before or after (its impulses). The optimiser keeps every ground
impulse pushing, within a friction cone where asked (``vsw optimize --friction``).

The VSW biped's own extension (a push from ``beta l``, then a stop at ``l``) is not among
this model's motions (the leg reaches ``l`` only as a failure); ``free_vsw_biped_stop.py``
adds the end stop. Neither is needed to bound VSW's price from below: any gait of this
body, verified, bounds its least work from above.

Coordinates: ``theta`` and ``psi`` as the VSW biped's (the legs' angles from the vertical,
positive with the hip ahead of the foot), ``r`` the stance leg's length.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Event,
    Failure,
    Impact,
    Impulse,
    Input,
    Model,
    Parameter,
    ParameterCondition,
    Phase,
    PointMass,
    leg,
    swing_foot_clearance,
)
from derive.models.common import falls, minus, stance_leg_angle, swing_leg_angle
from derive.models.vsw_biped import PARAMETERS as VSW_PARAMETERS
from derive.models.vsw_biped import UNITS, UNITS_TEXT, biped_bodies
from derive.quantities import Derivation

BETA, MU, B_OVER_L = (p for p in VSW_PARAMETERS if p.name in ("beta", "mu", "b_over_l"))
PARAMETERS = (
    BETA,
    MU,
    B_OVER_L,
    Parameter(
        name="l_min",
        latex=r"l_{min}",
        lower=0.0,
        upper=1.0,
        reason="0 < l_min < 1 (a leg's shortest length, in l)",
        description="shortest length of the stance leg, over l (the end of its stroke)",
        assumptions={"positive": True},
        default=0.5,
        unit="1",
    ),
)
beta, mu, b, l_min = (p.symbol for p in PARAMETERS)

THETA, PSI = stance_leg_angle(), swing_leg_angle()
R = Coordinate("r", "stance leg length", "l", reference="the stance foot",
               positive="the hip away from the foot")  # fmt: skip
theta, psi, r = THETA.q, PSI.q, R.q


def bodies(stance_length: sm.Expr) -> tuple[PointMass, ...]:
    """The hip and the two legs' masses, the stance leg ``stance_length`` long."""
    return biped_bodies(leg(theta, stance_length), psi)


def swing_foot(stance_length: sm.Expr) -> tuple[sm.Expr, sm.Expr]:
    """The swing foot, ``beta`` below the hip along the swing leg."""
    return minus(leg(theta, stance_length), leg(psi, beta))


LEG_FORCE = Input(
    "leg_force",
    r,
    "leg",
    unit="m_H g",
    bounds=(0.0, None),
    description="the stance leg's force along itself, pushing the hip away from the foot "
    "(>= 0: a leg cannot pull on the ground)",
)
HIP_TORQUE = Input(
    "hip_torque",
    theta - psi,
    "hip",
    unit="m_H g l",
    description="torque between the legs at the hip, positive spreading them (the swing leg "
    "forward)",
)
PUSH_OFF = Impulse(
    "push_off",
    r,
    "leg",
    unit="m_H sqrt(g l)",
    bounds=(0.0, None),
    description="the trailing leg's impulse along itself just before heelstrike",
)
HIP_IMPULSE_BEFORE = Impulse(
    "hip_impulse_before",
    theta - psi,
    "hip",
    unit="m_H l sqrt(g l)",
    description="the hip torque's impulse just before heelstrike",
)
HEEL_STRIKE = Impulse(
    "heel_strike",
    r,
    "leg",
    after=True,
    unit="m_H sqrt(g l)",
    bounds=(0.0, None),
    description="the new stance leg's impulse along itself just after heelstrike (a "
    "collision where it stops the leg shortening)",
)
HIP_IMPULSE_AFTER = Impulse(
    "hip_impulse_after",
    theta - psi,
    "hip",
    after=True,
    unit="m_H l sqrt(g l)",
    description="the hip torque's impulse just after heelstrike",
)
FALLS = falls(THETA, backward="the walker stops before the apex and falls back")
CROUCHED = Failure(
    "crouched",
    r - l_min,
    -1,
    "the stance leg would be shorter than l_min: the end of its stroke",
    unit="l",
)
OVEREXTENDED = Failure("overextended", r - 1, +1, "the stance leg would be longer than l", unit="l")
SEARCH = {
    "theta": (-0.6, 0.0),
    "psi": (0.0, 0.6),
    "theta_dot": (0.0, 2.0),
    "psi_dot": (-3.0, 1.0),
    "r_dot": (-1.0, 1.0),
}
PARAMETER_CONDITIONS = (
    ParameterCondition(
        beta - l_min,
        "the swing leg's length at heelstrike, beta, must be at least l_min",
        strict=False,
    ),
)


def heelstrike(source: Phase, impulses: tuple[Impulse, ...], target: str = "stance") -> Event:
    """Heelstrike from ``source`` to ``target``: the swing foot reaches the ground ahead of
    the stance foot; the new foot sticks, the legs swap, the new stance leg ``beta`` long
    and free to slide."""
    return Event(
        "heelstrike",
        source.name,
        target,
        guard=source.points["swing_foot"][1],  # the swing foot's height
        direction=-1,
        reset=Impact(
            "swing_foot",
            {theta: psi, psi: theta, r: beta},
            bodies={"stance_leg": "swing_leg", "swing_leg": "stance_leg"},
        ),
        ends_step=True,
        when=theta - psi,  # the new foot lands ahead of the stance foot
        impulses=impulses,
        equation="(5), (6) with massive legs, the new stance leg free to slide",
    )


def stance_phase(name: str) -> Phase:
    """The stance, ``name``: the leg free to slide under its force, the hip torque free
    (the models that split the stance or stop the leg name it again)."""
    return Phase(
        name,
        coordinates=(THETA, PSI, R),
        bodies=bodies(r),
        gravity=(0, -1),
        points={"swing_foot": swing_foot(r)},
        inputs=(LEG_FORCE, HIP_TORQUE),
    )


STANCE = stance_phase("stance")

MODEL = Model(
    name="free_vsw_biped",
    title="VSW biped's body, free actuation",
    description="the VSW biped's body (hip mass, leg masses on the legs' upper segments, "
    "telescoping massless feet, level ground) with its leg force and hip torque free in "
    "time: the least-work gaits VSW's price is measured against; no passive gait: it walks "
    "only powered",
    source="derive/models/free_vsw_biped.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(heelstrike(STANCE, (PUSH_OFF, HIP_IMPULSE_BEFORE, HEEL_STRIKE, HIP_IMPULSE_AFTER)),),
    failures=(*FALLS, CROUCHED, OVEREXTENDED),
    conditions=(swing_foot_clearance(STANCE.points["swing_foot"][1], "l"),),
    units=UNITS,
    step_length=STANCE.points["swing_foot"][0],
    # Just after heelstrike the new stance leg is beta l long.
    section={"r": beta},
    search=SEARCH,
    powered_only=True,
    parameter_conditions=PARAMETER_CONDITIONS,
)


def derive() -> Derivation:
    return model_derivation(MODEL, UNITS_TEXT)
