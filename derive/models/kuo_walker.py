"""Kuo's simplest walking model, powered, on level ground (Kuo 2002).

A. D. Kuo, "Energetics of actively powered locomotion using the simplest walking model",
J. Biomech. Eng. 124 (2002) 113-120: a point mass ``m`` at the hip on two rigid massless
legs ``l`` long, on level ground. The stance leg swings as an inverted pendulum; the step
comes where the legs are at +-alpha (the swing leg mirrors the stance leg, massless: the
step length ``d = 2 l sin(alpha)`` is a parameter); heelstrike is inelastic (the hip's
velocity along the new leg is lost). Kuo powers it in two ways, whose costs he compares:

* a push-off impulse along the trailing leg just before heelstrike, which the rigid leg's
  length, held by its actuator, takes as a push-off whose foot the impact releases
  (:attr:`derive.engine.model.Impulse.at_impact`): the hip's velocity gains the impulse
  along the trailing leg, then the collision removes its component along the leading leg;
* a torque on the stance leg about its foot (Kuo's "torque applied on the stance leg"; an
  idealisation: a point mass has no trunk for a hip to act against).

Its rigid-leg question (Kuo's ratio) is the factor between the two least costs at
one speed and step length. The point-mass biped (point_mass_biped.py) has the same body on
telescoping legs; there rigid legs (``l_min = l``) are held by a leg force scheduled in
time, which a re-simulation cannot keep at ``l``: here the leg is held exactly.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    NORMAL_FORCE,
    Event,
    Failure,
    Impact,
    Impulse,
    Input,
    Model,
    Phase,
    PointMass,
    leg,
)
from derive.models.common import SI_UNITS, fell_backward, push_off_with_heelstrike, stance_leg_angle
from derive.models.families import (
    POINT_MASS_UNITS_TEXT,
    legs_reach_the_step,
    point_mass_walker_rows,
)
from derive.quantities import Derivation

PARAMETERS = point_mass_walker_rows("length of each leg")
m, g, l, d = (p.symbol for p in PARAMETERS)

THETA = stance_leg_angle()
theta = THETA.q
r = sm.Symbol("r", positive=True)
"""The stance leg's length, held at l by its actuator (the leg)."""

hip = leg(theta, r)
STANCE = Phase(
    "stance",
    coordinates=(THETA,),
    bodies=(PointMass("hip", m, hip),),
    gravity=(0, -g),
    held={r: l},
    # The massless swing leg mirrors the stance leg: its foot at 2 r sin(theta) ahead.
    points={"swing_foot": (2 * r * sm.sin(theta), 0)},
    inputs=(
        Input(
            "stance_torque",
            theta,
            "stance torque",
            unit="N m",
            description="a torque on the stance leg about its foot, positive turning the "
            "hip forward (Kuo 2002's torque on the stance leg)",
        ),
    ),
)

MODEL = Model(
    name="kuo_walker",
    title="Kuo's powered simplest walker",
    description="Kuo 2002: a point mass on two rigid massless legs on level ground, powered "
    "by a push-off along the trailing leg with heelstrike or by a torque on the stance leg; "
    "no passive gait: it walks only powered",
    source="derive/models/kuo_walker.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "heelstrike",
            "stance",
            "stance",
            guard=2 * l * sm.sin(theta) - d,  # the legs at +-alpha: the step is d long
            direction=+1,
            reset=Impact("swing_foot", {theta: -theta}),
            ends_step=True,
            impulses=(
                push_off_with_heelstrike(r),
                # The least-work torque concentrates just after heelstrike (a torque
                # scheduled on a mesh approaches it from above): its limit, as an impulse.
                Impulse(
                    "torque_impulse",
                    theta,
                    "stance torque",
                    after=True,
                    unit="N m s",
                    description="the stance torque's impulse on the new stance leg just "
                    "after heelstrike",
                ),
            ),
            equation="Kuo 2002, eqs. (3)-(4)",
        ),
    ),
    failures=(
        fell_backward(THETA, "the hip stops and swings back"),
        Failure(
            "lift-off", NORMAL_FORCE, -1, "the stance foot leaves the ground (the leg would pull)"
        ),
    ),
    units=SI_UNITS,
    step_length=d,  # the guard fixes it: --target-step-length other than d is refused
    # Just after the step the new stance leg is at -alpha.
    section={"theta": -sm.atan2(d, sm.sqrt(4 * l**2 - d**2))},
    search={"theta_dot": (0.0, 2.0)},
    actuators={r: "leg"},
    powered_only=True,
    parameter_conditions=(legs_reach_the_step(l, d),),
)


def derive() -> Derivation:
    return model_derivation(MODEL, POINT_MASS_UNITS_TEXT)
