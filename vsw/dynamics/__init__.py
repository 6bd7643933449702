"""A derived model at run time: its hybrid dynamics (:mod:`~vsw.dynamics.hybrid`), the
parameters and quantities it is evaluated with, and its simulators, numpy/CasADi
(:mod:`~vsw.dynamics.trajectories`) and compiled C in batches (:mod:`~vsw.dynamics.batch`,
its map's fixed points in :mod:`~vsw.dynamics.step_map`).

Layer 2: imports :mod:`vsw.runtime` and :mod:`vsw.orbits` (the periodic-orbit problem the
model is solved on), nothing above.
"""
