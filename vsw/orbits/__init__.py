"""Periodic orbits of hybrid models: one problem, two discretisations, one monodromy, one
Newton.

* :mod:`vsw.orbits.problem`: :class:`OrbitProblem`, a hybrid period-``p`` orbit of a model
  with some parameters free: its unknowns, residual, exact Jacobian, monodromy matrix and
  quantities, and its solution at fixed parameters;
* :mod:`vsw.orbits.shooting`: the multiple-shooting discretisation on CasADi CVODES flows;
* :mod:`vsw.orbits.collocation`: the collocation discretisations, Hermite-Simpson (the
  powered gaits' NLP, :mod:`vsw.synthesis.powered`, with its discrete phase map's
  derivative) and Gauss-Legendre (the design's search, :mod:`vsw.synthesis.design`);
* :mod:`vsw.orbits.monodromy`: the monodromy matrix (variational equations, the events'
  saltation matrices, reset Jacobians) and its eigenvalues;
* :mod:`vsw.orbits.newton`: Newton's method, bordered or not, for one start or many.

The gait search (:mod:`vsw.gaits.search`), the periodic-orbit solver
(:meth:`vsw.dynamics.hybrid.HybridModel.periodic_orbit`), continuation
(:mod:`vsw.gaits.continuation`), the design NLPs (:mod:`vsw.synthesis.design`: the
Gauss-Legendre collocation, the shooting flows and the monodromy) and the powered gaits' NLP
(:mod:`vsw.synthesis.powered`: the Hermite-Simpson collocation and the monodromy) are built
on it. It takes a model by its interface and imports nothing of ``vsw`` above
``vsw.runtime.stop`` and ``vsw.runtime.errors`` (:mod:`vsw.dynamics.hybrid` builds on it);
CasADi is imported inside functions, so ``import vsw.orbits`` stays cheap.
"""

from vsw.orbits.monodromy import by_modulus
from vsw.orbits.newton import Solution, System, solve
from vsw.orbits.problem import OrbitProblem, Solved
from vsw.orbits.shooting import phase_sequence

__all__ = [
    "OrbitProblem",
    "Solution",
    "Solved",
    "System",
    "by_modulus",
    "phase_sequence",
    "solve",
]
