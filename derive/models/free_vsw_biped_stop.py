"""The VSW biped's body with free actuation and an end stop at ``l``: every step extends
the stance leg to its stop, as the VSW biped does (VSW's price on its own biped).

The body, its actuators, heelstrike and units are ``free_vsw_biped.py``'s. A step has two
phases, as the VSW biped's:

* stroke: the stance leg, ``beta l`` long at the step's start, free to lengthen and
  shorten under its force and the motion (its actuator can only push);
* end stop: where the leg reaches ``l`` it stops there dead, a plastic impact at its end
  stop (:class:`Lock`: the generalised momenta of both leg angles kept, as the VSW
  biped's extension keeps them);
* extended: the stance leg held at ``l`` until heelstrike (the stop holds any pull, the
  actuator any push, at no work: the length does not change).

So the VSW biped's extension, a push from ``beta l`` then a stop at ``l``, is the limit
of this model's motions as the leg force grows short and large, and its least work is at
most the VSW biped's work (in that limit). Every step reaches the stop (the phases' order
is fixed): the least work here is over gaits that extend the leg fully once a step. The
trailing leg, at its stop, cannot push off (it would lengthen past ``l``); the hip torque
may act in an instant just before or after heelstrike. Stopping a lengthening leg pulls
its foot (the stop's impulse is along the leg, toward the foot): the optimiser reports
that ground impulse, or forbids it (``vsw optimize --pushing-locks``).
"""

from __future__ import annotations

import dataclasses

from derive.engine import model_derivation
from derive.engine.model import Event, Lock, Model, Phase, swing_foot_clearance
from derive.models.free_vsw_biped import (
    CROUCHED,
    FALLS,
    HEEL_STRIKE,
    HIP_IMPULSE_AFTER,
    HIP_IMPULSE_BEFORE,
    HIP_TORQUE,
    PARAMETER_CONDITIONS,
    PARAMETERS,
    PSI,
    SEARCH,
    THETA,
    beta,
    bodies,
    heelstrike,
    r,
    stance_phase,
    swing_foot,
)
from derive.models.vsw_biped import UNITS, UNITS_TEXT
from derive.quantities import Derivation

STROKE = stance_phase("stroke")
EXTENDED = Phase(
    "extended",
    coordinates=(THETA, PSI),
    bodies=bodies(r),
    gravity=(0, -1),
    held={r: 1},
    points={"swing_foot": swing_foot(r)},
    inputs=(HIP_TORQUE,),
)

MODEL = Model(
    name="free_vsw_biped_stop",
    title="VSW biped's body, free actuation, end stop",
    description="the VSW biped's body with its leg force and hip torque free in time, the "
    "stance leg extended to an end stop at l once a step (the VSW biped's extension is the "
    "limit of its motions); no passive gait: it walks only powered",
    source="derive/models/free_vsw_biped_stop.py",
    parameters=PARAMETERS,
    phases=(STROKE, EXTENDED),
    events=(
        Event(
            "end_stop",
            "stroke",
            "extended",
            guard=r - 1,
            direction=+1,
            reset=Lock(),
            equation="(3) with massive legs, the extension's end",
        ),
        heelstrike(EXTENDED, (HIP_IMPULSE_BEFORE, HEEL_STRIKE, HIP_IMPULSE_AFTER), "stroke"),
    ),
    failures=(*FALLS, dataclasses.replace(CROUCHED, phases=("stroke",))),
    conditions=(swing_foot_clearance(EXTENDED.points["swing_foot"][1], "l"),),
    units=UNITS,
    step_length=EXTENDED.points["swing_foot"][0],
    # Just after heelstrike the new stance leg is beta l long.
    section={"r": beta},
    search=SEARCH,
    powered_only=True,
    parameter_conditions=PARAMETER_CONDITIONS,
)


def derive() -> Derivation:
    return model_derivation(MODEL, UNITS_TEXT)
