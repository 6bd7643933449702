"""The compass-like VSW biped with the ILE's own assumption made physical: the swing leg
caught and held at the inter-leg angle ``phi0`` by a hip actuator.

The ILE model's swing leg is massless and strikes the ground at the fixed inter-leg angle
``phi0`` (the paper's Section III). With a massive swing leg something must put it there:
here the swing leg swings freely about the hip from heelstrike until the inter-leg angle
reaches ``phi0``; a hip actuator then catches it (a plastic lock of the hip joint, as a
knee locks: :class:`~derive.engine.model.Lock`) and holds it at ``phi0`` until heelstrike.
At ``theta_II`` the stance leg extends instantaneously from ``beta l`` to ``l`` with the hip
held: the walker is then one rigid body about the stance foot, and the only momentum the
extension keeps is the angular momentum about the foot (the leg's impulse passes through
the foot, the hip's is internal): the ILE's eq. (3), with nothing unnamed. Unlike the
ILE's point mass, the walker turns through the extension (``Jump(limit=True)``): the leg's
push drags the swing leg's mass, which is off the stance leg's line, about the foot, so
the instantaneous extension is the limit of a fast one only with the stance angle moved
by ``-integral of M_theta,r / M_theta,theta dr`` (1.8e-4 rad at the defaults). Heelstrike is
the biped's, at the ILE's configuration (inter-leg angle ``phi0``, the ILE's eq. (5), (6),
(11)), after which the new swing leg is free again.

One step: swing (both legs ``beta l``, the hip free), the catch (inter-leg angle ``phi0``),
caught short stance, the extension at ``theta_II``, caught long stance, heelstrike. If the
stance leg reaches ``theta_II`` before the swing leg is caught the model has no rule for it:
the walk ends (``swing-late``). The hip actuator does work at the catch only (it holds a
fixed angle otherwise; the energy ledger reports it), the leg's at the extension.

Coordinates: ``theta``, the stance leg's angle from the vertical (the ILE's); ``phi``, the
inter-leg angle, the stance leg's angle less the swing leg's (positive with the swing foot
ahead of the stance foot), so that the hip actuator acts on ``phi`` alone. Bodies and units
as the biped's (derive/models/vsw_biped.py): lengths in ``l``, time in ``sqrt(l/g)``, masses
in ``m_H``; ``mu = m / m_H``, the legs' masses at ``b`` from the hip.

What it is for: as ``mu -> 0`` it is the ILE at ``phi0`` itself (its closed-form fixed
point (10)); for heavier legs it shows what holding the swing leg costs, which the paper's
future work asks.
"""

from __future__ import annotations

import dataclasses

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Event,
    Failure,
    Impact,
    Jump,
    Lock,
    Model,
    Phase,
    leg,
    swing_foot_clearance,
)
from derive.models.common import legs_skeleton, minus
from derive.models.ile.model import PARAMETERS as ILE_PARAMETERS
from derive.models.vsw_biped import FALLS, THETA, UNITS, UNITS_TEXT, biped_bodies, r
from derive.models.vsw_biped import PARAMETERS as BIPED_PARAMETERS
from derive.quantities import Derivation

# Defaults where it walks: a passive swing leg must travel 2 phi0 in the short time the
# ILE's stance takes, which a leg pendulum of b / l = 0.3 cannot do (no gait was found at
# beta 0.8-0.95, theta_II 0.1-0.3, phi0 0.4-0.7: the swing comes late); with its mass near
# the hip (b / l = 0.05) and the extension just before heelstrike it can.
_DEFAULTS = {"beta": 0.9, "theta_II": 0.43, "phi0": 0.4, "b_over_l": 0.05}
PARAMETERS = tuple(
    dataclasses.replace(p, default=_DEFAULTS.get(p.name, p.default))
    for p in (*ILE_PARAMETERS, *(p for p in BIPED_PARAMETERS if p.name in ("mu", "b_over_l")))
)
beta, theta_II, phi0, mu, b = (p.symbol for p in PARAMETERS)

PHI = Coordinate(
    "phi",
    "inter-leg angle (stance leg less swing leg)",
    "rad",
    reference="the stance leg",
    positive="the swing foot ahead of the stance foot",
)
theta, phi = THETA.q, PHI.q
hip = leg(theta, r)
swing_foot = minus(hip, leg(theta - phi, beta))
SKELETON = legs_skeleton(hip, swing_foot)
BODIES = biped_bodies(hip, theta - phi)


def _phase(name: str, length: sm.Expr, caught: bool) -> Phase:
    return Phase(
        name,
        coordinates=(THETA,) if caught else (THETA, PHI),
        bodies=BODIES,
        gravity=(0, -1),
        held={r: length, phi: phi0} if caught else {r: length},
        points={"swing_foot": swing_foot},
    )


SWING = _phase("swing", beta, caught=False)
CAUGHT_SHORT = _phase("caught_short", beta, caught=True)
CAUGHT_LONG = _phase("caught_long", sm.Integer(1), caught=True)
THETA_I = -sm.atan((beta - sm.cos(phi0)) / sm.sin(phi0))
"""Stance angle just after heelstrike, the ILE's eq. (11)."""

MODEL = Model(
    actuators={r: "leg", phi: "hip"},
    name="vsw_biped_phi0",
    title="Compass-like VSW biped, swing leg caught and held at phi0",
    description="the VSW biped with the ILE's assumption made physical: a hip actuator "
    "catches the swinging leg at the inter-leg angle phi0 and holds it there through the "
    "instantaneous extension at theta_II to heelstrike",
    source="derive/models/vsw_biped_phi0.py",
    parameters=PARAMETERS,
    phases=(SWING, CAUGHT_SHORT, CAUGHT_LONG),
    events=(
        Event("catch", "swing", "caught_short", phi - phi0, +1, Lock()),
        Event("extension", "caught_short", "caught_long", theta - theta_II, +1, Jump(limit=True),
              at=theta_II, equation="(3) with massive legs"),
        Event(
            "heelstrike",
            "caught_long",
            "swing",
            guard=swing_foot[1].xreplace({r: 1, phi: phi0}),
            direction=-1,
            reset=Impact(
                "swing_foot",
                {theta: theta - phi0, phi: -phi0},
                bodies={"stance_leg": "swing_leg", "swing_leg": "stance_leg"},
            ),
            at=THETA_I + phi0,
            ends_step=True,
            equation="(5), (6) with massive legs",
        ),
    ),
    failures=(
        *FALLS,
        Failure("swing-late", theta - theta_II, +1, "the stance leg reaches theta_II before "
                "the swing leg is caught at phi0: the model has no rule for it",
                unit="rad", phases=("swing",)),
    ),
    conditions=(swing_foot_clearance(swing_foot[1], "l"),),
    units=UNITS,
    skeleton=SKELETON,
    step_length=swing_foot[0],
    # Just after heelstrike the walker is in the ILE's configuration: the new stance leg at
    # theta_I (11), the new swing leg phi0 behind it.
    section={"theta": THETA_I, "phi": -phi0},
    search={"theta_dot": (0.0, 2.5), "phi_dot": (-4.0, 4.0)},
)  # fmt: skip


def derive() -> Derivation:
    return model_derivation(MODEL, UNITS_TEXT)
