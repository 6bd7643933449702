"""The simplest walking model (Garcia, Chatterjee, Ruina, Coleman 1998, "The simplest
walking model: stability, complexity, and scaling", J. Biomech. Eng. 120(2):281-288).

Two rigid massless legs of length ``l`` hinged at the hip, a point mass ``M`` at the hip and
point masses ``m`` at the feet, in the limit ``m/M -> 0``, on a slope ``gamma``. The stance
foot is a hinge; the swing leg swings freely (its foot passes through the slope near
mid-stance: the paper ignores that scuffing, and so does this model); heelstrike is an
inelastic impact of the swing foot, after which the legs swap roles. The only parameter
after scaling (lengths in ``l``, time in ``sqrt(l/g)``, mass in ``M``) is ``gamma``.

Coordinates on the slope (x downhill, y along its normal): ``theta`` is the stance leg's
angle from the slope normal, positive with the hip downhill of the stance foot; ``phi`` is
the angle between the legs (stance minus swing), so the swing leg is at ``theta - phi``.
Garcia et al. measure both angles the other way round: their state is minus this one.

The foot masses enter as ``epsilon`` and the model is the limit ``epsilon -> 0``
(:attr:`Model.limits`): with ``epsilon = 0`` exactly the swing leg's equation is 0 = 0.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Event,
    Impact,
    Model,
    Phase,
    PointMass,
    leg,
)
from derive.models.common import (
    PI,
    falls,
    legs_skeleton,
    minus,
    slope_gravity,
    slope_parameter,
    stance_leg_angle,
)
from derive.quantities import Derivation

PARAMETERS = (
    slope_parameter(
        0.009,
        computed=(1e-8, PI / 2),
        computed_reason="on slopes below 1e-8 rad the gait "
        "search runs long (at 1e-12 it ran past a 20 s limit); 1e-8 takes about 10 s",
    ),
)
(gamma,) = (p.symbol for p in PARAMETERS)
epsilon = sm.Symbol("epsilon", positive=True)  # foot mass / hip mass, taken to 0

THETA = stance_leg_angle(slope=True)
PHI = Coordinate(
    "phi",
    "angle between the legs (stance minus swing)",
    "rad",
    reference="the stance leg",
    positive="the swing leg turned downhill of it",
)
theta, phi = THETA.q, PHI.q

hip = leg(theta)
swing_foot = minus(hip, leg(theta - phi))
SKELETON = legs_skeleton(hip, swing_foot)

STANCE = Phase(
    "stance",
    coordinates=(THETA, PHI),
    bodies=(
        PointMass("hip", 1, hip),
        PointMass("stance_foot", epsilon, (0, 0)),
        PointMass("swing_foot", epsilon, swing_foot),
    ),
    gravity=slope_gravity(1, gamma),
    points={"swing_foot": swing_foot},
)

MODEL = Model(
    name="simplest_walker",
    title="Simplest walking model",
    description="Garcia et al. 1998: a hip mass on two massless legs with infinitesimal "
    "feet, walking down a slope",
    source="derive/models/simplest_walker.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "heelstrike",
            "stance",
            "stance",
            # The swing foot's height is -2 sin(theta - phi/2) sin(phi/2): zero where the
            # legs are together (the scuffing the model ignores) and at heelstrike, where
            # the first factor rises through zero.
            guard=sm.sin(theta - phi / 2),
            direction=1,
            reset=Impact(
                "swing_foot",
                {theta: theta - phi, phi: -phi},
                bodies={"stance_foot": "swing_foot", "swing_foot": "stance_foot"},
            ),
            ends_step=True,
            when=theta,  # past mid-stance: the new foot lands ahead of the hip
        ),
    ),
    failures=falls(THETA, ground="slope"),
    units={"time": "sqrt(l/g)", "length": "l", "mass": "M", "energy": "M g l", "force": "M g"},
    skeleton=SKELETON,
    step_length=swing_foot[0],
    # Just after heelstrike the new stance foot is downhill of the hip (theta < 0); Garcia
    # et al.'s gaits at gamma = 0.009 have theta = -0.2003 and -0.1939, theta_dot 0.2.
    search={"theta": (-0.8, 0.0), "theta_dot": (0.0, 1.5)},
    limits={epsilon: 0},
    # Just after heelstrike the legs are at the guard's zero (phi = 2 theta) and the impact
    # gives the swing leg 1 - cos(phi) of the stance leg's rate (Garcia et al., eq. 5).
    section={"phi": 2 * theta, "phi_dot": (1 - sm.cos(2 * theta)) * THETA.u},
)


def derive() -> Derivation:
    return model_derivation(
        MODEL, "Angles in radians; lengths in l, time in sqrt(l/g), energies in M g l."
    )
