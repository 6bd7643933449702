"""Benchmarks: every speed claim measured side by side with what a user would write instead.

``python benchmarks/run.py [--quick] [--json FILE]`` runs every case, prints a table and
writes ``benchmarks/results.md`` (table, machine, versions). Each comparison is a ratio
measured within one run: the two sides interleaved, warm-up first, then at least five
repetitions (two with ``--quick``); medians are reported with min and max. Absolute times
are reported, only ratios are claimed. ``--quick`` uses small sizes so the test suite can
run it to keep this code working; its numbers mean nothing.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import generated.ile as ile  # noqa: E402
from vsw.vectorize import chunked  # noqa: E402


@dataclass
class Timing:
    median: float
    low: float
    high: float

    @classmethod
    def of(cls, samples: list[float]) -> Timing:
        return cls(statistics.median(samples), min(samples), max(samples))


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
    extra: dict = field(default_factory=dict)

    @property
    def ratio(self) -> float | None:
        if self.subject_time is None or self.baseline_time is None:
            return None
        return self.subject_time.median / self.baseline_time.median


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


def random_parameters(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``n`` parameter sets at which every physical existence condition holds."""
    from tests.conftest import random_walking_parameters

    p = random_walking_parameters(n, seed)
    return p["beta"], p["theta_II"], p["phi0"]


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# ---------------------------------------------------------------------------- cases


def case_fixed_point_vectorised(n: int, reps: int) -> list[Row]:
    """Case 1: q^f, eigenvalue, conditions over n sets vs lambdify(raw) and the trig floor."""
    import sympy as sm

    from derive.models import ile as model

    beta, theta_II, phi0 = random_parameters(n, seed=1)
    d = model.derive()
    hs = model.heelstrike()
    raw_qf = d.facts["stride.q_fixed"].subs(model.theta_I, hs["theta_I"])
    raw_margins = [c.margin for c in d.conditions]
    args = (model.beta, model.theta_II, model.phi0)
    raw = sm.lambdify(args, [raw_qf, d.facts["stride.eigenvalue"], *raw_margins], "numpy")

    def generated():
        with np.errstate(all="ignore"):
            chunked(ile.q_fixed, beta, theta_II, phi0)
            chunked(ile.eigenvalue, beta, phi0)
            chunked(ile.condition_margins, beta, theta_II, phi0)

    def lambdified():
        with np.errstate(all="ignore"):
            raw(beta, theta_II, phi0)

    def floor():
        np.cos(theta_II), np.cos(phi0), np.sin(phi0)

    t_gen, t_floor = interleaved(generated, floor, reps)
    t_gen2, t_raw = interleaved(generated, lambdified, reps)
    rows = [
        Row("1", f"generated q^f+eigenvalue+conditions, n={n}", "3 numpy trig evaluations",
            t_gen, t_floor, "<= 1.5x floor", None),
        Row("1", f"generated q^f+eigenvalue+conditions, n={n}", "sympy.lambdify of raw expressions",
            t_gen2, t_raw, "(faster is better)", None),
    ]  # fmt: skip
    rows[0].met = rows[0].ratio <= 1.5
    rows[1].met = rows[1].ratio < 1.0
    rows[0].extra["peak_rss_mb"] = peak_rss_mb()
    return rows


def case_fixed_point_vs_simulation(samples: int, reps: int) -> list[Row]:
    """Case 2: closed-form q^f per set vs solve_ivp Poincare map + brentq."""
    from vsw.simulate import fixed_point_by_simulation

    beta, theta_II, phi0 = random_parameters(samples, seed=2)
    agreement = []
    for b, t, p in zip(beta, theta_II, phi0):
        q_sim = float(np.asarray(fixed_point_by_simulation(b, t, p)).ravel()[0])
        agreement.append(abs(q_sim / ile.q_fixed(b, t, p) - 1))

    def closed():
        for b, t, p in zip(beta, theta_II, phi0):
            ile.q_fixed(b, t, p)

    def simulated():
        for b, t, p in zip(beta, theta_II, phi0):
            fixed_point_by_simulation(b, t, p)

    t_closed, t_sim = interleaved(closed, simulated, reps)
    row = Row("2", f"generated q^f (scalar calls), {samples} sets",
              "solve_ivp Poincare map + brentq", t_closed, t_sim, ">= 1e5x faster", None,
              note=f"max rel. disagreement {max(agreement):.1e}")  # fmt: skip
    row.met = 1 / row.ratio >= 1e5
    return [row]


