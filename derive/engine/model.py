"""The declarative description of a hybrid walking model: facts only, no machinery.

A model file builds one :class:`Model`: its parameter table, its generalised coordinates,
its phases (each a planar mechanical system of point masses and rigid segments pivoting
about the stance foot, with the coordinates its actuators hold), its events (a guard that
crosses zero and a reset: an inelastic impact, an instantaneous actuation, or none where
the actuators' program changes without a jump) and the
failures that end a walk. :mod:`derive.engine.hybrid` derives everything else: equations
of motion (with :mod:`sympy.physics.mechanics`), energies, ground reactions, the resets from
momentum balances, and, where the model allows, its stride map in closed form.

Conventions: planar, x along the ground (downhill on a slope) and y along its normal; each
phase's chart puts the stance foot at the origin; a leg at angle ``theta`` from the ground
normal (positive when the hip is ahead of the foot) points along ``(sin theta, cos theta)``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import sympy as sm

from derive.quantities import Parameter

__all__ = [
    "Condition",
    "Continuous",
    "Coordinate",
    "Event",
    "Failure",
    "Impact",
    "Impulse",
    "Input",
    "Jump",
    "Lock",
    "Model",
    "Parameter",
    "Phase",
    "PointMass",
    "RigidSegment",
    "Skeleton",
    "held_force",
    "leg",
]


def leg(angle: sm.Expr, length: sm.Expr = 1) -> tuple[sm.Expr, sm.Expr]:
    """Foot-to-hip vector of a straight leg at ``angle`` from the ground normal."""
    return (length * sm.sin(angle), length * sm.cos(angle))


@dataclass(frozen=True, eq=False)
class Coordinate:
    """A generalised coordinate; its rate is named ``<name>_dot`` in every model.

    Attributes
    ----------
    name : str
        Python identifier (``theta``).
    description : str
        What the coordinate is (``stance leg angle``).
    unit : str
        Unit of the coordinate (``rad``); the rate's is this per the model's time unit.
    reference : str
        What it is measured from: where it is zero (``the slope normal``).
    positive : str
        What a positive value means (``the hip downhill of the stance foot``).
    """

    name: str
    description: str = ""
    unit: str = "rad"
    reference: str = ""
    positive: str = ""

    @property
    def rate(self) -> str:
        """The rate's name: ``<name>_dot``, the one convention of every model."""
        return f"{self.name}_dot"

    @property
    def q(self) -> sm.Symbol:
        return sm.Symbol(self.name, real=True)

    @property
    def u(self) -> sm.Symbol:
        return sm.Symbol(self.rate, real=True)


@dataclass(frozen=True, eq=False)
class PointMass:
    """A point mass at ``position`` (x, y) in the phase's chart."""

    name: str
    mass: sm.Expr
    position: tuple[sm.Expr, sm.Expr]


@dataclass(frozen=True, eq=False)
class RigidSegment:
    """A rigid body in the plane: centre of mass, orientation angle and central inertia."""

    name: str
    mass: sm.Expr
    position: tuple[sm.Expr, sm.Expr]
    angle: sm.Expr
    inertia: sm.Expr


Body = PointMass | RigidSegment


@dataclass(frozen=True, eq=False)
class Skeleton:
    """What a drawing of the walker shows: named points of the chart and the segments
    between them (a thigh from ``hip`` to ``swing_knee``), stated once with the geometry
    the bodies are placed by, so a picture cannot drift from the mechanics.

    The points are expressions in the chart's coordinates (held ones included: each
    phase's held values are put in) and the parameters; the engine derives
    ``<phase>_skeleton``, their x and y in every phase. A model that states none is drawn
    from what it has: its stance foot, its body 0 as the hip and its step event's contact
    point as the swing foot. Names that begin with ``stance`` or ``swing`` say which leg a
    point is on (a drawing colours a leg by it).

    Attributes
    ----------
    points : mapping of str to (x, y)
        Python identifiers to positions in the chart.
    segments : tuple of (str, str)
        Pairs of point names, each drawn as a straight line.
    spokes : (str, str, sympy.Expr), optional
        A wheel: the segment from the first point to the second, turned about the first by
        every multiple of the angle (a function of the parameters) round the circle (the
        rimless wheel's spokes, whose count follows from a parameter).
    """

    points: Mapping[str, tuple[sm.Expr, sm.Expr]]
    segments: tuple[tuple[str, str], ...]
    spokes: tuple[str, str, sm.Expr] | None = None


