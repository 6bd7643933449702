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

from derive.engine import model_derivation
from derive.engine.model import (
    Model,
    Phase,
    PointMass,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    SI_UNITS,
    SI_UNITS_TEXT,
    falls,
    gravity_parameter,
    legs_skeleton,
    minus,
    slope_gravity,
    slope_parameter,
    stance_leg_angle,
    swapping_heelstrike,
    swing_leg_angle,
)
from derive.models.families import compass_gait_hip_torque, compass_gait_rows
from derive.quantities import Derivation

# Drake's CompassGaitParams: the body's rows, slope 0.0525 rad, gravity 9.81 m/s^2.
PARAMETERS = (*compass_gait_rows(), slope_parameter(0.0525), gravity_parameter())
m_h, m, a, b, gamma, g = (p.symbol for p in PARAMETERS)
length = a + b

THETA, PSI = stance_leg_angle(slope=True), swing_leg_angle(slope=True)
theta, psi = THETA.q, PSI.q

hip = leg(theta, length)
swing_foot = minus(hip, leg(psi, length))
SKELETON = legs_skeleton(hip, swing_foot)

STANCE = Phase(
    "stance",
    coordinates=(THETA, PSI),
    bodies=(
        PointMass("hip", m_h, hip),
        PointMass("stance_leg", m, leg(theta, a)),
        PointMass("swing_leg", m, minus(hip, leg(psi, b))),
    ),
    gravity=slope_gravity(g, gamma),
    points={"swing_foot": swing_foot},
    # Drake's CompassGait has the same input (its "control" port: the hip torque). Passive
    # walking is this input at zero, which is all the commands but powered walking use.
    inputs=(compass_gait_hip_torque(theta, psi),),
)

MODEL = Model(
    name="compass_gait",
    title="Compass gait",
    description="Goswami et al. 1996: a hip mass and two legs with point masses, walking "
    "down a slope",
    source="derive/models/compass_gait.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    # The legs swap at heelstrike, past mid-stance (the swing foot's height through zero).
    events=(swapping_heelstrike(theta, psi),),
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
