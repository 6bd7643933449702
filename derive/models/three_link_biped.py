"""The three-link biped of Grizzle, Abba & Plestan 2001 ("Asymptotically stable walking for
biped robots: analysis via systems with impulse effects", IEEE Trans. Automatic Control
46(1):51-64, Section V) and of Westervelt, Grizzle, Chevallereau, Choi & Morris 2007
("Feedback Control of Dynamic Bipedal Robot Locomotion", CRC Press, Section 6.6.1), with its
two hip torques as inputs, on level ground.

Two legs of length ``r``, each a point mass ``m`` at its middle, a point mass ``m_h`` at
the hip and a torso, a point mass ``m_t`` at ``l`` above the hip, under gravity ``g``. The
stance foot is a hinge; two actuators at the hip act between the torso and each leg. The
model has one degree of underactuation: the actuators exert no torque about the stance
foot, so the angular momentum about it changes by gravity alone (the structure hybrid zero
dynamics rests on: ``vsw hzd``). Heelstrike is an inelastic impact at the swing foot, after
which the legs swap roles; the swing foot passes through the ground near mid-stance
(scuffing is ignored, as in the sources).

Coordinates, absolute angles from the vertical, positive leaning forward (the sources'
``q = (theta_1, theta_2, theta_3)``): ``theta1`` the stance leg, ``theta2`` the swing leg,
both measured from foot to hip, and ``theta3`` the torso, from the hip to its mass. The
inputs do work along ``theta3 - theta1`` (between the torso and the stance leg) and
``theta3 - theta2`` (between the torso and the swing leg): the sources' ``B = [-1 0; 0 -1;
1 1]`` up to the sign of the torques. It has no passive gait on level ground: it walks only
powered (``vsw hzd``, ``vsw optimize``).
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Failure,
    Input,
    Model,
    Phase,
    PointMass,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    SI_UNITS,
    SI_UNITS_TEXT,
    fell_backward,
    fell_forward,
    gravity_parameter,
    legs_skeleton,
    lift_off,
    minus,
    plus,
    scale_parameter,
    stance_leg_angle,
    swapping_heelstrike,
    swing_leg_angle,
)
from derive.models.families import three_link_rows
from derive.quantities import Derivation

# Grizzle et al. 2001, Table I (and the book's model_params_three_link.m, with g = 9.81).
PARAMETERS = (
    *three_link_rows(),
    scale_parameter(
        name="l",
        latex="l",
        reason="l > 0",
        description="distance from the hip to the torso's mass",
        default=0.5,
        unit="m",
    ),
    gravity_parameter(),
)
m_h, m, m_t, r, l, g = (p.symbol for p in PARAMETERS)

STANCE_LEG, SWING_LEG = stance_leg_angle("theta1"), swing_leg_angle("theta2")
TORSO = Coordinate("theta3", "torso angle", "rad", reference="the vertical",
                   positive="the torso leaning forward")  # fmt: skip
theta1, theta2, theta3 = STANCE_LEG.q, SWING_LEG.q, TORSO.q

hip = leg(theta1, r)
swing_foot = minus(hip, leg(theta2, r))
torso = plus(hip, leg(theta3, l))
SKELETON = legs_skeleton(hip, swing_foot, torso)
STANCE = Phase(
    "stance",
    coordinates=(STANCE_LEG, SWING_LEG, TORSO),
    bodies=(
        PointMass("hip", m_h, hip),
        PointMass("stance_leg", m, leg(theta1, r / 2)),
        PointMass("swing_leg", m, minus(hip, leg(theta2, r / 2))),
        PointMass("torso", m_t, torso),
    ),
    gravity=(0, -g),
    points={"swing_foot": swing_foot},
    inputs=(
        Input(
            "torso_stance_torque",
            theta3 - theta1,
            "hip",
            unit="N m",
            description="torque between the stance leg and the torso, positive turning the "
            "torso forward (its reaction turns the stance leg back)",
        ),
        Input(
            "torso_swing_torque",
            theta3 - theta2,
            "hip",
            unit="N m",
            description="torque between the swing leg and the torso, positive turning the "
            "torso forward (its reaction turns the swing leg back)",
        ),
    ),
)

MODEL = Model(
    name="three_link_biped",
    title="Three-link biped",
    description="Grizzle, Abba & Plestan 2001 (Westervelt et al. 2007): legs with point "
    "masses, a hip mass and a torso, two hip torques, level ground; one degree of "
    "underactuation, no passive gait: it walks only powered",
    source="derive/models/three_link_biped.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        # The legs swap at heelstrike, past mid-stance (the swing foot's height through
        # zero); the torso keeps its angle.
        swapping_heelstrike(
            theta1, theta2, kept=(theta3,), equation="Grizzle et al. 2001, eqs. (18)-(21)"
        ),
    ),
    failures=(
        fell_backward(STANCE_LEG, "the stance leg stops and swings back"),
        fell_forward(STANCE_LEG),
        Failure("torso-fell", sm.cos(theta3), -1, "the torso reaches the horizontal"),
        lift_off(),
    ),
    conditions=(swing_foot_clearance(swing_foot[1], "m"),),
    units=SI_UNITS,
    skeleton=SKELETON,
    step_length=swing_foot[0],
    search={
        "theta1": (-0.6, 0.0),
        "theta3": (-0.5, 0.8),
        "theta1_dot": (0.0, 3.0),
        "theta2_dot": (-3.0, 3.0),
        "theta3_dot": (-3.0, 3.0),
    },
    # Just after heelstrike the legs are at the guard's zero, swapped.
    section={"theta2": -theta1},
    powered_only=True,
)


def derive() -> Derivation:
    return model_derivation(MODEL, SI_UNITS_TEXT)
