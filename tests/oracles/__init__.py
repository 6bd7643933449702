"""Independent routes to results the runtime computes otherwise: kept for the tests (and
the benchmarks' comparisons), not part of the installed package."""
