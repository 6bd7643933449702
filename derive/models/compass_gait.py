"""The compass gait (Goswami, Thuilot, Espiau 1996, "Compass-like biped robot part I:
stability and bifurcation of passive gaits", INRIA RR-2996; Drake, examples/compass_gait).

Two rigid legs of length ``a + b`` hinged at the hip, a point mass ``m_h`` at the hip and a
point mass ``m`` on each leg at distance ``a`` from its foot (``b`` from the hip), on a
slope ``gamma`` under gravity ``g``. The stance foot is a hinge; the swing leg swings
freely (its foot passes through the slope near mid-stance: scuffing is ignored, as in the
sources); heelstrike is an inelastic impact of the swing foot, after which the legs swap
roles. Drake's defaults are the parameters' defaults.

Coordinates on the slope (x downhill, y along its normal): ``theta`` is the stance leg's
angle from the slope normal, positive with the hip downhill of the stance foot; ``psi`` is
the swing leg's angle from the slope normal, measured the same way (a swing foot ahead of
the hip has ``psi < 0``).
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Event,
    Impact,
    Input,
    Model,
    Phase,
    PointMass,
    Skeleton,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    SI_UNITS,
    SI_UNITS_TEXT,
    falls,
    gravity_parameter,
    scale_parameter,
    slope_gravity,
    slope_parameter,
)
from derive.quantities import Derivation

# Drake's CompassGaitParams: mass_hip 10 kg, mass_leg 5 kg, length_leg 1 m,
# center_of_mass_leg 0.5 m (from the hip), slope 0.0525 rad, gravity 9.81 m/s^2.
PARAMETERS = (
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
    slope_parameter(0.0525),
    gravity_parameter(),
)
m_h, m, a, b, gamma, g = (p.symbol for p in PARAMETERS)
length = a + b

THETA = Coordinate(
    "theta",
    "stance leg angle",
    "rad",
    reference="the slope normal",
    positive="the hip downhill of the stance foot",
)
PSI = Coordinate(
    "psi",
    "swing leg angle",
    "rad",
    reference="the slope normal",
    positive="the hip downhill of the swing foot",
)
theta, psi = THETA.q, PSI.q

hip = leg(theta, length)
swing_foot = tuple(h - f for h, f in zip(hip, leg(psi, length)))
SKELETON = Skeleton(
    points={"stance_foot": (0, 0), "hip": hip, "swing_foot": swing_foot},
    segments=(("stance_foot", "hip"), ("hip", "swing_foot")),
)

STANCE = Phase(
    "stance",
    coordinates=(THETA, PSI),
    bodies=(
        PointMass("hip", m_h, hip),
        PointMass("stance_leg", m, leg(theta, a)),
        PointMass("swing_leg", m, tuple(h - f for h, f in zip(hip, leg(psi, b)))),
    ),
    gravity=slope_gravity(g, gamma),
    points={"swing_foot": swing_foot},
    # Drake's CompassGait has the same input (its "control" port: the hip torque). Passive
    # walking is this input at zero, which is all the commands but powered walking use.
    inputs=(
        Input(
            "hip_torque",
            theta - psi,
            "hip",
            unit="N m",
            description="torque between the legs at the hip, positive spreading them (the "
            "swing leg forward); its reaction acts on the stance leg",
        ),
    ),
)

MODEL = Model(
    name="compass_gait",
    title="Compass gait",
    description="Goswami et al. 1996: a hip mass and two legs with point masses, walking "
    "down a slope",
    source="derive/models/compass_gait.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "heelstrike",
            "stance",
            "stance",
            # The swing foot's height is -2 (a + b) sin((theta + psi)/2) sin((theta - psi)/2):
            # zero where the legs are together (the scuffing the model ignores) and at
            # heelstrike, where the first factor rises through zero.
            guard=sm.sin((theta + psi) / 2),
            direction=1,
            reset=Impact(
                "swing_foot",
                {theta: psi, psi: theta},
                bodies={"stance_leg": "swing_leg", "swing_leg": "stance_leg"},
            ),
            ends_step=True,
            when=theta,  # past mid-stance: the new foot lands ahead of the hip
        ),
    ),
    failures=falls(THETA, ground="slope"),
    conditions=(swing_foot_clearance(swing_foot[1], "m"),),
    units=SI_UNITS,
    skeleton=SKELETON,
    step_length=swing_foot[0],
    # Just after heelstrike the new stance foot is downhill of the hip (theta < 0); Drake's
    # gait at its defaults: theta = -0.271, theta_dot = 1.09 rad/s, psi_dot = 0.38 rad/s.
    search={"theta": (-0.8, 0.0), "theta_dot": (0.0, 5.0), "psi_dot": (-5.0, 5.0)},
    # Just after heelstrike the legs are at the guard's zero, swapped: psi = -theta.
    section={"psi": -theta},
)


def derive() -> Derivation:
    return model_derivation(MODEL, SI_UNITS_TEXT)
