"""Case 18: HZD gait optimisation (vsw hzd --optimize) against full-order collocation
(vsw optimize) on the three-link biped at 0.8 m/s, step 2 r sin(pi/8) = 0.765 m (the
constraints file's theta_plus = -pi/8 and theta_minus = pi/8 fix it), minimising the
inputs' squared integral (torque2, (N m)^2 s), one run each, CPU time (the machine is
shared).

* ``vsw hzd --optimize`` on examples/hzd/three_link_mirror_invariant.py (two Bezier
  outputs of degree 6, ten free coefficients): impact invariant, the swing foot above the
  ground away from mid-stance, verified on the full-order closed loop (its periodic orbit
  and eigenvalues);
* ``vsw optimize --model three-link-biped`` (Hermite-Simpson collocation of the full-order
  step, 80 intervals: at 20 and 40 its re-simulation misses the last knot by 5e-5 and 3e-6
  and it reports not-converged), its default: no clearance, an open-loop gait.

The target: the HZD optimum verified, and its cost not below the full-order optimum's (the
gaits on a surface of this family are a subset of the full-order gaits of that speed and
step; the surface and the clearance cost the rest).

RABBIT (without ``--quick`` only: minutes of CPU) at 0.6 m/s and step 0.45 m, torque2:

* ``vsw hzd --optimize`` from the rough start recorded in examples/hzd/rabbit_walk.py (its
  text before the optimum; four Bezier outputs of degree 5, sixteen free coefficients),
  verified on the full-order closed loop;
* ``vsw optimize --model rabbit`` at 10 intervals, run as the command with a limit of
  RABBIT_LIMIT seconds of wall clock: its start for a model without a passive gait is the
  search box's centre moving at constant rates, whose swing leg stays behind and lands
  on the stance foot (a step of length 0, 0.45 m from the target), from which IPOPT stops
  after one iteration (Restoration_Failed) and the re-simulation of that answer takes the
  time; a start given as an orbit is simulated with the inputs at zero, on which RABBIT
  folds at the knees.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CONSTRAINTS = ROOT / "examples" / "hzd" / "three_link_mirror_invariant.py"
SPEED = 0.8
STEP = 2 * math.sin(math.pi / 8)
COLLOCATION_NODES = 80
RABBIT_EXAMPLE = ROOT / "examples" / "hzd" / "rabbit_walk.py"
RABBIT_SPEED = 0.6
RABBIT_STEP = 0.45
RABBIT_NODES = 10
RABBIT_LIMIT = 600.0


def case_hzd_optimize(quick: bool, Row, Timing) -> list:
    """The rows of case 18 (``quick``: the three-link biped's runs, no target claimed; each
    is one run; RABBIT's only without ``quick``)."""
    rows = _three_link(quick, Row, Timing)
    if not quick:
        rows.append(_rabbit(Row, Timing))
    return rows


def _three_link(quick: bool, Row, Timing) -> list:
    """The three-link biped's row."""
    from vsw.models import key, load
    from vsw.synthesis.hzd import DEFAULT_GAINS
    from vsw.synthesis.hzd.optimize import HzdRequest, optimize
    from vsw.synthesis.powered import Request
    from vsw.synthesis.powered import optimize as collocate

    model = load("three-link-biped")
    params = model.parameters()
    begin = time.process_time()
    request = HzdRequest(speed=SPEED, minimize="torque2", clearance=0.0)
    hzd = optimize(model, key("three-link-biped"), str(CONSTRAINTS), None, request, DEFAULT_GAINS)
    t_hzd = time.process_time() - begin
    begin = time.process_time()
    against = Request("torque2", target_speed=SPEED, target_step_length=STEP,
                      nodes=COLLOCATION_NODES)  # fmt: skip
    full = collocate(model, params, against)
    t_full = time.process_time() - begin
    loop = None if hzd.report is None else hzd.report.full_order
    eigen = math.nan if loop is None else loop.max_abs_eigenvalue
    met = hzd.optimal and full.status == "optimal" and hzd.objective >= full.cost * (1 - 1e-6)
    met = None if quick else met  # a quick run claims no target
    return [Row(
        "18", f"vsw hzd --optimize --model three-link-biped --constraints "
        f"three_link_mirror_invariant.py --speed {SPEED:g} (step {STEP:.6g} m): "
        f"{'optimal, verified' if hzd.optimal else 'NOT optimal'}, torque2 "
        f"{hzd.objective:.6g} (N m)^2 s",
        f"vsw optimize --model three-link-biped --target-speed {SPEED:g} --target-step-length "
        f"{STEP:.6g} --nodes {COLLOCATION_NODES}: {full.status}, torque2 {full.cost:.6g} "
        "(N m)^2 s",
        Timing.of([t_hzd]), Timing.of([t_full]),
        "HZD optimum verified; its cost >= the full-order optimum's", met,
        note=f"CPU seconds, one run each; cost ratio HZD/full order "
        f"{hzd.objective / full.cost:.4g}; HZD: {hzd.iterations} IPOPT iterations, "
        f"build {hzd.build_seconds:.2f} s, solve {hzd.solve_seconds:.2f} s, the rest the "
        f"runtime's verification; full-order loop max |eigenvalue| {eigen:.4g}; vsw optimize "
        "has no clearance by default and gives an open-loop gait",
        extra={"hzd_cost": hzd.objective, "full_order_cost": full.cost,
               "hzd_failures": hzd.failures, "full_order_status": full.status},
    )]  # fmt: skip


def _rabbit_start(tmp: Path) -> Path:
    """The example's rough start: its text before the optimum it records."""
    text = RABBIT_EXAMPLE.read_text()
    path = tmp / "rabbit_start.py"
    path.write_text(text[: text.index("# The optimum of:")])
    return path


def _collocate_rabbit() -> tuple[str, float]:
    """``vsw optimize --model rabbit`` as the command, within RABBIT_LIMIT seconds: its
    status (or that it gave none) and its CPU seconds."""
    import json
    import resource
    import subprocess
    import sys

    argv = [sys.executable, "-m", "vsw", "optimize", "--model", "rabbit", "--target-speed",
            f"{RABBIT_SPEED:g}", "--target-step-length", f"{RABBIT_STEP:g}", "--nodes",
            str(RABBIT_NODES), "--json"]  # fmt: skip
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        done = subprocess.run(argv, capture_output=True, text=True, timeout=RABBIT_LIMIT)
        try:
            data = json.loads(done.stdout)
            answer = f"{data.get('status')}, torque2 {data.get('cost')}"
        except ValueError:
            answer = f"no gait (exit {done.returncode}: {done.stderr.strip()[:120]})"
    except subprocess.TimeoutExpired:
        answer = f"no result within {RABBIT_LIMIT:g} s"
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return answer, cpu


def _rabbit(Row, Timing):
    """RABBIT's row: the HZD optimum from the example's rough start against the full-order
    collocation at the same speed and step."""
    import tempfile

    from vsw.models import key, load
    from vsw.synthesis.hzd import DEFAULT_GAINS
    from vsw.synthesis.hzd.optimize import HzdRequest, optimize

    model = load("rabbit")
    request = HzdRequest(speed=RABBIT_SPEED, step_length=RABBIT_STEP, minimize="torque2",
                         clearance=0.0)  # fmt: skip
    with tempfile.TemporaryDirectory() as tmp:
        start = _rabbit_start(Path(tmp))
        begin = time.process_time()
        hzd = optimize(model, key("rabbit"), str(start), None, request, DEFAULT_GAINS)
        t_hzd = time.process_time() - begin
    answer, t_full = _collocate_rabbit()
    loop = None if hzd.report is None else hzd.report.full_order
    eigen = math.nan if loop is None else loop.max_abs_eigenvalue
    return Row(
        "18", f"vsw hzd --optimize --model rabbit --constraints rabbit_walk.py's rough start "
        f"--speed {RABBIT_SPEED:g} --step-length {RABBIT_STEP:g}: "
        f"{'optimal, verified' if hzd.optimal else 'NOT optimal'}, torque2 "
        f"{hzd.objective:.6g} (N m)^2 s",
        f"vsw optimize --model rabbit --target-speed {RABBIT_SPEED:g} --target-step-length "
        f"{RABBIT_STEP:g} --nodes {RABBIT_NODES}: {answer}",
        Timing.of([t_hzd]), Timing.of([t_full]),
        "HZD optimum verified (the full-order collocation's start is a step of length 0)",
        hzd.optimal,
        note=f"CPU seconds, one run each; HZD: {hzd.iterations} IPOPT iterations, build "
        f"{hzd.build_seconds:.2f} s, solve {hzd.solve_seconds:.2f} s; full-order loop max "
        f"|eigenvalue| {eigen:.4g}; vsw optimize's start for RABBIT (no passive gait) keeps "
        "the swing leg behind and lands it on the stance foot: a step of length 0 (IPOPT "
        "Restoration_Failed after one iteration, then the re-simulation takes the time)",
        extra={"hzd_cost": hzd.objective, "hzd_failures": hzd.failures,
               "full_order": answer},
    )  # fmt: skip
