"""RABBIT, the five-link planar biped with knees and point feet: Chevallereau, Abba,
Aoustin, Plestan, Westervelt, Canudas-de-Wit & Grizzle 2003, "RABBIT: a testbed for
advanced control theory", IEEE Control Systems Magazine 23(5):57-79, and Westervelt,
Grizzle, Chevallereau, Choi & Morris 2007, "Feedback Control of Dynamic Bipedal Robot
Locomotion" (CRC Press), its RABBIT model.

Five rigid links: a torso, two femurs and two tibias, joined at one hip and two knees;
four actuators, one at each hip (between the torso and a femur) and one at each knee
(between a femur and its tibia), are the model's inputs. The feet are points; in single
support the stance foot is a hinge on level ground, so the walker has five degrees of
freedom and four actuators: one degree of underactuation. Heelstrike is the swing foot
reaching the ground past mid-stance (ahead of the stance foot): a plastic impact at the
swing foot (the book's rigid impact model, chapter 3), after which the old stance foot
lifts without interaction and the legs swap roles (the book's relabelling). Scuffing of
the swing foot is ignored (the book's gaits lift it by the controller). Without its
actuators RABBIT has no gait: it folds at the knees, so it walks only powered
(``vsw optimize``).

Parameters (the defaults), from RABBIT's published tables:

=========  ======  =============  ======================  ==========================
link       mass    length         mass centre             inertia about it
=========  ======  =============  ======================  ==========================
torso      12 kg   0.625 m        0.24 m above the hip    1.33 kg m^2
femur      6.8 kg  0.4 m          0.11 m below the hip    0.47 kg m^2
tibia      3.2 kg  0.4 m          0.24 m below the knee   0.20 kg m^2
=========  ======  =============  ======================  ==========================

* masses, lengths and inertias: Chevallereau et al. 2003, Table II, "Experimentally
  measured parameters for RABBIT" (so numbered in the authors' revised manuscript, paper
  CSM-02-038): femur 0.4 m, 6.8 kg, 0.47 kg m^2; tibia 0.4 m, 3.2 kg, 0.20 kg m^2; torso
  0.625 m, 12.0 kg, 1.33 kg m^2. It gives no mass centres;
* mass centres and where they are measured from: Westervelt, Buche & Grizzle 2004,
  "Experimental validation of a framework for the design of controllers that induce
  stable walking in planar bipeds", International Journal of Robotics Research
  23(6):559-582, Table 1, "Identified link parameters for RABBIT" (the same masses and
  inertias), with its Fig. 5, "Schematic of RABBIT's link parameter measurement
  conventions": the torso's ``p_T^M`` = 0.24 m from the hip up the torso, a femur's
  ``p_f^M`` from the hip down the femur, a tibia's ``p_t^M`` = 0.24 m from the knee down
  the tibia;
* inertias about the links' own mass centres: Chevallereau, Westervelt & Grizzle 2005,
  "Asymptotically stable running for a five-link, four-actuator, planar bipedal robot",
  International Journal of Robotics Research 24(6):431-464, Table I, "Experimentally
  measured parameters for RABBIT", whose row is "Inertia about COM" (0.47, 0.20 and
  1.33 kg m^2).

The mass centres are thus measured from the joint nearer the torso (the hip for the torso
and a femur, the knee for a tibia), on the link's line. Where sources differ:

* the femur's mass centre is printed 1.11 m in the authors' manuscript of Westervelt,
  Buche & Grizzle's Table 1, longer than the 0.4 m femur: this model takes 0.11 m, the
  value of the public reproductions (FROST's ``example/rabbit/urdf/five_link_walker.xacro``,
  which cites Westervelt et al. 2007 for its values, and ``RabbitParam.m`` below);
* Westervelt, Buche & Grizzle's Table 1 and the reproductions give the torso's length as
  0.63 m; it also lists the gear ratio 50 and a "motor rotor inertia" of 0.83 kg m^2,
  which is the ratio squared times the rotor inertia 3.32e-4 kg m^2 of a MATLAB
  reproduction of the table (``RabbitParam.m``: "COM Positions (From joint origin)"):
  a model with the rotors adds that reflected inertia on each joint's relative rate.
  This model leaves the rotors out: its links are the table's bare links;
* Chevallereau, Westervelt & Grizzle's Table I gives the torso 17.0 kg, not 12 kg: not
  used here;
* Westervelt, Grizzle & Koditschek 2003, "Hybrid zero dynamics of planar biped walkers",
  IEEE Trans. Automatic Control 48(1):42-56, Table I, "Model parameters for example
  robot" (reproduced by OptimTraj's five-link biped,
  ``demo/fiveLinkBiped/costOfTransport/getPhysicalParameters.m``), gives a 20 kg torso,
  inertias 2.22, 1.08 and 0.93 kg m^2 and mass centres 0.2, 0.163 and 0.128 m: an
  example robot, not RABBIT's measured links: not used here;
* the torso's length enters only the drawing: the dynamics take its mass centre and
  inertia.

Coordinates on level ground, each link's angle from the vertical, positive with the link's
upper end ahead of its lower end (the engine's :func:`~derive.engine.model.leg`):
``theta_t`` the stance tibia, ``theta_f`` the stance femur, ``phi`` the torso (leaning
forward positive), ``psi_f`` the swing femur and ``psi_t`` the swing tibia. Absolute angles
make the relabelling at heelstrike a swap (stance tibia <-> swing tibia, stance femur <->
swing femur, torso kept) and the mass matrix's entries cosines of angle differences. The
book's coordinates are the joints' relative angles and the torso's absolute angle: up to
its signs, the hips' ``theta_f - phi`` and ``psi_f - phi``, the knees' ``theta_t - theta_f``
and ``psi_t - psi_f`` (flexion positive here) and ``phi``.
"""

