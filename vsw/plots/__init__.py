"""Figures and pages: the house style, the stick figures drawn from a model's own
geometry, animations and the explorer page.

Layer 3: imports :mod:`vsw.runtime` and :mod:`vsw.dynamics` (a walk to draw), nothing above.
"""
