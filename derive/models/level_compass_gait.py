"""The compass gait on level ground, powered (Kuo's ratio with massive legs).

The body of the compass gait (compass_gait.py: Goswami, Thuilot, Espiau 1996; Drake,
examples/compass_gait, whose parameters are the defaults): two rigid legs ``a + b`` long
hinged at the hip, a point mass ``m_h`` at the hip and ``m`` on each leg at ``a`` from its
foot. On level ground it has no passive gait; Kuo (2002, "Energetics of actively powered
locomotion using the simplest walking model", J. Biomech. Eng. 124) compares two ways of
powering it, here with its legs' masses:

* a push-off along the trailing (stance) leg with heelstrike, whose foot the impact
  releases (:attr:`derive.engine.model.Impulse.at_impact`). The rigid stance leg's length
  ``r`` is held at ``a + b`` by its actuator; the push-off is that actuator's impulse. The
  actuator sits at the foot (the leg's shaft and its mass, ``b`` below the hip, move with
  the hip): an impulse from the ground along a rigid leg moves the whole leg so;
* the hip torque between the legs (Drake's ``CompassGait`` input), which on level ground
  must do its work through the swing leg's reaction on the stance leg.

Coordinates on level ground: ``theta`` is the stance leg's angle from the vertical,
positive with the hip ahead of the stance foot; ``psi`` the swing leg's, measured the same
way (a swing foot ahead of the hip has ``psi < 0``). The swing foot passes through the
ground near mid-stance (scuffing is ignored, as for the compass gait on its slope).
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Impulse,
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
    minus,
    push_off_with_heelstrike,
    stance_leg_angle,
    swapping_heelstrike,
    swing_leg_angle,
)
from derive.models.families import compass_gait_hip_torque, compass_gait_rows
from derive.quantities import Derivation

# Drake's CompassGaitParams (as compass_gait.py), without the slope.
PARAMETERS = (*compass_gait_rows(), gravity_parameter())
m_h, m, a, b, g = (p.symbol for p in PARAMETERS)
length = a + b

THETA, PSI = stance_leg_angle(), swing_leg_angle()
theta, psi = THETA.q, PSI.q
r = sm.Symbol("r", positive=True)
"""The stance leg's length, held at a + b by its actuator (the leg, at its foot)."""

hip = leg(theta, r)
swing_foot = minus(hip, leg(psi, length))

STANCE = Phase(
    "stance",
    coordinates=(THETA, PSI),
    bodies=(
        PointMass("hip", m_h, hip),
        PointMass("stance_leg", m, minus(hip, leg(theta, b))),
        PointMass("swing_leg", m, minus(hip, leg(psi, b))),
    ),
    gravity=(0, -g),
    held={r: length},
    points={"swing_foot": swing_foot},
    inputs=(compass_gait_hip_torque(theta, psi),),
)

MODEL = Model(
    name="level_compass_gait",
    title="Compass gait on level ground, powered",
    description="the compass gait's body (Goswami et al. 1996, Drake's parameters) on level "
    "ground, powered by a push-off along the trailing leg with heelstrike or by the hip "
    "torque (Kuo 2002's comparison with massive legs); no passive gait: it walks only powered",
    source="derive/models/level_compass_gait.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        # The legs swap at heelstrike, past mid-stance (the swing foot's height through zero,
        # the leg at its held length, as on the slope at gamma = 0).
        swapping_heelstrike(
            theta,
            psi,
            impulses=(
                push_off_with_heelstrike(r),
                # The hip torque's least-work schedule concentrates at the step's two ends
                # (a torque on a mesh approaches them from above): its limits, as impulses.
                Impulse(
                    "hip_impulse_before",
                    theta - psi,
                    "hip",
                    unit="N m s",
                    description="the hip torque's impulse just before heelstrike",
                ),
                Impulse(
                    "hip_impulse_after",
                    theta - psi,
                    "hip",
                    after=True,
                    unit="N m s",
                    description="the hip torque's impulse just after heelstrike",
                ),
            ),
            equation="Kuo 2002, eqs. (3)-(4), with the legs' masses",
        ),
    ),
    failures=falls(THETA),
    conditions=(swing_foot_clearance(swing_foot[1], "m"),),
    units=SI_UNITS,
    step_length=swing_foot[0],
    search={"theta": (-0.8, 0.0), "theta_dot": (0.0, 5.0), "psi_dot": (-5.0, 5.0)},
    # Just after heelstrike the legs are at the guard's zero, swapped: psi = -theta.
    section={"psi": -theta},
    actuators={r: "leg"},
    powered_only=True,
)


def derive() -> Derivation:
    return model_derivation(MODEL, SI_UNITS_TEXT)
