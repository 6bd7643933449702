"""What a design asks for and what it gives: :class:`DesignRequest`, :class:`GaitDesign`,
the transcription's and the verification's constants, and the distance kept from a
parameter's open limit."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from vsw.dynamics.hybrid import Orbit
from vsw.dynamics.quantities import QUANTITIES

__all__ = [
    "DESIGN_QUANTITIES",
    "MAXIMISED",
    "MINIMISED",
    "SEGMENTS",
    "STATUSES",
    "DesignRequest",
    "GaitDesign",
    "open_distance",
    "range_text",
]


DEGREE = 3
"""Collocation points per interval of the collocated NLP: Gauss-Legendre, of order 6."""

INTERVALS = 6
"""Collocation intervals per phase."""

SEGMENTS = 4
"""Shooting segments per phase of the polishing NLP."""

INTEGRATOR_TOL = 1e-10
"""CVODES' relative and absolute tolerance inside the NLP (the verification re-solves the
orbit at 1e-13)."""

STRICT_MARGIN = 1e-4
"""A condition that must hold strictly (a failure's margin > 0) is imposed as
``margin >= STRICT_MARGIN`` in the failure guard's unit."""

CLOSED_FAILURES = ("lift-off",)
"""Failures whose margin may reach zero: a normal force of exactly zero keeps the foot on
the ground. Imposed as ``>= CLOSED_MARGIN`` (the ILE's closed forms keep 1e-9; here the
nodes are integrated to 1e-10 and the verifying orbit is re-solved at 1e-13, so a margin
of 1e-9 can turn negative between the two)."""

CLOSED_MARGIN = 1e-7

MIN_DURATION = 1e-6
"""Lower bound of a phase duration (time units): a phase of zero length is no phase."""

MAX_ITERATIONS = 60
"""IPOPT's iterations per solve, in either NLP: the starts that converge take 5-55; one
that runs longer has wandered into a region of no gait."""

TARGET_TOL = 1e-6
"""Relative tolerance of a target on the verified gait."""

STATUSES = ("optimal", "not-attained", "infeasible", "not-converged")

MAXIMISED = tuple(q.name for q in QUANTITIES.values()
                  if "design" in q.commands and q.sense == "max")  # fmt: skip
MINIMISED = tuple(q.name for q in QUANTITIES.values()
                  if "design" in q.commands and q.sense == "min")  # fmt: skip
"""The objectives of a design (:mod:`vsw.dynamics.quantities`), by their sense."""
DESIGN_QUANTITIES = ("speed", "step_length", "step_frequency", "period")
"""Quantities a target or a bound may name (each in the model's units)."""


def open_distance(p: Any) -> float:
    """How far the design keeps from an open limit of parameter ``p``'s interval:
    1e-3 of the interval's width or of the default's magnitude, whichever is smaller (so
    a slope of 0.009 rad keeps 9e-6 from 0, a ratio in (0, 1) 1e-3 from its ends)."""
    width = p.upper - p.lower
    size = abs(p.default) if p.default else 1.0
    return 1e-3 * min(width, size)


@dataclass(frozen=True)
class DesignRequest:
    """What a design asks for, in the model's units (angles in rad).

    ``objective``: term -> weight of the sum minimised, each term signed by its sense
    (:data:`MAXIMISED` terms enter as ``-weight * value``). ``targets``: quantity ->
    value (equalities). ``fixed``: parameter -> value. ``bounds``: parameter or quantity
    -> (lower, upper), either None. ``max_eigenvalue``: the bound on max |λ|.
    ``min_margin``: every condition's margin at least this (in its unit; >= the strict
    margin). ``starts``: how many of the gaits found at the start are tried. ``start``:
    free parameter -> the value its search for starting gaits begins at (else its default,
    or its box's middle where the default lies outside the box): a design whose targets are
    far from the defaults' gaits is started near them.
    """

    objective: Mapping[str, float] = field(default_factory=dict)
    targets: Mapping[str, float] = field(default_factory=dict)
    fixed: Mapping[str, float] = field(default_factory=dict)
    bounds: Mapping[str, tuple[float | None, float | None]] = field(default_factory=dict)
    max_eigenvalue: float | None = None
    min_margin: float = 0.0
    starts: int = 4
    start: Mapping[str, float] = field(default_factory=dict)


@dataclass
class GaitDesign:
    """The outcome of :func:`design`; ``orbit`` and ``parameters`` only for a design."""

    status: str
    message: str
    parameters: dict[str, float] | None = None
    orbit: Orbit | None = None
    quantities: dict[str, float | None] = field(default_factory=dict)
    margins: list[dict[str, Any]] = field(default_factory=list)
    objective: float | None = None
    active_constraints: tuple[str, ...] = ()
    open_limits: tuple[str, ...] = ()
    ipopt_status: str = ""
    starts: int = 0
    simulation_rel_error: float | None = None  # of one simulated step from the gait's state
    infeasible_reason: str | None = None

    @property
    def found(self) -> bool:
        return self.status in ("optimal", "not-attained")

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"status": self.status, "message": self.message}
        if self.found:
            out["parameters"] = dict(self.parameters or {})
            out["gait"] = self.orbit.to_dict() if self.orbit is not None else None
            out["quantities"] = dict(self.quantities)
            out["conditions"] = list(self.margins)
            out["objective"] = self.objective
            out["active_constraints"] = list(self.active_constraints)
            out["open_limits"] = list(self.open_limits)
            out["simulation_rel_error"] = self.simulation_rel_error
        if self.infeasible_reason is not None:
            out["infeasible_reason"] = self.infeasible_reason
        out["ipopt_status"] = self.ipopt_status
        out["starts"] = self.starts
        out["transcription"] = (
            f"from each start Gauss-Legendre collocation ({DEGREE} points, {INTERVALS} "
            "intervals per phase; IPOPT with exact second derivatives), each distinct "
            "optimum carried onto the orbit solver's gait: at a vertex by Newton on its "
            "active constraints, else polished by multiple shooting "
            f"({SEGMENTS} segments per phase, CVODES {INTEGRATOR_TOL:g}; IPOPT with exact "
            "first derivatives and a limited-memory Hessian); stability by the Jury "
            "inequalities of the monodromy matrix's characteristic polynomial"
        )
        return out


def range_text(low: float | None, high: float | None) -> str:
    """A bound as the user writes it, ``low:high`` (a side left empty where open)."""
    return f"{'' if low is None else f'{low:g}'}:{'' if high is None else f'{high:g}'}"
