"""Benchmarks: every speed claim measured side by side with what a user would write instead.

``python benchmarks/run.py [--quick] [--json FILE] [--results FILE] [--case N ...]`` runs
the cases, prints a table and writes ``benchmarks/results.md`` (the table, the machine, the
versions). Each comparison is a ratio measured within one run: the two sides interleaved,
a warm-up call of each first, then at least five repetitions (two with ``--quick``);
medians are reported with min and max. Absolute times are reported; only ratios are
claimed, except where a case sets an absolute target (cases 4-7).
Case 9 times one passive-walker gait solve per model; cases 10 and 11 the
compiled batch simulator, per step and as a 500 x 500 basin, locally and on Dask.

Every case runs in a fresh Python process, so its peak resident memory (RSS) is its own;
the peak memory of one call of each side is measured with ``tracemalloc`` (numpy reports
its array buffers to it). ``--quick`` uses small sizes so the test suite can run it to keep
this code working; its numbers mean nothing and it writes to a temporary file unless
``--results`` says otherwise.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
# The tests' oracles (tests/oracles: routes the runtime does not ship) are case 3's subject.
if str(ROOT / "tests") not in sys.path:
    sys.path.append(str(ROOT / "tests"))

import generated.ile as ile  # noqa: E402
from vsw.models.ile.params import random_parameters  # noqa: E402
from vsw.runtime.vectorize import chunked, default_threads  # noqa: E402

CASES = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18)

DESIGN_BEFORE = "39d527c"
DERIVE_BEFORE = "5e02f11"
"""The tree case 7 derives side by side with this one: the last whose impulse at an impact
was solved by one symbolic solve inside another (its level compass gait took minutes)."""
DERIVE_COSTS_BEFORE = "24e9efe"
"""The tree beside which case 7's rows noted 'against 24e9efe' were measured, apart from
the rest of the case: the derivation of every model, the heaviest models alone,
``derive --check`` and the user's model file, each process alternating with the same
command in a checkout of this commit (medians)."""
DERIVE_MODEL_LIMIT = 4.0
"""Seconds within which each model derives alone, cold (case 7)."""
DERIVE_MEDIAN_LIMIT = 3.0
"""Times the median of the other models' cold derivations within which each model derives
alone (case 7): a model far above it has a cost the engine should not have."""
USER_MODEL_SOURCE = "level_compass_gait"
"""The model case 7 copies outside the package as a user's model file with an impulse at
heelstrike, and times through ``vsw analyze --model path.py`` on first use."""
BATCH_BEFORE = "cc98831"
"""The commit before the batch simulator's C was rewritten in lanes (case 15 runs its table
and integrator side by side with the current ones)."""
BATCH_BEFORE_FLAGS = (
    ["-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-lm"],
    ["-O2", "-ffp-contract=off", "-lm"],
)
"""vsw/dynamics/batch.py's flags at BATCH_BEFORE."""
THREADS_BEFORE = "9fcf285"
"""The commit before BLAS's threads were bounded by the walks' (case 15 with ``--against``
and no REF times its walks in a checkout of it, beside this tree's)."""
BATCH_VALUES = {"vsw_biped": {"beta": 0.97, "theta_II": -0.2}}
"""Case 15's parameters where not the defaults: the biped at a stable gait (its defaults'
gaits are unstable, so the walks would fall within a few steps)."""
"""The commit whose vsw/synthesis/design.py case 8 compares with (before the design was
rewritten)."""


@dataclass
class Timing:
    median: float
    low: float
    high: float

    @classmethod
    def of(cls, samples: list[float]) -> Timing:
        return cls(statistics.median(samples), min(samples), max(samples))

    def per(self, count: int) -> Timing:
        return Timing(self.median / count, self.low / count, self.high / count)


@dataclass
class Row:
    case: str
    subject: str
    baseline: str
    subject_time: Timing | None
    baseline_time: Timing | None
    target: str
    met: bool | None
    note: str = ""
    subject_peak_mb: float | None = None
    baseline_peak_mb: float | None = None
    extra: dict = field(default_factory=dict)

    @property
    def ratio(self) -> float | None:
        if self.subject_time is None or self.baseline_time is None:
            return None
        return self.subject_time.median / self.baseline_time.median

    @classmethod
    def from_dict(cls, d: dict) -> Row:
        d = dict(d)
        d.pop("ratio", None)
        for key in ("subject_time", "baseline_time"):
            if d[key] is not None:
                d[key] = Timing(**d[key])
        return cls(**d)


def interleaved(a: Callable, b: Callable, repetitions: int) -> tuple[Timing, Timing]:
    """Time ``a`` and ``b`` alternately after one warm-up call of each."""
    a()
    b()
    ta, tb = [], []
    for _ in range(repetitions):
        for fn, sink in ((a, ta), (b, tb)):
            start = time.perf_counter()
            fn()
            sink.append(time.perf_counter() - start)
    return Timing.of(ta), Timing.of(tb)


def timed(fn: Callable, repetitions: int) -> Timing:
    fn()
    samples = []
    for _ in range(repetitions):
        start = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - start)
    return Timing.of(samples)


def peak_alloc_mb(fn: Callable) -> float:
    """Peak memory traced during one call of ``fn`` (numpy buffers included), in MB."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def parameter_arrays(n: int, seed: int, walking: bool) -> tuple[np.ndarray, ...]:
    p = random_parameters(n, seed, walking=walking)
    return p["beta"], p["theta_II"], p["phi0"]


def _max_rel(a, b) -> float:
    """max |a - b| / max(|b|, 1) over entries finite in both (margins cross zero)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ok = np.isfinite(a) & np.isfinite(b)
    if not ok.any():
        return 0.0
    return float(np.max(np.abs(a[ok] - b[ok]) / np.maximum(np.abs(b[ok]), 1.0)))


# ---------------------------------------------------------------------------- cases


def case_fixed_point_vectorised(n: int, reps: int) -> list[Row]:
    """Case 1: q^f, eigenvalue, conditions over n sets vs lambdify(raw) and the trig floor."""
    beta, theta_II, phi0 = parameter_arrays(n, seed=1, walking=False)
    threads = default_threads()
    outputs = tuple(np.empty(n) for _ in range(2 + len(ile.CONDITIONS)))
    floor_outputs = tuple(np.empty(n) for _ in range(3))

    def fused(threads: int, reuse: bool = False) -> Callable:
        def run():
            with np.errstate(all="ignore"):
                return chunked(
                    ile.fixed_point_conditions, beta, theta_II, phi0, threads=threads,
                    out=outputs if reuse else None,
                )  # fmt: skip

        return run

    def separate():
        with np.errstate(all="ignore"):
            return (
                chunked(ile.q_fixed, beta, theta_II, phi0, threads=1),
                chunked(ile.eigenvalue, beta, phi0, threads=1),
                *chunked(ile.condition_margins, beta, theta_II, phi0, threads=1),
            )

    def floor():
        return np.cos(theta_II), np.cos(phi0), np.sin(phi0)

    def cos_sin_floor():
        from generated._backend import NUMPY

        return NUMPY.cos_sin(theta_II), NUMPY.cos_sin(phi0)

    def floor_reused():
        np.cos(theta_II, out=floor_outputs[0])
        np.cos(phi0, out=floor_outputs[1])
        np.sin(phi0, out=floor_outputs[2])

    from vsw.models.ile import kernels

    # The first build, into an empty cache directory (one compiler run).
    with tempfile.TemporaryDirectory() as cache:
        os.environ["VSW_CACHE_DIR"] = cache
        start = time.perf_counter()
        kernels.library()
        build_seconds = time.perf_counter() - start
        del os.environ["VSW_CACHE_DIR"]

    def compiled(threads: int) -> Callable:
        def run():
            return kernels.fixed_point_conditions(beta, theta_II, phi0, threads=threads)

        return run

    # The generated code first, in a process that has not run sympy: the floor and the
    # generated code then see the same allocator state.
    floor_label = "3 numpy trig evaluations (cos theta_II, cos phi0, sin phi0)"
    kernel_rows = []
    if kernels.library() is None:
        kernel_rows.append(Row("1", "compiled batch kernel", "-", None, None, "<= 1.5x floor",
                               None, note=kernels.build_error or "disabled"))  # fmt: skip
    else:
        for k in sorted({threads, 1}, reverse=True):
            t_k, t_f = interleaved(compiled(k), floor, reps)
            row = Row("1", f"compiled batch kernel (generated/ile/c/ile_batch.c), {k} thread"
                      f"{'s' if k > 1 else ''}: {n} sets, same outputs", floor_label, t_k, t_f,
                      "<= 1.5x floor", None, subject_peak_mb=peak_alloc_mb(compiled(k)),
                      baseline_peak_mb=peak_alloc_mb(floor),
                      note="floor on 1 thread" if k > 1 else "")  # fmt: skip
            row.met = row.ratio <= 1.5
            kernel_rows.append(row)
        build = Timing(build_seconds, build_seconds, build_seconds)
        kernel_rows.append(Row("1", "building the compiled kernel (first use, empty cache)", "-",
                               build, None, "-", None, note="single run"))  # fmt: skip
    what = f"q^f+eigenvalue+{len(ile.CONDITIONS)} margins, n={n}"
    t_fused, t_floor = interleaved(fused(threads), floor, reps)
    t_one, t_floor1 = interleaved(fused(1), floor, reps)
    t_reused, t_floor_reused = interleaved(fused(threads, True), floor_reused, reps)
    t_reused1, t_floor_reused1 = interleaved(fused(1, True), floor_reused, reps)
    t_sep, t_floor2 = interleaved(separate, floor, reps)
    t_one2, t_cos_sin = interleaved(fused(1), cos_sin_floor, reps)
    floor_mb, fused_mb = peak_alloc_mb(floor), peak_alloc_mb(fused(threads))
    rows = [
        Row("1", f"generated numpy fixed_point_conditions, {threads} threads: {what}", floor_label,
            t_fused, t_floor, "<= 1.5x floor", None, subject_peak_mb=fused_mb,
            baseline_peak_mb=floor_mb),
        Row("1", "the same, 1 thread", "3 numpy trig evaluations", t_one, t_floor1,
            "<= 1.5x floor", None, subject_peak_mb=fused_mb, baseline_peak_mb=floor_mb),
        Row("1", f"the same, {threads} threads, writing into reused output arrays",
            "3 numpy trig evaluations into reused arrays", t_reused, t_floor_reused,
            "<= 1.5x floor", None),
        Row("1", "the same, 1 thread, writing into reused output arrays",
            "3 numpy trig evaluations into reused arrays", t_reused1, t_floor_reused1,
            "<= 1.5x floor", None),
        Row("1", "generated q_fixed, eigenvalue, condition_margins called separately, 1 thread",
            "3 numpy trig evaluations", t_sep, t_floor2, "(not fused; informative)", None),
        Row("1", "generated fixed_point_conditions, 1 thread",
            "the generated code's own trig: be.cos_sin of theta_II and phi0 (2 tan)", t_one2,
            t_cos_sin, "(informative: cost beyond the trig it uses)", None),
    ]  # fmt: skip
    if threads > 1:  # the target's floor is plain numpy, on one thread
        rows[0].note = rows[2].note = "floor on 1 thread"
    for row in rows[:4]:  # the numpy path: what runs where no C compiler is available
        row.target = "(numpy fallback; informative)"

    import sympy as sm

    from derive.models import ile as model

    d = model.derive()
    raw_qf = d.facts["stride.q_fixed"].subs(model.theta_I, model.heelstrike()["theta_I"])
    raw_margins = [c.margin for c in d.conditions]
    args = (model.beta, model.theta_II, model.phi0)
    raw = sm.lambdify(args, [raw_qf, d.facts["stride.eigenvalue"], *raw_margins], "numpy")

    def lambdified():
        with np.errstate(all="ignore"):
            return raw(beta, theta_II, phi0)

    agreement = max(_max_rel(a, b) for a, b in zip(fused(threads)(), lambdified()))
    t_fused2, t_raw = interleaved(fused(threads), lambdified, reps)
    row = Row("1", f"generated fixed_point_conditions, {threads} threads",
              "sympy.lambdify of the raw derived expressions", t_fused2, t_raw,
              "faster; values agree to 1e-7", None,
              note=f"max disagreement {agreement:.1e} relative to max(|value|, 1)",
              subject_peak_mb=fused_mb, baseline_peak_mb=peak_alloc_mb(lambdified))  # fmt: skip
    # Both sides round differently where the model is ill-conditioned (beta -> 0, or
    # phi0 -> 0 with beta -> 1); tests/test_generated_backends.py checks the generated side
    # against 40-digit evaluation.
    row.met = row.ratio < 1.0 and agreement <= 1e-7
    return [*kernel_rows, *rows, row]


