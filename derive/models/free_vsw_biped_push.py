"""The VSW biped's body with free actuation and a push at a chosen angle: the least work of
that body where its leg may also push in an instant within the stance (VSW's price on its own
biped).

The body, its actuators, heelstrike and units are ``free_vsw_biped.py``'s. On that model
the least work does not converge as the mesh refines: near the end of the stance the leg
force grows within one interval (7.9, 12.9, 28.8 m_H g on 40, 80, 160 intervals) and
lengthens the leg at about 0.33 l per time unit, which it then keeps until heelstrike, a
few hundredths of a time unit later. In the limit that is an impulse along the stance leg
at a time of the optimiser's choosing, before heelstrike and not with it: the hip, moving
out, rises before the swing foot lands. A mesh cannot place an impulse between its knots;
a phase boundary can. So the stance is split in two where the stance leg passes the
angle ``theta_push``, a parameter of the gait that ``vsw optimize`` chooses
(:attr:`Model.chosen_parameters`: the guard ``theta - theta_push`` makes the push's time
free), and at that instant the leg may push along itself (``push``, >= 0) and the hip
may act (``hip_impulse_push``). Nothing else changes at the split (:class:`Continuous`):
with both impulses zero, the two phases are one stance of ``free_vsw_biped``, so every
gait of that model is one of this model's too, and its least work is at most that
model's.

Coordinates as ``free_vsw_biped.py``'s: ``theta``, ``psi`` the legs' angles from the
vertical, ``r`` the stance leg's length.
"""

from __future__ import annotations

from derive.engine import model_derivation
from derive.engine.model import (
    Continuous,
    Event,
    Impulse,
    Model,
    Parameter,
    swing_foot_clearance,
)
from derive.models.common import PI
from derive.models.free_vsw_biped import (
    CROUCHED,
    FALLS,
    HEEL_STRIKE,
    HIP_IMPULSE_AFTER,
    HIP_IMPULSE_BEFORE,
    OVEREXTENDED,
    PARAMETER_CONDITIONS,
    PSI,
    PUSH_OFF,
    SEARCH,
    beta,
    heelstrike,
    r,
    stance_phase,
    theta,
)
from derive.models.free_vsw_biped import PARAMETERS as BODY_PARAMETERS
from derive.models.vsw_biped import UNITS, UNITS_TEXT
from derive.quantities import Derivation

PARAMETERS = (
    *BODY_PARAMETERS,
    Parameter(
        name="theta_push",
        latex=r"\theta_{push}",
        lower=-PI / 2,
        upper=PI / 2,
        reason="the stance leg must point below the horizontal: |theta_push| < pi/2",
        description="stance leg angle at which the leg "
        "may push in an instant (chosen by vsw optimize with the gait; the given value "
        "is its start)",
        default=0.5,
        unit="rad",
    ),
)
theta_push = PARAMETERS[-1].symbol

LEG_PUSH = Impulse(
    "push",
    r,
    "leg",
    unit="m_H sqrt(g l)",
    bounds=(0.0, None),
    description="the stance leg's impulse along itself where the stance leg passes "
    "theta_push (>= 0: a leg cannot pull on the ground)",
)
HIP_IMPULSE_PUSH = Impulse(
    "hip_impulse_push",
    theta - PSI.q,
    "hip",
    unit="m_H l sqrt(g l)",
    description="the hip torque's impulse where the stance leg passes theta_push",
)


STANCE, PUSHED = stance_phase("stance"), stance_phase("pushed")

MODEL = Model(
    name="free_vsw_biped_push",
    title="VSW biped's body, free actuation, a push at a chosen angle",
    description="the VSW biped's body with its leg force and hip torque free in time and "
    "an impulsive push along the stance leg, with a hip impulse, where the stance leg "
    "passes an angle the optimiser chooses; no passive gait: it walks only powered",
    source="derive/models/free_vsw_biped_push.py",
    parameters=PARAMETERS,
    phases=(STANCE, PUSHED),
    events=(
        Event(
            "push",
            "stance",
            "pushed",
            guard=theta - theta_push,
            direction=+1,
            reset=Continuous(),
            at=theta_push,
            impulses=(LEG_PUSH, HIP_IMPULSE_PUSH),
            equation="the ILE's extension (2)-(3) as the leg's impulse, its time free",
        ),
        heelstrike(PUSHED, (PUSH_OFF, HIP_IMPULSE_BEFORE, HEEL_STRIKE, HIP_IMPULSE_AFTER)),
    ),
    failures=(*FALLS, CROUCHED, OVEREXTENDED),
    conditions=(swing_foot_clearance(PUSHED.points["swing_foot"][1], "l"),),
    units=UNITS,
    step_length=PUSHED.points["swing_foot"][0],
    # Just after heelstrike the new stance leg is beta l long.
    section={"r": beta},
    search=SEARCH,
    powered_only=True,
    parameter_conditions=PARAMETER_CONDITIONS,
    chosen_parameters=("theta_push",),
)


def derive() -> Derivation:
    return model_derivation(MODEL, UNITS_TEXT)
