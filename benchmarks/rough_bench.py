"""Case 17: walks on rough ground (vsw rough), per step walked.

* The stochastic batch simulator (:meth:`vsw.dynamics.batch.BatchSimulator.walk_varying`: calls
  of the batch simulator of up to 32 steps over the walks still walking, each walk's
  slopes of those steps from the counter-based draws, drawn between calls) against the
  deterministic one (the same walks on the mean slope in one call of many steps), one
  thread each, the same starts: the target is within 1.2x per step. The noise is small
  (MFPT far above the walk's length), so both sides walk (nearly) every step. Each row
  notes the process's CPU time per step beside the wall time (a machine shared with other
  work stretches wall time, not CPU time).
* The same terrain walked by the hand-written numba DOP853 peer
  (benchmarks/peers/numba_dop853.py: the same integrator rules, each model typed by hand),
  a jitted loop over the walks and their steps setting each step's slope from the same
  draws, against walk_varying, one thread each (informative; skipped without numba).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

SIGMA = {"simplest_walker": 0.0003, "compass_gait": 0.002}
"""Slope noise [rad] of the walks: small enough that few walks fall within STEPS."""
STEPS = 100
TOLERANCE = 1e-10


def _terrain_walker(walk_one: Callable, index: int) -> Callable:
    """A jitted walk of every start on the per-step slopes ``params[index] + sigma *
    xi[n, k]`` by the peer's one-step walk (its rules: a fall keeps the step's start)."""
    from numba import njit

    @njit
    def run(params, xi, sigma, starts, steps, tol, final, walked, outcome):
        p = params.copy()
        nx = starts.shape[1]
        y = np.empty((1, nx))
        one_final = np.empty((1, nx))
        one_walked = np.empty(1, np.int64)
        one_outcome = np.empty(1, np.int64)
        for n in range(starts.shape[0]):
            y[0] = starts[n]
            count = 0
            result = 0
            for k in range(steps):
                p[index] = params[index] + sigma * xi[n, k]
                walk_one(p, y, 1, tol, tol, one_final, one_walked, one_outcome)
                if one_outcome[0] != 0:
                    result = one_outcome[0]
                    break
                y[0] = one_final[0]
                count += 1
            final[n] = y[0]
            walked[n] = count
            outcome[n] = result

    return run


def _cpu_timed(fn: Callable, samples: list[float]) -> Callable:
    """``fn`` recording each call's CPU time (``time.process_time``) into ``samples``."""

    def timed() -> None:
        start = time.process_time()
        fn()
        samples.append(time.process_time() - start)

    return timed


def _cpu_note(cpu: dict[str, list[float]], steps: dict[str, int]) -> str:
    """The two sides' median CPU time per step (the warm-up call left out) and their ratio."""
    ours, other = (statistics.median(cpu[k][1:]) / steps[k] for k in ("ours", "other"))
    return f"CPU {ours * 1e6:.2f} us and {other * 1e6:.2f} us a step: {ours / other:.3f}x"