def case_fixed_point_vs_simulation(samples: int, batch: int, reps: int) -> list[Row]:
    """Case 2: closed-form q^f per set vs a solve_ivp Poincare map with brentq per set."""
    from vsw.models.ile.simulate import fixed_point_by_simulation

    beta, theta_II, phi0 = parameter_arrays(samples, seed=2, walking=True)
    many = parameter_arrays(batch, seed=3, walking=True)
    agreement = max(
        abs(float(np.ravel(fixed_point_by_simulation(b, t, p))[0]) / ile.q_fixed(b, t, p) - 1)
        for b, t, p in zip(beta, theta_II, phi0)
    )

    def vectorised():
        ile.q_fixed(*many)

    def scalar_calls():
        for b, t, p in zip(beta, theta_II, phi0):
            ile.q_fixed(float(b), float(t), float(p))

    def simulated():
        for b, t, p in zip(beta, theta_II, phi0):
            fixed_point_by_simulation(b, t, p)

    t_vec, t_sim = interleaved(vectorised, simulated, reps)
    t_scalar = timed(scalar_calls, reps)
    sim_per_set = t_sim.per(samples)
    note = f"simulation: rtol 1e-10, {samples} sets; max rel. disagreement {agreement:.1e}"
    rows = [
        Row("2", f"generated q_fixed, vectorised over {batch} sets (time per set)",
            "solve_ivp Poincare map + brentq (time per set)", t_vec.per(batch), sim_per_set,
            ">= 1e5x faster", None, note=note),
        Row("2", "generated q_fixed, one Python call per set", "the same simulation per set",
            t_scalar.per(samples), sim_per_set, ">= 1e5x faster", None,
            note="call overhead of numpy on Python floats"),
    ]  # fmt: skip
    for row in rows:
        row.met = 1 / row.ratio >= 1e5 and agreement <= 1e-8
    return rows


def case_rootfinders_and_c(reps: int) -> list[Row]:
    """Case 3: CasADi rootfinder per solve (closed form, integrated map); compiled C per call."""
    from oracles.ile_fixed_point import solve_fixed_point  # tests/oracles

    from vsw.dynamics.ccode import CLibrary

    b, t, p = 0.8, 0.0, np.pi / 4
    calls = 1000
    t_closed = timed(lambda: solve_fixed_point(b, t, p, method="closed-form"), reps)
    t_integrated = timed(lambda: solve_fixed_point(b, t, p, method="integrated"), reps)
    rows = [
        Row("3", f"CasADi rootfinder on the {label} map (per solve)", "-", timing, None, "-", None)
        for label, timing in (("closed-form", t_closed), ("integrated", t_integrated))
    ]
    try:
        lib = CLibrary.build()
    except Exception as exc:  # no C compiler: say so in the table instead of failing
        rows.append(Row("3", "compiled C", "-", None, None, "-", None, note=f"not built: {exc}"))
        return rows
    t_c, t_py = interleaved(
        lambda: [lib.call("q_fixed", b, t, p) for _ in range(calls)],
        lambda: [ile.q_fixed(b, t, p) for _ in range(calls)],
        reps,
    )
    rows.append(
        Row("3", "compiled C vsw_ile_q_fixed per call (via ctypes)",
            "generated numpy q_fixed per scalar call", t_c.per(calls), t_py.per(calls), "-",
            None, note="ctypes call overhead included")
    )  # fmt: skip
    return rows


def case_step_metrics(n: int, reps: int) -> list[Row]:
    """Case 4: step period (elliptic), length, speed, contact margin for n sets."""
    beta, theta_II, phi0 = parameter_arrays(n, seed=4, walking=True)

    def metrics(blockwise: bool):
        def run():
            with np.errstate(all="ignore"):
                ev = chunked if blockwise else (lambda f, *a: f(*a))
                qf = ev(ile.q_fixed, beta, theta_II, phi0)
                t1, t2 = ev(ile.phase_durations, beta, theta_II, phi0, qf)
                length = ev(ile.step_length, beta, phi0)
                _ = length / (t1 + t2)
                ev(ile.contact_margin, beta, theta_II, phi0, qf)

        return run

    t_chunk, t_whole = interleaved(metrics(True), metrics(False), reps)
    row = Row("4", f"step metrics, n={n}, blockwise on {default_threads()} threads",
              "same code on whole arrays", t_chunk, t_whole, "<= 1 s absolute", None,
              subject_peak_mb=peak_alloc_mb(metrics(True)),
              baseline_peak_mb=peak_alloc_mb(metrics(False)))  # fmt: skip
    row.met = t_chunk.median <= 1.0 * n / 1e6
    row.note = "target scaled to n/1e6" if n != 10**6 else ""
    return [row]


def case_basin(n: int, reps: int) -> list[Row]:
    """Case 5: basin of attraction on an n x n grid (theta_II x initial q), classified."""
    from vsw.models.ile import basin as basin_module

    grid = np.radians(np.linspace(-30, 40, n))

    def run():
        basin_module.basin(0.8, np.pi / 4, grid, n_q=n, refine=False)

    start = time.perf_counter()
    run()  # the first call in this fresh process: what a `vsw basin` command pays
    first = time.perf_counter() - start
    t = timed(run, reps)
    row = Row("5", f"basin classification, {n}x{n} grid", "-", t, None, "<= 1 s absolute", None,
              subject_peak_mb=peak_alloc_mb(run))  # fmt: skip
    row.met = t.median <= 1.0 * (n * n) / 1e6
    cold = Row("5", "the same, first call in a fresh process", "-", Timing(first, first, first),
               None, "-", None, note="single run")  # fmt: skip
    return [row, cold]


def case_design(quick: bool) -> list[Row]:
    """Case 6: gait design with CasADi/IPOPT vs SciPy SLSQP on a simulation-based map."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_design

    result = bench_design.compare(quick=quick)
    ipopt = Timing(*result["ipopt_seconds"])
    slsqp = Timing(*result["slsqp_seconds"])
    full = Timing(*result["full_design_seconds"])
    row = Row(
        "6",
        "design() whole (scan + one IPOPT start per region), after set-up",
        "SciPy SLSQP on the simulated map from the first IPOPT start",
        ipopt,
        slsqp,
        "<= 100 ms and >= 100x faster, objective >=",
        None,
        note=result.get("note", ""),
    )
    row.met = ipopt.median <= 0.1 and 1 / row.ratio >= 100 and result.get("objective_ok", False)
    setup = Timing(result["setup_seconds"], result["setup_seconds"], result["setup_seconds"])
    return [
        row,
        Row("6", "design as `vsw design` runs it, with the simulation check", "-", full,
            None, "-", None),
        Row("6", "first design in a process (builds the CasADi solver)", "-", setup, None, "-",
            None, note="single run"),
    ]  # fmt: skip


def case_design_suite(quick: bool) -> list[Row]:
    """Case 8: the design suite (benchmarks/design_suite.py) against a grid + SLSQP
    reference, the code before the design's rewrite side by side."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import design_suite

    before = None if quick else DESIGN_BEFORE
    out = design_suite.run(6 if quick else 220, 2026, before, grid=12 if quick else 40,
                           processes=1 if quick else 2)  # fmt: skip
    records = out["records"]
    after = out["summary"]["after"]
    old = out["summary"].get("before")

    def times(side: str) -> Timing:
        return Timing.of([r[side]["seconds"] for r in records])

    def rate(s: dict) -> str:
        return f"{s['success']}/{s['problems']} = {100 * s['success_rate']:.1f} %"

    def statuses(s: dict) -> str:
        return ", ".join(f"{k} {v}" for k, v in s["statuses"].items())

    failures = [r["label"] for r in records if not r["after_verdict"]["success"]]
    extra = {"failures": failures, "after": after, "before": old}
    checks = (
        f"reference missing {after['reference_missing']}; status agrees with whether the "
        f"reference optimum lies on a kept distance {after['status_agrees_with_reference']}; "
        f"not-attained paths optimal at their last distance {after['not_attained_paths_optimal']}"
    )
    n = after["problems"]
    rows = [
        Row("8", f"design suite, {n} problems: success (feasible: optimal or not-attained, "
            "objective <= reference + 1e-6 rel., constraints re-checked by the closed forms, "
            "q^f/period/length/speed by simulation; infeasible: status infeasible naming the "
            "constraint in conflict)",
            f"design code before ({DESIGN_BEFORE})" if old else "-", None, None, ">= 99 %",
            after["success_rate"] >= 0.99,
            note=f"{rate(after)}" + (f"; before: {rate(old)}" if old else "") + f"; {checks}"
            + (f"; failed: {', '.join(failures)}" if failures else ""), extra=extra),
        Row("8", "feasible problems reported infeasible or not-converged", "-", None, None,
            "0", after["feasible_reported_infeasible_or_not_converged"] == 0,
            note=f"{after['feasible_reported_infeasible_or_not_converged']}" + (
                f"; before: {old['feasible_reported_infeasible_or_not_converged']}"
                if old else "")),
        Row("8", "infeasible problems reported feasible", "-", None, None, "0",
            after["infeasible_reported_feasible"] == 0,
            note=f"{after['infeasible_reported_feasible']}" + (
                f"; before: {old['infeasible_reported_feasible']}" if old else "")),
        Row("8", "time of design() per problem, no simulation check: median [min, max]",
            "the code before the design's rewrite, same problems" if old else "-", times("after"),
            times("before") if old else None, "median <= 100 ms", after["median_s"] <= 0.1,
            note=f"statuses {statuses(after)}" + (f"; before: {statuses(old)}" if old else "")),
        Row("8", "time of design() per problem: 95th percentile", "-", None, None,
            "<= 500 ms", after["p95_s"] <= 0.5,
            note=f"{1e3 * after['p95_s']:.0f} ms" + (
                f"; before: {1e3 * old['p95_s']:.0f} ms" if old else "")),
    ]  # fmt: skip
    return rows


