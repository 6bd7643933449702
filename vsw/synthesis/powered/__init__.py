"""Powered gaits: periodic gaits with the model's inputs, optimal for a cost, by direct
collocation (IPOPT through CasADi).

A model's phases may declare continuous inputs (``Input`` in the model language: a hip
torque, a leg force), whose gains on the accelerations the derivation generates
(``<phase>_input_gains``): ``q'' = a(q, q') + B(q) u``; its events may declare impulses
(``Impulse``: a push-off), whose gains on the rates it generates too
(``event_<e>_impulse_gains_before/after``, and ``_with`` for one applied with an impact
along a held coordinate: a rigid leg's push-off). This module finds the step, with its inputs and
impulses, that meets the targets (speed, step length) at the least cost.

Transcription: Hermite–Simpson, separated form
----------------------------------------------
Each phase of a step is cut into :attr:`Request.nodes` intervals of equal length
``h = T_k / N`` (``T_k`` the phase's duration, an unknown > 0). The unknowns are the state
and the inputs at every knot and every interval's midpoint, the durations and each event's
impulses. Per interval ``[x_i, x_{i+1}]`` with midpoint ``x_c``:
``x_c = (x_i + x_{i+1}) / 2 + h / 8 (f_i - f_{i+1})`` and
``x_{i+1} = x_i + h / 6 (f_i + 4 f_c + f_{i+1})`` (Simpson's rule on a cubic state: the
scheme is fourth order); the inputs are quadratic on each interval through ``u_i``, ``u_c``,
``u_{i+1}`` (what the re-simulation interpolates; under the work costs the midpoint is tied
to its knots' mean, so the inputs are linear: see :func:`vsw.synthesis.powered.problem._collocate`).
Each phase ends on its event's guard (= 0, its ``when`` >= 0), the event's impulses
before its reset, the reset with the impulse at its impact and its impulses after map the
last knot to the next
phase's first, and the step is
periodic. Every failure of a phase is a path constraint at the knots, with
the inputs' share of its guard (``<guard>_input_gains``: the ground reaction moves with
them). The model's parameters are fixed, but for those it names as the gait's own
(``chosen_parameters``: an angle at which an impulse acts), which are unknowns too.

Costs (per step): ``torque2``, the integral of the squared inputs; ``work``, the inputs'
positive work, the integral of ``max(P, 0)`` of each input's power ``P = u d(along)/dt``,
without smoothing, priced from above on each interval: where the input's rate is linear
in the state (a leg's length rate, a hip's angle rate) ``P`` there is a quartic (a linear
input times that rate of the scheme's cubic state), fixed by five samples (knots, quarter
points, midpoint: :data:`SAMPLES`), and the cost prices a quartic slack ``s >= 0, s >=
P`` by its Bernstein coefficients ``c_j >= 0, c_j >= b_j(P)`` (which make it so on the
whole interval), at their mean (its integral); where the rate is not linear (the
point-mass biped's leg in Cartesian coordinates) the bound is on the quartic through the
samples, to that interpolation's error. Samples alone (the epigraph at knots and
midpoints, used before) let the optimum hide a power that changes sign between them: a
landing absorbed by a leg force and pushed back within one interval, positive work the
mesh did not count and no refinement removed. The bound is tight where the power keeps
its sign and its Bernstein coefficients theirs; elsewhere it exceeds ``max(P, 0)``'s
integral by a small multiple of ``h max |P|`` on the interval, which vanishes as the mesh
refines (a power that wiggles about zero on a held coordinate, by O(h^3)). The ledger
(the work reported) is composite Simpson of ``max(P, 0)`` and ``min(P, 0)`` on the five
samples. ``cost_of_transport``, that work over weight times step length; impulses count by
their positive work (each applied in two parts whose split is free, each part priced by slacks
at its power's ends: exact where the split stops a reversing rate, see
:func:`~vsw.synthesis.powered.events.event_map`; ``c iota^2 / 2`` for one at an impact; ``torque2``
holds them at zero: it does not price them). ``eigenvalue``: the spectral radius of the
open-loop step map (:func:`vsw.orbits.collocation.sensitivity`,
:func:`~vsw.synthesis.powered.events.event_jacobian`,
:func:`~vsw.synthesis.powered.objectives.stability_rows`; impulses held at zero, as ``torque2``
holds them). The last three add
:attr:`Request.regularization` times the squared inputs' integral, made dimensionless.
The squared inputs' integral by Simpson's rule on the knots and midpoints. ``work``,
``cost_of_transport`` and ``eigenvalue`` start from the ``torque2`` optimum with the same
targets.

Verification: the problem is solved on N and on 2N intervals a phase (the finer from the
coarser optimum) and the cost's change between them reported; each phase is integrated
again from its first knot with the inputs as the scheme interpolates them (SciPy DOP853,
1e-11; its event's guard and its failures watched between the knots), and its end
compared with the last knot (``resimulation_error``, relative to max(1, |state|)).
``optimal`` needs all of it (:func:`optimize`). The start is the model's passive gait at
the same parameters, inputs zero; a model without one starts from its search box's centre
moving at constant rates (:func:`~vsw.synthesis.powered.starts.kinematic_guess`). The open-loop
map's eigenvalues are reported (:func:`powered_eigenvalues`).

The package, by job: :mod:`~vsw.synthesis.powered.request` (the request, its checks, the result),
:mod:`~vsw.synthesis.powered.dynamics` (the model's CasADi functions),
:mod:`~vsw.synthesis.powered.variables` (unknowns, constraints, bounds),
:mod:`~vsw.synthesis.powered.problem` (the NLP, each phase by
:mod:`vsw.orbits.collocation`), :mod:`~vsw.synthesis.powered.events`,
:mod:`~vsw.synthesis.powered.objectives`,
:mod:`~vsw.synthesis.powered.starts`, :mod:`~vsw.synthesis.powered.solve` (:func:`optimize`),
:mod:`~vsw.synthesis.powered.step` (the open-loop step), :mod:`~vsw.synthesis.powered.verify` and
:mod:`~vsw.synthesis.powered.plot`.
"""

from vsw.dynamics.quantities import weight as walker_weight
from vsw.synthesis.powered.request import (
    COSTS,
    MAX_TARGET,
    RESIMULATION_TOL,
    PoweredGait,
    Request,
    canonical_cost,
    chosen_indices,
    estimate_seconds,
    gait_parameters,
    impulse_names,
    input_names,
    ordered_impulses,
    prices_work,
)
from vsw.synthesis.powered.solve import best_start, optimize
from vsw.synthesis.powered.step import powered_eigenvalues, powered_step, powered_step_jacobian

__all__ = [
    "COSTS",
    "MAX_TARGET",
    "RESIMULATION_TOL",
    "PoweredGait",
    "Request",
    "best_start",
    "canonical_cost",
    "chosen_indices",
    "estimate_seconds",
    "gait_parameters",
    "impulse_names",
    "input_names",
    "optimize",
    "ordered_impulses",
    "powered_eigenvalues",
    "powered_step",
    "powered_step_jacobian",
    "prices_work",
    "walker_weight",
]
