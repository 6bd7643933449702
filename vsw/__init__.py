"""vsw: the runtime of the walking models ``python -m derive`` writes into ``generated/``.

Its packages are layers; each imports only the ones above it in this list:

* :mod:`vsw.runtime`: errors, limits, Ctrl-C, progress, threads, JSON;
* :mod:`vsw.orbits`: the periodic-orbit problem of a hybrid model, its discretisations,
  monodromy and Newton;
* :mod:`vsw.dynamics`: a derived model's hybrid dynamics and its simulators;
* :mod:`vsw.plots`: figures, stick figures, animations, the explorer page;
* :mod:`vsw.gaits`: the gait search and continuation with bifurcations;
* :mod:`vsw.synthesis`: design, powered gaits, hybrid zero dynamics;
* :mod:`vsw.models`: the model interface every command goes through (the ILE's closed
  forms behind it);
* :mod:`vsw.studies`: sweeps, basins, rough ground, the Dask cluster, gait files;
* :mod:`vsw.cli`: the ``vsw`` command, a module per subcommand.

numpy and CasADi at import time only; SciPy, matplotlib and sympy-free generated code are
loaded where needed (the runtime never imports sympy).
"""

__version__ = "0.1.0"
