"""The process around every computation: errors, limits, Ctrl-C and the run-time limit,
progress on a terminal, threads, forked processes and BLAS, JSON.

Layer 0: imports nothing of ``vsw`` outside this package.
"""
