"""The compass gait with a torso held by a hip actuator: the three-link biped of Grizzle,
Abba & Plestan 2001 ("Asymptotically stable walking for biped robots: analysis via systems
with impulse effects", IEEE Trans. Automatic Control 46(1):51-64) and of Westervelt,
Grizzle, Chevallereau, Choi & Morris 2007 ("Feedback Control of Dynamic Bipedal Robot
Locomotion", CRC Press; its companion code ``WGCCM_three_link_walker_example``), with the
torso held at a fixed lean and the swing leg free.

Two legs of length ``r``, each a point mass ``m`` at its middle, a point mass ``m_h`` at
the hip and a torso, a point mass ``m_t`` at distance ``l_t`` above the hip, on a slope
``gamma`` under gravity ``g``. The stance foot is a hinge; the
swing leg swings freely about the hip (scuffing ignored, as in the compass gait's sources);
heelstrike is the compass gait's inelastic impact at the swing foot, after which the legs
swap roles.

The torso is held at the lean ``rho`` from the vertical (positive forward, downhill) by an
actuator between the torso and the stance leg, in every phase and through heelstrike (an
impulsive torque there, between the torso and the new stance leg). Its torque's reaction
drives the stance leg forward when the torso leans forward, and the actuator does positive
work over a step; the torque is derived (the force of the held coordinate ``phi``), not
assumed. The companion code holds the torso with two hip motors and also holds the
swing leg; here the swing leg is free, so the walker is the compass gait with one actuator.

Coordinates on the slope (x downhill, y along its normal): ``theta`` is the stance leg's
angle from the slope normal, positive with the hip downhill of the stance foot; ``psi`` is
the swing leg's angle, measured the same way; ``phi`` is the torso's angle relative to the
stance leg (the actuator's joint). The book's angles from the vertical are
``theta_1 = theta + gamma``, ``theta_2 = psi + gamma``, ``theta_3 = theta + phi + gamma``.
"""

from __future__ import annotations

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Model,
    Parameter,
    Phase,
    PointMass,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    PI,
    SI_UNITS,
    SI_UNITS_TEXT,
    falls,
    gravity_parameter,
    legs_skeleton,
    minus,
    plus,
    scale_parameter,
    slope_gravity,
    stance_leg_angle,
    swapping_heelstrike,
    swing_leg_angle,
)
from derive.models.families import three_link_rows
from derive.quantities import Derivation

# The companion code's model_params_three_link.m: r = 1, m = 5, Mh = 15, Mt = 10, L = 0.5,
# g = 9.8 (SI units); its control_params_three_link.m holds the torso at th3d = pi/6. The
# slope is Drake's compass gait's (CompassGaitParams, 0.0525 rad): with the swing leg free
# there is no gait on level ground (docs/models/torso_walker.md).
PARAMETERS = (
    *three_link_rows(),
    scale_parameter(
        name="l_t",
        latex="L",
        reason="l_t > 0",
        description="distance from the hip to the torso's mass",
        default=0.5,
        unit="m",
    ),
    Parameter(
        name="rho",
        latex=r"\rho",
        lower=-PI / 2,
        upper=PI / 2,
        reason="the torso above the hip: -pi/2 < rho < pi/2",
        description="torso lean from the vertical (forward positive)",
        default=PI / 6,
        unit="rad",
    ),
    Parameter(
        name="gamma",
        latex=r"\gamma",
        lower=-PI / 2,
        upper=PI / 2,
        reason="-pi/2 < gamma < pi/2",
        description="slope angle (downhill positive; 0 is level ground)",
        default=0.0525,
        unit="rad",
    ),
    gravity_parameter(9.8),
)
m_h, m, m_t, r, l_t, rho, gamma, g = (p.symbol for p in PARAMETERS)

THETA, PSI = stance_leg_angle(slope=True), swing_leg_angle(slope=True)
TORSO = Coordinate(
    "phi",
    "torso angle relative to the stance leg",
    "rad",
    reference="the stance leg",
    positive="the torso leaning forward of the stance leg",
)
theta, psi, phi = THETA.q, PSI.q, TORSO.q

hip = leg(theta, r)
swing_foot = minus(hip, leg(psi, r))
torso = plus(hip, leg(theta + phi, l_t))
# The legs and the torso up to its mass (the model has no other torso length).
SKELETON = legs_skeleton(hip, swing_foot, torso)
STANCE = Phase(
    "stance",
    coordinates=(THETA, PSI),
    bodies=(
        PointMass("hip", m_h, hip),
        PointMass("stance_leg", m, leg(theta, r / 2)),
        PointMass("swing_leg", m, minus(hip, leg(psi, r / 2))),
        PointMass("torso", m_t, torso),
    ),
    gravity=slope_gravity(g, gamma),
    # The torso's angle from the vertical is theta + phi + gamma: held at rho.
    held={phi: rho - gamma - theta},
    points={"swing_foot": swing_foot},
)

MODEL = Model(
    actuators={phi: "hip"},
    name="torso_walker",
    title="Compass gait with a torso",
    description="Grizzle et al. 2001, Westervelt et al. 2007: the three-link biped, its "
    "torso held at a lean by a hip actuator, the swing leg free",
    source="derive/models/torso_walker.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    # The legs swap at heelstrike, past mid-stance (the swing foot's height through zero,
    # as in the compass gait).
    events=(swapping_heelstrike(theta, psi),),
    failures=falls(THETA),
    conditions=(swing_foot_clearance(swing_foot[1], "m"),),
    units=SI_UNITS,
    skeleton=SKELETON,
    step_length=swing_foot[0],
    search={"theta": (-0.8, 0.0), "theta_dot": (0.0, 5.0), "psi_dot": (-5.0, 5.0)},
    # Just after heelstrike the legs are at the guard's zero, swapped: psi = -theta.
    section={"psi": -theta},
)


def derive() -> Derivation:
    return model_derivation(MODEL, SI_UNITS_TEXT)