# Case 9's gaits and the published numbers each is held against (sources as in
# tests/test_passive_walkers.py): the simplest walker's long gait at gamma = 0.009 (Garcia's
# code: theta, theta_dot in its signs, "to 1e-10"); the compass gait at 3 degrees (Goswami
# et al. 1996 as quoted: half inter-leg angle 0.271 rad, 3 digits); the VSW biped (no
# published number: the ILE's closed form (10) at the emergent angle, mu = 0.01, is its
# O(mu) check, not a published value).
def _gaits():
    from paper_check.walkers import GARCIA_LONG

    theta, theta_dot = GARCIA_LONG
    return (
        ("simplest_walker", {"gamma": 0.009},
         lambda s: max(abs(-s["theta"] - theta), abs(-s["theta_dot"] - theta_dot))),
        ("compass_gait", {"gamma": float(np.radians(3.0))}, lambda s: abs(-s["theta"] - 0.271)),
        ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 0.01}, None),
    )  # fmt: skip


def _most_stable_gait(m, params):
    """The model's most stable gait from a coarse search (24 points a side): the cases that
    start from it time what follows, not the search (vsw.gaits.search; its own default is finer,
    to find the gaits with tiny basins too)."""
    from vsw.gaits.search import search

    found = search(m, params, cells=24 ** len(m.spec["search"]))
    return min(found.gaits, key=lambda o: o.max_abs_eigenvalue)


def case_gait_rootfinder(reps: int) -> list[Row]:
    """Case 9: one period-one gait per model by the engine's boundary-value rootfinder
    (CasADi Newton on CVODES flows, eigenvalues included, confirmed by one simulated step)
    against SciPy root (hybr, xtol 1e-12) on the simulated map (solve_ivp DOP853 with
    events, rtol = atol = 1e-12: vsw.dynamics.hybrid's own step), both from the same guess: the gait
    with every component moved by 1e-3 (relative), as a continuation step leaves it."""
    from scipy.optimize import root

    from vsw.models import load

    rows = []
    for key, values, published in _gaits():
        m = load(key)
        params = m.parameters(values)
        orbit = _most_stable_gait(m, params)
        x_star = np.array(list(orbit.state.values()))
        guess = x_star * (1 + 1e-3)
        durations = m.step(params, guess).durations
        found = {}

        def ours(m=m, params=params, guess=guess, durations=durations, found=found):
            found["ours"] = m.periodic_orbit(params, guess, durations)

        def theirs(m=m, params=params, guess=guess, found=found):
            solution = root(lambda x: m.step(params, x).state - x, guess, method="hybr",
                            options={"xtol": 1e-12})  # fmt: skip
            found["theirs"] = solution

        t_ours, t_theirs = interleaved(ours, theirs, reps)
        x_ours = np.array(list(found["ours"].state.values()))
        x_theirs = found["theirs"].x
        names = m.coordinates + m.rates
        note = (f"SciPy root success {found['theirs'].success}, {found['theirs'].nfev} steps; "
                f"the two gaits differ by {np.max(np.abs(x_ours - x_theirs)):.1g}")  # fmt: skip
        if published is not None:
            gap_ours = published(found["ours"].state)
            gap_theirs = published(dict(zip(names, x_theirs)))
            note += (f"; from the published values: ours {gap_ours:.2g}, SciPy's "
                     f"{gap_theirs:.2g}")  # fmt: skip
        ratio = t_ours.median / t_theirs.median
        # Of ours, the simulated step that confirms the orbit (SciPy, as the baseline's).
        t_step = timed(lambda m=m, params=params, x=x_ours: m.step(params, x), reps)
        note += f"; of ours, the confirming simulated step {t_step.median * 1e3:.1f} ms"
        rows.append(Row(
            "9", f"{key}: period-one gait by vsw.dynamics.hybrid periodic_orbit",
            "SciPy root on solve_ivp (DOP853, events) steps", t_ours, t_theirs,
            ">= 20x faster", ratio <= 1 / 20, note=note,
        ))  # fmt: skip
        # The same gait as a fixed point of the compiled batch simulator's map (Newton with
        # central differences), against the same baseline, side by side.
        from vsw.dynamics.batch import simulator

        sim = simulator(load(key))
        sim.library()

        def batch(sim=sim, params=params, guess=guess, found=found):
            found["batch"] = sim.fixed_point(params, guess)[0]

        t_batch, t_theirs = interleaved(batch, theirs, reps)
        gap = np.max(np.abs(found["batch"] - x_ours))
        note = (
            f"the batch fixed point and the rootfinder's differ by {gap:.1g}; no "
            "eigenvalues or confirmation step in this time (periodic_orbit has both)"
        )
        ratio = t_batch.median / t_theirs.median
        rows.append(Row(
            "9", f"{key}: period-one gait by the batch simulator's Newton (vsw.dynamics.batch)",
            "SciPy root on solve_ivp (DOP853, events) steps", t_batch, t_theirs,
            ">= 20x faster", ratio <= 1 / 20, note=note,
        ))  # fmt: skip
    return rows


def _near_gait_starts(key: str, count: int, values: dict | None = None):
    """The model's default parameters (or these ``values``), its most stable gait and
    ``count`` section states around it (1 % relative noise, fixed seed) that all complete
    a step."""
    from vsw.dynamics.batch import WALKED, simulator
    from vsw.models import load

    m = load(key)
    params = m.parameters(values)
    orbit = _most_stable_gait(m, params)
    x = np.array(list(orbit.state.values()))
    starts = x * (1 + 0.01 * np.random.default_rng(14).standard_normal((4 * count, x.size)))
    if m.spec.get("section"):
        starts = np.column_stack(m.module.section_completion(*params, *starts.T))
    ok = simulator(load(key)).step(params, starts).outcome == WALKED
    return m, params, starts[ok][:count]


def case_batch_step(count: int, reps: int) -> list[Row]:
    """Case 10: one step of the Poincare map from each of ``count`` section states near the
    gait: the compiled batch simulator (one thread, one call) at its default rtol = atol =
    1e-12 against SciPy's solve_ivp (DOP853, events; vsw.dynamics.hybrid's step) at 1e-10 (the
    target's baseline) and at 1e-12 (the same tolerance), and both at 1e-10."""
    import vsw.dynamics.hybrid as hybrid
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    rows = []
    for key in ("simplest_walker", "compass_gait", "vsw_biped"):
        m, params, starts = _near_gait_starts(key, count)
        sim = simulator(load(key))
        sim.library()
        found = {}

        for our_tol, tol in ((1e-12, 1e-10), (1e-12, 1e-12), (1e-10, 1e-10)):

            def ours(sim=sim, params=params, starts=starts, found=found, our_tol=our_tol):
                found["ours"] = sim.step(params, starts, threads=1, tolerance=our_tol).final

            def theirs(m=m, params=params, starts=starts, found=found, tol=tol):
                saved = hybrid.RTOL, hybrid.ATOL
                hybrid.RTOL = hybrid.ATOL = tol
                try:
                    found["theirs"] = np.array([m.step(params, x).state for x in starts])
                finally:
                    hybrid.RTOL, hybrid.ATOL = saved

            t_ours, t_theirs = interleaved(ours, theirs, reps)
            gap = np.max(np.abs(found["ours"] - found["theirs"])
                         / np.maximum(1, np.abs(found["theirs"])))  # fmt: skip
            ratio = t_ours.median / t_theirs.median
            rows.append(Row(
                "10", f"{key}: one step per start, batch simulator (1 thread) at rtol = atol "
                f"= {our_tol:g}", f"solve_ivp DOP853 + events, rtol = atol = {tol:g}",
                t_ours.per(len(starts)), t_theirs.per(len(starts)), ">= 300x faster",
                ratio <= 1 / 300,
                note=f"per step over {len(starts)} starts; post-step states differ by at most "
                f"{gap:.1g} (relative)",
            ))  # fmt: skip
    return rows


def _simulator_at(key: str, ref: str):
    """The batch simulator of ``key`` with the C table and integrator of commit ``ref``
    (built with that commit's flags; the calling convention has not changed)."""
    from vsw.dynamics.batch import BatchSimulator
    from vsw.models import load

    def show(path: str) -> bytes:
        return subprocess.run(["git", "show", f"{ref}:{path}"], cwd=ROOT, check=True,
                              capture_output=True).stdout  # fmt: skip

    def integrator() -> bytes:
        # The C sources moved with the runtime's layers; a commit before that has them in vsw/.
        try:
            return show("vsw/dynamics/csrc/hybrid_batch.c")
        except subprocess.CalledProcessError:
            return show("vsw/csrc/hybrid_batch.c")

    source = show(f"generated/{key}/c/{key}_sim.c") + b"\n" + integrator()
    sim = BatchSimulator(load(key))
    sim.use_build(source, f"{key}_sim_{ref}", BATCH_BEFORE_FLAGS)
    return sim


@dataclass
class _SideBySide:
    """Walks of 20 steps from the same starts by two simulators, alternately: their times
    per step, steps, whether every walk ended the same way, and the largest relative gap
    between the section states of walks both completed."""

    ours: Timing
    theirs: Timing
    steps: int
    same: bool
    gap: float


def _walks_side_by_side(ours, theirs, params, starts, tol: float, reps: int) -> _SideBySide:
    found = {}

    def walker(sim, name):
        def walk():
            found[name] = sim.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0,
                                   threads=1, tolerance=tol)  # fmt: skip

        return walk

    t_ours, t_theirs = interleaved(walker(ours, "ours"), walker(theirs, "theirs"), reps)
    a, b = found["ours"], found["theirs"]
    done = (a.steps == 20) & (b.steps == 20)
    gap = float(np.max(np.abs(a.final[done] - b.final[done])
                       / np.maximum(1, np.abs(b.final[done])), initial=0.0))  # fmt: skip
    return _SideBySide(t_ours.per(int(a.steps.sum())), t_theirs.per(int(b.steps.sum())),
                       int(a.steps.sum()), a.ended() == b.ended(), gap)  # fmt: skip


