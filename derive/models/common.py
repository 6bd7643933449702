"""What the model files share: the bounds their parameter tables take, the standard
parameters (a positive scale, gravity, a passive walker's slope), SI units, gravity in a
slope's frame, the legs' angles and their drawing, heelstrike swapping two legs and a push-off
released by it, the ways a walk on a stance leg ends (falling backward or forward, the stance
foot lifting off), and the point of a phase nearest the apex.

Each is written once so that a model file states only what is its own; the wording of a
parameter's reason or a failure's meaning is the generated tables' and messages', so it is
passed where a model's differs.
"""

from __future__ import annotations

import sympy as sm

from derive.engine.model import (
    NORMAL_FORCE,
    Coordinate,
    Event,
    Failure,
    Impact,
    Impulse,
    Parameter,
    Skeleton,
)

PI = float(sm.pi.evalf(17))
"""pi as a float: the angle bounds of the parameter tables (``PI / 2``)."""
INF = float("inf")
"""The upper bound of a scale (a mass, a length, gravity)."""
SI_UNITS = {"time": "s", "length": "m", "mass": "kg", "energy": "J", "force": "N"}
"""The units of a model in SI, for :class:`~derive.engine.model.Model`'s ``units``."""
SI_UNITS_TEXT = "Angles in radians, lengths in m, time in s, energies in J."
"""The generated docstrings' sentence on the units of a model in SI."""


def scale_parameter(
    *, name: str, latex: str, reason: str, description: str, default: float, unit: str
) -> Parameter:
    """A positive scale (a mass, a length, an inertia): ``0 < value < inf``, its symbol
    positive."""
    return Parameter(
        name=name,
        latex=latex,
        lower=0.0,
        upper=INF,
        reason=reason,
        description=description,
        assumptions={"positive": True},
        default=default,
        unit=unit,
    )


def gravity_parameter(default: float = 9.81, unit: str = "m/s^2") -> Parameter:
    """The gravitational acceleration ``g > 0``."""
    return scale_parameter(
        name="g",
        latex="g",
        reason="gravity g > 0",
        description="gravitational acceleration",
        default=default,
        unit=unit,
    )


def slope_parameter(default: float, **fields) -> Parameter:
    """The slope ``0 < gamma < pi/2`` a passive walker walks down (``fields``: the other
    fields of :class:`~derive.quantities.Parameter`, such as ``computed``)."""
    return Parameter(
        name="gamma",
        latex=r"\gamma",
        lower=0.0,
        upper=PI / 2,
        reason="a passive walker walks down a slope: 0 < gamma < pi/2",
        description="slope angle",
        default=default,
        unit="rad",
        **fields,
    )


def slope_gravity(g: sm.Expr, gamma: sm.Expr) -> tuple[sm.Expr, sm.Expr]:
    """Gravity in the frame of a slope of angle ``gamma`` (x down the slope, y along its
    normal): a walker on the slope walks as on level ground under tilted gravity."""
    return (g * sm.sin(gamma), -g * sm.cos(gamma))


def plus(point: tuple, vector: tuple) -> tuple:
    """``point`` moved by ``vector``: a link's upper end from its lower end and
    :func:`~derive.engine.model.leg` (``plus(knee, leg(theta, thigh))``)."""
    return tuple(p + v for p, v in zip(point, vector))


def minus(point: tuple, vector: tuple) -> tuple:
    """``point`` moved back by ``vector``: a link's lower end from its upper end and
    :func:`~derive.engine.model.leg` (``minus(hip, leg(psi, thigh))``)."""
    return tuple(p - v for p, v in zip(point, vector))


def stance_leg_angle(name: str = "theta", slope: bool = False) -> Coordinate:
    """The stance leg's angle from the vertical (from the slope normal on a ``slope``),
    positive with the hip ahead of (downhill of) the stance foot."""
    if slope:
        return Coordinate(name, "stance leg angle", "rad", reference="the slope normal",
                          positive="the hip downhill of the stance foot")  # fmt: skip
    return Coordinate(name, "stance leg angle", "rad", reference="the vertical",
                      positive="the hip ahead of the stance foot")  # fmt: skip


def swing_leg_angle(name: str = "psi", slope: bool = False) -> Coordinate:
    """The swing leg's angle, measured as :func:`stance_leg_angle`'s (a swing foot ahead of
    the hip has a negative angle)."""
    if slope:
        return Coordinate(name, "swing leg angle", "rad", reference="the slope normal",
                          positive="the hip downhill of the swing foot")  # fmt: skip
    return Coordinate(name, "swing leg angle", "rad", reference="the vertical",
                      positive="the hip ahead of the swing foot")  # fmt: skip


