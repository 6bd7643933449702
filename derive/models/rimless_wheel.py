"""The rimless wheel (McGeer 1990, "Passive dynamic walking"; Drake, examples/rimless_wheel).

A point mass at the hub of a wheel without rim: spokes of length ``l`` spaced ``2 alpha``
apart, rolling down a slope of angle ``gamma`` under gravity ``g``. Between collisions the
wheel pivots about the stance spoke's foot; the next spoke touches the slope when the stance
spoke has turned ``alpha`` past the slope normal; the collision is inelastic (the new foot
sticks, the old one leaves the ground). Energies are per unit mass (the mass cancels).

Coordinates on the slope: x downhill, y along its normal; ``theta`` is the stance spoke's
angle from the slope normal, positive downhill, ``theta_dot`` its rate.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Event,
    Impact,
    Model,
    Parameter,
    Phase,
    PointMass,
    Skeleton,
    leg,
)
from derive.models.common import (
    PI,
    fell_backward,
    gravity_parameter,
    lift_off,
    scale_parameter,
    slope_gravity,
)
from derive.quantities import Derivation

PARAMETERS = (
    Parameter(
        name="alpha",
        latex=r"\alpha",
        lower=0.0,
        upper=PI / 2,
        reason="half the angle between spokes: 0 < alpha < pi/2",
        description="half inter-spoke angle",
        assumptions={"positive": True},
        default=PI / 8,
        unit="rad",
    ),
    Parameter(
        name="gamma",
        latex=r"\gamma",
        lower=-PI / 2,
        upper=PI / 2,
        reason="slope angle, downhill positive: |gamma| < pi/2",
        description="slope angle",
        default=0.08,
        unit="rad",
    ),
    scale_parameter(
        name="l",
        latex="l",
        reason="spoke length l > 0",
        description="spoke length",
        default=1.0,
        unit="m",
    ),
    gravity_parameter(),
)
alpha, gamma, l, g = (p.symbol for p in PARAMETERS)

THETA = Coordinate(
    "theta",
    "stance spoke angle",
    "rad",
    reference="the slope normal",
    positive="the hub downhill of the stance foot",
)
theta = THETA.q

STANCE = Phase(
    "stance",
    coordinates=(THETA,),
    bodies=(PointMass("hub", 1, leg(theta, l)),),
    gravity=slope_gravity(g, gamma),
    # The next spoke, 2 alpha behind the stance spoke, and its foot.
    points={"next_foot": tuple(h - f for h, f in zip(leg(theta, l), leg(theta - 2 * alpha, l)))},
    # The stance spoke and the next, and every other spoke round the hub.
    skeleton=Skeleton(
        points={"stance_foot": (0, 0), "hub": leg(theta, l)},
        segments=(("stance_foot", "hub"),),
        spokes=("hub", "stance_foot", 2 * alpha),
    ),
)

MODEL = Model(
    name="rimless_wheel",
    title="Rimless wheel",
    description="McGeer's rimless wheel: a hub mass on massless spokes rolling down a slope",
    source="derive/models/rimless_wheel.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "collision",
            "stance",
            "stance",
            guard=STANCE.points["next_foot"][1],  # the next foot's height above the slope
            direction=-1,
            reset=Impact("next_foot", {theta: theta - 2 * alpha}),
            at=alpha,
            ends_step=True,
        ),
    ),
    failures=(fell_backward(THETA, "the wheel stops and rolls back"), lift_off("slope")),
    units={
        "time": "s",
        "length": "m",
        "mass": "kg (energies per unit mass)",
        "energy": "J/kg",
        "force": "N/kg",
    },
    step_length=2 * l * sm.sin(alpha),
    # Just after a collision the new spoke is alpha behind the normal; its rate is the state.
    section={"theta": -alpha},
    search={"theta_dot": (0.0, 12.0)},
)


def derive() -> Derivation:
    return model_derivation(MODEL, "Angles in radians, lengths in m, time in s, energies in J/kg.")
