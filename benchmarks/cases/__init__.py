"""The benchmark cases by topic, each a function returning its rows (benchmarks/run.py
runs one per process): ile (cases 1-5), startup (7), design (6, 8, 13, 16), gaits (9, 10,
12, 14), basins (11) and batch (15); cases 17 and 18 are benchmarks/rough_bench.py and
benchmarks/hzd_bench.py."""
