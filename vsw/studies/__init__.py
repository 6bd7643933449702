"""What is run over many walks of a model: sweeps, basins of attraction, walking on rough
ground (mean first-passage time, the Markov chain, the gait sensitivity norm), the Dask
cluster they can run on, and the powered gait files replayed by the simulation.

Layer 7: imports every layer below, :mod:`vsw.models` included; only :mod:`vsw.cli`
imports it.
"""
