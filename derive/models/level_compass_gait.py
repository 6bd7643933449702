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
    Coordinate,
    Event,
    Impact,
    Impulse,
    Input,
    Model,
    Phase,
    PointMass,
    leg,
    swing_foot_clearance,
)
from derive.models.common import SI_UNITS, SI_UNITS_TEXT, falls, gravity_parameter, scale_parameter
from derive.quantities import Derivation

# Drake's CompassGaitParams (as compass_gait.py), without the slope.
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
    gravity_parameter(),
)
m_h, m, a, b, g = (p.symbol for p in PARAMETERS)
length = a + b

THETA = Coordinate("theta", "stance leg angle", "rad", reference="the vertical",
                   positive="the hip ahead of the stance foot")  # fmt: skip
PSI = Coordinate("psi", "swing leg angle", "rad", reference="the vertical",
                 positive="the hip ahead of the swing foot")  # fmt: skip
theta, psi = THETA.q, PSI.q
r = sm.Symbol("r", positive=True)
"""The stance leg's length, held at a + b by its actuator (the leg, at its foot)."""

hip = leg(theta, r)
swing_foot = tuple(h - f for h, f in zip(hip, leg(psi, length)))

STANCE = Phase(
    "stance",
    coordinates=(THETA, PSI),
    bodies=(
        PointMass("hip", m_h, hip),
        PointMass("stance_leg", m, tuple(h - f for h, f in zip(hip, leg(theta, b)))),
        PointMass("swing_leg", m, tuple(h - f for h, f in zip(hip, leg(psi, b)))),
    ),
    gravity=(0, -g),
    held={r: length},
    points={"swing_foot": swing_foot},
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
    name="level_compass_gait",
    title="Compass gait on level ground, powered",
    description="the compass gait's body (Goswami et al. 1996, Drake's parameters) on level "
    "ground, powered by a push-off along the trailing leg with heelstrike or by the hip "
    "torque (Kuo 2002's comparison with massive legs); no passive gait: it walks only powered",
    source="derive/models/level_compass_gait.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "heelstrike",
            "stance",
            "stance",
            # The swing foot's height is -2 (a + b) sin((theta + psi)/2) sin((theta - psi)/2)
            # with the leg at its held length, as on the slope at gamma = 0.
            guard=sm.sin((theta + psi) / 2),
            direction=1,
            reset=Impact(
                "swing_foot",
                {theta: psi, psi: theta},
                bodies={"stance_leg": "swing_leg", "swing_leg": "stance_leg"},
            ),
            ends_step=True,
            when=theta,  # past mid-stance: the new foot lands ahead of the hip
            impulses=(
                Impulse(
                    "push_off",
                    r,
                    "leg",
                    at_impact=True,
                    unit="N s",
                    bounds=(0.0, None),
                    description="the trailing leg's impulse along itself with heelstrike "
                    "(just before it; the impact releases its foot)",
                ),
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