from __future__ import annotations

import sympy as sm

from derive.engine import model_derivation
from derive.engine.model import (
    Coordinate,
    Event,
    Failure,
    Impact,
    Input,
    Model,
    Phase,
    RigidSegment,
    Skeleton,
    leg,
    swing_foot_clearance,
)
from derive.models.common import (
    SI_UNITS,
    SI_UNITS_TEXT,
    gravity_parameter,
    lift_off,
    minus,
    plus,
    scale_parameter,
)
from derive.quantities import Derivation

# RABBIT's published tables (Chevallereau et al. 2003; Westervelt et al. 2004): see the docstring.
PARAMETERS = (
    scale_parameter(
        name="m_torso",
        latex="M_T",
        reason="torso mass m_torso > 0",
        description="torso mass",
        default=12.0,
        unit="kg",
    ),
    scale_parameter(
        name="m_femur",
        latex="M_f",
        reason="femur mass m_femur > 0",
        description="mass of each femur",
        default=6.8,
        unit="kg",
    ),
    scale_parameter(
        name="m_tibia",
        latex="M_t",
        reason="tibia mass m_tibia > 0",
        description="mass of each tibia",
        default=3.2,
        unit="kg",
    ),
    scale_parameter(
        name="i_torso",
        latex="I_T",
        reason="i_torso > 0",
        description="torso's moment of inertia about its mass centre",
        default=1.33,
        unit="kg m^2",
    ),
    scale_parameter(
        name="i_femur",
        latex="I_f",
        reason="i_femur > 0",
        description="a femur's moment of inertia about its mass centre",
        default=0.47,
        unit="kg m^2",
    ),
    scale_parameter(
        name="i_tibia",
        latex="I_t",
        reason="i_tibia > 0",
        description="a tibia's moment of inertia about its mass centre",
        default=0.20,
        unit="kg m^2",
    ),
    scale_parameter(
        name="l_torso",
        latex="L_T",
        reason="l_torso > 0",
        description="torso length from the hip (drawn only)",
        default=0.625,
        unit="m",
    ),
    scale_parameter(
        name="l_femur",
        latex="L_f",
        reason="l_femur > 0",
        description="femur length (hip to knee)",
        default=0.4,
        unit="m",
    ),
    scale_parameter(
        name="l_tibia",
        latex="L_t",
        reason="l_tibia > 0",
        description="tibia length (knee to foot)",
        default=0.4,
        unit="m",
    ),
    scale_parameter(
        name="c_torso",
        latex="p_{M_T}",
        reason="c_torso > 0",
        description="distance from the hip up to the torso's mass centre",
        default=0.24,
        unit="m",
    ),
    scale_parameter(
        name="c_femur",
        latex="p_{M_f}",
        reason="c_femur > 0",
        description="distance from the hip down to a femur's mass centre",
        default=0.11,
        unit="m",
    ),
    scale_parameter(
        name="c_tibia",
        latex="p_{M_t}",
        reason="c_tibia > 0",
        description="distance from the knee down to a tibia's mass centre",
        default=0.24,
        unit="m",
    ),
    gravity_parameter(),
)
(m_torso, m_femur, m_tibia, i_torso, i_femur, i_tibia, l_torso, l_femur, l_tibia,
 c_torso, c_femur, c_tibia, g) = (p.symbol for p in PARAMETERS)  # fmt: skip