def case_batch_before(count: int, reps: int, before: str = BATCH_BEFORE) -> list[Row]:
    """Case 15: walks of 20 steps from ``count`` section states near each model's
    gait, one thread, through today's batch simulator and through the C table and
    integrator of ``before``, alternately in one run, at rtol = atol = 1e-10 and 1e-12.
    Time per step walked (walks that fall end early, the same in both)."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    rows = []
    for key in ("simplest_walker", "compass_gait", "vsw_biped"):
        _, params, starts = _near_gait_starts(key, count, BATCH_VALUES.get(key))
        now, then = simulator(load(key)), _simulator_at(key, before)
        now.library()
        for tol in (1e-10, 1e-12):
            run = _walks_side_by_side(now, then, params, starts, tol, reps)
            rows.append(Row(
                "15", f"{key}: walks of 20 steps, batch simulator (1 thread), rtol = atol = "
                f"{tol:g}", f"the same, C table and integrator of {before}", run.ours,
                run.theirs, "faster than before", run.ours.median < run.theirs.median,
                note=f"per step over {len(starts)} walks ({run.steps} steps); every walk ends "
                f"the same way: {run.same}; after 20 steps the states differ by at most "
                f"{run.gap:.1g} (relative)",
            ))  # fmt: skip
    return (rows + _cpu_rows(count) + _limit_rows(count, 3 * reps) + _sines_rows(count, reps)
            + _numba_rows(count, reps) + _cyrk_rows(count, reps)
            + _floor_rows(count, reps))  # fmt: skip


def _limit_rows(count: int, reps: int) -> list[Row]:
    """Case 15: walks of 20 steps (one thread, rtol = atol = 1e-10) as they run, within
    :func:`vsw.runtime.blas.limited`, against the same walks with the limit taken out, alternately
    in one process: what bounding BLAS's threads costs a walk."""
    import vsw.runtime.blas
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    limited = vsw.runtime.blas.limited
    rows = []
    for key in ("simplest_walker", "compass_gait", "vsw_biped"):
        _, params, starts = _near_gait_starts(key, count, BATCH_VALUES.get(key))
        sim = simulator(load(key))
        steps = int(sim.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0, threads=1,
                             tolerance=1e-10).steps.sum())  # fmt: skip

        def walk(sim=sim, params=params, starts=starts):
            sim.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0, threads=1,
                     tolerance=1e-10)  # fmt: skip

        def unlimited():
            vsw.runtime.blas.limited = lambda threads=None: contextlib.nullcontext(threads)
            try:
                walk()
            finally:
                vsw.runtime.blas.limited = limited

        ours, theirs = interleaved(walk, unlimited, reps)
        cost = _limit_cost()
        share = cost / ours.median
        rows.append(Row(
            "15", f"{key}: walks of 20 steps, batch simulator (1 thread), rtol = atol = 1e-10, "
            "BLAS bounded by the walks' threads (vsw.runtime.blas.limited)",
            "the same walks without the limit, alternately in one process", ours.per(steps),
            theirs.per(steps),
            "no slower: the limit's own cost <= 0.1% of a call", share <= 1e-3,
            note=f"per step over {len(starts)} walks ({steps} steps), {reps} calls each; the "
            f"limit's own cost, timed alone: {cost * 1e6:.1f} us a call, {100 * share:.3f}% of "
            "one (the medians' ratio moves with the machine's other work)",
        ))  # fmt: skip
    return rows


def _limit_cost(calls: int = 2000) -> float:
    """Seconds a walk's :func:`vsw.runtime.blas.limited` block costs at one thread outside any
    other (entered and left, numpy's and SciPy's BLAS lowered and given back), the best of
    five rounds of ``calls``."""
    from vsw.runtime.blas import limited

    best = math.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(calls):
            with limited(1):
                pass
        best = min(best, (time.perf_counter() - start) / calls)
    return best


def blas_threading() -> str:
    """The BLAS threading of this process, which the processes it starts inherit: each BLAS
    that numpy and SciPy load (threadpoolctl) with its thread count outside any limit of
    vsw's, and the environment variables that set the counts."""
    import scipy.linalg  # noqa: F401  (SciPy's own BLAS, loaded with it)
    from threadpoolctl import threadpool_info

    libraries = [f"{i['internal_api']} {i['version']} on {i['num_threads']} threads"
                 for i in threadpool_info() if i["user_api"] == "blas"]  # fmt: skip
    names = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    given = [f"{n}={os.environ[n]}" for n in names if n in os.environ]
    settings = ", ".join(given) if given else "OPENBLAS_NUM_THREADS and OMP_NUM_THREADS unset"
    return f"BLAS: {', '.join(libraries) or 'none found'} ({settings})"


CPU_CALLS = 10
"""Calls of case 15's CPU-time row, each within its bound."""


def _cpu_rows(count: int) -> list[Row]:
    """Case 15: one step from each of ``count`` starts near the simplest walker's gait,
    one thread, rtol = atol = 1e-10, :data:`CPU_CALLS` calls in this process: CPU time
    (``time.process_time``: every thread of the process) against wall time, per step. One
    thread must bill at most 1.2 times its wall time in every call, BLAS's workers
    included (vsw/runtime/blas.py), under the BLAS threading a user has by default (no
    OPENBLAS_NUM_THREADS; the row says what it ran under). A shared machine lowers the
    ratio (wall time waiting for a core), never raises it."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    _, params, starts = _near_gait_starts("simplest_walker", count)
    sim = simulator(load("simplest_walker"))
    steps = int(sim.step(params, starts, threads=1, tolerance=1e-10).steps.sum())
    cpu, wall = [], []
    for _ in range(CPU_CALLS):
        c0, w0 = time.process_time(), time.perf_counter()
        sim.step(params, starts, threads=1, tolerance=1e-10)
        wall.append((time.perf_counter() - w0) / steps)
        cpu.append((time.process_time() - c0) / steps)
    ratios = [c / w for c, w in zip(cpu, wall)]
    return [Row(
        "15", "simplest_walker: one step from each start, batch simulator (1 thread), rtol = "
        "atol = 1e-10: CPU time (every thread of the process)", "its wall time",
        Timing.of(cpu), Timing.of(wall), "<= 1.2x the wall time in every call",
        max(ratios) <= 1.2, note=f"per step over {len(starts)} walks, {CPU_CALLS} calls; "
        f"CPU / wall per call {min(ratios):.2f}-{max(ratios):.2f}; {blas_threading()}, "
        "bounded by the call's threads inside it (vsw.runtime.blas.limited)",
    )]  # fmt: skip


TREE_WALKS = """
import json, sys, time
import numpy as np
from vsw.dynamics.batch import simulator
from vsw.models import load
given, reps, out = np.load(sys.argv[1]), int(sys.argv[2]), {}
for key in sys.argv[3].split(","):
    params, starts = given[key + " params"], given[key + " starts"]
    sim = simulator(load(key))
    for tol in (1e-10, 1e-12):
        def walk():
            return sim.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0, threads=1,
                            tolerance=tol)
        steps, samples = int(walk().steps.sum()), []
        for _ in range(reps):
            start = time.perf_counter()
            walk()
            samples.append(time.perf_counter() - start)
        out[f"{key} {tol:g}"] = [min(samples) / steps, steps]
print(json.dumps(out))
"""
"""Case 15's walks in one tree (its vsw), from the parameters and starts of the file
``argv[1]``: the best of ``argv[2]`` calls per model and tolerance, per step, as JSON."""


def case_walks_against(ref: str, count: int, reps: int) -> list[Row]:
    """Case 15 with ``--against REF``: its walks (20 steps from ``count`` starts near each
    gait, the same starts on both sides, one thread, rtol = atol = 1e-10 and 1e-12) in this
    tree and in a checkout of ``ref``, each in a process of its own, the two trees'
    processes alternately ``reps`` times (each tree first in turn): the whole walk as each
    tree's vsw runs it. The target compares each tree's fastest process (the least
    disturbed by other work)."""
    keys = ("simplest_walker", "compass_gait", "vsw_biped")
    found: dict[str, list[dict]] = {"ours": [], "theirs": []}
    with _checkout(ref) as old, tempfile.TemporaryDirectory() as tmp:
        given = {}
        for key in keys:
            _, params, starts = _near_gait_starts(key, count, BATCH_VALUES.get(key))
            given[f"{key} params"], given[f"{key} starts"] = np.asarray(params), starts
        np.savez(Path(tmp) / "starts.npz", **given)
        for rep in range(reps):
            sides = (("ours", ROOT), ("theirs", old))
            for side, tree in sides if rep % 2 == 0 else sides[::-1]:  # either first in turn
                env = {**os.environ, "PYTHONPATH": str(tree), "PYTHONDONTWRITEBYTECODE": "1"}
                command = [sys.executable, "-c", TREE_WALKS, str(Path(tmp) / "starts.npz"), "5",
                           ",".join(keys)]  # fmt: skip
                done = subprocess.run(command, cwd=tree, env=env, check=True,
                                      capture_output=True, text=True)  # fmt: skip
                found[side].append(json.loads(done.stdout.splitlines()[-1]))
    rows = []
    for label in found["ours"][0]:
        ours = Timing.of([run[label][0] for run in found["ours"]])
        theirs = Timing.of([run[label][0] for run in found["theirs"]])
        steps = {run[label][1] for run in found["ours"] + found["theirs"]}
        key, tol = label.split()
        rows.append(Row(
            "15", f"{key}: walks of 20 steps, batch simulator (1 thread), rtol = atol = {tol}, "
            "this tree", f"the same in a checkout of {ref}", ours, theirs,
            "no slower (<= 1.05x, fastest process against fastest)",
            ours.low <= 1.05 * theirs.low,
            note=f"per step over {count} walks ({', '.join(map(str, sorted(steps)))} steps); "
            f"best of 5 calls in each of {reps} processes a tree, alternately; fastest "
            f"against fastest {ours.low / theirs.low:.3f}x (a machine's other work slows "
            "whole processes: the medians move with it)",
        ))  # fmt: skip
    return rows


def _sines_rows(count: int, reps: int) -> list[Row]:
    """Case 15: the library in use (libmvec's sines and cosines where the CPU has AVX2 on
    glibc, vsw/dynamics/csrc/lanes.h) against the same code built with libm's (-DVSW_NO_MVEC), walks
    of 20 steps, one thread, alternately; the walks' largest gap after 20 steps."""
    from vsw.dynamics.batch import _LIBM_FLAGS, BatchSimulator, simulator
    from vsw.models import load

    rows = []
    for key in ("simplest_walker", "compass_gait", "vsw_biped"):
        _, params, starts = _near_gait_starts(key, count, BATCH_VALUES.get(key))
        vector = simulator(load(key))
        vector.library()
        if not vector._lib.vsw_batch_vector_sines():
            return [Row("15", "libmvec's sines against libm's", "-", None, None,
                        "(informative)", None, note="not run: this build takes libm's (no AVX2 "
                        "or no libmvec)")]  # fmt: skip
        libm = BatchSimulator(load(key))
        libm.use_build(libm.c_source(), f"{key}_sim_libm", (_LIBM_FLAGS,))
        run = _walks_side_by_side(vector, libm, params, starts, 1e-10, reps)
        rows.append(Row(
            "15", f"{key}: walks of 20 steps, batch simulator (1 thread), rtol = atol = 1e-10, "
            "libmvec's sines", "the same code with libm's (-DVSW_NO_MVEC)", run.ours,
            run.theirs, "(informative)", None,
            note=f"per step over {len(starts)} walks ({run.steps} steps); every walk ends the "
            f"same way: {run.same}; after 20 steps the states differ by at most {run.gap:.1g} "
            "(relative)",
        ))  # fmt: skip
    return rows


