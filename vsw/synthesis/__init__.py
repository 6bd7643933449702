"""Making gaits: passive gaits designed by IPOPT on the periodic-orbit problem
(:mod:`~vsw.synthesis.design`), powered gaits by collocation (:mod:`~vsw.synthesis.powered`)
and controlled walking by hybrid zero dynamics (:mod:`~vsw.synthesis.hzd`).

Layer 5: imports the layers below (runtime, orbits, dynamics, plots, gaits), never
:mod:`vsw.models`: a problem takes a model by its interface.
"""
