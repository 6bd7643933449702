"""The compass-like biped of Virtual Slope Walking: the ILE model with massive legs.

The future work that "The Instantaneous Leg Extension Model of Virtual Slope Walking" ends
with: "a compass-like biped model to investigate the effect of swing leg on mechanical
energy restoration". On level ground, a point mass ``m_H`` at the hip and two legs whose
mass ``m`` sits at distance ``b`` from the hip on the upper, non-telescoping segment of the
leg (so telescoping moves only the massless foot and changes no inertia about the hip).

One step, as in the ILE model (Section III of the paper):

* short stance: the stance leg, ``beta l`` long, swings as a pendulum carrying the hip;
  the swing leg, shortened to ``beta l``, swings freely about the hip (its foot passes
  through the ground where the legs are together: scuffing is ignored, as in the passive
  walkers);
* extension: at the stance angle ``theta_II`` the stance leg extends instantaneously to
  ``l`` (an impulse along the stance leg: the generalised momenta of both leg angles are
  conserved, the ILE's eq. (3) with massive legs);
* long stance: the same motion with the stance leg ``l`` long;
* a step that begins with the stance leg already past ``theta_II`` (heelstrike came after
  the extension angle: heavy legs shorten the step) has no rule in the model: the walk
  ends there with the failure ``extension-missed``, as the ILE requires
  ``theta_I < theta_II``;
* heelstrike: the swing foot (``beta l`` below the hip) reaches the ground ahead of the
  stance foot; the impact is inelastic (angular momentum about the new contact and that
  of the trailing leg about the hip are conserved) and the legs swap roles.

The inter-leg angle at heelstrike is not a parameter, as the ILE's ``phi0`` is: it emerges
from the swing leg's motion. Scaled units: lengths in ``l``, time in ``sqrt(l/g)``, masses
in ``m_H``, so ``mu = m / m_H`` and energies are in ``m_H g l``.

Coordinates: ``theta`` is the stance leg's angle from the vertical, positive with the hip
ahead of the stance foot (the ILE's); ``psi`` is the swing leg's angle from the vertical,
measured the same way (a swing foot ahead of the hip has ``psi < 0``), so the inter-leg
angle is ``theta - psi``.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Event,
    Failure,
    Impact,
    Jump,
    Model,
    Parameter,
    Phase,
    PointMass,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    falls,
    legs_skeleton,
    minus,
    scale_parameter,
    stance_leg_angle,
    swing_leg_angle,
)
from derive.models.ile.model import PARAMETERS as ILE_PARAMETERS
from derive.quantities import Derivation

BETA, THETA_II = (p for p in ILE_PARAMETERS if p.name in ("beta", "theta_II"))
PARAMETERS = (
    BETA,
    THETA_II,
    scale_parameter(
        name="mu",
        latex=r"\mu",
        reason="mu = m / m_H > 0: the legs have mass",
        description="mass of each leg over the hip mass",
        default=0.1,
        unit="1",
    ),
    Parameter(
        name="b_over_l",
        latex="b / l",
        lower=0.0,
        upper=1.0,
        reason="the leg's mass lies between the hip and the foot: 0 < b / l < 1",
        description="distance from the hip to a leg's mass, over l",
        assumptions={"positive": True},
        default=0.3,
        unit="1",
        computed=(1e-6, 1.0),
        computed_reason="the swing leg's inertia about the hip, mu (b/l)^2, vanishes in "
        "double precision below; near it the swing is so fast that the gait search runs "
        "long (at b/l = 1e-3 it ran past a 40 s limit, which stops it)",
    ),
)
beta, theta_II, mu, b = (p.symbol for p in PARAMETERS)

THETA, PSI = stance_leg_angle(), swing_leg_angle()
theta, psi = THETA.q, PSI.q
r = sm.Symbol("r", positive=True)
"""The stance leg's length, held by its actuator."""


def biped_bodies(hip: tuple, swing: sm.Expr) -> tuple[PointMass, ...]:
    """The biped's masses: the hip's (the unit of mass) and each leg's, ``mu``, ``b`` below
    the ``hip`` on the stance leg and on the swing leg (at the angle ``swing``)."""
    return (
        PointMass("hip", 1, hip),
        PointMass("stance_leg", mu, minus(hip, leg(theta, b))),
        PointMass("swing_leg", mu, minus(hip, leg(swing, b))),
    )