def case_rootfinders_and_c(reps: int) -> list[Row]:
    """Case 3: CasADi rootfinder per solve (closed form, integrated map); compiled C per call."""
    from vsw.ccode import CLibrary
    from vsw.fixed_point import solve_fixed_point

    b, t, p = 0.8, 0.0, np.pi / 4
    lib = CLibrary.build()
    calls = 1000
    rows = []
    t_closed = timed(lambda: solve_fixed_point(b, t, p, method="closed-form"), reps)
    t_integrated = timed(lambda: solve_fixed_point(b, t, p, method="integrated"), reps)
    t_c = timed(lambda: [lib.call("q_fixed", b, t, p) for _ in range(calls)], reps)
    t_c = Timing(t_c.median / calls, t_c.low / calls, t_c.high / calls)
    t_py = timed(lambda: [ile.q_fixed(b, t, p) for _ in range(calls)], reps)
    t_py = Timing(t_py.median / calls, t_py.low / calls, t_py.high / calls)
    for label, t in (("closed-form", t_closed), ("integrated", t_integrated)):
        rows.append(Row("3", f"CasADi rootfinder on the {label} map", "-", t, None, "-", None))
    rows.append(Row("3", "compiled C vsw_ile_q_fixed per call (via ctypes)",
                    "generated numpy q_fixed per scalar call", t_c, t_py, "-", None,
                    note="ctypes call overhead included"))  # fmt: skip
    return rows


def case_step_metrics(n: int, reps: int) -> list[Row]:
    """Case 4: step period (elliptic), length, speed, contact margin for n sets."""
    beta, theta_II, phi0 = random_parameters(n, seed=4)

    def metrics(chunk: bool):
        def run():
            with np.errstate(all="ignore"):
                ev = chunked if chunk else (lambda f, *a: f(*a))
                qf = ev(ile.q_fixed, beta, theta_II, phi0)
                t1, t2 = ev(ile.phase_durations, beta, theta_II, phi0, qf)
                length = ev(ile.step_length, beta, phi0)
                _ = length / (t1 + t2)
                ev(ile.contact_margin, beta, theta_II, phi0, qf)

        return run

    t_chunk, t_whole = interleaved(metrics(True), metrics(False), reps)
    row = Row("4", f"step metrics, n={n}, blockwise", "same code on whole arrays",
              t_chunk, t_whole, "<= 1 s absolute", None)  # fmt: skip
    row.met = t_chunk.median <= 1.0 * n / 1e6
    row.note = "target scaled to n/1e6" if n != 10**6 else ""
    row.extra["peak_rss_mb"] = peak_rss_mb()
    return [row]


def case_basin(n: int, reps: int) -> list[Row]:
    """Case 5: basin of attraction on an n x n grid (theta_II x initial q), classified."""
    from vsw import basin as basin_module

    theta_II_grid = np.radians(np.linspace(-30, 40, n))
    t = timed(lambda: basin_module.basin(0.8, np.pi / 4, theta_II_grid, n_q=n, refine=False), reps)
    row = Row("5", f"basin classification, {n}x{n} grid", "-", t, None, "<= 1 s absolute", None)
    row.met = t.median <= 1.0 * (n * n) / 1e6
    row.extra["peak_rss_mb"] = peak_rss_mb()
    return [row]