@dataclass(frozen=True, eq=False)
class Input:
    """A continuous input of a phase: an actuator's generalised force ``u(t)`` that does
    the virtual work ``u * d(along)`` (the principle of virtual work gives its generalised
    force on each chart coordinate ``q``: ``u * d(along)/dq``).

    A hip torque between two legs acts along the angle between them (``along = theta -
    psi``); a force along a telescoping leg acts along the leg's length. ``along`` is in the
    phase's chart coordinates (free and held) and the parameters. The phase's accelerations
    stay its passive ones (every input zero); the engine derives each input's gain, the
    derivative of the accelerations by ``u`` (Lagrange's equations are linear in the
    generalised forces, so ``q'' = a(q, q') + B(q) u`` exactly), and the rate of ``along``,
    whose product with ``u`` is the input's power.

    Attributes
    ----------
    name : str
        Python identifier (``hip_torque``).
    along : sympy.Expr
        What the input does work along.
    actuator : str
        The actuator exerting it, by name (the ledger's and ``vsw models``' name).
    unit : str
        Unit of ``u`` (``N m``; in the model's units).
    bounds : (low, high)
        Bounds on ``u`` for an optimiser (``None``: unbounded that way).
    description : str
    """

    name: str
    along: sm.Expr
    actuator: str
    unit: str = ""
    bounds: tuple[float | None, float | None] = (None, None)
    description: str = ""


@dataclass(frozen=True, eq=False)
class Impulse:
    """An impulsive input at an event: an actuator's impulse ``iota`` that acts, in an
    instant, along ``along`` (a push-off along the trailing leg just before heelstrike, a
    leg's impulse along the new stance leg just after it).

    Integrated over the instant, Lagrange's equations give the rates' change
    ``M dq' = iota d(along)/dq``: the same gain on the rates as a continuous :class:`Input`
    along ``along`` has on the accelerations, and the configuration does not move. Its work
    is ``iota`` times the mean of ``along``'s rate just before and just after it (the
    kinetic energy's change, exactly: ``M`` does not change in the instant).

    Attributes
    ----------
    name : str
        Python identifier (``push_off``).
    along : sympy.Expr
        What the impulse acts along, in the chart of the event's source phase (``after``
        false: applied just before the reset) or of its target phase (``after`` true: just
        after it), and the parameters.
    actuator : str
        The actuator delivering it, by name.
    after : bool
        Applied after the event's reset, in the target phase's chart.
    at_impact : bool
        Applied with the event's impact, along a coordinate the source phase holds
        (``along`` that symbol: a rigid leg's length): the push-off of a trailing leg whose
        foot the impact releases, which a chart that holds the leg cannot take before the
        reset (Kuo's simplest walking model). Over the instant the coordinate is free; the
        engine takes the impact's balance with the velocities the impulse gives
        (:func:`derive.engine.hybrid.held_impulse_at_impact`); its work is
        ``c iota^2 / 2``. One such impulse an event.
    unit : str
        Unit of ``iota`` (``N s``; in the model's units).
    bounds : (low, high)
        Bounds on ``iota`` for an optimiser (a leg that can push only: ``(0, None)``).
    description : str
    """

    name: str
    along: sm.Expr
    actuator: str
    after: bool = False
    unit: str = ""
    bounds: tuple[float | None, float | None] = (None, None)
    description: str = ""
    at_impact: bool = False


@dataclass(frozen=True, eq=False)
class Phase:
    """One continuous phase: the stance foot pinned at the origin of its chart.

    Attributes
    ----------
    name : str
    coordinates : tuple of Coordinate
        The free coordinates: no actuator holds them (an :class:`Input` may act on them).
    bodies : tuple of PointMass or RigidSegment
    gravity : (gx, gy)
        Gravity in the chart's axes (``(g sin gamma, -g cos gamma)`` on a slope gamma).
    held : mapping of sympy.Symbol to sympy.Expr
        Coordinates an actuator holds at a value (a constant, or a function of the free
        coordinates); the actuator's force acts on them alone, so the equations of motion
        are the free coordinates' rows of Lagrange's equations in the chart of all of them.
        That is a fact about the chart, so choose it to make it true: a locked knee is held
        by a torque between thigh and shank, which acts on the knee's relative angle alone,
        not on the shank's absolute angle. A coordinate free in another phase and held here
        stays in the state (the state is every phase's free coordinates): here it moves
        with its held value.
    points : mapping of str to (x, y)
        Named points of the chart that guards and impacts refer to (a swing foot).
    inputs : tuple of Input
        Continuous inputs an optimiser or a controller may apply (a hip torque): zero in
        the passive dynamics, which is what every command but the powered-walking ones
        simulates.
    skeleton : Skeleton, optional
        The drawing in this phase's chart, where it differs from the model's.
    """

    name: str
    coordinates: tuple[Coordinate, ...]
    bodies: tuple[Body, ...]
    gravity: tuple[sm.Expr, sm.Expr]
    held: Mapping[sm.Symbol, sm.Expr] = field(default_factory=dict)
    points: Mapping[str, tuple[sm.Expr, sm.Expr]] = field(default_factory=dict)
    inputs: tuple[Input, ...] = ()
    skeleton: Skeleton | None = None


