"""A model's gaits: the search for its periodic orbits (:mod:`~vsw.gaits.search`, cached by
:mod:`~vsw.gaits.search_cache`) and their continuation in a parameter with located
bifurcations (:mod:`~vsw.gaits.continuation` on :mod:`~vsw.gaits.pseudo_arclength`, test
functions in :mod:`~vsw.gaits.special_curves`).

Layer 4: imports :mod:`vsw.runtime`, :mod:`vsw.orbits`, :mod:`vsw.dynamics` and
:mod:`vsw.plots`, nothing above.
"""
