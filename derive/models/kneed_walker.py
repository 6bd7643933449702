"""The passive walker with knees and point feet (McGeer 1990, "Passive walking with knees",
Proc. IEEE ICRA, pp. 1640-1645; the point-foot model and parameters of V. F. Hsu Chen 2007,
"Passive dynamic walking with knees: a point foot model", MEng thesis, MIT, chapter 3).

A point mass ``m_h`` at the hip; each leg a thigh (a point mass ``m_t`` at ``a2`` above the
knee, ``b2`` below the hip) and a shank (a point mass ``m_s`` at ``a1`` above the foot,
``b1`` below the knee), on a slope ``gamma`` under gravity ``g``. A step has two phases:

* **knee free**: the stance leg is straight (its knee stays locked) and the swing leg's
  knee swings freely: three degrees of freedom;
* **knee locked**: the swing knee straightened and locked: the compass gait's two.

Knee strike (the swing knee reaches its stop) is a plastic impact inside the walker: the
lock's impulse acts on the knee angle alone and the stance foot stays pinned, so the other
coordinates' generalised momenta are conserved (:class:`~derive.engine.model.Lock`).
Heelstrike is the compass gait's inelastic impact at the swing foot; the new swing leg's
knee is straight at that instant and, as in Hsu Chen's model, still locked through the
impact (its thigh and shank leave it with one rate), then released. Scuffing is ignored,
as in the sources. The stance knee is held straight in both phases, as the sources assume;
the torque its lock exerts is derived and reported (the condition ``stance-knee-stop``:
where it is negative a stop alone would let the knee buckle, and a latch must pull).

Coordinates on the slope (x downhill, y along its normal): ``theta`` is the stance leg's
angle from the slope normal, positive with the hip downhill of the stance foot; ``psi`` is
the swing thigh's angle, measured the same way (hip downhill of the knee); ``kappa`` is the
knee angle, the swing shank's angle less the thigh's: zero straight, positive flexed (the
swing foot behind the knee). The knee's lock acts between thigh and shank, so on ``kappa``
alone: the knee-locked phase holds ``kappa = 0``. Hsu Chen measures angles from the
vertical with the opposite sign: her ``q1 = -(theta + gamma)``, ``q2 = -(psi + gamma)``,
``q3 = -(psi + kappa + gamma)``.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Condition,
    Coordinate,
    Event,
    Impact,
    Lock,
    Model,
    Phase,
    PointMass,
    Skeleton,
    held_force,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    SI_UNITS,
    SI_UNITS_TEXT,
    falls,
    gravity_parameter,
    minus,
    plus,
    scale_parameter,
    slope_gravity,
    slope_parameter,
    stance_leg_angle,
)
from derive.quantities import Derivation

# Hsu Chen 2007, chapter 3 (her table of the point-foot walker): m_H = 0.5, m_t = 0.5,
# m_s = 0.05 kg; a1 = 0.375, b1 = 0.125 (shank), a2 = 0.175, b2 = 0.325 m (thigh); slope
# 0.0504 rad; g = 9.81 m/s^2.
PARAMETERS = (
    scale_parameter(
        name="m_h",
        latex="m_H",
        reason="hip mass m_h > 0",
        description="hip mass",
        default=0.5,
        unit="kg",
    ),
    scale_parameter(
        name="m_t",
        latex="m_t",
        reason="thigh mass m_t > 0",
        description="mass of each thigh",
        default=0.5,
        unit="kg",
    ),
    scale_parameter(
        name="m_s",
        latex="m_s",
        reason="shank mass m_s > 0",
        description="mass of each shank",
        default=0.05,
        unit="kg",
    ),
    scale_parameter(
        name="a1",
        latex="a_1",
        reason="a1 > 0",
        description="distance from a foot to its shank's mass",
        default=0.375,
        unit="m",
    ),
    scale_parameter(
        name="b1",
        latex="b_1",
        reason="b1 > 0",
        description="distance from a shank's mass to the knee",
        default=0.125,
        unit="m",
    ),
    scale_parameter(
        name="a2",
        latex="a_2",
        reason="a2 > 0",
        description="distance from a knee to its thigh's mass",
        default=0.175,
        unit="m",
    ),
    scale_parameter(
        name="b2",
        latex="b_2",
        reason="b2 > 0",
        description="distance from a thigh's mass to the hip",
        default=0.325,
        unit="m",
    ),
    slope_parameter(0.0504),
    gravity_parameter(),
)
m_h, m_t, m_s, a1, b1, a2, b2, gamma, g = (p.symbol for p in PARAMETERS)
shank, thigh = a1 + b1, a2 + b2
length = shank + thigh

THETA = stance_leg_angle(slope=True)
PSI = Coordinate(
    "psi",
    "swing thigh angle",
    "rad",
    reference="the slope normal",
    positive="the hip downhill of the swing knee",
)
KAPPA = Coordinate(
    "kappa",
    "swing knee angle (shank less thigh)",
    "rad",
    reference="the straight knee",
    positive="the knee flexed, the swing foot behind the knee",
)
STANCE_KNEE = Coordinate(
    "kappa_stance",
    "stance knee angle (shank less thigh)",
    "rad",
    reference="the straight knee",
    positive="the knee flexed",
)
theta, psi, kappa = THETA.q, PSI.q, KAPPA.q
kappa_stance = STANCE_KNEE.q


# The stance leg with its knee as a coordinate that every phase holds straight: it is no
# state, but its lock's torque is derived (the condition below).
stance_knee = leg(theta, shank)
hip = plus(stance_knee, leg(theta - kappa_stance, thigh))
knee = minus(hip, leg(psi, thigh))
swing_foot = minus(knee, leg(psi + kappa, shank))
BODIES = (
    PointMass("hip", m_h, hip),
    PointMass("stance_shank", m_s, leg(theta, a1)),
    PointMass("stance_thigh", m_t, plus(stance_knee, leg(theta - kappa_stance, a2))),
    PointMass("swing_thigh", m_t, minus(hip, leg(psi, b2))),
    PointMass("swing_shank", m_s, minus(knee, leg(psi + kappa, b1))),
)
GRAVITY = slope_gravity(g, gamma)
# Both legs through their knees: in the knee-locked phase the swing knee is straight.
SKELETON = Skeleton(
    points={"stance_foot": (0, 0), "stance_knee": stance_knee, "hip": hip,
            "swing_knee": knee, "swing_foot": swing_foot},
    segments=(("stance_foot", "stance_knee"), ("stance_knee", "hip"),
              ("hip", "swing_knee"), ("swing_knee", "swing_foot")),
)  # fmt: skip

KNEE_FREE = Phase(
    "knee_free",
    coordinates=(THETA, PSI, KAPPA),
    bodies=BODIES,
    gravity=GRAVITY,
    held={kappa_stance: 0},
    points={"swing_foot": swing_foot},
)
KNEE_LOCKED = Phase(
    "knee_locked",
    coordinates=(THETA, PSI),
    bodies=BODIES,
    gravity=GRAVITY,
    held={kappa: 0, kappa_stance: 0},
    points={"swing_foot": swing_foot},
)

MODEL = Model(
    name="kneed_walker",
    title="Kneed walker",
    description="McGeer 1990, Hsu Chen 2007: a passive walker with knees and point feet, "
    "walking down a slope",
    source="derive/models/kneed_walker.py",
    parameters=PARAMETERS,
    phases=(KNEE_FREE, KNEE_LOCKED),
    events=(
        Event(
            "kneestrike",
            "knee_free",
            "knee_locked",
            # The knee flexes from straight after heelstrike and straightens again: it
            # locks when kappa falls back through zero.
            guard=kappa,
            direction=-1,
            reset=Lock(),
        ),
        Event(
            "heelstrike",
            "knee_locked",
            "knee_free",
            # With the knee straight the swing foot's height is
            # -2 l sin((theta + psi)/2) sin((theta - psi)/2), as in the compass gait.
            guard=sm.sin((theta + psi) / 2),
            direction=1,
            reset=Impact(
                "swing_foot",
                {theta: psi, psi: theta, kappa: 0},
                bodies={
                    "stance_shank": "swing_shank",
                    "stance_thigh": "swing_thigh",
                    "swing_thigh": "stance_thigh",
                    "swing_shank": "stance_shank",
                },
                holding={kappa: 0},
            ),
            ends_step=True,
            when=theta,  # past mid-stance: the new foot lands ahead of the hip
        ),
    ),
    failures=falls(THETA, ground="slope"),
    conditions=(
        swing_foot_clearance(swing_foot[1], "m"),
        # The sources assume the stance knee locked: a stop keeps it from hyperextending
        # (it pushes towards flexion, a positive torque on kappa_stance); where the lock
        # would have to pull, only a latch keeps the knee straight.
        Condition(
            "stance-knee-stop",
            held_force(STANCE_KNEE),
            -1,
            "the stance knee presses into its stop (else its lock must pull: a latch)",
            unit="N m",
        ),
    ),
    units=SI_UNITS,
    skeleton=SKELETON,
    step_length=swing_foot[0],
    # Just after heelstrike the new stance foot is downhill of the hip (theta < 0); Hsu
    # Chen's gait: theta = -0.238 rad, theta_dot = 1.10 rad/s, psi_dot = 0.04 rad/s.
    search={"theta": (-0.6, 0.0), "theta_dot": (0.0, 4.0), "psi_dot": (-4.0, 4.0)},
    # Just after heelstrike the legs are at the guard's zero, swapped, and the new swing
    # knee is straight and at rest relative to its thigh.
    section={"psi": -theta, "kappa": sm.Integer(0), "kappa_dot": sm.Integer(0)},
)


def derive() -> Derivation:
    return model_derivation(MODEL, SI_UNITS_TEXT)