@dataclass(frozen=True, eq=False)
class Impact:
    """An inelastic impact: the point ``new_contact`` sticks, the stance foot leaves.

    The configuration does not change: ``coordinates`` gives each coordinate of the phase
    after in terms of the phase before (a fact of geometry, which the engine checks by the
    bodies' positions). The velocities after follow from the momentum balance: the
    impulse at the new contact does no work on any motion the phase after allows.
    """

    new_contact: str
    coordinates: Mapping[sm.Symbol, sm.Expr]
    bodies: Mapping[str, str] = field(default_factory=dict)
    """Bodies whose role changes (the legs swap): the phase after's body name -> the phase
    before's body it is. A body not named here keeps its name."""
    holding: Mapping[sm.Symbol, sm.Expr] = field(default_factory=dict)
    """Free coordinates of the phase after that a lock still holds through the impact, at
    these constant values (a knee that is straight at heelstrike and released just after):
    their rates after are zero and the lock's impulse acts on them alone, so the balance
    is taken over the phase after's other coordinates."""


@dataclass(frozen=True, eq=False)
class ParameterCondition:
    """The parameters are valid only where ``expression`` > 0 (``strict``) or >= 0: a
    condition between parameters (a step shorter than the legs can reach), which no one
    parameter's range states."""

    expression: sm.Expr
    reason: str
    strict: bool = True


@dataclass(frozen=True, eq=False)
class Jump:
    """An instantaneous actuation: the held coordinates jump to the phase after's values.

    The actuator's impulse acts on the held coordinates alone, so the generalised momentum
    of every free coordinate is conserved across the jump (M(q+) q'+ = M(q-) q'- in those
    rows).

    Where the free coordinates are at the jump depends on ``limit``:

    * ``False``: they do not move. Exact where no free coordinate's momentum has a held
      rate in it (``M_qh = 0``: the ILE's point mass on its leg); otherwise an idealisation
      the model must state, since moving a held coordinate fast drags the free ones.
    * ``True``: the jump is the limit of the held coordinate moving ever faster along its
      one path: with ``p_q = M_qq q' + M_qh h'`` bounded and ``h'`` growing as 1 / eps, the
      free coordinates turn by ``-integral of M_qq^-1 M_qh dh`` (a geometric phase, as a
      falling cat turns). The limit exists when the kinetic energy does not depend on the
      free coordinates (then nothing else grows with 1 / eps); the engine requires that and
      one held coordinate that changes.
    """

    limit: bool = False


@dataclass(frozen=True, eq=False)
class Lock:
    """A plastic impact inside the walker: a joint reaches its stop and locks (a knee
    straightening), so the coordinates the phase after holds stop dead.

    The lock's impulse acts on the held coordinates alone (a relative joint angle; see
    :attr:`Phase.held`) and the stance foot stays pinned, so the generalised momentum of
    every free coordinate of the phase after is conserved; the configuration does not
    change, which is true on the guard's surface (where the held coordinates are at the
    phase after's values: the engine checks it there).
    """


@dataclass(frozen=True, eq=False)
class Continuous:
    """A change of phase that leaves the state as it is: only the actuators' program changes.

    Between two phases whose held coordinates agree, in value and rate, where the event
    happens (a prescribed leg-length profile that starts or ends there), nothing jumps.
    The engine checks that agreement at the event's ``at``, which it therefore requires;
    a :class:`Jump` there would conserve the momenta and so reset nothing either.
    """