STANCE_TIBIA = Coordinate("theta_t", "stance tibia angle", "rad", reference="the vertical",
                          positive="the stance knee ahead of the stance foot")  # fmt: skip
STANCE_FEMUR = Coordinate("theta_f", "stance femur angle", "rad", reference="the vertical",
                          positive="the hip ahead of the stance knee")  # fmt: skip
TORSO = Coordinate("phi", "torso angle", "rad", reference="the vertical",
                   positive="the torso leaning forward of the hip")  # fmt: skip
SWING_FEMUR = Coordinate("psi_f", "swing femur angle", "rad", reference="the vertical",
                         positive="the hip ahead of the swing knee")  # fmt: skip
SWING_TIBIA = Coordinate("psi_t", "swing tibia angle", "rad", reference="the vertical",
                         positive="the swing knee ahead of the swing foot")  # fmt: skip
COORDINATES = (STANCE_TIBIA, STANCE_FEMUR, TORSO, SWING_FEMUR, SWING_TIBIA)
theta_t, theta_f, phi, psi_f, psi_t = (c.q for c in COORDINATES)


stance_knee = leg(theta_t, l_tibia)
hip = plus(stance_knee, leg(theta_f, l_femur))
swing_knee = minus(hip, leg(psi_f, l_femur))
swing_foot = minus(swing_knee, leg(psi_t, l_tibia))
head = plus(hip, leg(phi, l_torso))
# A link at angle a from the vertical (upper end ahead) is turned by -a counterclockwise.
BODIES = (
    RigidSegment("stance_tibia", m_tibia, minus(stance_knee, leg(theta_t, c_tibia)),
                 -theta_t, i_tibia),
    RigidSegment("stance_femur", m_femur, minus(hip, leg(theta_f, c_femur)), -theta_f,
                 i_femur),
    RigidSegment("torso", m_torso, plus(hip, leg(phi, c_torso)), -phi, i_torso),
    RigidSegment("swing_femur", m_femur, minus(hip, leg(psi_f, c_femur)), -psi_f, i_femur),
    RigidSegment("swing_tibia", m_tibia, minus(swing_knee, leg(psi_t, c_tibia)), -psi_t,
                 i_tibia),
)  # fmt: skip
SKELETON = Skeleton(
    points={"stance_foot": (0, 0), "stance_knee": stance_knee, "hip": hip, "head": head,
            "swing_knee": swing_knee, "swing_foot": swing_foot},
    segments=(("stance_foot", "stance_knee"), ("stance_knee", "hip"), ("hip", "head"),
              ("hip", "swing_knee"), ("swing_knee", "swing_foot")),
)  # fmt: skip

