"""The point-mass biped with its legs' switch point chosen: the least work of that body over
every place where the legs may exchange roles (the ILE's price).

The body, its actuators, failures and units are ``point_mass_biped.py``'s. That model
exchanges the legs where the hip passes midway between the feet (``x = d / 2``), so its
least work is that of gaits symmetric in the switch, and the ILE's price measured against
it is a lower bound on a more constrained body: the ILE's legs do not exchange midway (at
heel-strike the new leg is the shortened one, ``beta`` times the other, at the angle
``phi0`` to it). Here the legs exchange where the hip passes ``x = sigma d``, ``sigma`` a
parameter of the gait that ``vsw optimize`` chooses (:attr:`Model.chosen_parameters`;
the given value is its start): at ``sigma = 1/2`` this is ``point_mass_biped`` exactly, so
every gait of that model is one of this model's too, and its least work is at most
that model's.

Just after the step the hip is ``(1 - sigma) d`` behind the new stance foot. At the switch
both legs must reach the ground: the new stance leg's length, ``sqrt(((1 - sigma) d)^2 +
y^2)``, is the stance leg's just after the step, which the failures ``overextended`` and
``crouched`` watch.
"""

from __future__ import annotations

import dataclasses

from derive.engine import model_derivation
from derive.engine.model import Model, Parameter, ParameterCondition
from derive.models import point_mass_biped as body
from derive.models.families import POINT_MASS_UNITS_TEXT
from derive.quantities import Derivation

PARAMETERS = (
    *body.PARAMETERS,
    Parameter(
        name="sigma",
        latex=r"\sigma",
        lower=0.0,
        upper=1.0,
        reason="the legs exchange between the feet: 0 < sigma < 1",
        description="where the legs exchange roles: the hip's distance from the stance foot "
        "then, over d (chosen by vsw optimize with the gait; the given value is its "
        "start)",
        assumptions={"positive": True},
        default=0.5,
        unit="1",
    ),
)
sigma = PARAMETERS[-1].symbol
x, d, l = body.x, body.d, body.l
# At the switch both legs reach the ground from the hip: the stance leg over sigma d, the
# new one over (1 - sigma) d (the midpoint model's d < 2 l is both at sigma = 1/2).
PARAMETER_CONDITIONS = (
    *body.PARAMETER_CONDITIONS,
    ParameterCondition(l - sigma * d, "the stance leg must reach the hip at the switch: "
                       "sigma d < l"),
    ParameterCondition(l - (1 - sigma) * d, "the new leg must reach the hip at the switch: "
                       "(1 - sigma) d < l"),
)  # fmt: skip

(HEELSTRIKE,) = body.MODEL.events
MODEL: Model = dataclasses.replace(
    body.MODEL,
    name="point_mass_biped_switch",
    title="Point-mass biped, switch point chosen",
    description="the point-mass biped (Srinivasan & Ruina 2006) whose legs exchange roles "
    "where the hip passes a point of the step the optimiser chooses, not only midway; no "
    "passive gait: it walks only powered",
    source="derive/models/point_mass_biped_switch.py",
    parameters=PARAMETERS,
    events=(dataclasses.replace(HEELSTRIKE, guard=x - sigma * d),),
    # Just after the step the hip is (1 - sigma) d behind the new stance foot.
    section={"x": -(1 - sigma) * d},
    parameter_conditions=PARAMETER_CONDITIONS,
    chosen_parameters=("sigma",),
)


def derive() -> Derivation:
    return model_derivation(MODEL, POINT_MASS_UNITS_TEXT)