def _floor_rows(count: int, reps: int) -> list[Row]:
    """Case 15's floor: the flow and guard evaluations a step needs (counted by a build
    with -DVSW_COUNT_CALLS over the same walks) times their cost alone (timed in C over
    the walks' start states), against the time per step of the walks themselves."""
    import ctypes

    from vsw.dynamics.batch import _FLAG_SETS, BatchSimulator, simulator
    from vsw.models import load

    rows = []
    for key in ("simplest_walker", "compass_gait", "vsw_biped"):
        _, params, starts = _near_gait_starts(key, count, BATCH_VALUES.get(key))
        sim = BatchSimulator(load(key))  # not the cached one: it gets the counting build
        source = b"#define _POSIX_C_SOURCE 199309L\n#define VSW_COUNT_CALLS 1\n" + sim.c_source()
        counting = sim.use_build(source, f"{key}_sim_counting", _FLAG_SETS)
        n_phases = len(sim.model.phases)
        counts = (ctypes.c_longlong * (3 * n_phases))()
        counting.vsw_batch_counts(counts)  # from zero
        walked = sim.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0, threads=1,
                          tolerance=1e-10)  # fmt: skip
        counting.vsw_batch_counts(counts)
        steps = int(walked.steps.sum())
        costs = (ctypes.c_double * 5)()
        dbl = ctypes.POINTER(ctypes.c_double)
        p = np.ascontiguousarray(params, dtype=float)
        x = np.ascontiguousarray(starts, dtype=float)
        floor = lanes_floor = rk_floor = 0.0
        per_step, per_lane, per_rk = [], [], []
        rk_cost = (ctypes.c_double * 2)()
        for phase in range(n_phases):
            # RK steps chained from the starts, 1e-3 long (their cost does not depend on h;
            # short steps keep the states near the gait's)
            counting.vsw_batch_rk_cost(ctypes.c_int(phase), p.ctypes.data_as(dbl),
                                       x.ctypes.data_as(dbl), ctypes.c_longlong(len(x)),
                                       ctypes.c_longlong(200), ctypes.c_double(1e-3),
                                       rk_cost)  # fmt: skip
            rk_steps = counts[2 * n_phases + phase] / steps
            rk_floor += rk_steps * rk_cost[0]
            per_rk.append(f"{rk_steps:.1f} RK steps at {rk_cost[0] * 1e9:.0f} ns")
            counting.vsw_batch_call_costs(ctypes.c_int(phase), p.ctypes.data_as(dbl),
                                          x.ctypes.data_as(dbl), ctypes.c_longlong(len(x)),
                                          ctypes.c_longlong(200), costs)  # fmt: skip
            flows, watches = counts[phase] / steps, counts[n_phases + phase] / steps
            floor += flows * costs[0] + watches * costs[1]
            lanes_floor += flows * costs[3] + watches * costs[4]
            per_step.append(f"{flows:.0f} flows at {costs[0] * 1e9:.0f} ns and {watches:.0f} "
                            f"guard sets at {costs[1] * 1e9:.0f} ns")  # fmt: skip
            per_lane.append(f"{costs[3] * 1e9:.0f} ns and {costs[4] * 1e9:.0f} ns")
        fast = simulator(load(key))
        fast.library()

        def walk(fast=fast, params=params, starts=starts):
            fast.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0, threads=1,
                      tolerance=1e-10)  # fmt: skip

        t = timed(walk, reps).per(steps)
        # One walk at a time, each of libmvec's sines is a four-wide call for one value:
        # that floor no longer bounds a step taken in lanes, so it is shown, not a target.
        rows.append(Row(
            "15", f"{key}: a step of the batch simulator at rtol = atol = 1e-10, against its "
            "floor", "the flow and guard evaluations it needs, timed alone, one walk at a time",
            t, Timing(floor, floor, floor), "(informative: the lanes' floor is the target)",
            None, note="per step: " + "; ".join(per_step),
        ))  # fmt: skip
        rows.append(Row(
            "15", f"{key}: the same step against the floor of its lanes", "the same evaluations "
            "at their cost per walk in lanes of four (vsw/dynamics/csrc/lanes.h)", t,
            Timing(lanes_floor, lanes_floor, lanes_floor), "<= 1.5x the floor",
            t.median <= 1.5 * lanes_floor,
            note="per walk, a flow and a guard set: " + "; ".join(per_lane),
        ))  # fmt: skip
        # What the floor leaves out: DOP853's own arithmetic (its stages' sums, the error
        # estimate) and the flows as a step chains them, each stage waiting for the last.
        rows.append(Row(
            "15", f"{key}: the same step against its RK steps alone", "its RK steps (twelve "
            "flows, the stages' sums, the error estimate) in lanes of four, chained as a walk "
            "chains them, counted and timed alone", t, Timing(rk_floor, rk_floor, rk_floor),
            "(informative)", None, note=f"per step: {'; '.join(per_rk)}; the RK steps alone "
            f"are {rk_floor / lanes_floor:.2f}x the floor of the lanes",
        ))  # fmt: skip
    return rows


PEER_MODELS = ("simplest_walker", "compass_gait", "vsw_biped")
"""Case 15's peers walk these models (each typed by hand in benchmarks/peers)."""


@dataclass
class _PeerRun:
    """One model and tolerance against a peer: times and steps of both sides, the largest
    gap between their one-step maps, whether every walk took as many steps, and the
    peer's own count (its calls, where it reports one)."""

    key: str
    tol: float
    walks: int
    ours: Timing
    theirs: Timing
    steps_ours: int
    steps_theirs: int
    gap: float
    same: bool
    calls: int | None

    @property
    def ratio(self) -> float:
        return (self.ours.median / self.steps_ours) / (self.theirs.median / self.steps_theirs)


