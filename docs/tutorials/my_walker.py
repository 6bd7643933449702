"""A wheel of N spokes rolling down a slope: the model file of the tutorial "Your own model".

A point mass at the hub on N massless spokes of length ``l``, 2 pi / N apart. While one
spoke stands on the slope the wheel pivots about its foot; the next spoke touches down
when the stance spoke has turned pi / N past the slope normal, and the collision is
inelastic (the new foot sticks, the old one leaves the ground).

The same walker as vsw's ``rimless-wheel`` (McGeer's), counted in spokes instead of the
half angle between them, so its gait can be checked against that model's.
"""

import sympy as sm

from derive.engine.model import (
    NORMAL_FORCE,
    Coordinate,
    Event,
    Failure,
    Impact,
    Model,
    Parameter,
    Phase,
    PointMass,
    leg,
)

PARAMETERS = (
    Parameter(
        name="N",
        latex="N",
        lower=2.0,
        upper=float("inf"),
        reason="more than two spokes: N > 2",
        description="number of spokes",
        assumptions={"positive": True},
        default=8.0,
        unit="1",
    ),
    Parameter(
        name="gamma",
        latex=r"\gamma",
        lower=-1.5,
        upper=1.5,
        reason="slope angle, downhill positive",
        description="slope angle",
        default=0.08,
        unit="rad",
    ),
    Parameter(
        name="l",
        latex="l",
        lower=0.0,
        upper=float("inf"),
        reason="spoke length l > 0",
        description="spoke length",
        assumptions={"positive": True},
        default=1.0,
        unit="m",
    ),
    Parameter(
        name="g",
        latex="g",
        lower=0.0,
        upper=float("inf"),
        reason="gravity g > 0",
        description="gravitational acceleration",
        assumptions={"positive": True},
        default=9.81,
        unit="m/s^2",
    ),
)
N, gamma, l, g = (p.symbol for p in PARAMETERS)
half_angle = sm.pi / N  # half the angle between neighbouring spokes

THETA = Coordinate(
    "theta",
    "stance spoke angle",
    "rad",
    reference="the slope normal",
    positive="the hub downhill of the stance foot",
)
theta = THETA.q

ROLLING = Phase(
    "rolling",
    coordinates=(THETA,),
    bodies=(PointMass("hub", 1, leg(theta, l)),),
    gravity=(g * sm.sin(gamma), -g * sm.cos(gamma)),
    # The next spoke's foot, relative to the stance foot: its height is the touchdown guard.
    points={
        "next_foot": tuple(
            h - f for h, f in zip(leg(theta, l), leg(theta - 2 * half_angle, l), strict=True)
        )
    },
)

MODEL = Model(
    name="my_walker",
    title="Wheel of N spokes",
    description="a hub mass on N massless spokes rolling down a slope",
    source="docs/tutorials/my_walker.py",
    parameters=PARAMETERS,
    phases=(ROLLING,),
    events=(
        Event(
            "touchdown",
            "rolling",
            "rolling",
            guard=ROLLING.points["next_foot"][1],
            direction=-1,
            reset=Impact("next_foot", {theta: theta - 2 * half_angle}),
            at=half_angle,
            ends_step=True,
        ),
    ),
    failures=(
        Failure("rolled-back", THETA.u, -1, "the wheel stops and rolls back"),
        Failure("lift-off", NORMAL_FORCE, -1, "the stance foot leaves the slope"),
    ),
    units={"time": "s", "length": "m", "mass": "kg", "energy": "J/kg", "force": "N/kg"},
    step_length=2 * l * sm.sin(half_angle),
    # Just after a touchdown the new spoke is half a spoke angle behind the normal.
    section={"theta": -half_angle},
    search={"theta_dot": (0.0, 12.0)},
)

UNITS = "Angles in radians, lengths in m, time in s, energies per unit mass in J/kg."
