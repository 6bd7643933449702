"""Constrained design of ILE gait parameters with CasADi and IPOPT.

The inverse question of :mod:`vsw.models.ile.analysis`: which (beta, theta_II, phi0) give the gait a
user wants within what the robot can do. The NLP is built from the generated closed forms
(``generated.ile`` accepts CasADi SX), so every function and derivative is exact:

* objective: a weighted sum of ``-speed``, ``eigenvalue`` (eq. 19) and the cost of
  transport ``E_c(q^f) / (m g L)`` (eq. 20 per unit step length);
* equality targets: speed, q^f, step length, step frequency;
* inequalities: every *physical* existence condition in its exact form, the stance contact
  margin ``>= max(0, min_contact_margin)``, an eigenvalue upper bound, step length and step
  frequency bounds, bounds / fixed values of the decision variables; with
  ``conditions="paper"`` also (15) and (17) as the paper prints them.

Why the problem is split into regions
-------------------------------------
The exact apex margin (14) and the stance-contact margin are minima over the two swing
phases, each at the point of the phase nearest the apex, chosen by the signs of theta_I and
theta_II: they have kinks, and IPOPT, which needs twice-differentiable functions, stalls at
them (the failures of the first version of this module: 0 of 30 random feasible requests
converged). The derivation hands out the smooth pieces (``ile.condition_pieces``):

* the stance contact is exactly "N >= margin at instants I, II and IV" (N is convex in
  cos theta and rises towards the apex wherever N >= 0), three smooth rows everywhere;
* the apex margin is one smooth piece in each of three regions of the parameter space:
  theta_II <= 0 (the apex is crossed in phase III-IV), theta_I <= 0 <= theta_II (in phase
  I-II) and theta_I >= 0 (never crossed: q^f > 0 suffices).

Each region is a smooth NLP; a request is solved in every region that a scan finds
promising and the best verified solution wins.

Starts and verification
-----------------------
A deterministic low-discrepancy scan of the box (Halton points, the generated numpy code)
gives each region its best feasible points for the objective and its least-violating one;
IPOPT starts there. A solution counts only when IPOPT reports success *and* a numpy
re-evaluation of the closed forms confirms every constraint, with every physical condition
in its exact strict form; the design is then re-checked by the independent time-domain
simulation (:mod:`vsw.models.ile.simulate`).

Statuses
--------
``optimal``: a verified local optimum, the best over the regions and starts, that keeps
away from every open limit. ``not-attained``: the best design presses against an open
boundary (a strict condition, an open parameter limit such as beta < 1): the supremum or
infimum is a limit the model never reaches; the design is re-solved ever closer to it
(distances scaled by :data:`CONTINUATION`) to estimate the limiting value.
``infeasible``: neither the scan nor any solve found a point satisfying the constraints
(the constraints in conflict are named). ``not-converged``: the scan found feasible
points but no solve converged to a verified design.

``import vsw.models.ile.design`` is cheap: casadi is imported inside functions.

The package, by job: :mod:`~vsw.models.ile.design.forms` (the closed-form quantities,
constants and regions), :mod:`~vsw.models.ile.design.problem` (the request checked, its
bounds and rows), :mod:`~vsw.models.ile.design.nlp` (solvers, scan, seeds, solves,
multistart), :mod:`~vsw.models.ile.design.limit` (the limit of a not-attained optimum),
:mod:`~vsw.models.ile.design.result` (the result) and :mod:`~vsw.models.ile.design.solve`
(:func:`design`).
"""

from vsw.models.ile.design.forms import (
    CLOSED_MARGIN,
    CONDITION_SETS,
    CONTINUATION,
    OBJECTIVES,
    STATUSES,
    STRICT_MARGIN,
    TABLE_DISTANCE,
)
from vsw.models.ile.design.limit import Limit
from vsw.models.ile.design.problem import finite
from vsw.models.ile.design.result import DesignResult, simulation_check
from vsw.models.ile.design.solve import design

__all__ = [
    "CLOSED_MARGIN",
    "CONDITION_SETS",
    "CONTINUATION",
    "OBJECTIVES",
    "STATUSES",
    "STRICT_MARGIN",
    "TABLE_DISTANCE",
    "DesignResult",
    "Limit",
    "design",
    "finite",
    "simulation_check",
]
