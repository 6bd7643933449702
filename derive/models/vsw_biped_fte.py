"""The compass-like VSW biped with a finite-time extension and a free hip.

The VSW biped (:mod:`derive.models.vsw_biped`) extends its stance leg instantaneously and
keeps both leg angles and both generalised momenta through the extension: a rule that
needs a hip actuator it does not name (the extension moves the hip across the swing leg,
and something must keep the swing leg from turning). This model names no hip actuator at
all: the hip is a free pin through the whole step, and the stance leg extends over a
stance-angle interval, as in the TLE model (:mod:`derive.models.tle`), along the TLE's
profile

    r(theta) = beta + (1 - beta) S(s),  S(s) = 3 s**2 - 2 s**3,  s = (theta - theta_II) / delta,

from ``beta l`` at ``theta_II`` to ``l`` at ``theta_II + delta`` (zero slope at both
ends: the leg's length and rate are continuous, so neither end is an impact). The only
actuator is the stance leg's, which does the extension's work; the swing leg turns as the
hip carries it.

One step: short stance (both legs ``beta l``), the extension (the stance leg along the
profile), long stance, heelstrike (the biped's: inelastic, the legs swap). A step that
begins past ``theta_II`` ends the walk (``extension-missed``), as in the biped.

What it is for: as ``mu -> 0`` the legs stop acting on the hip and the gait is the TLE's at
the emergent inter-leg angle; as ``delta -> 0`` it shows what a free hip does to an
instantaneous extension (the swing leg's rate after the extension grows without bound,
as ``1/delta``: docs/models/vsw_biped.md). Units and coordinates as the biped's.
"""

from __future__ import annotations

import dataclasses

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import Continuous, Event, Model, swing_foot_clearance
from derive.models.common import PI
from derive.models.families import extension_interval
from derive.models.tle import profile
from derive.models.vsw_biped import (
    EXTENSION_MISSED,
    FALLS,
    SEARCH,
    SECTION,
    THETA,
    UNITS,
    UNITS_TEXT,
    heelstrike,
    r,
    stance_phase,
)
from derive.models.vsw_biped import PARAMETERS as BIPED_PARAMETERS
from derive.quantities import Derivation

# Defaults where this walker has a stable gait (max |eigenvalue| 0.31 at mu = 0.1; the
# biped's defaults, beta = 0.8 and theta_II = 0, give gaits with eigenvalues in the
# hundreds here).
_DEFAULTS = {"beta": 0.97, "theta_II": -0.2}
PARAMETERS = (
    *(dataclasses.replace(p, default=_DEFAULTS.get(p.name, p.default)) for p in BIPED_PARAMETERS),
    extension_interval(
        bounds="0 < delta < pi/2",
        default=0.3,
        computed=(1e-3, PI / 2),
        computed_reason="the leg force grows as 1/delta^2 and the free swing leg's "
        "rate after the extension as 1/delta: below 1e-3 rad the extension is too "
        "stiff to integrate in reasonable time; the instantaneous limit does not "
        "exist with a free hip (the vsw_biped model holds the hip instead)",
    ),
)
beta, theta_II, mu, b, delta = (p.symbol for p in PARAMETERS)
theta = THETA.q
# The TLE's profile, in l here: its beta, theta_II and delta are these symbols (same
# names and assumptions), which the import would otherwise silently break.
if profile(theta).free_symbols != {beta, theta_II, delta, theta}:
    raise ValueError("vsw_biped_fte: the TLE's profile uses symbols other than this model's")
SHORT = stance_phase("short", beta)
EXTENSION = stance_phase("extension", profile(theta))
LONG = stance_phase("long", sm.Integer(1))

MODEL = Model(
    actuators={r: "leg"},
    name="vsw_biped_fte",
    title="Compass-like VSW biped, finite-time extension, free hip",
    description="the VSW biped whose stance leg extends along the TLE's profile over "
    "[theta_II, theta_II + delta] with a free hip (no hip actuator)",
    source="derive/models/vsw_biped_fte.py",
    parameters=PARAMETERS,
    phases=(SHORT, EXTENSION, LONG),
    events=(
        Event("extension_start", "short", "extension", theta - theta_II, +1, Continuous(),
              at=theta_II),
        Event("extension_end", "extension", "long", theta - theta_II - delta, +1,
              Continuous(), at=theta_II + delta),
        heelstrike(LONG),
    ),
    failures=(*FALLS, EXTENSION_MISSED),
    conditions=(swing_foot_clearance(SHORT.points["swing_foot"][1], "l"),),
    units=UNITS,
    step_length=LONG.points["swing_foot"][0],
    section=SECTION,
    search=SEARCH,
)  # fmt: skip


def derive() -> Derivation:
    return model_derivation(MODEL, UNITS_TEXT)
