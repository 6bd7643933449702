"""Cases 6, 8, 13 and 16: gait design and optimisation (CasADi and IPOPT) against SciPy's
SLSQP on simulated steps, and the seeded design suites against their references."""

from __future__ import annotations

import sys
import time

from harness import ROOT, Row, Timing
from pins import DESIGN_BEFORE


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


def case_design_every_model(quick: bool) -> list[Row]:
    """Case 13: design on the periodic orbit, a seeded suite per model against
    references without IPOPT (benchmarks/design_every_model.py), SLSQP side by side."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import design_every_model

    keys = ["rimless_wheel"] if quick else list(design_every_model.SUITE_MODELS)
    report = design_every_model.run(2 if quick else 50, 2026, keys, 1 if quick else 5)
    return design_every_model.rows(report, Row, Timing)


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