def _against_peer(count: int, reps: int, walk_for: Callable) -> list[_PeerRun]:
    """The batch simulator (one thread, walks of 20 steps from ``count`` starts near each
    gait of :data:`PEER_MODELS`, at 1e-10 and 1e-12) side by side with a peer:
    ``walk_for(key)`` gives ``walk(p, starts, steps, tol) -> (final, walked, calls)``."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load

    runs = []
    for key in PEER_MODELS:
        _, params, starts = _near_gait_starts(key, count, BATCH_VALUES.get(key))
        sim = simulator(load(key))
        sim.library()
        walk = walk_for(key)
        p = np.ascontiguousarray(params, dtype=float)
        x0 = np.ascontiguousarray(starts, dtype=float)
        for tol in (1e-10, 1e-12):
            found: dict = {}

            def theirs(steps=20, tol=tol, found=found, walk=walk, p=p, x0=x0):
                found["theirs"] = walk(p, x0, steps, tol)

            def ours(steps=20, tol=tol, found=found, sim=sim, params=params, starts=starts):
                found["ours"] = sim.walk(params, starts, steps, converge_tol=0.0,
                                         period_tol=0.0, threads=1, tolerance=tol)  # fmt: skip

            ours(1), theirs(1)  # one step from each start: the two step maps
            final = found["theirs"][0]
            gap = float(np.max(np.abs(found["ours"].final - final)
                               / np.maximum(1, np.abs(final))))  # fmt: skip
            t_ours, t_theirs = interleaved(ours, theirs, reps)
            _, walked, calls = found["theirs"]
            runs.append(_PeerRun(key, tol, len(starts), t_ours, t_theirs,
                                 int(found["ours"].steps.sum()), int(walked.sum()), gap,
                                 bool(np.array_equal(found["ours"].steps, walked)),
                                 calls))  # fmt: skip
    return runs


def _peer_subject(run: _PeerRun) -> str:
    return (f"{run.key}: walks of 20 steps, batch simulator (1 thread), rtol = atol = "
            f"{run.tol:g}")  # fmt: skip


def _numba_rows(count: int, reps: int) -> list[Row]:
    """Case 15's peer: the simplest walker, the compass gait and the VSW biped through a
    hand-written numba DOP853 (benchmarks/peers/numba_dop853.py: the same integrator rules,
    each model typed by hand) against the batch simulator, one thread each, walks of 20 steps;
    skipped without numba."""
    try:
        from peers import numba_dop853
    except ImportError as exc:
        return [Row("15", "the batch simulator against a numba DOP853", "-", None, None,
                    ">= 1.5x faster than numba", None,
                    note=f"not run: {exc} (pip install numba)")]  # fmt: skip

    def walk_for(key: str) -> Callable:
        walk_numba = getattr(numba_dop853, key)()

        def walk(p, starts, steps, tol):
            n = len(starts)
            final, walked = np.empty((n, 4)), np.empty(n, np.int64)
            walk_numba(p, starts, steps, tol, tol, final, walked, np.empty(n, np.int64))
            return final, walked, None

        return walk

    return [Row("15", _peer_subject(r),
                "a hand-written numba DOP853 (benchmarks/peers), the same rules",
                r.ours.per(r.steps_ours), r.theirs.per(r.steps_theirs), ">= 1.5x faster",
                r.ratio <= 1 / 1.5,
                note=f"per step over {r.walks} walks ({r.steps_ours} and {r.steps_theirs} "
                f"steps); one step from each start: the two maps differ by at most "
                f"{r.gap:.1g} (relative)")
            for r in _against_peer(count, reps, walk_for)]  # fmt: skip


def _cyrk_rows(count: int, reps: int) -> list[Row]:
    """Case 15's second peer: the same three models through CyRK's C++ DOP853 and its events
    (benchmarks/peers/cyrk_peer: its Cython API, ``cysolve_ivp_noreturn``, one integration a
    phase from the phase's start, the numba peer's equations and rules, built with Cython
    into a cache directory on first use) against the batch simulator, one thread each,
    walks of 20 steps; skipped without CyRK or Cython."""
    try:
        from peers import cyrk_peer

        cyrk = cyrk_peer.load()
    except Exception as exc:  # not installed, or no C++ compiler: the row says why
        return [Row("15", "the batch simulator against CyRK's DOP853", "-", None, None,
                    "ahead of CyRK", None,
                    note=f"not run: {exc} (pip install cyrk cython)")]  # fmt: skip

    def walk_for(key: str) -> Callable:
        def walk(p, starts, steps, tol):
            n = len(starts)
            final, walked = np.empty((n, 4)), np.empty(n, np.int64)
            calls = cyrk.walk(key, p, starts, steps, tol, tol, final, walked,
                              np.empty(n, np.int64))  # fmt: skip
            return final, walked, calls

        return walk

    return [Row("15", _peer_subject(r),
                "CyRK's C++ DOP853 with events, the same rules (benchmarks/peers)",
                r.ours.per(r.steps_ours), r.theirs.per(r.steps_theirs), "ahead of CyRK",
                r.ratio < 1,
                note=f"per step over {r.walks} walks ({r.steps_ours} and {r.steps_theirs} "
                f"steps, the same in every walk: {r.same}; "
                f"{r.calls / max(r.steps_theirs, 1):.2f} CyRK integrations a step: one a "
                "phase, one more after each event skipped 1e-9 past itself); one step from "
                f"each start: the two maps differ by at most {r.gap:.1g} (relative); CyRK "
                "locates events by Brent's method on its dense output")
            for r in _against_peer(count, reps, walk_for)]  # fmt: skip


def _basin_grid(side: int):
    """The simplest walker's basin at gamma = 0.009 over theta x theta_dot just after
    heelstrike (phi and phi_dot from the section), the region around its thin band."""
    return np.linspace(-0.36, -0.1, side), np.linspace(0.1, 0.4, side)


def case_basin_grid(side: int, reps: int) -> list[Row]:
    """Case 11: a side x side basin of the simplest walker at gamma = 0.009, up to 50 steps
    a cell (stopping on convergence or a fall), by ``grid_basin`` as ``vsw basin --grid``
    runs it, its stable gait found before (the gait search is case 12's: about 12 s here):
    in-process threads (every core), and on a Dask LocalCluster of two worker processes
    with one thread each (started before timing; each side warmed up once)."""
    from distributed import LocalCluster

    from vsw.dynamics.batch import simulator
    from vsw.models import load
    from vsw.runtime.vectorize import default_threads
    from vsw.studies.cluster import runner
    from vsw.studies.grid_basin import grid_basin

    m = load("simplest_walker")
    params = m.parameters({"gamma": 0.009})
    x, y = _basin_grid(side)
    simulator(load("simplest_walker")).library()
    gait = m.stable_gait(params, "no basin")
    found = {}

    def local():
        found["local"] = grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait)

    peak = peak_alloc_mb(local)
    t_local = timed(local, reps)
    counts = found["local"].counts()
    steps = int(found["local"].steps.sum())
    rows = [Row(
        "11", f"basin {side} x {side}, simplest walker (vsw.studies.grid_basin, "
        f"{default_threads()} threads)", "-", t_local, None, "<= 60 s",
        t_local.median <= 60,
        note=f"{steps} steps walked ({t_local.median / steps * 1e6:.1f} us a step); classes "
        f"{counts}", subject_peak_mb=peak,
    )]  # fmt: skip
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:  # fmt: skip
        address = cluster.scheduler_address

        def remote():
            found["remote"] = grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait,
                                         runner=runner(address, m.name))  # fmt: skip

        t_remote, t_local = interleaved(remote, local, reps)
    same = found["remote"].to_dict() == found["local"].to_dict()
    ratio = t_remote.median / t_local.median
    rows.append(Row(
        "11", "the same basin on a Dask LocalCluster (2 workers x 1 thread)",
        f"in-process threads ({default_threads()})", t_remote, t_local, "<= 1.3x the local time",
        ratio <= 1.3, note=f"results identical: {same}; cluster start-up not timed",
    ))  # fmt: skip
    # the CLI's target is for 200 x 200 (the quick mode's 20 x 20 only runs it)
    return rows + _compass_gait_basin(side, reps) + _cli_basin_cost(min(side, 200), reps)


def _compass_gait_basin(side: int, reps: int) -> list[Row]:
    """Case 11: a side x side basin of the compass gait (its section declares
    psi = -theta) around its stable gait at the defaults, over theta x theta_dot just
    after heelstrike (psi_dot the gait's), up to 50 steps a cell, in-process threads."""
    from vsw.models import load
    from vsw.runtime.vectorize import default_threads
    from vsw.studies.grid_basin import grid_basin

    m = load("compass_gait")
    params = m.parameters()
    gait = m.stable_gait(params, "no basin")
    x, y = np.linspace(-0.5, -0.15, side), np.linspace(0.8, 1.7, side)
    found = {}

    def basin():
        found["basin"] = grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait)

    t = timed(basin, reps)
    steps = int(found["basin"].steps.sum())
    return [Row(
        "11", f"basin {side} x {side}, compass gait (vsw.studies.grid_basin, {default_threads()} "
        "threads)", "-", t, None, "measured", None,
        note=f"{steps} steps walked ({t.median / steps * 1e6:.1f} us a step); classes "
        f"{found['basin'].counts()}",
    )]  # fmt: skip


CLI_BASINS = (
    ("compass_gait", "compass-gait", {}, (-0.5, -0.15), (0.8, 1.7)),
    ("simplest_walker", "simplest-walker", {"gamma": 0.009}, (-0.36, -0.1), (0.1, 0.4)),
)
"""The basins whose `vsw basin` command case 11 times against the library call: model,
CLI name, parameters, theta range, theta_dot range (the grids of the basins above)."""


def _cli_basin_cost(side: int, reps: int) -> list[Row]:
    """Case 11: `vsw basin --grid` (a whole process: start, imports, kernel load,
    gait search, the basin, text output) against the library call it makes
    (``grid_basin`` with the gait known and the kernel loaded, in this process), alternately.
    The target, 1.3x, is for a 200 x 200 basin; on the simplest walker the basin
    itself takes about 0.1 s, less than an interpreter's start with numpy."""
    from vsw.models import load
    from vsw.studies.grid_basin import grid_basin

    rows = []
    for name, cli, values, (x0, x1), (y0, y1) in CLI_BASINS:
        m = load(name)
        params = m.parameters(values)
        gait = m.stable_gait(params, "no basin")
        x, y = np.linspace(x0, x1, side), np.linspace(y0, y1, side)
        command = [sys.executable, "-m", "vsw", "basin", "--model", cli,
                   *(f"--param={k}={v!r}" for k, v in values.items()),
                   f"--grid=theta={x0!r}:{x1!r}:{side}", f"--grid=theta_dot={y0!r}:{y1!r}:{side}",
                   "--steps", "50"]  # fmt: skip

        def process(command=command):
            subprocess.run(command, cwd=ROOT, check=True, capture_output=True)

        def library(m=m, params=params, x=x, y=y, gait=gait):
            grid_basin(m, params, "theta", x, "theta_dot", y, 50, gait=gait)

        t_cli, t_library = interleaved(process, library, reps)
        ratio = t_cli.median / t_library.median
        rows.append(Row(
            "11", f"vsw basin --model {cli}, {side} x {side} (a whole process: start, imports, "
            "kernel load, gait search, text output)",
            "the library call: grid_basin, gait known, kernel loaded", t_cli, t_library,
            "<= 1.3x the library call", ratio <= 1.3,
        ))  # fmt: skip
    return rows


def _process_time(command: list[str], reps: int, env: dict | None = None) -> Timing:
    def run():
        subprocess.run(command, cwd=ROOT, check=True, capture_output=True, env=env)

    return timed(run, reps)


def case_startup(reps: int, include_audit: bool, every_model: bool = True) -> list[Row]:
    """Case 7: whole-process start-up times (``every_model``: also `python -m derive` of
    every model, 40 s; the quick mode, which only checks the harness, leaves it out)."""
    py = sys.executable
    rows = []
    modules = ("cli, models, gaits.search, studies.sweeps, studies.grid_basin, dynamics.batch, "
               "models.ile.analysis, "
               "models.ile.basin, models.ile.design, models.ile.plots, "
               "models.ile.simulate, models.ile.sweep")  # fmt: skip
    lazy_check = (
        f"import vsw.{modules.replace(', ', ', vsw.')}; import sys; "
        "heavy = [m for m in ('scipy', 'matplotlib', 'sympy') if m in sys.modules]; "
        "assert not heavy, heavy"
    )
    with tempfile.TemporaryDirectory() as out:
        env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        if every_model:
            rows += case_derive(reps=2)
        cases = [
            ("import vsw", [py, "-c", "import vsw"], 0.3),
            (f"import vsw.{{{modules}}} (no scipy, matplotlib, sympy)",
             [py, "-c", lazy_check], 0.3),
            ("vsw analyze --beta 0.8 --theta-ii 0 --phi0 45 --json",
             [py, "-m", "vsw", "analyze", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45",
              "--json"], 0.6),
        ]  # fmt: skip
        if include_audit:
            cases.append(("python -m paper_check", [py, "-m", "paper_check", "--out", out], 60.0))
        baseline = _process_time([py, "-c", "pass"], reps)
        for label, command, target in cases:
            t = _process_time(command, 1 if "paper_check" in label else reps, env=env)
            row = Row("7", label, "python -c pass", t, baseline, f"<= {target} s absolute", None)
            if "paper_check" in label:
                row.note = "single run"
            row.met = t.median <= target
            rows.append(row)
    return rows


@contextlib.contextmanager
def _checkout(ref: str):
    """A detached worktree of ``ref`` in a temporary directory (removed after)."""
    with tempfile.TemporaryDirectory() as parent:
        tree = Path(parent) / "tree"
        subprocess.run(["git", "worktree", "add", "--detach", str(tree), ref], cwd=ROOT,
                       check=True, capture_output=True)  # fmt: skip
        try:
            yield tree
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           capture_output=True)  # fmt: skip


def _alternating(commands: list[tuple[list[str], Path]], reps: int,
                 envs: list[Callable[[], dict] | None] | None = None,
                 ) -> list[tuple[Timing, Timing]]:  # fmt: skip
    """Each command ``reps`` times, in turn (no warm-up: a cold derivation is the subject;
    no bytecode is written): for each, its wall time and its CPU time (user and system,
    of the process and its children), as Timings. ``envs``: extra environment per command,
    called afresh for each run (a run that must start cold gets a new cache; a variable
    given as None is removed)."""
    base = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
    walls: list[list[float]] = [[] for _ in commands]
    cpus: list[list[float]] = [[] for _ in commands]
    for _ in range(reps):
        for k, (command, cwd) in enumerate(commands):
            extra = (envs or [None] * len(commands))[k]
            merged = {**base, **(extra() if extra else {})}
            env = {key: value for key, value in merged.items() if value is not None}
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run(command, cwd=cwd, check=True, capture_output=True, env=env)
            walls[k].append(time.perf_counter() - start)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus[k].append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return [(Timing.of(w), Timing.of(c)) for w, c in zip(walls, cpus)]


