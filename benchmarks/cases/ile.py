"""Cases 1-5: the ILE's generated closed forms (fixed point, eigenvalue, conditions, step
metrics, basin) against what a user would write instead."""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Callable
from types import SimpleNamespace

import numpy as np
from harness import Row, Timing, interleaved, peak_alloc_mb, timed

import generated.ile as ile
from vsw.models.ile.params import random_parameters
from vsw.runtime.threads import default_threads
from vsw.runtime.vectorize import chunked


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
    sides = _case1_sides(beta, theta_II, phi0, n)
    # The generated code first, in a process that has not run sympy: the floor and the
    # generated code then see the same allocator state.
    kernel_rows = _kernel_rows(sides, n, threads, reps)
    rows = _numpy_rows(sides, n, threads, reps)
    row = _lambdify_row(sides, threads, reps, fused_mb=rows[0].subject_peak_mb)
    return [*kernel_rows, *rows, row]


FLOOR_LABEL = "3 numpy trig evaluations (cos theta_II, cos phi0, sin phi0)"
"""Case 1's floor: the trigonometry any evaluation of the model needs."""


def _case1_sides(beta, theta_II, phi0, n: int) -> SimpleNamespace:
    """Case 1's sides over the sets ``beta, theta_II, phi0``: the generated numpy code
    (fused, optionally into reused outputs, or its three functions separately) and the trig
    floors it is held against."""
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

    return SimpleNamespace(sets=(beta, theta_II, phi0), fused=fused, separate=separate,
                           floor=floor, cos_sin_floor=cos_sin_floor,
                           floor_reused=floor_reused)  # fmt: skip


def _kernel_rows(sides: SimpleNamespace, n: int, threads: int, reps: int) -> list[Row]:
    """Case 1's compiled batch kernel against the floor, on every thread and on one, and
    its first build (into an empty cache directory)."""
    from vsw.models.ile import kernels

    beta, theta_II, phi0 = sides.sets
    floor = sides.floor
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

    floor_label = FLOOR_LABEL
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
    return kernel_rows


def _numpy_rows(sides: SimpleNamespace, n: int, threads: int, reps: int) -> list[Row]:
    """Case 1's generated numpy code (the fallback where no C compiler is available)
    against the floor: fused on every thread and on one, into reused outputs, its functions
    called separately, and against the generated code's own trig."""
    fused, floor, floor_reused = sides.fused, sides.floor, sides.floor_reused
    floor_label = FLOOR_LABEL
    what = f"q^f+eigenvalue+{len(ile.CONDITIONS)} margins, n={n}"
    t_fused, t_floor = interleaved(fused(threads), floor, reps)
    t_one, t_floor1 = interleaved(fused(1), floor, reps)
    t_reused, t_floor_reused = interleaved(fused(threads, True), floor_reused, reps)
    t_reused1, t_floor_reused1 = interleaved(fused(1, True), floor_reused, reps)
    t_sep, t_floor2 = interleaved(sides.separate, floor, reps)
    t_one2, t_cos_sin = interleaved(fused(1), sides.cos_sin_floor, reps)
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
    return rows


def _lambdify_row(sides: SimpleNamespace, threads: int, reps: int, fused_mb: float) -> Row:
    """Case 1's generated code against sympy.lambdify of the raw derived expressions, and
    their largest disagreement."""
    import sympy as sm

    from derive.models import ile as model

    beta, theta_II, phi0 = sides.sets
    fused = sides.fused
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
    return row


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