@dataclass(frozen=True, eq=False)
class Event:
    """A transition: when ``guard`` crosses zero in ``direction`` (+1 rising, -1 falling),
    the state is reset and the phase ``target`` begins.

    Attributes
    ----------
    name, source, target : str
    guard : sympy.Expr
        In the source phase's coordinates, rates and the parameters.
    direction : int
    reset : Impact, Jump, Lock or Continuous
    at : sympy.Expr, optional
        The coordinate value at which the guard vanishes, when it depends on the
        configuration only (a fact the engine checks); needed for a closed-form stride map.
    ends_step : bool
        The Poincaré section: a step ends with this event.
    when : sympy.Expr, optional
        The guard counts only where this is positive (for example past mid-stance, where
        a swing foot scuffs the ground and the model ignores it).
    equation : str, optional
        The paper's equation number of the reset.
    impulses : tuple of Impulse
        Impulsive inputs an optimiser may apply at the event (zero in the passive walk):
        those with ``after`` false just before the reset, the others just after it.
    """

    name: str
    source: str
    target: str
    guard: sm.Expr
    direction: int
    reset: Impact | Jump | Lock | Continuous
    at: sm.Expr | None = None
    ends_step: bool = False
    when: sm.Expr | None = None
    equation: str | None = None
    impulses: tuple[Impulse, ...] = ()


@dataclass(frozen=True, eq=False)
class Failure:
    """A walk ends when ``guard`` crosses zero in ``direction`` during any phase (or
    those of ``phases``), or when a phase begins with it already past zero.

    ``guard`` may use the phase's ground reaction ``N`` (:data:`NORMAL_FORCE`) and the
    state; ``name`` is what the simulation reports (``fell-backward``, ``lift-off``).
    """

    name: str
    guard: sm.Expr
    direction: int
    meaning: str = ""
    unit: str | None = None
    """Unit of the guard, where the engine cannot tell it: a guard that is the ground
    reaction is in the model's force unit, a rate in its coordinate's unit per time, and
    anything else is taken as dimensionless unless stated here."""
    phases: tuple[str, ...] = ()
    """The phases it is checked in (all when empty)."""
    at_start: bool = False
    """Checked only where a phase begins, not watched through it: a phase that must begin
    before its event's configuration (the VSW biped's extension at theta_II), whose guard
    is the event's own and reaches zero at the phase's end by design."""


NORMAL_FORCE = sm.Symbol("N_ground", real=True)
"""Stands for the normal ground reaction on the stance foot in a Failure guard."""


def held_force(coordinate: Coordinate | sm.Symbol) -> sm.Symbol:
    """Stands, in a Failure or Condition guard, for the generalised force that holds
    ``coordinate`` (the torque of a knee's lock, the force of a leg's actuator): in every
    phase the guard is evaluated in, that phase must hold it."""
    return sm.Symbol(f"Q_held_{coordinate.name}", real=True)


@dataclass(frozen=True, eq=False)
class Condition:
    """A condition the model assumes and reports but does not enforce: along a gait, the
    margin ``-direction * guard`` (its least over a step) says whether it holds. A walk
    goes on when it fails (that is the difference from a :class:`Failure`): the stance
    knee's lock that must pull, where the model assumes a latch that can.

    ``guard`` may use the ground reaction (:data:`NORMAL_FORCE`), the generalised force of
    a held coordinate (:func:`held_force`) and the state; ``unit`` is its unit. With
    ``interior`` the least is taken between the guard's first rise and its last fall over
    the step (its first and last instants left out, then the run over which it first rises
    and the one over which it last falls: ``vsw.dynamics.conditions._least_inside``): for a quantity
    the step's events put at or near zero at its ends, the swing foot's height, whose
    margin is then its lowest dip between lift and landing (its peak if it has none).
    """

    name: str
    guard: sm.Expr
    direction: int
    meaning: str = ""
    unit: str | None = None
    interior: bool = False


def swing_foot_clearance(height: sm.Expr, unit: str) -> Condition:
    """The swing foot's clearance, reported and not enforced (the walkers' sources ignore
    scuffing): ``height`` is the swing foot's height above the ground, its margin the
    lowest dip between the foot's lift and its landing (``interior``)."""
    return Condition(
        "swing-foot-clearance",
        height,
        -1,
        "the swing foot stays above the ground (where negative it scuffs: ignored)",
        unit=unit,
        interior=True,
    )