def stance_phase(name: str, length: sm.Expr) -> Phase:
    """The stance leg ``length`` long, the swing leg shortened to ``beta``."""
    hip = leg(theta, r)
    swing_foot = minus(hip, leg(psi, beta))
    return Phase(
        name,
        coordinates=(THETA, PSI),
        bodies=biped_bodies(hip, psi),
        gravity=(0, -1),
        held={r: length},
        points={"swing_foot": swing_foot},
        # The stance leg at its held length, the swing leg shortened.
        skeleton=legs_skeleton(hip, swing_foot),
    )


SHORT = stance_phase("short", beta)
LONG = stance_phase("long", 1)

SECTION = {"psi": sm.acos(beta * sm.cos(theta))}
"""Just after heelstrike the new swing leg (the old stance leg, l long before the swap) has
its foot on the ground and the new stance leg (beta l) too: cos psi = beta cos theta, with
psi > 0 (the trailing foot behind the hip)."""
UNITS = {"time": "sqrt(l/g)", "length": "l", "mass": "m_H", "energy": "m_H g l", "force": "m_H g"}
# theta may be positive just after heelstrike (a foot landing behind the hip): the gait
# with max |eigenvalue| 2.31 at (0.8, 0.1, 0.3, 0.3) has theta = 0.095.
SEARCH = {"theta": (-0.8, 0.8), "theta_dot": (0.0, 2.5), "psi_dot": (-4.0, 4.0)}
FALLS = falls(THETA, backward="the walker stops before the apex and falls back")
"""How a VSW biped's walk ends, in every phase (the other biped models share them)."""
# Heavier legs shorten the step: past a point heelstrike leaves the new stance leg already
# beyond theta_II, and the extension, an event at theta_II, never comes. The model has no
# rule for that step (the ILE's theta_I < theta_II); it ends the walk by name rather than
# walking on unextended.
EXTENSION_MISSED = Failure(
    "extension-missed", theta - theta_II, +1, "the step begins past theta_II, so the stance "
    "leg never extends (heelstrike came after the extension angle)", unit="rad",
    phases=("short",), at_start=True,
)  # fmt: skip


def heelstrike(long: Phase) -> Event:
    """Heelstrike from the phase ``long`` to ``short``: the swing foot reaches the ground
    ahead of the stance foot; inelastic, the legs swap roles."""
    return Event(
        "heelstrike",
        long.name,
        "short",
        guard=long.points["swing_foot"][1],  # the swing foot's height
        direction=-1,
        reset=Impact(
            "swing_foot",
            {theta: psi, psi: theta},
            bodies={"stance_leg": "swing_leg", "swing_leg": "stance_leg"},
        ),
        ends_step=True,
        when=theta - psi,  # the new foot lands ahead of the stance foot
        equation="(5), (6) with massive legs",
    )


MODEL = Model(
    # The held-hip rule's jump is the leg's push and a hip impulse together (its split has
    # no limit: docs/models/vsw_biped.md), so the one actuator named at it is both.
    actuators={r: "leg and held hip"},
    name="vsw_biped",
    title="Compass-like biped of Virtual Slope Walking",
    description="the ILE model with massive legs (the paper's future work): hip mass, leg "
    "masses on the legs' upper segments, instantaneous extension at theta_II keeping both "
    "leg angles and generalised momenta (the held-hip rule: a hip impulse the model does "
    "not name holds the swing leg), heelstrike where the swinging leg reaches the level "
    "ground",
    source="derive/models/vsw_biped.py",
    parameters=PARAMETERS,
    phases=(SHORT, LONG),
    events=(
        Event(
            "extension",
            "short",
            "long",
            guard=theta - theta_II,
            direction=+1,
            reset=Jump(),
            at=theta_II,
            equation="(3) with massive legs",
        ),
        heelstrike(LONG),
    ),
    failures=(*FALLS, EXTENSION_MISSED),
    conditions=(swing_foot_clearance(SHORT.points["swing_foot"][1], "l"),),
    units=UNITS,
    step_length=LONG.points["swing_foot"][0],
    section=SECTION,
    search=SEARCH,
)


UNITS_TEXT = "Angles in radians; lengths in l, time in sqrt(l/g), energies in m_H g l."


def derive() -> Derivation:
    return model_derivation(MODEL, UNITS_TEXT)