def case_rough(count: int, reps: int, Row, interleaved, near_gait_starts) -> list:
    """Case 17's rows (see the module docstring); ``Row`` and ``interleaved`` are
    benchmarks/harness.py's, ``near_gait_starts`` is benchmarks/cases/gaits.py's."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load
    from vsw.studies.rough import Terrain, slope_index

    rows = []
    for key in ("simplest_walker", "compass_gait"):
        _, params, starts = near_gait_starts(key, count)
        model = load(key)
        sim = simulator(model)
        sim.library()
        index = slope_index(model)
        terrain = Terrain(params, index, SIGMA[key], 0)
        found = {}

        def stochastic(sim=sim, terrain=terrain, starts=starts, found=found):
            found["ours"] = sim.walk_varying(terrain, starts, STEPS, threads=1,
                                             tolerance=TOLERANCE)  # fmt: skip

        def deterministic(sim=sim, params=params, starts=starts, found=found):
            found["plain"] = sim.walk(params, starts, STEPS, converge_tol=0.0, period_tol=0.0,
                                      threads=1, tolerance=TOLERANCE)  # fmt: skip

        cpu: dict[str, list[float]] = {"ours": [], "other": []}
        t_ours, t_plain = interleaved(_cpu_timed(stochastic, cpu["ours"]),
                                      _cpu_timed(deterministic, cpu["other"]), reps)  # fmt: skip
        ours_steps, plain_steps = int(found["ours"].steps.sum()), int(found["plain"].steps.sum())
        ratio = (t_ours.median / ours_steps) / (t_plain.median / plain_steps)
        cpu_note = _cpu_note(cpu, {"ours": ours_steps, "other": plain_steps})
        rows.append(Row(
            "17", f"{key}: walks of {STEPS} steps on a slope drawn per step (sigma = "
            f"{SIGMA[key]:g} rad), walk_varying (1 thread), rtol = atol = {TOLERANCE:g}",
            "the same walks on the mean slope, one call of the batch simulator",
            t_ours.per(ours_steps), t_plain.per(plain_steps), "within 1.2x per step",
            ratio <= 1.2,
            note=f"per step over {len(starts)} walks ({ours_steps} and {plain_steps} steps); "
            f"{ratio:.3f}x; {cpu_note}",
        ))  # fmt: skip
        rows.append(_numba_row(key, params, index, starts, found, reps, Row, interleaved))
    return rows


def _numba_row(key, params, index, starts, found, reps, Row, interleaved):
    """The numba peer walking the same terrain against walk_varying."""
    from vsw.dynamics.batch import simulator
    from vsw.models import load
    from vsw.studies.rough import Terrain, terrain_noise

    subject = f"{key}: the same terrain, walk_varying (1 thread)"
    try:
        from peers import numba_dop853
    except ImportError as exc:
        return Row("17", subject, "numba DOP853 on the same terrain", None, None,
                   "(informative)", None, note=f"not run: {exc} (pip install numba)")  # fmt: skip
    walk = _terrain_walker(getattr(numba_dop853, key)(), index)
    n = len(starts)
    xi = terrain_noise(0, np.arange(n)[:, None], np.arange(STEPS))
    p = np.asarray(params, dtype=float)
    out = {"final": np.empty((n, starts.shape[1])), "walked": np.empty(n, np.int64),
           "outcome": np.empty(n, np.int64)}  # fmt: skip
    sim = simulator(load(key))
    terrain = Terrain(params, index, SIGMA[key], 0)

    def peer():
        walk(p, xi, SIGMA[key], starts, STEPS, TOLERANCE, out["final"], out["walked"],
             out["outcome"])  # fmt: skip

    def ours():
        found["ours"] = sim.walk_varying(terrain, starts, STEPS, threads=1, tolerance=TOLERANCE)

    cpu: dict[str, list[float]] = {"ours": [], "other": []}
    t_ours, t_peer = interleaved(_cpu_timed(ours, cpu["ours"]), _cpu_timed(peer, cpu["other"]),
                                 reps)  # fmt: skip
    ours_steps, peer_steps = int(found["ours"].steps.sum()), int(out["walked"].sum())
    cpu_note = _cpu_note(cpu, {"ours": ours_steps, "other": peer_steps})
    same = int(np.sum(found["ours"].steps == out["walked"]))
    ratio = (t_ours.median / ours_steps) / (t_peer.median / peer_steps)
    return Row(
        "17", subject, "numba DOP853 (benchmarks/peers/numba_dop853.py) walking the same "
        "draws, one jitted loop over walks and steps", t_ours.per(ours_steps),
        t_peer.per(peer_steps), "(informative)", None,
        note=f"per step over {n} walks ({ours_steps} and {peer_steps} steps; {same} of {n} "
        f"walks the same number of steps); {ratio:.3f}x; {cpu_note}",
    )  # fmt: skip