def case_derive(reps: int, before: str = DERIVE_BEFORE) -> list[Row]:
    """Case 7's derivation: ``python -m derive``, every model of the registry and each
    model alone, cold (nothing on disk) and warm (nothing changed), this tree against
    commit ``before``'s side by side (each run of one alternating with the other's), each
    model's cold time against the median of the others'; and a user's model file with an
    impulse at heelstrike through ``vsw analyze --model path.py`` on first use."""
    from derive.registry import MODEL_NAMES

    py = sys.executable
    rows = []
    with _checkout(before) as old, tempfile.TemporaryDirectory() as out:
        new_all, old_all = f"{out}/new_all", f"{out}/old_all"
        (cold, cold_cpu), (old_cold, old_cold_cpu) = _alternating(
            [([py, "-m", "derive", "--force", "--out", new_all], ROOT),
             ([py, "-m", "derive", "--force", "--out", old_all], old)], reps)  # fmt: skip
        earlier = [name for name in MODEL_NAMES if _has_model(old, name)]
        added = [name for name in MODEL_NAMES if name not in earlier]
        extra = f"; {', '.join(added)} not at {before}: this tree derives more" if added else ""
        every = f"every model of the registry, cold ({len(MODEL_NAMES)}: {', '.join(MODEL_NAMES)})"
        rows.append(Row("7", f"python -m derive --force: {every}", f"the same at {before}",
                        cold, old_cold, "<= 10 s absolute", cold.median <= 10.0,
                        note="2 worker processes" + extra))  # fmt: skip
        rows.append(Row("7", f"python -m derive --force: {every}, CPU time (user + system)",
                        f"the same at {before}", cold_cpu, old_cold_cpu, "<= 20 s absolute",
                        cold_cpu.median <= 20.0,
                        note=f"2 worker processes; {blas_threading()}" + extra))  # fmt: skip
        ((warm, _), (old_warm, _)) = _alternating(
            [([py, "-m", "derive", "--check", "--out", new_all], ROOT),
             ([py, "-m", "derive", "--check", "--out", old_all], old)], reps)  # fmt: skip
        rows.append(Row("7", "python -m derive --check, nothing changed (warm: generated/MANIFEST)",
                        f"the same at {before}", warm, old_warm, "<= 1 s absolute",
                        warm.median <= 1.0))  # fmt: skip
        alone = {}
        for name in MODEL_NAMES:
            ours = ([py, "-m", "derive", "--model", name, "--force", "--out", f"{out}/n_{name}"],
                    ROOT)  # fmt: skip
            theirs = ([py, "-m", "derive", "--model", name, "--force", "--out", f"{out}/o_{name}"],
                      old)  # fmt: skip
            alone[name] = _alternating([ours] if name in added else [ours, theirs], reps)
        rows += _each_model_rows(alone, before)
        rows.append(_user_model_row(reps, before, old, Path(out)))
    return rows


def _each_model_rows(alone: dict[str, list[tuple[Timing, Timing]]], before: str) -> list[Row]:
    """A row per model derived alone: its cold time beside ``before``'s, and against the
    median of the other models' (a model far above it is a cost the engine should not
    have: the guard that no model escapes the measure)."""
    rows = []
    for name, timings in alone.items():
        wall = timings[0][0]
        others = [t[0][0].median for n, t in alone.items() if n != name] or [wall.median]
        median = statistics.median(others)
        peer = timings[1][0] if len(timings) > 1 else None
        rows.append(Row(
            "7", f"python -m derive --model {name}, cold (one process)",
            f"the same at {before}" if peer else f"none: not at {before}", wall, peer,
            f"<= {DERIVE_MODEL_LIMIT:g} s absolute and <= {DERIVE_MEDIAN_LIMIT:g}x the "
            "median of the others",
            wall.median <= DERIVE_MODEL_LIMIT and wall.median <= DERIVE_MEDIAN_LIMIT * median,
            note=f"{wall.median / median:.2f}x the median of the others ({median:.2f} s); "
            f"CPU {timings[0][1].median:.2f} s; {blas_threading()}",
        ))  # fmt: skip
    return rows


def _user_model_row(reps: int, before: str, old: Path, out: Path) -> Row:
    """``vsw analyze --model my_walker.py`` on first use (a fresh cache each run: the
    model derived, its library compiled, its gaits searched), the file a copy of
    USER_MODEL_SOURCE outside the package, in this tree and in ``before``'s, each with its
    own tree's copy (a model file imports what its tree's ``derive`` offers)."""
    paths = []
    for tree, name in ((ROOT, "user"), (old, "user_before")):
        folder = out / name
        folder.mkdir()
        paths.append(folder / "my_walker.py")
        shutil.copy(Path(tree) / "derive" / "models" / f"{USER_MODEL_SOURCE}.py", paths[-1])

    def fresh_cache() -> dict:
        # A models or searches directory of the caller's would make every run but the
        # first a warm one: the runs keep theirs in the fresh cache.
        return {"VSW_CACHE_DIR": tempfile.mkdtemp(dir=out), "VSW_MODELS_DIR": None,
                "VSW_SEARCH_CACHE": None}  # fmt: skip

    # Each tree's own vsw: the checkout's package first on the path.
    ours_command, old_command = ([sys.executable, "-m", "vsw", "analyze", "--model", str(p)]
                                 for p in paths)  # fmt: skip
    (ours, ours_cpu), (theirs, _) = _alternating(
        [(ours_command, ROOT), (old_command, old)], reps,
        envs=[lambda: {**fresh_cache(), "PYTHONPATH": str(ROOT)},
              lambda: {**fresh_cache(), "PYTHONPATH": str(old)}],
    )  # fmt: skip
    return Row("7", f"vsw analyze --model my_walker.py (a copy of {USER_MODEL_SOURCE}: an "
               "impulse at heelstrike), first use: derived, compiled, searched",
               f"the same at {before}", ours, theirs, "<= 8 s absolute", ours.median <= 8.0,
               note=f"CPU {ours_cpu.median:.2f} s; an empty cache each run; "
               f"{blas_threading()}, bounded by VSW_THREADS ({default_threads()}) in the "
               "command")  # fmt: skip


def _has_model(tree: Path, name: str) -> bool:
    """Whether the checkout ``tree`` has the model ``name`` (a module or a package)."""
    models = Path(tree) / "derive" / "models"
    return (models / f"{name}.py").is_file() or (models / name / "__init__.py").is_file()


def run_case(case: int, quick: bool, against: str | None = None) -> list[Row]:
    reps = 2 if quick else 5
    if case == 1:
        return case_fixed_point_vectorised(2_000 if quick else 10**6, reps)
    if case == 2:
        return case_fixed_point_vs_simulation(2 if quick else 10, 1000 if quick else 10**5, reps)
    if case == 3:
        return case_rootfinders_and_c(reps)
    if case == 4:
        return case_step_metrics(2_000 if quick else 10**6, reps)
    if case == 5:
        return case_basin(50 if quick else 1000, reps)
    if case == 6:
        return case_design(quick)
    if case == 7:
        return case_startup(1 if quick else 5, include_audit=not quick, every_model=not quick)
    if case == 8:
        return case_design_suite(quick)
    if case == 9:
        return case_gait_rootfinder(reps)
    if case == 10:
        return case_batch_step(8 if quick else 200, reps)
    if case == 11:
        return case_basin_grid(20 if quick else 500, 1 if quick else 2)
    if case == 12:
        return case_gait_search(quick)
    if case == 13:
        return case_design_every_model(quick)
    if case == 14:
        return case_locate_flip(quick)
    if case == 15:
        count = 100 if quick else 1000
        rows = case_batch_before(count, reps)
        return rows + (case_walks_against(against, count, reps) if against else [])
    if case == 16:
        return case_powered_shooting(quick)
    if case == 17:  # walks on rough ground: benchmarks/rough_bench.py
        from rough_bench import case_rough

        return case_rough(20 if quick else 2000, reps, Row, interleaved, _near_gait_starts)
    if case == 18:  # HZD gait optimisation against collocation: benchmarks/hzd_bench.py
        from hzd_bench import case_hzd_optimize

        return case_hzd_optimize(quick, Row, Timing)
    raise ValueError(f"no benchmark case {case}; cases are {CASES}")