INPUTS = (
    Input("stance_hip", phi - theta_f, "stance_hip", unit="N m",
          description="torque between the torso and the stance femur, positive turning the "
          "torso forward of the femur"),
    Input("swing_hip", phi - psi_f, "swing_hip", unit="N m",
          description="torque between the torso and the swing femur, positive turning the "
          "swing femur forward (its reaction turns the torso back)"),
    Input("stance_knee", theta_t - theta_f, "stance_knee", unit="N m",
          description="torque between the stance femur and tibia, positive flexing the knee"),
    Input("swing_knee", psi_t - psi_f, "swing_knee", unit="N m",
          description="torque between the swing femur and tibia, positive flexing the knee"),
)  # fmt: skip

STANCE = Phase(
    "single_support",
    coordinates=COORDINATES,
    bodies=BODIES,
    gravity=(0, -g),
    points={"swing_foot": swing_foot},
    inputs=INPUTS,
)

hip_height = hip[1]
hip_speed = sum(sm.diff(hip[0], c.q) * c.u for c in COORDINATES)

MODEL = Model(
    name="rabbit",
    title="RABBIT",
    description="Chevallereau et al. 2003, Westervelt et al. 2007: the five-link planar biped "
    "RABBIT (torso, femurs, tibias; point feet), four actuators at hips and knees on level "
    "ground; no passive gait: it walks only powered",
    source="derive/models/rabbit.py",
    parameters=PARAMETERS,
    phases=(STANCE,),
    events=(
        Event(
            "heelstrike",
            "single_support",
            "single_support",
            guard=swing_foot[1],  # the swing foot's height
            direction=-1,
            reset=Impact(
                "swing_foot",
                {theta_t: psi_t, theta_f: psi_f, phi: phi, psi_f: theta_f, psi_t: theta_t},
                bodies={
                    "stance_tibia": "swing_tibia",
                    "stance_femur": "swing_femur",
                    "swing_femur": "stance_femur",
                    "swing_tibia": "stance_tibia",
                },
            ),
            ends_step=True,
            when=swing_foot[0],  # past mid-stance: the swing foot lands ahead of the stance foot
            equation="Westervelt et al. 2007's rigid impact with relabelling",
        ),
    ),
    failures=(
        Failure("fell-backward", hip_speed, -1, "the hip stops and moves back", unit="m/s"),
        Failure("fell-forward", hip_height, -1, "the hip reaches the ground", unit="m"),
        lift_off(),
    ),
    conditions=(swing_foot_clearance(swing_foot[1], "m"),),
    units=SI_UNITS,
    skeleton=SKELETON,
    step_length=swing_foot[0],
    # The gait search has nine free components (three points an axis): a box about the
    # book's gaits, a new stance leg ahead of the hip and the swing leg behind it.
    search={
        "theta_t": (-0.5, 0.0),
        "theta_f": (-0.5, 0.0),
        "phi": (-0.2, 0.4),
        "psi_f": (0.0, 0.5),
        "theta_t_dot": (0.0, 2.0),
        "theta_f_dot": (0.0, 2.0),
        "phi_dot": (-2.0, 2.0),
        "psi_f_dot": (-2.0, 2.0),
        "psi_t_dot": (-2.0, 2.0),
    },
    # Just after heelstrike the new swing foot (the old stance foot) is on the ground,
    # behind the hip: its tibia's angle follows from the others.
    section={
        "psi_t": sm.acos(sm.cos(theta_t) + l_femur / l_tibia * (sm.cos(theta_f) - sm.cos(psi_f)))
    },
    powered_only=True,
)


def derive() -> Derivation:
    return model_derivation(MODEL, SI_UNITS_TEXT)
