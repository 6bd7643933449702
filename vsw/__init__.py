"""vsw: analysis, simulation and design of Virtual Slope Walking gaits (ILE model).

Runs on the code that ``python -m derive`` writes into ``generated/``; numpy and CasADi
only at import time (SciPy and matplotlib are imported lazily where needed).
"""

__version__ = "0.1.0"