def case_design_every_model(quick: bool) -> list[Row]:
    """Case 13: design on the periodic orbit, a seeded suite per model against
    references without IPOPT (benchmarks/design_every_model.py), SLSQP side by side."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import design_every_model

    keys = ["rimless_wheel"] if quick else list(design_every_model.SUITE_MODELS)
    report = design_every_model.run(2 if quick else 50, 2026, keys, 1 if quick else 5)
    return design_every_model.rows(report, Row, Timing)


GAIT_SEARCH_SETS = (
    ("simplest_walker", {}),
    ("compass_gait", {}),
    ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 0.3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 1e-4, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.8, "theta_II": 0.1, "mu": 1e-3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.85, "theta_II": 0.05, "mu": 0.3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.85, "theta_II": 0.05, "mu": 1.0, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.8, "theta_II": -0.2, "mu": 0.3, "b_over_l": 0.3}),
    ("vsw_biped", {"beta": 0.99, "theta_II": -0.2, "mu": 0.3, "b_over_l": 0.3}),
)
"""Where the gait search is checked against a scan twice as fine (case 12): the passive
walkers' defaults and the biped's sets of tests/test_gaits.py."""


MILD = 100.0
"""Case 12's bound: gaits with a max |eigenvalue| below it (every gait a walker could use
or a controller hold) must all be found; the very unstable ones near falling back lie in
ever thinner bands of states and are found where the grid resolves them."""


def case_gait_search(quick: bool) -> list[Row]:
    """Case 12: the gait search (vsw.gaits.search) as analyze runs it, one run per set, against a
    scan twice as fine along every free component (4 times the cells in two components,
    8 in three): the gaits the finer scan adds (each component apart by more than 1e-8),
    none of them with max |eigenvalue| below :data:`MILD`. Quick: the rimless wheel only."""
    from vsw.gaits import search as gaits
    from vsw.models import load

    sets = (("rimless_wheel", {}),) if quick else GAIT_SEARCH_SETS
    rows = []
    for key, values in sets:
        m = load(key)
        params = m.parameters(values)
        dims = len(m.spec["search"])
        points = gaits.SCAN_POINTS[dims]
        start = time.perf_counter()
        default = gaits.search(m, params)
        t_default = time.perf_counter() - start
        start = time.perf_counter()
        finer = gaits.search(m, params, cells=(2 * points) ** dims)
        t_finer = time.perf_counter() - start

        def states(found):
            return [np.array(list(g.state.values())) for g in found.gaits]

        extra = [g for g, y in zip(finer.gaits, states(finer))
                 if all(np.max(np.abs(y - x)) > 1e-8 for x in states(default))]  # fmt: skip
        mild = [g for g in extra if g.max_abs_eigenvalue < MILD]
        moduli = ", ".join(f"{g.max_abs_eigenvalue:.4g}" for g in default.gaits)
        added = ", ".join(f"{g.max_abs_eigenvalue:.4g}" for g in extra) or "none"
        label = f"{key} {values}" if values else f"{key} (defaults)"
        rows.append(Row(
            "12", f"gait search, {label}: {points} points a side ({default.cells} cells)",
            f"scan twice as fine ({finer.cells} cells)", Timing.of([t_default]),
            Timing.of([t_finer]), f"the finer scan finds no other gait with max |eigenvalue| "
            f"< {MILD:g}", None if quick else not mild,
            note=f"{len(default.gaits)} gaits (max |eigenvalue| {moduli}); the finer scan adds "
            f"{added}; Newton from {default.candidates} completed cells",
        ))  # fmt: skip
    return rows


def case_locate_flip(quick: bool) -> list[Row]:
    """Case 14: the simplest walker's first flip from gamma = 0.009, located by
    ``vsw continue``'s library call (Garcia et al. 1998's long gait, continued without
    switching to the flip's bracket below 1e-11 of the range) against ``vsw sweep``'s
    continuation on a grid, one run each in this process. A grid locates the flip only to
    its spacing: the grid of the same precision is far too large to run, so its time is the
    measured grid's per point times the points it would need (stated as extrapolated).
    Quick: a 5-point grid."""
    from vsw.gaits import continuation
    from vsw.models import load
    from vsw.studies import sweeps

    m = load("simplest_walker")
    long_gait = (-0.200310900563820, -0.400621801127640, 0.199832473025474,
                 0.015822999949030)  # fmt: skip  # Bhounsule 2013, as paper_check quotes
    start, stop_value = 0.009, 0.016
    params = m.parameters({"gamma": start})
    guess_durations = m.step(params, np.array(long_gait)).durations
    begin = time.perf_counter()
    (branch,) = continuation.continue_gaits(
        m, params, "gamma", start, stop_value, long_gait, guess_durations,
        options=continuation.Options(switch=False),
    )  # fmt: skip
    t_continue = time.perf_counter() - begin
    flip = next(s for s in branch.special_points if s.type == "flip")
    precision = continuation.LOCATE_TOL * (stop_value - start)
    count = 5 if quick else 71
    grid = np.linspace(start, stop_value, count)
    begin = time.perf_counter()
    points = sweeps.continuation(m, {}, "gamma", grid)
    t_grid = time.perf_counter() - begin
    lost = next((p["gamma"] for p in points if p["max_abs_eigenvalue"] is not None
                 and p["max_abs_eigenvalue"] > 1), None)  # fmt: skip
    spacing = grid[1] - grid[0]
    needed = (stop_value - start) / precision
    extrapolated = t_grid / count * needed
    return [Row(
        "14", f"vsw continue locates the simplest walker's first flip at gamma = "
        f"{flip.parameter:.12f} (|mu + 1| = {flip.defining:.1g}, bracket {precision:.1g})",
        f"vsw sweep on {count} values (spacing {spacing:.2g}: its first unstable value "
        f"{lost}), extrapolated to the spacing {precision:.1g} ({needed:.2g} values)",
        Timing.of([t_continue]), Timing.of([extrapolated]),
        "locating the flip by continuation faster than a grid of equal precision",
        None if quick else t_continue < extrapolated,
        note=f"the {count}-value grid itself took {t_grid:.3g} s; {len(branch.points)} "
        "continuation points",
    )]  # fmt: skip


def case_powered_shooting(quick: bool) -> list[Row]:
    """Case 16: the compass gait on level ground powered by its push-off alone,
    the least work a step at one step length: ``vsw optimize``'s library call (collocation
    on 20 and 40 intervals, IPOPT, the re-simulation and the eigenvalues) against single
    shooting with SciPy's SLSQP on the simulated step from a plain start
    (benchmarks/powered_peer.py ``compass_push_off_by_shooting``), one run each, side by
    side. The target: equal cost at convergence (not judged where SLSQP does not converge:
    its row says so). Quick: one step length, 50 iterations."""
    from powered_peer import compass_push_off_by_shooting

    from vsw.models import load
    from vsw.synthesis.powered import Request, optimize

    model = load("level_compass_gait")
    params = model.parameters()
    rows = []
    for length in (0.4,) if quick else (0.4, 0.5):
        begin = time.perf_counter()
        gait = optimize(model, params, Request("work", target_step_length=length,
                                               use=("push_off",)))  # fmt: skip
        t_ours = time.perf_counter() - begin
        peer = compass_push_off_by_shooting(length, params, maxiter=50 if quick else 100)
        gap = abs(peer.cost - gait.cost) / abs(gait.cost)
        equal = peer.success and gait.status == "optimal" and gap <= 1e-6
        rows.append(Row(
            "16", f"vsw optimize --model level-compass-gait --minimize work "
            f"--target-step-length {length:g} --use push_off: {gait.status}, work "
            f"{gait.cost:.9g} J a step",
            f"SLSQP single shooting on the simulated step (benchmarks/powered_peer.py): "
            f"{'converged' if peer.success else 'NOT converged'}, work {peer.cost:.9g} J",
            Timing.of([t_ours]), Timing.of([peer.seconds]),
            "equal cost at convergence (1e-6 relative)", equal if peer.success else None,
            note=f"single run each; costs differ by {gap:.2g} (relative); SLSQP: "
            f"{peer.iterations} iterations, {peer.evaluations} evaluations, {peer.message}",
        ))  # fmt: skip
    return rows


# ---------------------------------------------------------------------------- output


def fmt_time(t: Timing | None) -> str:
    if t is None:
        return "-"

    def one(x: float) -> str:
        if x >= 1:
            return f"{x:.2f} s"
        if x >= 1e-3:
            return f"{x * 1e3:.1f} ms"
        if x >= 1e-6:
            return f"{x * 1e6:.1f} us"
        return f"{x * 1e9:.1f} ns"

    return f"{one(t.median)} [{one(t.low)}, {one(t.high)}]"


def fmt_ratio(r: float | None) -> str:
    if r is None:
        return "-"
    return f"{r:.3g}x" if r >= 0.01 else f"1/{1 / r:,.0f}"


def fmt_memory(row: Row) -> str:
    parts = []
    if row.subject_peak_mb is not None:
        parts.append(f"{row.subject_peak_mb:,.0f}")
    if row.baseline_peak_mb is not None:
        parts.append(f"{row.baseline_peak_mb:,.0f}")
    rss = row.extra.get("case_peak_rss_mb")
    text = " / ".join(parts) if parts else "-"
    return text + (f" (RSS {rss:,.0f})" if rss is not None else "")


def table(rows: list[Row]) -> str:
    lines = [
        "| case | measured | against | time: median [min, max] | baseline: median [min, max] "
        "| ratio | peak MB: measured / against (case RSS) | target | met |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        met = {True: "yes", False: "**MISSED**", None: "-"}[r.met]
        note = f" ({r.note})" if r.note else ""
        lines.append(
            f"| {r.case} | {r.subject}{note} | {r.baseline} | {fmt_time(r.subject_time)} "
            f"| {fmt_time(r.baseline_time)} | {fmt_ratio(r.ratio)} | {fmt_memory(r)} "
            f"| {r.target} | {met} |"
        )
    return "\n".join(lines)


def machine() -> str:
    import casadi
    import scipy
    import sympy

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}, "
        f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
        f"casadi {casadi.__version__}, sympy {sympy.__version__}; vsw threads "
        f"{default_threads()}; {blas_threading()}"
    )


def _plain(value):
    """numpy scalars as Python numbers for JSON."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _run_isolated(case: int, quick: bool, against: str | None = None) -> list[Row]:
    """One case in a fresh interpreter, so that its peak RSS is its own."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.json"
        command = [sys.executable, str(Path(__file__).resolve()), "--case", str(case)]
        command += ["--rows-out", str(out)] + (["--quick"] if quick else [])
        command += ["--against", against] if against else []
        done = subprocess.run(command, cwd=ROOT, text=True, capture_output=True)
        if done.returncode != 0:
            raise RuntimeError(f"benchmark case {case} failed:\n{done.stdout}\n{done.stderr}")
        payload = json.loads(out.read_text())
    rows = [Row.from_dict(r) for r in payload["rows"]]
    for row in rows:
        row.extra["case_peak_rss_mb"] = payload["peak_rss_mb"]
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes; checks the code runs")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    parser.add_argument("--results", type=Path, help="markdown report (default: see module doc)")
    parser.add_argument("--case", type=int, action="append", choices=CASES, help="run only these")
    parser.add_argument("--rows-out", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--against", metavar="REF", nargs="?", const=THREADS_BEFORE,
                        help="case 15: also its walks in a checkout of REF (a commit; default "
                        f"{THREADS_BEFORE}), process by process, alternately with this "
                        "tree's")  # fmt: skip
    args = parser.parse_args(argv)
    if args.rows_out is not None:  # child process of _run_isolated: exactly one case
        rows = run_case(args.case[0], args.quick, args.against)
        children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        # Case 7 measures whole processes: their peak is that of the largest child.
        peak = children if args.case[0] == 7 else peak_rss_mb()
        payload = {"rows": [asdict(r) for r in rows], "peak_rss_mb": peak}
        args.rows_out.write_text(json.dumps(payload, default=_plain))
        return 0
    rows: list[Row] = []
    for case in args.case or CASES:
        started = time.perf_counter()
        rows += _run_isolated(case, args.quick, args.against)
        print(f"case {case}: {time.perf_counter() - started:.1f} s", file=sys.stderr)
    if args.quick:  # sizes are reduced: the targets do not apply
        for row in rows:
            row.met = None
    text = table(rows)
    if any(r.case == "8" for r in rows):
        text += (
            "\n\nCase 8: the reference (benchmarks/design_suite.py) does not use IPOPT or the "
            "design's smooth pieces, but shares with it the generated closed forms (the exact "
            "margins) and the closed problem's distances (STRICT_MARGIN, TABLE_DISTANCE): a "
            "defect of the generated code itself would not show here (the derivation's own "
            "tests cover it). The 'before' side runs vsw/synthesis/design.py of commit "
            f"{DESIGN_BEFORE} on today's generated code, vsw.models.ile.analysis and "
            "vsw.models.ile.simulate."
        )
    print(text)
    mode = "quick (sizes reduced; numbers not meaningful)" if args.quick else "full"
    missed = [f"{r.case} ({r.subject})" for r in rows if r.met is False]
    report = (
        "# Benchmark results\n\n"
        "Written by `python benchmarks/run.py`; rerun it to measure your machine.\n\n"
        f"Mode: {mode}. Machine: {machine()}.\n\n"
        "Each ratio is measured side by side in one run (interleaved, medians of at least five "
        "repetitions after a warm-up; rows noted 'single run' are one sample); absolute times "
        "hold for this machine only. Peak MB is "
        "the largest memory traced (tracemalloc, numpy buffers included) during one call of "
        "each side; RSS is the peak resident size of the process that ran the case (for case "
        "7, of the largest measured process).\n\n"
        + text
        + "\n\n"
        + ("Targets missed: " + "; ".join(missed) + ".\n" if missed else "Every target met.\n")
    )
    results = args.results
    if results is None:
        if args.quick:
            results = Path(tempfile.gettempdir()) / "vsw-benchmark-quick.md"
        else:
            results = ROOT / "benchmarks" / "results.md"
    results.write_text(report)
    print(f"wrote {results}", file=sys.stderr)
    if args.json:
        rows_json = [asdict(r) | {"ratio": r.ratio} for r in rows]
        args.json.write_text(json.dumps(rows_json, indent=1, default=_plain))
    return 0


if __name__ == "__main__":
    sys.exit(main())