def legs_skeleton(hip: tuple, swing_foot: tuple, torso: tuple | None = None) -> Skeleton:
    """The drawing of two straight legs from the hip (and a ``torso`` up to its mass)."""
    points = {"stance_foot": (0, 0), "hip": hip, "swing_foot": swing_foot}
    segments = (("stance_foot", "hip"), ("hip", "swing_foot"))
    if torso is not None:
        points["torso"] = torso
        segments += (("hip", "torso"),)
    return Skeleton(points=points, segments=segments)


def swapping_heelstrike(stance: sm.Expr, swing: sm.Expr, kept: tuple = (), **fields) -> Event:
    """Heelstrike of two straight legs of one length at the angles ``stance`` and ``swing``
    (the ``kept`` coordinates unchanged; ``fields``: the event's others, such as
    ``impulses``): the swing foot's height is ``-2 l sin((stance + swing)/2) sin((stance -
    swing)/2)``, zero where the legs are together (the scuffing the models ignore) and at
    heelstrike, where the first factor rises through zero past mid-stance (the new foot
    ahead of the hip). The impact is inelastic at the swing foot; the legs swap roles."""
    return Event(
        "heelstrike",
        "stance",
        "stance",
        guard=sm.sin((stance + swing) / 2),
        direction=1,
        reset=Impact(
            "swing_foot",
            {stance: swing, swing: stance, **{q: q for q in kept}},
            bodies={"stance_leg": "swing_leg", "swing_leg": "stance_leg"},
        ),
        ends_step=True,
        when=stance,
        **fields,
    )


def push_off_with_heelstrike(leg_length: sm.Expr) -> Impulse:
    """The trailing leg's push-off along itself, released by heelstrike's impact (the leg's
    ``leg_length`` held by its actuator), in N s."""
    return Impulse(
        "push_off",
        leg_length,
        "leg",
        at_impact=True,
        unit="N s",
        bounds=(0.0, None),
        description="the trailing leg's impulse along itself with heelstrike "
        "(just before it; the impact releases its foot)",
    )


def fell_backward(stance: Coordinate, meaning: str) -> Failure:
    """The stance coordinate's rate falls through zero: the walker stops before the apex
    and goes back."""
    return Failure("fell-backward", stance.u, -1, meaning)


def fell_forward(stance: Coordinate, ground: str = "ground") -> Failure:
    """The stance leg's angle from the ground's normal reaches a right angle: the hip
    reaches the ground (``"slope"`` on a slope)."""
    return Failure("fell-forward", sm.cos(stance.q), -1, f"the hip reaches the {ground}")


def lift_off(ground: str = "ground") -> Failure:
    """The ground's normal force on the stance foot falls through zero."""
    return Failure("lift-off", NORMAL_FORCE, -1, f"the stance foot leaves the {ground}")


def falls(
    stance: Coordinate,
    ground: str = "ground",
    backward: str = "the stance leg stops and swings back",
) -> tuple[Failure, ...]:
    """The three ways a walk on a stance leg ends, in this order (their indices in the
    generated code): :func:`fell_backward`, :func:`fell_forward`, :func:`lift_off`."""
    return (fell_backward(stance, backward), fell_forward(stance, ground), lift_off(ground))


def closest_to_apex_cos(
    sin_lo: sm.Expr, cos_lo: sm.Expr, sin_hi: sm.Expr, cos_hi: sm.Expr, evaluate: bool = True
) -> sm.Expr:
    """cos of the angle in [lo, hi] closest to the apex theta = 0 (where cos is largest),
    where a stance leg's rate is least: the apex condition's point of a phase (the ILE's
    eq. (14)).

    With both ends on one side of the apex it is the larger end cosine; otherwise the
    interval contains the apex and it is 1. Written as a maximum with the indicator of
    "contains the apex" (cosines lie in (0, 1] on the domain), which evaluates without a
    select; ``evaluate=False`` spares sympy comparing the arguments (seconds on large
    ones). For a reversed interval (lo > hi: the stance leg never reaches the phase's end,
    a set that does not walk) the value means nothing (only its sign is used).
    """
    contains_apex = sm.Piecewise((1, sin_lo * sin_hi <= 0), (0, True))
    return sm.Max(cos_lo, cos_hi, contains_apex, evaluate=evaluate)