@dataclass(frozen=True, eq=False)
class Model:
    """A hybrid walking model.

    Attributes
    ----------
    name : str
        Python identifier; ``generated/<name>/`` and the CLI's ``--model`` (with ``-``
        for ``_``).
    title, description : str
    source : str
        The model file (goes into generated headers).
    parameters : tuple of Parameter
    phases : tuple of Phase
        In the order a step visits them; the first starts after the step's event.
    events : tuple of Event
    failures : tuple of Failure
    conditions : tuple of Condition
        What the model assumes and reports along a gait without ending a walk.
    units : mapping of str to str
        ``time``, ``length``, ``mass``, ``energy``, ``force``: the units the model's
        quantities are in (``force``: the ground reaction's).
    step_length : sympy.Expr, optional
        Distance from one stance foot to the next (in the state just before the step
        event), when the model defines it.
    search : mapping of str to (low, high)
        Where the search for gaits looks: an interval for each component of the section
        state (just after the step event) that the section does not determine. Gaits
        outside this box are not looked for; ``vsw analyze`` states it.
    section : mapping of str to sympy.Expr
        The section (states just after the step event) as the model defines it: each
        coordinate or rate named here follows from the others there (the event's geometry
        and its reset), e.g. ``{"phi": 2 * theta}``. The search for gaits and basins over
        a slice of the section take these from the free components
        (``section_completion``); tests check them on simulated steps.
    actuators : mapping of sympy.Symbol to str
        Who holds each held coordinate, by name: the stance leg's force on its length
        ``r`` ("leg"), the hip's torque on the inter-leg angle ("hip"). The ledger and
        ``vsw models`` name an actuator's work by it (an actuator not named here is called
        after its coordinate); a coordinate a :class:`Lock` stops and that is named here is
        caught by that actuator (the lock's loss is its negative work: the ledger counts it
        as the lock's loss, naming the actuator, not in the actuator's total), one not named
        is stopped by the mechanism (a knee's latch). Names are distinct.
    limits : mapping of sympy.Symbol to sympy.Expr
        Symbols of the mechanics (not parameters) that every derived quantity is taken to
        the limit of: a walker with massless feet states each foot with a mass ``epsilon``
        and ``{epsilon: 0}``, because the equations with the mass exactly zero are singular
        (the swing leg's row vanishes) while their limit is not.
    """

    name: str
    title: str
    description: str
    source: str
    parameters: tuple[Parameter, ...]
    phases: tuple[Phase, ...]
    events: tuple[Event, ...]
    failures: tuple[Failure, ...] = ()
    conditions: tuple[Condition, ...] = ()
    units: Mapping[str, str] = field(default_factory=dict)
    step_length: sm.Expr | None = None
    search: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    limits: Mapping[sm.Symbol, sm.Expr] = field(default_factory=dict)
    section: Mapping[str, sm.Expr] = field(default_factory=dict)
    actuators: Mapping[sm.Symbol, str] = field(default_factory=dict)
    powered_only: bool = False
    """The walker has no passive gait: its inputs hold it up (a point mass on telescoping
    legs falls without its leg force). The commands that follow a passive gait say so and
    name ``vsw optimize``."""
    parameter_conditions: tuple[ParameterCondition, ...] = ()
    """Conditions on several parameters at once (each parameter's own range is its row's):
    a parameter set that breaks one is refused in one line with its reason."""
    chosen_parameters: tuple[str, ...] = ()
    """Parameters of the gait rather than of the body, by name: ``vsw optimize`` chooses
    them with the gait (the given value is its start), as it chooses the inputs. An angle
    at which an impulse acts (an event's guard ``theta - theta_push``) makes that
    impulse's time free: the optimum's value is reported with it."""
    skeleton: Skeleton | None = None
    """How the walker is drawn (:class:`Skeleton`), in the chart every phase shares; a
    phase's own ``skeleton`` replaces it there. None: the engine's stick figure from the
    stance foot, body 0 and the step event's contact point."""

    def phase(self, name: str) -> Phase:
        for p in self.phases:
            if p.name == name:
                return p
        raise KeyError(name)

    @property
    def coordinates(self) -> tuple[Coordinate, ...]:
        """The state's coordinates: every phase's free coordinates, in the order the
        phases first name them. A phase that holds one of them (a locked knee) carries it
        at its held value, so the state has one layout over a whole walk."""
        seen: dict[str, Coordinate] = {}
        for phase in self.phases:
            for c in phase.coordinates:
                seen.setdefault(c.name, c)
        return tuple(seen.values())

    @property
    def parameter_symbols(self) -> tuple[sm.Symbol, ...]:
        return tuple(p.symbol for p in self.parameters)
