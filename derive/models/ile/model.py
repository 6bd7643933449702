"""The instantaneous leg extension (ILE) model of Virtual Slope Walking: the model's facts.

Section III of "The Instantaneous Leg Extension Model of Virtual Slope Walking": a point mass
at the hip on two massless telescoping legs. Phase I-II: the stance leg, shortened to
r_s = beta r_e, swings as an inverted pendulum (eq. 1, 2). Instant II -> III: at the stance
angle theta_II the stance leg extends instantaneously to r_e; angular momentum about the
stance foot is conserved (eq. 3). Phase III-IV: the extended leg swings (eq. 4). Instant
IV -> I: the swing leg, shortened to r_s and held at the inter-leg angle phi0, touches the
level ground (eq. 5); the impact is inelastic, angular momentum about the new contact is
conserved (eq. 6), and the legs exchange roles.

Conventions (the paper's): ``theta`` is the stance-leg angle from the vertical, positive
when the hip is ahead of the stance foot, so a step runs from ``theta_I < 0`` forward to
``theta_IV > 0``. Time is dimensionless, ``tau = sqrt(g / r_e) t``, and
``omega = dtheta/dtau`` (the engine's state names it ``theta_dot``, as every model does);
lengths in ``r_e``; energies in ``m g r_e`` unless ``m, g, r_e`` appear explicitly. The
engine (:mod:`derive.engine`) derives the equations of motion and the resets from this
description; :mod:`derive.models.ile.closed_form` derives the paper's closed forms from
those.
"""

from __future__ import annotations

import sympy as sm

from derive.engine.model import (
    Event,
    Impact,
    Jump,
    Model,
    Phase,
    PointMass,
    leg,
)
from derive.models.common import PI, fell_backward, lift_off, minus, stance_leg_angle
from derive.models.families import extension_angle, heelstrike_inter_leg_angle, shortening_ratio
from derive.quantities import Parameter

PARAMETERS: tuple[Parameter, ...] = (
    shortening_ratio(default=0.8),
    extension_angle(
        description="stance leg angle at which the leg extends (instant II)",
        default=0.0,
        cli_degrees=True,
    ),
    heelstrike_inter_leg_angle(equation="eq. (16)", default=PI / 4, cli_degrees=True),
)

beta, theta_II, phi0 = (p.symbol for p in PARAMETERS)
q = sm.Symbol("q", real=True)
q_next = sm.Symbol("q_next", real=True)
theta, omega = sm.symbols("theta omega", real=True)
leg_ratio = sm.Symbol("leg_ratio", positive=True)
omega_II, omega_IV = sm.symbols("omega_II omega_IV", real=True)
m, g, r_e = sm.symbols("m g r_e", positive=True)
theta_I, theta_IV = sm.symbols("theta_I theta_IV", real=True)
"""Kept as symbols in the paper-shaped forms; eliminated by :func:`eliminate_contact_angles`."""

# --- The model (Section III of the paper), for the engine ------------------------------
# A point mass at the hip on two massless telescoping legs, in the paper's dimensionless
# units (lengths in r_e, time in sqrt(r_e / g), mass in m). theta: the stance leg's angle
# from the vertical, positive when the hip is ahead of the foot; the actuator holds the
# stance leg's length r.
THETA = stance_leg_angle()
r = sm.Symbol("r", positive=True)
"""The stance leg's length, held by its actuator."""


def stance_phase(name: str, length: sm.Expr, mass=1, gravity=1, unit_length=1) -> Phase:
    """A stance phase: the hip mass on a leg of ``length`` (times ``unit_length``), the
    shortened swing leg (beta r_e) at the inter-leg angle phi0 behind it."""
    hip = leg(theta, r)
    swing_foot = minus(hip, leg(theta - phi0, beta * unit_length))
    return Phase(
        name,
        coordinates=(THETA,),
        bodies=(PointMass("hip", mass, hip),),
        gravity=(0, -gravity),
        held={r: length * unit_length},
        points={"swing_foot": swing_foot},
    )


PHASE_I_II = stance_phase("phase_I_II", beta)  # r_s = beta r_e, from instant I to II
PHASE_III_IV = stance_phase("phase_III_IV", 1)  # r_e, from instant III to IV
_SWING_FOOT = PHASE_III_IV.points["swing_foot"]
_THETA_I = -sm.atan((beta - sm.cos(phi0)) / sm.sin(phi0))  # eq. (11)

MODEL = Model(
    actuators={r: "leg"},
    name="ile",
    title="Instantaneous leg extension model of Virtual Slope Walking",
    description="point-mass hip on massless telescoping legs: the stance leg extends "
    "instantaneously at theta_II, heelstrike at the inter-leg angle phi0 (level ground)",
    source="derive/models/ile/model.py",
    parameters=PARAMETERS,
    phases=(PHASE_I_II, PHASE_III_IV),
    events=(
        # II -> III: the actuator extends the stance leg to r_e instantly; angular momentum
        # about the stance foot is conserved.
        Event(
            "extension",
            "phase_I_II",
            "phase_III_IV",
            guard=theta - theta_II,
            direction=+1,
            reset=Jump(),
            at=theta_II,
            equation="(3)",
        ),
        # IV -> I: the swing foot touches level ground, sticks, and becomes the stance foot.
        Event(
            "heelstrike",
            "phase_III_IV",
            "phase_I_II",
            guard=_SWING_FOOT[1],
            direction=-1,
            reset=Impact("swing_foot", {theta: theta - phi0}),
            at=_THETA_I + phi0,
            ends_step=True,
            equation="(5), (6)",
        ),
    ),
    failures=(fell_backward(THETA, "the walker stops before the apex and falls back"), lift_off()),
    units={
        "time": "sqrt(r_e/g)",
        "length": "r_e",
        "mass": "m",
        "energy": "m g r_e",
        "force": "m g",
    },
    step_length=_SWING_FOOT[0],
    # Just after heelstrike the stance leg is at theta_I (eq. 11); its rate is the state.
    section={"theta": _THETA_I},
    # omega_I**2 = q stays below the lift-off bound, about 1/beta: rates up to 3 cover it.
    search={"theta_dot": (0.0, 3.0)},
)
