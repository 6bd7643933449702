"""The VSW biped (derive/models/vsw_biped.py) on footholds of random height: its model with
one parameter more, ``step_height``, the next foothold's height above the stance foot, and
heelstrike's guard (the swing foot's height) less it. A user's model file
(``vsw rough --model docs/guide/rough-models/vsw_biped_height.py --terrain height``); with
``step_height`` 0 its walks are the VSW biped's."""

import dataclasses

from derive.models import vsw_biped as base
from derive.quantities import Parameter

HEIGHT = Parameter(
    "step_height",
    "h",
    -0.5,
    0.5,
    "a foothold within half a leg of the stance foot: |h| < l / 2",
    "height of the next foothold above the stance foot (along the ground normal, up positive)",
    default=0.0,
    unit="l",
)
h = HEIGHT.symbol

MODEL = dataclasses.replace(
    base.MODEL,
    name="vsw_biped_height",
    title="Compass-like biped of Virtual Slope Walking, footholds of random height",
    source="docs/guide/rough-models/vsw_biped_height.py",
    parameters=(*base.MODEL.parameters, HEIGHT),
    events=tuple(
        dataclasses.replace(e, guard=e.guard - h) if e.ends_step else e for e in base.MODEL.events
    ),
)
UNITS = base.UNITS_TEXT
