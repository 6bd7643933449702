"""Case 15: walks of the compiled batch simulator against an earlier commit's C, with and
without the BLAS limit, in CPU time, against libm's sines, the floor of the evaluations a
step needs, and hand-written peers (numba, CyRK); with ``--against``, whole processes of
this tree against a checkout."""

from __future__ import annotations

import contextlib
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import numpy as np
from harness import ROOT, Row, Timing, _checkout, blas_threading, interleaved, timed
from pins import BATCH_BEFORE, BATCH_BEFORE_FLAGS

from .gaits import _near_gait_starts

BATCH_VALUES = {"vsw_biped": {"beta": 0.97, "theta_II": -0.2}}
"""Case 15's parameters where not the defaults: the biped at a stable gait (its defaults'
gaits are unstable, so the walks would fall within a few steps)."""


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
        floors = _floor_costs(counting, counts, n_phases, steps, params, starts)
        fast = simulator(load(key))
        fast.library()

        def walk(fast=fast, params=params, starts=starts):
            fast.walk(params, starts, 20, converge_tol=0.0, period_tol=0.0, threads=1,
                      tolerance=1e-10)  # fmt: skip

        t = timed(walk, reps).per(steps)
        rows += _floor_model_rows(key, t, floors)
    return rows


def _floor_costs(counting, counts, n_phases: int, steps: int, params, starts) -> SimpleNamespace:
    """Case 15's floors of one model from its counting build ``counting`` and the calls it
    counted (``counts``) over walks of ``steps`` steps: each phase's flows, guard sets and RK
    steps a step times their cost alone, one walk at a time and in lanes of four."""
    import ctypes

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
    return SimpleNamespace(floor=floor, lanes_floor=lanes_floor, rk_floor=rk_floor,
                           per_step=per_step, per_lane=per_lane, per_rk=per_rk)  # fmt: skip


def _floor_model_rows(key: str, t: Timing, floors: SimpleNamespace) -> list[Row]:
    """Case 15's rows of one model's step time ``t`` against its floors."""
    floor, lanes_floor, rk_floor = floors.floor, floors.lanes_floor, floors.rk_floor
    # One walk at a time, each of libmvec's sines is a four-wide call for one value:
    # that floor no longer bounds a step taken in lanes, so it is shown, not a target.
    return [
        Row(
            "15", f"{key}: a step of the batch simulator at rtol = atol = 1e-10, against its "
            "floor", "the flow and guard evaluations it needs, timed alone, one walk at a time",
            t, Timing(floor, floor, floor), "(informative: the lanes' floor is the target)",
            None, note="per step: " + "; ".join(floors.per_step),
        ),
        Row(
            "15", f"{key}: the same step against the floor of its lanes", "the same evaluations "
            "at their cost per walk in lanes of four (vsw/dynamics/csrc/lanes.h)", t,
            Timing(lanes_floor, lanes_floor, lanes_floor), "<= 1.5x the floor",
            t.median <= 1.5 * lanes_floor,
            note="per walk, a flow and a guard set: " + "; ".join(floors.per_lane),
        ),
        # What the floor leaves out: DOP853's own arithmetic (its stages' sums, the error
        # estimate) and the flows as a step chains them, each stage waiting for the last.
        Row(
            "15", f"{key}: the same step against its RK steps alone", "its RK steps (twelve "
            "flows, the stages' sums, the error estimate) in lanes of four, chained as a walk "
            "chains them, counted and timed alone", t, Timing(rk_floor, rk_floor, rk_floor),
            "(informative)", None, note=f"per step: {'; '.join(floors.per_rk)}; the RK steps "
            f"alone are {rk_floor / lanes_floor:.2f}x the floor of the lanes",
        ),
    ]  # fmt: skip


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
