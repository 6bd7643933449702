"""Gait design for every model: IPOPT on the periodic orbit itself.

The question of :mod:`vsw.models.ile.design` (which parameters give the gait a user wants)
for any model of the generic runtime, whose gaits have no closed form. The gait is part of
the unknowns of one nonlinear program, solved by IPOPT through CasADi:

Transcriptions: collocation, then multiple shooting
---------------------------------------------------
The unknowns are the free parameters, the gait's states and each phase's duration ``T_k``
(an unknown, > 0); the constraints are the dynamics, each phase's event guard at its end
(= 0) and the event's ``when`` (>= 0: the crossing counts), the resets between phases and
periodicity (the state after the step event equals the first). Two NLPs share them
(:mod:`~vsw.synthesis.design.nlp`):

* collocation (:mod:`~vsw.synthesis.design.collocation`): each phase cut into
  :data:`INTERVALS` intervals of Gauss-Legendre collocation (:data:`DEGREE` points, order
  6), the state at every knot and stage an unknown; the NLP is expanded to CasADi SX, so
  IPOPT has exact second derivatives at a few milliseconds an iteration. IPOPT runs from
  every start here.
* multiple shooting (:mod:`~vsw.synthesis.design.shooting`): each phase cut into
  :data:`SEGMENTS` segments integrated by CVODES (tolerance 1e-10) with exact first
  derivatives (forward sensitivities) and IPOPT's limited-memory Hessian. Each distinct
  collocated optimum the periodic-orbit solver confirms as a gait and that is no vertex
  (below) is polished here, from that gait, so the design is the runtime's gait without
  a mesh's error: a gait's eigenvalue can move two hundred times faster than its period as
  a parameter changes (the compass gait's slope near a period of 0.75 s), so the
  collocation's error of about 2e-7 in the period would show in the design. Where no
  polished optimum is verified, the starts themselves are shot.
* a vertex (:mod:`~vsw.synthesis.design.pin`): where the collocated optimum's active
  constraints are as many as its free parameters (the period's target of one free slope;
  the eigenvalue bound of the fastest gait), they alone fix it: Newton solves them again
  on the periodic-orbit solver's gait, with no shooting NLP to build or solve; its last
  solve, confirmed by a simulated step, is the gait (no second orbit solve).

Conditions: each failure of a phase (falling back, falling forward, the stance foot lifting
off, ...) as ``-direction * guard >= margin`` at every node and at each phase's end;
between nodes the verifying simulation checks them
(:func:`vsw.dynamics.conditions.gait_conditions`).

Stability without a non-smooth spectral radius
----------------------------------------------
The monodromy matrix ``M`` (the Poincaré map's Jacobian) is built in the NLP from the
variational equations (integrated beside the state, so their derivatives need only first
sensitivities; in the collocated NLP collocated beside it, which is the exact derivative of
its discrete map), each phase's saltation at its guard and the reset's Jacobian. ``max |λ|``
is not differentiable where two eigenvalues meet; instead "every eigenvalue lies in the
disc of radius ρ" is imposed as the Jury (Schur–Cohn) inequalities on the characteristic
polynomial of ``M / ρ``, polynomials in its coefficients (Newton's identities on traces of
powers of ``M``) and so smooth everywhere. ``--max-eigenvalue E`` fixes ``ρ = E``;
``--minimize eigenvalue`` makes ``ρ`` an unknown and minimises it (the epigraph form: at the
optimum the inequality of the eigenvalue(s) of largest modulus is active, whichever they
are). The polynomial keeps the model's nontrivial eigenvalues only: a reset onto a lower
dimensional set makes ``M`` singular (the simplest walker's 4x4 map has rank 2), its
structural zero eigenvalues would only scale the Jury rows badly. The count is the largest
over the starts' gaits (eigenvalues above 1e-7 of the largest).

Starts, verification and statuses
---------------------------------
The starts are the gaits the runtime's gait search finds at the parameters the request
starts from (defaults, fixes, clipped into the bounds). A solve counts only when IPOPT
reports success and the periodic-orbit solver, from IPOPT's point, confirms the gait by
simulation and every request holds on it: targets, bounds, the eigenvalue bound, every
condition's margin along the simulated step. The best verified solve wins; the step is
simulated for the best vertex first, and for the next only where a condition fails on it
(those after it cannot win). ``optimal``: a
verified local optimum away from every open limit. ``not-attained``: it presses against an
open limit (a parameter's open interval, kept :func:`open_distance` away, or a strict
condition margin, kept :data:`STRICT_MARGIN` above zero): the model's supremum is not a
gait. ``infeasible``: a target outside the range the same starts reach (the extreme of that
quantity designed under the other constraints), said with the extreme; ``not-converged``:
no verified design and no such proof.

The package, by job: :mod:`~vsw.synthesis.design.request` (the request, the result, the constants),
:mod:`~vsw.synthesis.design.problem` (a request checked against a model),
:mod:`~vsw.synthesis.design.nlp` (what the two NLPs share),
:mod:`~vsw.synthesis.design.collocation` (the collocated NLP, on the scheme of
:mod:`vsw.orbits.collocation`), :mod:`~vsw.synthesis.design.shooting` (the NLP on the
shooting flows of :mod:`vsw.orbits.shooting`), :mod:`~vsw.synthesis.design.pin` (a vertex
solved on the orbit solver's gait) and
:mod:`~vsw.synthesis.design.solve` (the starts, the solves, their verification and the status:
:func:`design`).
"""

from vsw.synthesis.design.request import (
    DEGREE,
    DESIGN_QUANTITIES,
    INTERVALS,
    MAXIMISED,
    MINIMISED,
    SEGMENTS,
    STATUSES,
    DesignRequest,
    GaitDesign,
    open_distance,
)
from vsw.synthesis.design.solve import design

__all__ = [
    "DEGREE",
    "DESIGN_QUANTITIES",
    "INTERVALS",
    "MAXIMISED",
    "MINIMISED",
    "SEGMENTS",
    "STATUSES",
    "DesignRequest",
    "GaitDesign",
    "design",
    "open_distance",
]