def case_design(quick: bool) -> list[Row]:
    """Case 6: gait design with CasADi/IPOPT vs SciPy SLSQP on a simulation-based map."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import bench_design

    result = bench_design.compare(quick=quick)
    ipopt = Timing(*result["ipopt_seconds"])
    slsqp = Timing(*result["slsqp_seconds"])
    row = Row("6", "design, CasADi/IPOPT (after set-up)", "SciPy SLSQP on simulated map",
              ipopt, slsqp, "<= 100 ms and >= 100x faster, objective >=", None,
              note=result.get("note", ""))  # fmt: skip
    row.met = ipopt.median <= 0.1 and 1 / row.ratio >= 100 and result.get("objective_ok", False)
    return [row]


def _process_time(command: list[str], reps: int, env: dict | None = None) -> Timing:
    def run():
        subprocess.run(command, cwd=ROOT, check=True, capture_output=True, env=env)

    return timed(run, reps)


def case_startup(reps: int, include_audit: bool) -> list[Row]:
    """Case 7: whole-process start-up times."""
    py = sys.executable
    rows = []
    with tempfile.TemporaryDirectory() as out:
        derive_env = {**os.environ, "PYTHONDONTWRITEBYTECODE": "1"}
        cases = [
            ("python -m derive (to a temp dir)", [py, "-m", "derive", "--out", out + "/g"], 5.0),
            ("import vsw", [py, "-c", "import vsw"], 0.3),
            ("vsw analyze ... --json",
             [py, "-m", "vsw", "analyze", "--beta", "0.8", "--theta-ii", "0", "--phi0", "45",
              "--json"], 0.6),
        ]  # fmt: skip
        if include_audit:
            cases.append(("python -m paper_check", [py, "-m", "paper_check", "--out", out], 60.0))
        baseline = _process_time([py, "-c", "pass"], reps)
        for label, command, target in cases:
            t = _process_time(command, 1 if "paper_check" in label else reps, env=derive_env)
            row = Row("7", label, "python -c pass", t, baseline, f"<= {target} s absolute", None)
            row.met = t.median <= target
            rows.append(row)
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
        return f"{x * 1e6:.1f} us"

    return f"{one(t.median)} [{one(t.low)}, {one(t.high)}]"


def table(rows: list[Row]) -> str:
    lines = [
        "| case | measured | against | time (median [min, max]) | baseline time | ratio "
        "| target | met |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        ratio = "-" if r.ratio is None else f"{r.ratio:.3g}x"
        met = {True: "yes", False: "**MISSED**", None: "-"}[r.met]
        note = f" ({r.note})" if r.note else ""
        lines.append(
            f"| {r.case} | {r.subject}{note} | {r.baseline} | {fmt_time(r.subject_time)} "
            f"| {fmt_time(r.baseline_time)} | {ratio} | {r.target} | {met} |"
        )
    return "\n".join(lines)


def machine() -> str:
    import casadi
    import scipy
    import sympy

    return (
        f"{platform.platform()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}, casadi {casadi.__version__}, "
        f"sympy {sympy.__version__}"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small sizes; checks the code runs")
    parser.add_argument("--json", type=Path, help="also write the rows as JSON here")
    parser.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results.md")
    args = parser.parse_args(argv)
    q = args.quick
    reps = 2 if q else 5
    rows: list[Row] = []
    rows += case_fixed_point_vectorised(2_000 if q else 10**6, reps)
    rows += case_fixed_point_vs_simulation(2 if q else 10, 1 if q else 5)
    rows += case_rootfinders_and_c(reps)
    rows += case_step_metrics(2_000 if q else 10**6, reps)
    rows += case_basin(50 if q else 1000, reps)
    rows += case_design(q)
    rows += case_startup(1 if q else 5, include_audit=not q)
    text = table(rows)
    print(text)
    mode = "quick (sizes reduced; numbers not meaningful)" if q else "full"
    report = (
        "# Benchmark results\n\n"
        f"Mode: {mode}. Machine: {machine()}.\n\n"
        "Ratios are measured side by side in one run (interleaved, medians); absolute times "
        "are for this machine only.\n\n" + text + "\n"
    )
    args.results.write_text(report)
    if args.json:
        args.json.write_text(json.dumps([asdict(r) | {"ratio": r.ratio} for r in rows], indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
