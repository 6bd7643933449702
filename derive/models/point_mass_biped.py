"""The point-mass biped: the ILE's body with free actuation (Srinivasan & Ruina 2006,
"Computer optimization of a minimal biped model discovers walking and running", Nature
439, 72-75).

A point mass ``m`` at the hip on two massless telescoping legs at most ``l`` long, on level
ground under gravity ``g``. The stance leg's actuator pushes along the leg with a force
``F(t) >= 0`` (a leg pushes, never pulls: the foot would leave the ground): with ``F = 0``
the hip falls freely, so the model has no passive gait and walks only powered (``vsw
optimize``). A second input, a torque on the stance leg about its foot, is Kuo (2002)'s
alternative to a push-off ("Energetics of actively powered locomotion using the simplest
walking model", J. Biomech. Eng. 124:113-120): ``vsw optimize --use`` chooses which
actuators a gait may use (Srinivasan & Ruina's model has the leg force and the impulses
only). At the step the legs exchange roles in an instant, as in the ILE: the trailing leg
may push off with an impulse along itself just before, the new stance leg may take an
impulse along itself just after (its heel-strike collision, or none: its length is free),
and the stance torque an impulse just after too; the massless legs transmit no impulse of
their own, so without those the hip's velocity is continuous.

A leg's length is between ``l_min`` and ``l`` (``l_min = l``: rigid legs, Kuo's simplest
walking model, for which the leg force holds the leg and does no work).

The step length ``d`` is a parameter: the new foot lands ``d`` ahead of the stance foot,
and the legs exchange roles when the hip passes midway between the feet (``x = d / 2``).
That restricts the gaits to those symmetric in the switch, which the cheapest gaits
Srinivasan & Ruina found are (inverted-pendulum walking with an impulsive push-off and
heel-strike at low speed); an asymmetric switch would need the switch point as a
parameter. Where the massless swing leg is between steps does not matter.

Coordinates: ``x, y``, the hip's position from the stance foot (x forward, y up), so the
stance leg's length is ``sqrt(x**2 + y**2)``. Units: those of the parameters, whose
defaults ``m = g = l = 1`` make every number scaled (lengths in ``l``, time in
``sqrt(l / g)``, energies in ``m g l``).
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    NORMAL_FORCE,
    Coordinate,
    Event,
    Failure,
    Impact,
    Impulse,
    Input,
    Model,
    ParameterCondition,
    Phase,
    PointMass,
)
from derive.models.common import SI_UNITS, scale_parameter
from derive.models.families import (
    POINT_MASS_UNITS_TEXT,
    legs_reach_the_step,
    point_mass_walker_rows,
)
from derive.quantities import Derivation

PARAMETERS = (
    *point_mass_walker_rows("longest length of a leg"),
    scale_parameter(
        name="l_min",
        latex=r"l_{min}",
        reason="shortest leg l_min > 0 (l_min = l: rigid legs, Kuo's simplest walking model)",
        description="shortest length of a leg (the end of its stroke)",
        default=0.5,
        unit="m",
    ),
)
m, g, l, d, l_min = (p.symbol for p in PARAMETERS)
PARAMETER_CONDITIONS = (
    legs_reach_the_step(l, d),
    ParameterCondition(l - l_min, "the shortest leg l_min must be at most l", strict=False),
)

X = Coordinate("x", "hip's horizontal position from the stance foot", "m",
               reference="above the stance foot", positive="the hip ahead of the foot")  # fmt: skip
Y = Coordinate("y", "hip's height above the ground", "m", reference="the ground",
               positive="the hip above the ground")  # fmt: skip
x, y = X.q, Y.q
leg_length = sm.sqrt(x**2 + y**2)
leg_angle = sm.atan2(x, y)  # the stance leg's angle from the vertical, the hip ahead > 0

STANCE = Phase(
    "stance",
    coordinates=(X, Y),
    bodies=(PointMass("hip", m, (x, y)),),
    gravity=(0, -g),
    points={"next_foot": (d, 0)},
    inputs=(
        Input(
            "leg_force",
            leg_length,
            "leg",
            unit="N",
            bounds=(0.0, None),
            description="the stance leg's force along itself, pushing the hip away from "
            "the foot (>= 0: a leg cannot pull on the ground)",
        ),
        # Kuo (2002) powers the simplest walking model by a push-off or by "a torque
        # applied on the stance leg": that torque, about the stance foot.
        Input(
            "stance_torque",
            leg_angle,
            "stance torque",
            unit="N m",
            description="a torque on the stance leg about its foot, positive turning the "
            "hip forward (Kuo 2002's torque on the stance leg; an idealisation: a point "
            "mass has no trunk for a hip to act against)",
        ),
    ),
)

MODEL = Model(
    name="point_mass_biped",
    title="Point-mass biped",
    description="Srinivasan & Ruina 2006: a point mass on two massless telescoping legs "
    "with a leg force and impulses at the step (the ILE's body with free actuation); no "
    "passive gait: it walks only powered",
    source="derive/models/point_mass_biped.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "heelstrike",
            "stance",
            "stance",
            guard=x - d / 2,  # the hip passes midway between the feet
            direction=+1,
            # The massless legs carry no impulse: the hip's velocity is continuous unless
            # the actuators' impulses act.
            reset=Impact("next_foot", {x: x - d, y: y}),
            ends_step=True,
            impulses=(
                Impulse(
                    "push_off",
                    leg_length,
                    "leg",
                    unit="N s",
                    bounds=(0.0, None),
                    description="the trailing leg's impulse along itself just before the step",
                ),
                Impulse(
                    "heel_strike",
                    leg_length,
                    "leg",
                    after=True,
                    unit="N s",
                    bounds=(0.0, None),
                    description="the new stance leg's impulse along "
                    "itself just after the step (a collision where it stops the leg "
                    "shortening)",
                ),
                Impulse(
                    "torque_impulse",
                    leg_angle,
                    "stance torque",
                    after=True,
                    unit="N m s",
                    description="the stance torque's impulse on the new stance leg just "
                    "after the step (the least-work torque concentrates there)",
                ),
            ),
        ),
    ),
    failures=(
        Failure("fell", y, -1, "the hip reaches the ground", unit="m"),
        Failure("fell-backward", X.u, -1, "the hip stops and moves back"),
        # With the leg force alone the ground's normal reaction is F y / r >= 0; the
        # stance torque's share, -tau x / r^2, pulls the foot up where the hip is ahead of it
        # and the torque drives it forward.
        Failure(
            "lift-off",
            NORMAL_FORCE,
            -1,
            "the stance foot leaves the ground (the stance torque would pull it up)",
        ),
        Failure(
            "crouched",
            leg_length - l_min,
            -1,
            "the stance leg would be shorter than l_min: the end of its stroke",
            unit="m",
        ),
        Failure(
            "overextended",
            leg_length - l,
            +1,
            "the stance leg would be longer than l: its foot leaves the ground",
            unit="m",
        ),
    ),
    units=SI_UNITS,
    step_length=d,
    # Just after the step the hip is d / 2 behind the new stance foot.
    section={"x": -d / 2},
    search={"y": (0.5, 1.0), "x_dot": (0.0, 2.0), "y_dot": (-1.0, 1.0)},
    powered_only=True,
    parameter_conditions=PARAMETER_CONDITIONS,
)


def derive() -> Derivation:
    return model_derivation(MODEL, POINT_MASS_UNITS_TEXT)
